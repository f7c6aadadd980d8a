//! Active-stick files (`models/active-stick.toml`): the motor's catalogue data, its driver and current
//! loop, the gearing to the push rod, the grip force sensor and the admittance loop
//! ([`crate::control::active`]).

use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use super::{InputError, Source};
use crate::control::active::{ActiveStickConfig, AdmittanceParams, DriverParams, GripSensor, MotorParams};

type S<T> = Spanned<T>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    motor: Motor,
    driver: Driver,
    gearing: Gearing,
    grip_sensor: Sensor,
    admittance: Admittance,
    load: Load,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Motor {
    torque_constant_nm_per_a: S<f64>,
    resistance_ohm: S<f64>,
    inductance_h: S<f64>,
    rotor_inertia_kg_m2: S<f64>,
    viscous_nm_s_per_rad: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Driver {
    supply_v: S<f64>,
    current_limit_a: S<f64>,
    current_loop_hz: S<f64>,
    kp_v_per_a: S<f64>,
    ki_v_per_a_s: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Gearing {
    rad_per_m: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Sensor {
    range_n: S<f64>,
    gain: S<f64>,
    offset_n: S<f64>,
    noise_rms_n: S<f64>,
    adc_bits: S<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Admittance {
    rate_hz: S<f64>,
    virtual_mass_kg: S<f64>,
    virtual_damping_n_s_per_m: S<f64>,
    breakout_band_m: S<f64>,
    travel_m: S<f64>,
    kp_n_per_m: S<f64>,
    kd_n_s_per_m: S<f64>,
    velocity_filter_hz: S<f64>,
    encoder_counts_per_rev: S<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Load {
    mass_kg: S<f64>,
}

impl ActiveStickConfig {
    /// Read and check an active-stick file: a value out of range names its line and field.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        let src = Source::read(path)?;
        let f: File = src.toml()?;
        let admittance = AdmittanceParams {
            rate_hz: within!(src, f.admittance.rate_hz, 100.0..=1e5, "Hz")?,
            virtual_mass_kg: within!(src, f.admittance.virtual_mass_kg, 1e-3..=1e3, "kg")?,
            virtual_damping_n_s_per_m: within!(
                src,
                f.admittance.virtual_damping_n_s_per_m,
                0.0..=1e5,
                "N·s/m"
            )?,
            breakout_band_m: within!(src, f.admittance.breakout_band_m, 1e-6..=0.01, "m")?,
            travel_m: within!(src, f.admittance.travel_m, 1e-3..=1.0, "m")?,
            kp_n_per_m: within!(src, f.admittance.kp_n_per_m, 0.0..=1e8, "N/m")?,
            kd_n_s_per_m: within!(src, f.admittance.kd_n_s_per_m, 0.0..=1e6, "N·s/m")?,
            velocity_filter_hz: within!(src, f.admittance.velocity_filter_hz, 1.0..=1e5, "Hz")?,
            encoder_counts_per_rev: src.within_int(
                &f.admittance.encoder_counts_per_rev,
                "admittance.encoder_counts_per_rev",
                4..=(1 << 32),
            )? as f64,
        };
        let current_loop_hz = within!(src, f.driver.current_loop_hz, 100.0..=1e6, "Hz")?;
        let ratio = current_loop_hz / admittance.rate_hz;
        if ratio < 1.0 || (ratio - ratio.round()).abs() > 1e-9 * ratio {
            let msg = format!(
                "{current_loop_hz} Hz is not a whole multiple of `admittance.rate_hz` = {} Hz: the current \
                 loop ticks a whole number of times per admittance tick",
                admittance.rate_hz
            );
            return Err(src.err(&f.driver.current_loop_hz, "driver.current_loop_hz", msg));
        }
        Ok(Self {
            motor: MotorParams {
                torque_constant_nm_per_a: within!(
                    src,
                    f.motor.torque_constant_nm_per_a,
                    1e-5..=100.0,
                    "N·m/A"
                )?,
                resistance_ohm: within!(src, f.motor.resistance_ohm, 1e-4..=1e4, "Ω")?,
                inductance_h: within!(src, f.motor.inductance_h, 1e-8..=10.0, "H")?,
                rotor_inertia_kg_m2: within!(src, f.motor.rotor_inertia_kg_m2, 0.0..=10.0, "kg·m²")?,
                viscous_nm_s_per_rad: within!(src, f.motor.viscous_nm_s_per_rad, 0.0..=10.0, "N·m·s/rad")?,
            },
            driver: DriverParams {
                supply_v: within!(src, f.driver.supply_v, 1.0..=1000.0, "V")?,
                current_limit_a: within!(src, f.driver.current_limit_a, 0.0..=1000.0, "A")?,
                current_loop_hz,
                kp_v_per_a: within!(src, f.driver.kp_v_per_a, 0.0..=1e4, "V/A")?,
                ki_v_per_a_s: within!(src, f.driver.ki_v_per_a_s, 0.0..=1e8, "V/(A·s)")?,
            },
            gear_rad_per_m: within!(src, f.gearing.rad_per_m, 1.0..=1e5, "rad/m")?,
            sensor: GripSensor {
                range_n: within!(src, f.grip_sensor.range_n, 1.0..=1e5, "N")?,
                gain: within!(src, f.grip_sensor.gain, 0.5..=2.0)?,
                offset_n: within!(src, f.grip_sensor.offset_n, -1e3..=1e3, "N")?,
                noise_rms_n: within!(src, f.grip_sensor.noise_rms_n, 0.0..=1e3, "N")?,
                adc_bits: src.within_int(&f.grip_sensor.adc_bits, "grip_sensor.adc_bits", 0..=32)? as u32,
            },
            admittance,
            load_mass_kg: within!(src, f.load.mass_kg, 1e-3..=1e3, "kg")?,
        })
    }
}
