//! Scenario files (`scenarios/*.toml`), read into a checked [`Scenario`]: every key typed, every number in
//! its range, every variant's keys required or refused, the files it names found, each error at its line.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use super::faults::FaultTable;
use super::{InputError, Source, Variant};
use crate::control::active::ActiveStickConfig;
use crate::control::feel::{CentringSpring, FeelKind, FeelSprings, FeelSystemConfig};
use crate::control::{AntiWindup, FeelLaw, PidGains};
use crate::pilot::attitude::{CrossoverPilotConfig, PilotLoop, Schedule};
use crate::pilot::{Signal, Task};
use crate::rig::{RigConfig, RigRoles};
use crate::scenario::{
    AircraftConfig, ControllerConfig, KeyLines, OuterLoopConfig, PilotConfig, PilotDesign, Scenario,
    MAX_PHYSICS_STEPS,
};
use crate::sensors::{DaqConfig, LaserConfig, LoadCellConfig, SensorsConfig};

type Num = Spanned<f64>;
type Opt = Option<Spanned<f64>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    #[serde(default, rename = "description")]
    _description: String,
    duration_s: Num,
    seed: Spanned<i64>,
    rig: RigSection,
    device: DeviceSection,
    load_cell: LoadCellSection,
    laser: LaserSection,
    daq: DaqSection,
    controller: ControllerSection,
    feel: FeelSection,
    pilot: PilotSection,
    #[serde(default)]
    fault: Vec<FaultTable>,
    aircraft: Option<AircraftSection>,
    outer_loop: Option<OuterLoopSection>,
    feel_system: Option<FeelSystemSection>,
}

/// [`RigConfig`] with the places of the keys a scenario's errors name (the table itself has no span when
/// written with dotted keys, `rig.urdf = …`).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RigSection {
    urdf: Spanned<PathBuf>,
    physics_hz: Opt,
    gravity: Option<bool>,
    solver_iterations: Option<usize>,
    pgs_iterations: Option<usize>,
    stop_natural_hz: Option<f64>,
    fuse_fixed_links: Option<bool>,
    planar_loop_rows: Option<bool>,
    roles: Option<RigRoles>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceSection {
    file: Spanned<PathBuf>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LoadCellSection {
    range_n: Num,
    gain: Num,
    offset_n: Num,
    noise_rms_n: Num,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LaserSection {
    range_m: Num,
    noise_rms_m: Num,
    velocity_cutoff_hz: Num,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DaqSection {
    sample_rate_hz: Num,
    latency_samples: Spanned<i64>,
    adc_bits: Spanned<i64>,
}

#[derive(Debug, Clone, Copy, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum AntiWindupName {
    None,
    Clamping,
    BackCalculation,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ControllerSection {
    kp_a_per_n: Num,
    ki_a_per_n_s: Num,
    kd_a_s_per_n: Num,
    derivative_filter_s: Num,
    anti_windup: Spanned<Variant<AntiWindupName>>,
    tracking_time_s: Opt,
    feedforward: bool,
    rest_speed_m_s: Num,
    rest_force_n: Num,
    current_min_a: Num,
    current_max_a: Num,
    /// The model the controller believes (a device file or a `PARAMS.json`); the plant's if absent.
    model: Option<Spanned<PathBuf>>,
}

#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum LawName {
    Spring,
    ForceSteps,
    Aircraft,
}

#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(rename_all = "kebab-case")]
enum SignalName {
    Hold,
    Step,
    Ramp,
    Sine,
    Triangle,
    Random,
    OuterLoop,
}

impl SignalName {
    /// The keys the signal takes (a command value without its unit suffix).
    fn keys(self) -> &'static [&'static str] {
        match self {
            Self::Hold => &["value"],
            Self::Step => &["initial", "final", "at_s"],
            Self::Ramp => &["from", "to", "start_s", "ramp_duration_s"],
            Self::Sine | Self::Triangle => &["offset", "amplitude", "frequency_hz"],
            Self::Random => &["offset", "rms", "cutoff_hz"],
            Self::OuterLoop => &[],
        }
    }
}

/// A section whose variant (chosen by one of its `fixed` fields) takes some of its optional numbers
/// (`keys`), listed by `keys()` so that those of another variant are refused.
macro_rules! keyed_section {
    ($(#[$doc:meta])* $name:ident { $($fixed:ident: $ty:ty),* } $($key:ident),*) => {
        $(#[$doc])*
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct $name {
            $($fixed: $ty,)*
            $($key: Opt,)*
        }

        impl $name {
            /// Every optional number as written.
            fn keys(&self) -> Vec<(&'static str, Option<&Num>)> {
                vec![$((stringify!($key), self.$key.as_ref())),*]
            }
        }
    };
}

keyed_section!(
    /// `[pilot]`: a command value's key ends in the task's unit (`_rad`, `_n`).
    PilotSection { model: Spanned<PathBuf>, task: Spanned<Variant<Task>>, signal: Spanned<Variant<SignalName>> }
    value_rad, value_n, initial_rad, initial_n, final_rad, final_n, from_rad, from_n, to_rad, to_n,
    offset_rad, offset_n, amplitude_rad, amplitude_n, rms_rad, rms_n, at_s, start_s, ramp_duration_s,
    frequency_hz, cutoff_hz
);

keyed_section!(
    FeelSection { law: Spanned<Variant<LawName>> }
    breakout_n, gradient_n_per_m, damping_n_s_per_m, max_force_n, low_n, high_n, start_s, period_s
);

keyed_section!(
    FeelSystemSection { kind: Spanned<String>, springs: Option<Spanned<PathBuf>>, model: Option<Spanned<PathBuf>> }
    damping_n_s_per_m, qbar_pa, hybrid_k_n_per_m, return_damping_n_s_per_m, motor_max_force_n
);

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AircraftSection {
    model: Spanned<String>,
    airspeed_m_s: Num,
    altitude_m: Num,
    rate_hz: Opt,
    throttle: Option<Spanned<Vec<Point>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OuterLoopSection {
    #[serde(rename = "loop")]
    loop_kind: Spanned<Variant<PilotLoop>>,
    gain: Opt,
    lead_s: Opt,
    lag_s: Opt,
    delay_s: Num,
    integral_per_s: Opt,
    crossover_rad_s: Opt,
    stick_lag_s: Opt,
    /// `[[t_s, value], ...]`: pitch in degrees relative to trim, or load factor in g.
    command: Spanned<Vec<Point>>,
}

/// A point `[t_s, value]` of a schedule: exactly two numbers (serde's `[f64; 2]` would read the first two
/// of a longer array and drop the rest).
#[derive(Clone, Copy)]
struct Point(f64, f64);

impl<'de> Deserialize<'de> for Point {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Two;
        impl<'de> serde::de::Visitor<'de> for Two {
            type Value = Point;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a point [t_s, value] of two numbers")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Point, A::Error> {
                use serde::de::Error;
                let t = seq
                    .next_element()?
                    .ok_or_else(|| A::Error::invalid_length(0, &self))?;
                let v = seq
                    .next_element()?
                    .ok_or_else(|| A::Error::invalid_length(1, &self))?;
                let mut n = 2;
                while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                    n += 1;
                }
                if n > 2 {
                    return Err(A::Error::invalid_length(n, &self));
                }
                Ok(Point(t, v))
            }
        }
        d.deserialize_seq(Two)
    }
}

/// Each number's allowed range and unit, by its key. A range that depends on another key (at most the
/// physics rate, within the run) is checked where that key is known.
const RANGES: &[(&str, f64, f64, &str)] = &[
    ("rig.physics_hz", 100.0, 100_000.0, "Hz"),
    ("duration_s", 1e-3, 3600.0, "s"),
    ("load_cell.range_n", 1.0, 1e5, "N"),
    ("load_cell.gain", 0.5, 2.0, ""),
    ("load_cell.offset_n", -50.0, 50.0, "N"),
    ("load_cell.noise_rms_n", 0.0, 50.0, "N"),
    ("laser.range_m", 1e-3, 1.0, "m"),
    ("laser.noise_rms_m", 0.0, 1e-2, "m"),
    ("laser.velocity_cutoff_hz", 0.1, 1e4, "Hz"),
    ("controller.tracking_time_s", 1e-5, 10.0, "s"),
    ("controller.current_min_a", 0.0, 14.0, "A"),
    ("controller.kp_a_per_n", 0.0, 10.0, "A/N"),
    ("controller.ki_a_per_n_s", 0.0, 1000.0, "A/(N·s)"),
    ("controller.kd_a_s_per_n", 0.0, 1.0, "A·s/N"),
    ("controller.derivative_filter_s", 0.0, 1.0, "s"),
    ("controller.rest_speed_m_s", 0.0, 1.0, "m/s"),
    ("controller.rest_force_n", 0.0, 250.0, "N"),
    ("feel.breakout_n", 0.0, 250.0, "N"),
    ("feel.gradient_n_per_m", 0.0, 1e6, "N/m"),
    ("feel.damping_n_s_per_m", 0.0, 1e5, "N·s/m"),
    ("feel.max_force_n", 0.0, 250.0, "N"),
    ("feel.low_n", 0.0, 250.0, "N"),
    ("feel.high_n", 0.0, 250.0, "N"),
    ("feel.period_s", 1e-3, 3600.0, "s"),
    ("feel_system.motor_max_force_n", 0.0, 1e4, "N"),
    ("feel_system.damping_n_s_per_m", 0.0, 1e5, "N·s/m"),
    ("feel_system.qbar_pa", 0.0, 1e6, "Pa"),
    ("feel_system.hybrid_k_n_per_m", 0.0, 1e6, "N/m"),
    ("feel_system.return_damping_n_s_per_m", 0.0, 1e5, "N·s/m"),
    ("aircraft.airspeed_m_s", 10.0, 300.0, "m/s"),
    ("aircraft.altitude_m", 0.0, 11_000.0, "m"),
    ("outer_loop.delay_s", 0.0, 1.0, "s"),
    ("outer_loop.gain", 0.0, 100.0, "stick rad per rad (or per g)"),
    ("outer_loop.lead_s", 0.0, 10.0, "s"),
    ("outer_loop.lag_s", 0.0, 100.0, "s"),
    ("outer_loop.integral_per_s", 0.0, 100.0, "stick rad per (unit·s)"),
    ("outer_loop.crossover_rad_s", 0.1, 10.0, "rad/s"),
    ("outer_loop.stick_lag_s", 0.0, 10.0, "s"),
    ("pilot.ramp_duration_s", 1e-3, 3600.0, "s"),
    ("pilot.frequency_hz", 1e-3, 100.0, "Hz"),
    ("pilot.cutoff_hz", 1e-3, 100.0, "Hz"),
];

/// The unit of a rate whose range ends at the physics rate.
const AT_MOST_PHYSICS: &str = "Hz (at most rig.physics_hz)";

/// `v` checked against the range [`RANGES`] declares for `field`.
fn num(src: &Source, v: &Num, field: &str) -> Result<f64, InputError> {
    let &(_, lo, hi, unit) = RANGES.iter().find(|r| r.0 == field).expect("a declared range");
    src.within(v, field, lo..=hi, unit)
}

/// A key that the variant chosen at `by` (named `name`) requires.
fn given<'a, T>(
    src: &Source,
    v: &'a Opt,
    field: &str,
    by: &Spanned<T>,
    name: &str,
) -> Result<&'a Num, InputError> {
    v.as_ref()
        .ok_or_else(|| src.err(by, field, format!("required by {name}")))
}

/// A number that the variant chosen at `by` (named `name`) requires, in its declared range.
fn need<T>(src: &Source, v: &Opt, field: &str, by: &Spanned<T>, name: &str) -> Result<f64, InputError> {
    num(src, given(src, v, field, by, name)?, field)
}

/// An optional number in its declared range, 0 when absent.
fn opt(src: &Source, v: &Opt, field: &str) -> Result<f64, InputError> {
    v.as_ref().map_or(Ok(0.0), |v| num(src, v, field))
}

/// Refuses the first key in the file, among `keys` (`section.key`), that is given but not in `used`.
fn unused(
    src: &Source,
    section: &str,
    keys: &[(&str, Option<&Num>)],
    used: &[&str],
    msg: &str,
) -> Result<(), InputError> {
    let first = keys
        .iter()
        .filter_map(|&(k, v)| v.map(|v| (k, v)))
        .filter(|(k, _)| !used.contains(k))
        .min_by_key(|(_, v)| v.span().start);
    match first {
        Some((k, v)) => Err(src.err(v, &format!("{section}.{k}"), msg)),
        None => Ok(()),
    }
}

/// A piecewise-linear schedule: at least one point, times finite and increasing, values in `[lo, hi]`.
fn schedule(
    src: &Source,
    pts: &Spanned<Vec<Point>>,
    field: &str,
    lo: f64,
    hi: f64,
    unit: &str,
) -> Result<Schedule, InputError> {
    let p = pts.get_ref();
    if p.is_empty() {
        return Err(src.err(pts, field, "needs at least one [t_s, value] point"));
    }
    for (i, q) in p.iter().enumerate() {
        let (t, v) = (q.0, q.1);
        if !(v.is_finite() && (lo..=hi).contains(&v)) {
            let msg = format!("point {i}: value {v} outside the allowed range [{lo}, {hi}] {unit}");
            return Err(src.err(pts, field, msg.trim_end()));
        }
        if !t.is_finite() || (i > 0 && t <= p[i - 1].0) {
            let msg = format!("point {i}: times must be finite and increasing");
            return Err(src.err(pts, field, msg));
        }
    }
    Ok(Schedule {
        points: p.iter().map(|q| (q.0, q.1)).collect(),
    })
}

/// The scenario in `src`, checked.
pub fn scenario(src: &Source) -> Result<Scenario, InputError> {
    let f: File = src.toml()?;
    let mut rig = RigConfig::new(src.named_file(&f.rig.urdf, "rig.urdf")?);
    let device_path = src.named_file(&f.device.file, "device.file")?;
    let model = f.controller.model.as_ref();
    let controller_model_path = model.map(|m| src.named_file(m, "controller.model")).transpose()?;
    let r = &f.rig;
    if let Some(hz) = &r.physics_hz {
        rig.physics_hz = num(src, hz, "rig.physics_hz")?;
    }
    rig.gravity = r.gravity.unwrap_or(rig.gravity);
    rig.solver_iterations = r.solver_iterations.unwrap_or(rig.solver_iterations);
    rig.pgs_iterations = r.pgs_iterations.unwrap_or(rig.pgs_iterations);
    rig.stop_natural_hz = r.stop_natural_hz.unwrap_or(rig.stop_natural_hz);
    rig.fuse_fixed_links = r.fuse_fixed_links.unwrap_or(rig.fuse_fixed_links);
    rig.planar_loop_rows = r.planar_loop_rows.unwrap_or(rig.planar_loop_rows);
    rig.roles = r.roles.clone().unwrap_or(rig.roles);
    let physics_hz = rig.physics_hz;

    let duration_s = num(src, &f.duration_s, "duration_s")?;
    let steps = duration_s * physics_hz;
    if steps > MAX_PHYSICS_STEPS {
        let msg = format!(
            "{duration_s} s at rig.physics_hz = {physics_hz} Hz is {steps:.0} physics steps: at most \
             {MAX_PHYSICS_STEPS:e} (a run that plots, flies an aircraft or runs from the library keeps a \
             row of ~300 bytes per step, 3 GB at the cap; a streamed one writes ~370 bytes of CSV a step and \
             takes about a minute per 10⁶ steps); shorten the run or lower the physics rate"
        );
        return Err(src.err(&f.duration_s, "duration_s", msg));
    }
    let seed = src.within_int(&f.seed, "seed", 0..=i64::MAX)? as u64;

    let (lc, la, daq) = (&f.load_cell, &f.laser, &f.daq);
    let sensors = SensorsConfig {
        load_cell: LoadCellConfig {
            range_n: num(src, &lc.range_n, "load_cell.range_n")?,
            gain: num(src, &lc.gain, "load_cell.gain")?,
            offset_n: num(src, &lc.offset_n, "load_cell.offset_n")?,
            noise_rms_n: num(src, &lc.noise_rms_n, "load_cell.noise_rms_n")?,
        },
        laser: LaserConfig {
            range_m: num(src, &la.range_m, "laser.range_m")?,
            noise_rms_m: num(src, &la.noise_rms_m, "laser.noise_rms_m")?,
            velocity_cutoff_hz: num(src, &la.velocity_cutoff_hz, "laser.velocity_cutoff_hz")?,
        },
        daq: DaqConfig {
            sample_rate_hz: within!(src, daq.sample_rate_hz, 1.0..=physics_hz, AT_MOST_PHYSICS)?,
            latency_samples: src.within_int(&daq.latency_samples, "daq.latency_samples", 0..=1000)? as usize,
            adc_bits: src.within_int(&daq.adc_bits, "daq.adc_bits", 0..=32)? as u32,
        },
    };

    let k = &f.controller;
    let anti_windup = match src.variant(&k.anti_windup, "controller.anti_windup")? {
        AntiWindupName::None => AntiWindup::None,
        AntiWindupName::Clamping => AntiWindup::Clamping,
        AntiWindupName::BackCalculation => {
            let (field, by) = ("controller.tracking_time_s", "anti_windup = \"back-calculation\"");
            let tracking_time_s = need(src, &k.tracking_time_s, field, &k.anti_windup, by)?;
            AntiWindup::BackCalculation { tracking_time_s }
        }
    };
    let out_min = num(src, &k.current_min_a, "controller.current_min_a")?;
    let saturation = "A (the driver saturates at 14 A)";
    let out_max = within!(src, f.controller.current_max_a, out_min..=14.0, saturation)?;
    let controller = ControllerConfig {
        gains: PidGains {
            kp: num(src, &k.kp_a_per_n, "controller.kp_a_per_n")?,
            ki: num(src, &k.ki_a_per_n_s, "controller.ki_a_per_n_s")?,
            kd: num(src, &k.kd_a_s_per_n, "controller.kd_a_s_per_n")?,
            derivative_filter_s: num(src, &k.derivative_filter_s, "controller.derivative_filter_s")?,
            out_min,
            out_max,
            anti_windup,
        },
        feedforward: k.feedforward,
        rest_speed_m_s: num(src, &k.rest_speed_m_s, "controller.rest_speed_m_s")?,
        rest_force_n: num(src, &k.rest_force_n, "controller.rest_force_n")?,
    };

    let feel = feel_law(src, &f.feel, duration_s, f.aircraft.is_some())?;
    let aircraft = f
        .aircraft
        .as_ref()
        .map(|a| aircraft(src, a, physics_hz))
        .transpose()?;
    let outer_loop = f.outer_loop.as_ref().map(|o| outer_loop(src, o)).transpose()?;
    let (feel_system, feel_system_file) = match &f.feel_system {
        Some(fs) => feel_system(src, fs, aircraft.is_some())?,
        None => (FeelSystemConfig::default(), None),
    };
    let signal = src.variant(&f.pilot.signal, "pilot.signal")?;
    match (&f.outer_loop, signal == SignalName::OuterLoop) {
        (Some(o), false) => {
            let msg = "an `[outer_loop]` section needs `pilot.signal = \"outer-loop\"`";
            return Err(src.err(&o.loop_kind, "outer_loop", msg));
        }
        (None, true) => {
            let msg = "`outer-loop` needs an `[outer_loop]` section (the pilot's loop on the aircraft)";
            return Err(src.err(&f.pilot.signal, "pilot.signal", msg));
        }
        (Some(o), true) if aircraft.is_none() => {
            let msg = "the pilot's outer loop needs an `[aircraft]` section to fly";
            return Err(src.err(&o.loop_kind, "outer_loop", msg));
        }
        // A force task's outer loop commands the grip force: only a fly-by-wire aircraft takes it, which is
        // known once the aircraft is opened (`sim::Flight::open` refuses it on a mechanical stick).
        _ => {}
    }
    let pilot = pilot(src, &f.pilot, signal, duration_s, 1.0 / physics_hz, seed)?;
    let (p, a) = (&f.pilot, f.aircraft.as_ref());
    // A key not written: a line of its table (a required key's).
    let lines = KeyLines {
        physics_hz: src.line_at(r.physics_hz.as_ref().map_or(r.urdf.span(), |v| v.span())),
        airspeed: a.map_or(1, |a| src.line_at(a.airspeed_m_s.span())),
        aircraft_model: a.map_or(1, |a| src.line_at(a.model.span())),
        feel_law: src.line_at(f.feel.law.span()),
        pilot_frequency: src.line_at(p.frequency_hz.as_ref().map_or(p.signal.span(), |v| v.span())),
        device_file: src.line_at(f.device.file.span()),
        controller_model: src.line_at(f.controller.model.as_ref().unwrap_or(&f.device.file).span()),
    };
    Ok(Scenario {
        path: src.path.clone(),
        lines,
        name: f.name,
        duration_s,
        seed,
        rig,
        device_path,
        controller_model_path,
        sensors,
        controller,
        feel,
        pilot,
        faults: super::faults::schedule(src, &f.fault, duration_s)?,
        aircraft,
        outer_loop,
        feel_system,
        feel_system_file,
    })
}

fn feel_law(
    src: &Source,
    fl: &FeelSection,
    duration_s: f64,
    has_aircraft: bool,
) -> Result<FeelLaw, InputError> {
    let name = src.variant(&fl.law, "feel.law")?;
    let by = &format!("`{}`", fl.law.get_ref().name());
    let need = |v: &Opt, key: &str| need(src, v, &format!("feel.{key}"), &fl.law, by);
    let (law, used): (_, &[&str]) = match name {
        LawName::Spring => (
            FeelLaw::Spring {
                breakout_n: need(&fl.breakout_n, "breakout_n")?,
                gradient_n_per_m: need(&fl.gradient_n_per_m, "gradient_n_per_m")?,
                damping_n_s_per_m: need(&fl.damping_n_s_per_m, "damping_n_s_per_m")?,
                max_force_n: need(&fl.max_force_n, "max_force_n")?,
            },
            &[
                "breakout_n",
                "gradient_n_per_m",
                "damping_n_s_per_m",
                "max_force_n",
            ],
        ),
        LawName::ForceSteps => (
            FeelLaw::ForceSteps {
                low_n: need(&fl.low_n, "low_n")?,
                high_n: need(&fl.high_n, "high_n")?,
                start_s: src.within(
                    given(src, &fl.start_s, "feel.start_s", &fl.law, by)?,
                    "feel.start_s",
                    0.0..=duration_s,
                    "s (within duration_s)",
                )?,
                period_s: need(&fl.period_s, "period_s")?,
            },
            &["low_n", "high_n", "start_s", "period_s"],
        ),
        LawName::Aircraft if !has_aircraft => {
            let msg = "`aircraft` needs an `[aircraft]` section (the aircraft whose stick force is felt)";
            return Err(src.err(&fl.law, "feel.law", msg));
        }
        LawName::Aircraft => (FeelLaw::Target { force_n: 0.0 }, &[]),
    };
    unused(src, "feel", &fl.keys(), used, &format!("not used by {by}"))?;
    Ok(law)
}

fn feel_system(
    src: &Source,
    fs: &FeelSystemSection,
    has_aircraft: bool,
) -> Result<(FeelSystemConfig, Option<PathBuf>), InputError> {
    let kind = FeelKind::from_name(fs.kind.get_ref()).ok_or_else(|| {
        let msg = format!("`{}` is not one of: {}", fs.kind.get_ref(), FeelKind::names());
        src.err(&fs.kind, "feel_system.kind", msg)
    })?;
    let by = format!("`{}`", kind.name());
    let need = |v: &Opt, key: &str| need(src, v, &format!("feel_system.{key}"), &fs.kind, &by);
    // The keys each kind takes; any other is refused.
    let used: &[&str] = match kind {
        FeelKind::Active => &["motor_max_force_n", "damping_n_s_per_m"],
        FeelKind::Mr => &[],
        FeelKind::MrSpring => &["springs", "hybrid_k_n_per_m", "return_damping_n_s_per_m"],
        FeelKind::QFeel => &["springs", "damping_n_s_per_m", "qbar_pa"],
        FeelKind::CentringSpring | FeelKind::VariableGradientSpring => &["springs", "damping_n_s_per_m"],
    };
    if let Some(p) = fs.springs.as_ref().filter(|_| !used.contains(&"springs")) {
        return Err(src.err(p, "feel_system.springs", format!("not used by {by}")));
    }
    if let Some(p) = fs.model.as_ref().filter(|_| kind != FeelKind::Active) {
        return Err(src.err(p, "feel_system.model", format!("not used by {by}")));
    }
    unused(src, "feel_system", &fs.keys(), used, &format!("not used by {by}"))?;
    if kind == FeelKind::Active {
        return active_stick(src, fs, &by);
    }
    let Some(p) = &fs.springs else {
        if kind == FeelKind::Mr {
            return Ok((FeelSystemConfig::default(), None));
        }
        let msg = format!("required by {by} (a feel-spring file such as models/feel-springs.toml)");
        return Err(src.err(&fs.kind, "feel_system.springs", msg));
    };
    let (path, springs) = src.load_named(p, "feel_system.springs", FeelSprings::load)?;
    let damping = match kind.has_coil() {
        true => 0.0,
        false => need(&fs.damping_n_s_per_m, "damping_n_s_per_m")?,
    };
    let (q_from_aircraft, qbar) = match (&fs.qbar_pa, kind) {
        (Some(q), _) => (false, num(src, q, "feel_system.qbar_pa")?),
        (None, FeelKind::QFeel) if has_aircraft => (true, 0.0),
        (None, FeelKind::QFeel) => {
            let msg = "required by `q_feel` without an `[aircraft]` (whose dynamic pressure it would follow)";
            return Err(src.err(&fs.kind, "feel_system.qbar_pa", msg));
        }
        (None, _) => (false, 0.0),
    };
    let (hybrid_k, ret) = match kind {
        FeelKind::MrSpring => (
            need(&fs.hybrid_k_n_per_m, "hybrid_k_n_per_m")?,
            need(&fs.return_damping_n_s_per_m, "return_damping_n_s_per_m")?,
        ),
        _ => (0.0, 0.0),
    };
    let hybrid = CentringSpring { k_n_per_m: hybrid_k };
    let mut config = FeelSystemConfig::from_springs(kind, &springs, qbar, hybrid, damping, ret);
    config.q_from_aircraft = q_from_aircraft;
    Ok((config, Some(path)))
}

/// `kind = "active"`: the modelled stick of an active-stick file (`model`, else the built-in
/// `models/active-stick.toml`), or with `motor_max_force_n` and `damping_n_s_per_m` an ideal clamped force
/// source.
fn active_stick(
    src: &Source,
    fs: &FeelSystemSection,
    by: &str,
) -> Result<(FeelSystemConfig, Option<PathBuf>), InputError> {
    let ideal = [
        ("motor_max_force_n", &fs.motor_max_force_n),
        ("damping_n_s_per_m", &fs.damping_n_s_per_m),
    ];
    let given = ideal.iter().find_map(|(key, v)| v.as_ref().map(|v| (*key, v)));
    match (&fs.model, given) {
        (Some(_), Some((key, v))) => {
            let msg = "not used with `feel_system.model` (the active-stick file gives the force limit and the friction)";
            Err(src.err(v, &format!("feel_system.{key}"), msg))
        }
        (_, Some(_)) => {
            let by = &format!("{by} without `model` (the ideal force source)");
            let need = |v: &Opt, key: &str| need(src, v, &format!("feel_system.{key}"), &fs.kind, by);
            let max_force = need(&fs.motor_max_force_n, "motor_max_force_n")?;
            let damping = need(&fs.damping_n_s_per_m, "damping_n_s_per_m")?;
            Ok((FeelSystemConfig::active(max_force, damping), None))
        }
        (Some(p), None) => {
            let (path, stick) = src.load_named(p, "feel_system.model", ActiveStickConfig::load)?;
            Ok((FeelSystemConfig::active_stick(stick), Some(path)))
        }
        (None, None) => {
            let path = crate::builtin::by_file_name("active-stick.toml").expect("a built-in file");
            let stick = ActiveStickConfig::load(&path)
                .map_err(|e| src.err(&fs.kind, "feel_system.kind", e.to_string()))?;
            Ok((FeelSystemConfig::active_stick(stick), None))
        }
    }
}

fn aircraft(src: &Source, a: &AircraftSection, physics_hz: f64) -> Result<AircraftConfig, InputError> {
    let throttle = match &a.throttle {
        None => Schedule {
            points: vec![(0.0, 1.0)],
        },
        Some(pts) => schedule(
            src,
            pts,
            "aircraft.throttle",
            0.0,
            3.0,
            "(ratio of the trim throttle)",
        )?,
    };
    let model = match a.model.get_ref().split_once(':') {
        // A JSBSim aircraft folder is found as the scenario's other files are (beside it first).
        Some(("jsbsim", name)) if crate::aero::backend::jsbsim_folder(name).is_some() => {
            let dir = src.path.parent().unwrap_or(Path::new("."));
            format!(
                "jsbsim:{}",
                crate::builtin::resolve(dir, Path::new(name)).display()
            )
        }
        _ => a.model.get_ref().clone(),
    };
    let file = match model.split_once(':') {
        Some(("jsbsim", name)) => crate::aero::backend::model_file(name),
        Some((other, _)) => {
            let msg = format!("unknown backend `{other}` (use `<name>` or `jsbsim:<name>`)");
            return Err(src.err(&a.model, "aircraft.model", msg));
        }
        None => crate::aero::AircraftModel::builtin(&model),
    };
    file.map_err(|e| src.err(&a.model, "aircraft.model", e.to_string()))?;
    Ok(AircraftConfig {
        model,
        airspeed_m_s: num(src, &a.airspeed_m_s, "aircraft.airspeed_m_s")?,
        altitude_m: num(src, &a.altitude_m, "aircraft.altitude_m")?,
        rate_hz: match &a.rate_hz {
            Some(r) => src.within(r, "aircraft.rate_hz", 10.0..=physics_hz, AT_MOST_PHYSICS)?,
            None => 120.0_f64.min(physics_hz),
        },
        throttle,
    })
}

fn outer_loop(src: &Source, o: &OuterLoopSection) -> Result<OuterLoopConfig, InputError> {
    let loop_kind = src.variant(&o.loop_kind, "outer_loop.loop")?;
    let delay_s = num(src, &o.delay_s, "outer_loop.delay_s")?;
    let pilot = match (&o.gain, &o.crossover_rad_s) {
        (Some(gain), None) => {
            if let Some(v) = &o.stick_lag_s {
                let msg = "only with `crossover_rad_s` (an adapted pilot)";
                return Err(src.err(v, "outer_loop.stick_lag_s", msg));
            }
            PilotDesign::Given(CrossoverPilotConfig {
                gain: num(src, gain, "outer_loop.gain")?,
                lead_s: opt(src, &o.lead_s, "outer_loop.lead_s")?,
                lag_s: opt(src, &o.lag_s, "outer_loop.lag_s")?,
                delay_s,
                integral_per_s: opt(src, &o.integral_per_s, "outer_loop.integral_per_s")?,
                stick_min_rad: f64::NEG_INFINITY,
                stick_max_rad: f64::INFINITY,
            })
        }
        (None, Some(wc)) => {
            let keys = [
                ("lead_s", o.lead_s.as_ref()),
                ("lag_s", o.lag_s.as_ref()),
                ("integral_per_s", o.integral_per_s.as_ref()),
            ];
            let msg = "the adapted pilot (`crossover_rad_s`) chooses its own equalisation; give `gain` instead to set it";
            unused(src, "outer_loop", &keys, &[], msg)?;
            let by = "`crossover_rad_s` (the lag from stick command to stick, s)";
            PilotDesign::Adapted {
                crossover_rad_s: num(src, wc, "outer_loop.crossover_rad_s")?,
                delay_s,
                stick_lag_s: need(src, &o.stick_lag_s, "outer_loop.stick_lag_s", wc, by)?,
            }
        }
        (Some(g), Some(_)) => {
            let msg =
                "give either `gain` (a pilot with given gains) or `crossover_rad_s` (adapted), not both";
            return Err(src.err(g, "outer_loop.gain", msg));
        }
        (None, None) => {
            let msg = "needs `gain` (given gains) or `crossover_rad_s` (a pilot adapted to the aircraft)";
            return Err(src.err(&o.loop_kind, "outer_loop.gain", msg));
        }
    };
    let command = match loop_kind {
        PilotLoop::Pitch => {
            let s = schedule(src, &o.command, "outer_loop.command", -30.0, 30.0, "deg")?;
            Schedule {
                points: s.points.iter().map(|&(t, v)| (t, v.to_radians())).collect(),
            }
        }
        PilotLoop::LoadFactor => schedule(src, &o.command, "outer_loop.command", -1.0, 4.0, "g")?,
    };
    Ok(OuterLoopConfig {
        loop_kind,
        pilot,
        command,
    })
}

fn pilot(
    src: &Source,
    p: &PilotSection,
    signal: SignalName,
    duration_s: f64,
    dt_s: f64,
    seed: u64,
) -> Result<PilotConfig, InputError> {
    let (hand_path, hand) = src.load_named(&p.model, "pilot.model", super::hand::load)?;
    let task = src.variant(&p.task, "pilot.task")?;
    let by = format!("signal = \"{}\"", p.signal.get_ref().name());
    // Command values carry the task's unit: `_rad` (stick angle) for position, `_n` (grip force) for force.
    let (unit, lim, other) = match task {
        Task::Position => ("rad", 1.0, "n"),
        Task::Force => ("n", 250.0, "rad"),
    };
    let keys = p.keys();
    let get = |key: String| keys.iter().find(|(k, _)| *k == key).and_then(|(_, v)| *v);
    let val = |name: &str| -> Result<Option<f64>, InputError> {
        if let Some(t) = get(format!("{name}_{other}")) {
            let msg = format!("a {} task takes `{name}_{unit}`", p.task.get_ref().name());
            return Err(src.err(t, &format!("pilot.{name}_{other}"), msg));
        }
        get(format!("{name}_{unit}"))
            .map(|v| src.within(v, &format!("pilot.{name}_{unit}"), -lim..=lim, unit))
            .transpose()
    };
    let need_v = |name: &str| -> Result<f64, InputError> {
        let field = format!("pilot.{name}_{unit}");
        val(name)?.ok_or_else(|| src.err(&p.signal, &field, format!("required by {by}")))
    };
    let need_t = |v: &Opt, key: &str| need(src, v, key, &p.signal, &by);
    let within_run =
        |v: &Opt, key: &str| src.within(given(src, v, key, &p.signal, &by)?, key, 0.0..=duration_s, "s");
    let offset = || Ok::<_, InputError>(val("offset")?.unwrap_or(0.0));
    let command = match signal {
        SignalName::Hold => Signal::Hold {
            value: need_v("value")?,
        },
        SignalName::Step => Signal::Step {
            initial: need_v("initial")?,
            last: need_v("final")?,
            at_s: within_run(&p.at_s, "pilot.at_s")?,
        },
        SignalName::Ramp => Signal::Ramp {
            from: need_v("from")?,
            to: need_v("to")?,
            start_s: within_run(&p.start_s, "pilot.start_s")?,
            duration_s: need_t(&p.ramp_duration_s, "pilot.ramp_duration_s")?,
        },
        SignalName::Sine => Signal::Sine {
            offset: offset()?,
            amplitude: need_v("amplitude")?,
            frequency_hz: need_t(&p.frequency_hz, "pilot.frequency_hz")?,
        },
        SignalName::Triangle => Signal::Triangle {
            offset: offset()?,
            amplitude: need_v("amplitude")?,
            frequency_hz: need_t(&p.frequency_hz, "pilot.frequency_hz")?,
        },
        SignalName::Random => Signal::random(
            offset()?,
            need_v("rms")?,
            need_t(&p.cutoff_hz, "pilot.cutoff_hz")?,
            duration_s,
            dt_s,
            seed ^ 0x005e_ed0f_9170,
        ),
        // The stick command comes from `[outer_loop]`.
        SignalName::OuterLoop => Signal::Hold { value: 0.0 },
    };
    // Keys of another signal are refused (the first one in the file is named).
    let used = signal.keys();
    let base = |k: &str| {
        k.strip_suffix("_rad")
            .or_else(|| k.strip_suffix("_n"))
            .unwrap_or(k)
            .to_string()
    };
    let given: Vec<(&str, Option<&Num>)> = keys
        .iter()
        .filter(|(k, _)| !used.contains(&base(k).as_str()))
        .copied()
        .collect();
    let msg = format!("not used by {by} (it takes: {})", used.join(", "));
    unused(src, "pilot", &given, &[], &msg)?;
    Ok(PilotConfig {
        hand_path,
        hand,
        task,
        command,
    })
}
