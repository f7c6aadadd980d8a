//! The active stick as control-loading systems build it: a brushless servo motor on the push rod through a
//! gearing, its driver's current loop, a force sensor at the grip, and an admittance loop that turns the
//! measured grip force into the motion the feel law asks for.
//!
//! ```text
//!  grip force ─► sensor ─► virtual model ─► x_r, v_r ─► PD ─► i* ─► current PI ─► V ─► R, L ─► i ─► Kt·N ─► push rod
//!  (pilot)       (noise,   M_v ẍ_r = F_h      (admittance,        (current loop,  (≤ supply)          (torque limit
//!                 bias)      − F_law(x_r, v_r)   rate_hz)           current_loop_hz)                     = current limit)
//!                                         ▲ encoder x, v (motor shaft / N) ◄──────────────────────────────┘
//! ```
//!
//! **Admittance, not impedance**: the measured grip force drives a virtual mass–spring–damper (the feel law)
//! whose motion a stiff position loop makes the motor track, which hides the geared motor's rotor inertia
//! and friction inside the position loop (an impedance loop would have to cancel them through a force loop).
//!
//! Both loops tick inside the rig's physics step, the encoder seeing the push rod move at the step's
//! starting velocity. The motor's force on the push rod is its electromagnetic force averaged over the step
//! minus the rotor's inertial force (`J N² a`); the rotor's viscous friction (`b N²`) is the rig's viscous
//! damper ([`ActiveStickConfig::rod_damping_n_s_per_m`]). Faults ([`crate::faults`]) act on the stick's own
//! paths: `driver_stuck` freezes the motor current, `coil_open` removes it, the `load_cell_*` faults act on
//! the grip sensor, `displacement_dropout` holds the encoder; `latency_spike` has no effect here.
//!
//! [`margins`] gives both loops' gain and phase margins from their linearised responses; [`motion_bandwidth_hz`]
//! measures the motion loop's bandwidth by a sine sweep of the nonlinear, sampled model.

use nalgebra::Complex;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::FeelLaw;
use crate::faults::{FaultKind, FaultSchedule};
use crate::signal::quantise;

/// The motor's catalogue data (SI units at the motor shaft).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotorParams {
    /// Torque constant, N·m/A (also the back-EMF constant, V·s/rad).
    pub torque_constant_nm_per_a: f64,
    /// Winding resistance, phase to phase, Ω.
    pub resistance_ohm: f64,
    /// Winding inductance, phase to phase, H.
    pub inductance_h: f64,
    /// Rotor inertia, kg·m².
    pub rotor_inertia_kg_m2: f64,
    /// Viscous friction at the shaft, N·m·s/rad.
    pub viscous_nm_s_per_rad: f64,
}

impl MotorParams {
    /// Electrical time constant `L / R`, s.
    pub fn electrical_time_constant_s(&self) -> f64 {
        self.inductance_h / self.resistance_ohm
    }
}

/// The driver: supply, current limit (the torque limit) and its PI current loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriverParams {
    /// Supply voltage: the PI's output limit, V.
    pub supply_v: f64,
    /// Peak current the driver allows, A (torque limit = `Kt ·` this).
    pub current_limit_a: f64,
    /// Current loop rate, Hz.
    pub current_loop_hz: f64,
    /// Proportional gain, V/A.
    pub kp_v_per_a: f64,
    /// Integral gain, V/(A·s).
    pub ki_v_per_a_s: f64,
}

/// The force sensor at the grip: `reading = gain · F + offset + noise`, clipped at ±`range_n`, quantised.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GripSensor {
    /// Full scale, N: readings clip at ±this.
    pub range_n: f64,
    /// Residual calibration gain (1: perfect).
    pub gain: f64,
    /// Residual calibration offset, N.
    pub offset_n: f64,
    /// RMS noise, N.
    pub noise_rms_n: f64,
    /// ADC resolution over the range, bits.
    pub adc_bits: u32,
}

/// The admittance loop: the virtual model's own mass and damping, the motion loop's PD and the encoder.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdmittanceParams {
    /// Loop rate, Hz.
    pub rate_hz: f64,
    /// Virtual mass at the push rod, kg.
    pub virtual_mass_kg: f64,
    /// Virtual damping at the push rod (added to the feel law's own), N·s/m.
    pub virtual_damping_n_s_per_m: f64,
    /// Half-width of the band over which the law's breakout rises from 0 to full, m (a breakout is a
    /// force step at the centre; the virtual model needs it continuous).
    pub breakout_band_m: f64,
    /// Virtual travel limit, ± m at the push rod.
    pub travel_m: f64,
    /// Position gain of the motion loop, N/m.
    pub kp_n_per_m: f64,
    /// Velocity gain of the motion loop, N·s/m.
    pub kd_n_s_per_m: f64,
    /// Cut-off of the encoder's differentiated velocity, Hz.
    pub velocity_filter_hz: f64,
    /// Encoder counts per motor revolution.
    pub encoder_counts_per_rev: f64,
}

/// A whole active stick (`models/active-stick.toml`, read by `input::motor`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActiveStickConfig {
    /// The motor.
    pub motor: MotorParams,
    /// The motor's current driver.
    pub driver: DriverParams,
    /// Gearing, motor rad per metre of push rod.
    pub gear_rad_per_m: f64,
    /// The grip force sensor.
    pub sensor: GripSensor,
    /// The admittance loop.
    pub admittance: AdmittanceParams,
    /// Moving mass at the push rod without the rotor, kg (stick, linkage and piston; the linearised
    /// model's plant).
    pub load_mass_kg: f64,
}

impl ActiveStickConfig {
    /// Force on the push rod per ampere, N/A.
    pub fn force_per_amp_n(&self) -> f64 {
        self.motor.torque_constant_nm_per_a * self.gear_rad_per_m
    }

    /// The motor's force limit on the push rod, N.
    pub fn max_force_n(&self) -> f64 {
        self.force_per_amp_n() * self.driver.current_limit_a
    }

    /// The rotor's inertia reflected to the push rod, kg.
    pub fn rotor_mass_kg(&self) -> f64 {
        self.motor.rotor_inertia_kg_m2 * self.gear_rad_per_m.powi(2)
    }

    /// The rotor's viscous friction reflected to the push rod, N·s/m.
    pub fn rod_damping_n_s_per_m(&self) -> f64 {
        self.motor.viscous_nm_s_per_rad * self.gear_rad_per_m.powi(2)
    }

    /// Current-loop ticks per admittance tick: a whole number, at least 1.
    fn inner_per_outer(&self) -> f64 {
        (self.driver.current_loop_hz / self.admittance.rate_hz)
            .round()
            .max(1.0)
    }

    /// The current loop's rate, Hz: a whole multiple of the admittance rate.
    fn inner_rate_hz(&self) -> f64 {
        self.admittance.rate_hz * self.inner_per_outer()
    }

    /// The same stick with every loop gain scaled (`current`: the current PI's; `outer`: the PD's).
    pub fn with_gains_scaled(mut self, current: f64, outer: f64) -> Self {
        self.driver.kp_v_per_a *= current;
        self.driver.ki_v_per_a_s *= current;
        self.admittance.kp_n_per_m *= outer;
        self.admittance.kd_n_s_per_m *= outer;
        self
    }
}

/// What the stick's loop needs from the rig at one physics step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RodState {
    /// Pilot's force at the grip (what the grip sensor measures), N along the grip path.
    pub grip_force_n: f64,
    /// Grip force to push-rod force, N/N (`grip arm / gearing` at the present angle).
    pub grip_to_rod: f64,
    /// Push-rod position, m.
    pub x_m: f64,
    /// Push-rod velocity, m/s.
    pub v_m_s: f64,
}

/// The stick's state: electrical, controller and virtual-model states, and the faults' held values.
#[derive(Debug, Clone)]
pub struct ActiveStick {
    cfg: ActiveStickConfig,
    /// Motor current, A.
    current_a: f64,
    /// Voltage applied over the present current-loop period (computed at the previous tick), V.
    volts: f64,
    integ_v: f64,
    current_ref_a: f64,
    /// Virtual model.
    x_r_m: f64,
    v_r_m_s: f64,
    enc_m: Option<f64>,
    v_filt_m_s: f64,
    inner_ticks: u64,
    /// Current-loop ticks per admittance tick (`current_loop_hz / rate_hz`, ≥ 1).
    inner_per_outer: u64,
    /// The current loop's period, s.
    inner_dt_s: f64,
    held_current_a: Option<f64>,
    held_sensor_n: Option<f64>,
    last_sensor_n: f64,
    last_rod_v_m_s: Option<f64>,
    rod_accel_m_s2: f64,
    rng: ChaCha8Rng,
    /// Last measured grip force at the push rod, N (for logs and tests).
    pub sensed_rod_force_n: f64,
    /// Electromagnetic force on the push rod over the last step, N.
    pub motor_force_n: f64,
}

impl ActiveStick {
    /// A stick at rest at the centre; `seed` seeds the grip sensor's noise.
    pub fn new(cfg: ActiveStickConfig, seed: u64) -> Self {
        let ratio = cfg.inner_per_outer() as u64;
        Self {
            cfg,
            current_a: 0.0,
            volts: 0.0,
            integ_v: 0.0,
            current_ref_a: 0.0,
            x_r_m: 0.0,
            v_r_m_s: 0.0,
            enc_m: None,
            v_filt_m_s: 0.0,
            inner_ticks: 0,
            inner_per_outer: ratio,
            inner_dt_s: 1.0 / cfg.inner_rate_hz(),
            held_current_a: None,
            held_sensor_n: None,
            last_sensor_n: 0.0,
            last_rod_v_m_s: None,
            rod_accel_m_s2: 0.0,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0x00ac_715e),
            sensed_rod_force_n: 0.0,
            motor_force_n: 0.0,
        }
    }

    /// The grip sensor's reading at `t_s`, N along the grip path, after its faults.
    fn read_sensor(&mut self, t_s: f64, true_n: f64, faults: &FaultSchedule) -> f64 {
        let s = self.cfg.sensor;
        let n: f64 = StandardNormal.sample(&mut self.rng);
        let healthy = quantise(
            s.gain * true_n + s.offset_n + s.noise_rms_n * n,
            s.range_n,
            s.adc_bits,
        );
        let out = if faults.active(FaultKind::LoadCellZero, t_s).is_some() {
            0.0
        } else if faults.active(FaultKind::LoadCellStuck, t_s).is_some() {
            *self.held_sensor_n.get_or_insert(self.last_sensor_n)
        } else {
            self.held_sensor_n = None;
            healthy
        };
        self.last_sensor_n = healthy;
        let m: f64 = StandardNormal.sample(&mut self.rng);
        match faults.active(FaultKind::LoadCellNoisy, t_s) {
            Some(f) => out + f.noise_rms_n * m,
            None => out,
        }
    }

    /// One admittance tick at `t_s` with the rod at `x_m` (true, before the encoder): sensor, virtual
    /// model, motion loop; sets the current reference.
    fn outer_tick(&mut self, t_s: f64, law: &FeelLaw, rod: &RodState, x_m: f64, faults: &FaultSchedule) {
        let a = self.cfg.admittance;
        let dt = 1.0 / a.rate_hz;
        let grip = self.read_sensor(t_s, rod.grip_force_n, faults);
        let f_h = grip * rod.grip_to_rod;
        self.sensed_rod_force_n = f_h;
        // Virtual model, semi-implicit Euler.
        // The law at the virtual model's state, its breakout continuous over the band (the virtual mass
        // integrates it).
        let (x_r, v_r) = (self.x_r_m, self.v_r_m_s);
        let f_law = law.force_n(t_s, x_r, v_r, super::law::sgn(v_r), Some(a.breakout_band_m));
        let acc = (f_h - f_law - a.virtual_damping_n_s_per_m * self.v_r_m_s) / a.virtual_mass_kg;
        self.v_r_m_s += acc * dt;
        self.x_r_m += self.v_r_m_s * dt;
        if self.x_r_m.abs() > a.travel_m {
            self.x_r_m = a.travel_m * self.x_r_m.signum();
            self.v_r_m_s = 0.0;
        }
        // Encoder: the motor shaft's angle in whole counts, as push-rod travel.
        let count_m = std::f64::consts::TAU / a.encoder_counts_per_rev / self.cfg.gear_rad_per_m;
        let fresh = (x_m / count_m).round() * count_m;
        let enc = match (faults.active(FaultKind::DisplacementDropout, t_s), self.enc_m) {
            (Some(_), Some(held)) => held,
            _ => fresh,
        };
        let prev = self.enc_m.unwrap_or(enc);
        self.enc_m = Some(enc);
        let alpha = (-std::f64::consts::TAU * a.velocity_filter_hz * dt).exp();
        self.v_filt_m_s = alpha * self.v_filt_m_s + (1.0 - alpha) * (enc - prev) / dt;
        let force = a.kp_n_per_m * (self.x_r_m - enc) + a.kd_n_s_per_m * (self.v_r_m_s - self.v_filt_m_s);
        let lim = self.cfg.driver.current_limit_a;
        self.current_ref_a = (force / self.cfg.force_per_amp_n()).clamp(-lim, lim);
    }

    /// One current-loop tick at `t_s`: the PI's new voltage (applied from the next tick), then the winding
    /// integrated exactly over the period with the present voltage and back-EMF. Returns the period's
    /// mean current, A.
    fn inner_tick(&mut self, t_s: f64, shaft_rad_s: f64, faults: &FaultSchedule) -> f64 {
        let (m, d, dt) = (self.cfg.motor, self.cfg.driver, self.inner_dt_s);
        if faults.active(FaultKind::DriverStuck, t_s).is_some() {
            let i = *self.held_current_a.get_or_insert(self.current_a);
            self.current_a = i;
            return i;
        }
        self.held_current_a = None;
        if faults.active(FaultKind::CoilOpen, t_s).is_some() {
            self.current_a = 0.0;
            self.integ_v = 0.0;
            self.volts = 0.0;
            return 0.0;
        }
        let e = self.current_ref_a - self.current_a;
        let u = d.kp_v_per_a * e + self.integ_v;
        let next_volts = u.clamp(-d.supply_v, d.supply_v);
        // Conditional integration: the integral stops while the output is saturated the same way.
        if u == next_volts || (u > next_volts) != (e > 0.0) {
            self.integ_v += d.ki_v_per_a_s * dt * e;
        }
        let tau = m.electrical_time_constant_s();
        let i_ss = (self.volts - m.torque_constant_nm_per_a * shaft_rad_s) / m.resistance_ohm;
        let decay = (-dt / tau).exp();
        let i0 = self.current_a;
        self.current_a = i_ss + (i0 - i_ss) * decay;
        self.volts = next_volts;
        i_ss + (i0 - i_ss) * (1.0 - decay) * tau / dt
    }

    /// Advance the stick's loops over one physics step `[t_s, t_s + dt_s)` with the rig in state `rod`;
    /// returns the motor's force on the push rod over the step, N along +x (electromagnetic force minus the
    /// rotor's inertial force).
    pub fn step(
        &mut self,
        t_s: f64,
        dt_s: f64,
        law: &FeelLaw,
        rod: &RodState,
        faults: &FaultSchedule,
    ) -> f64 {
        if let Some(v0) = self.last_rod_v_m_s {
            self.rod_accel_m_s2 = (rod.v_m_s - v0) / dt_s;
        }
        self.last_rod_v_m_s = Some(rod.v_m_s);
        let t_inner = self.inner_dt_s;
        let (mut sum, mut n) = (0.0, 0u32);
        loop {
            let t = self.inner_ticks as f64 * t_inner;
            if t >= t_s + dt_s - 1e-6 * t_inner {
                break;
            }
            let x = rod.x_m + rod.v_m_s * (t - t_s).max(0.0);
            if self.inner_ticks.is_multiple_of(self.inner_per_outer) {
                self.outer_tick(t, law, rod, x, faults);
            }
            sum += self.inner_tick(t, rod.v_m_s * self.cfg.gear_rad_per_m, faults);
            n += 1;
            self.inner_ticks += 1;
        }
        let i_mean = if n > 0 { sum / f64::from(n) } else { self.current_a };
        self.motor_force_n = i_mean * self.cfg.force_per_amp_n();
        self.motor_force_n - self.cfg.rotor_mass_kg() * self.rod_accel_m_s2
    }
}

// ---------------------------------------------------------------------------------------------------
// Linearised loops: frequency responses, margins, bandwidth

/// Gain and phase margins of one loop, from its open-loop frequency response on a grid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margins {
    /// Gain crossover, Hz (|L| = 1).
    pub crossover_hz: f64,
    /// Phase margin at the gain crossover, degrees.
    pub phase_margin_deg: f64,
    /// Gain margin at the first phase crossover (the phase falling through −180°), dB: negative when the
    /// loop is unstable; `inf` if the phase stays above −180° up to the loop's Nyquist frequency.
    pub gain_margin_db: f64,
    /// That phase crossover, Hz (NaN if none).
    pub phase_crossover_hz: f64,
}

/// Both loops' margins.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoopMargins {
    /// The current loop's margins.
    pub current: Margins,
    /// The outer (admittance) loop's margins.
    pub outer: Margins,
}

/// The current loop's open-loop response at `w` rad/s: discrete PI, one period of computation delay,
/// and the winding `1/(L s + R)` sampled exactly through the zero-order hold (back-EMF neglected: the
/// mechanics are three decades slower).
pub fn current_open_loop(cfg: &ActiveStickConfig, w: f64) -> Complex<f64> {
    let (m, d) = (cfg.motor, cfg.driver);
    let t = 1.0 / cfg.inner_rate_hz();
    let z = Complex::from_polar(1.0, w * t);
    let a = (-t / m.electrical_time_constant_s()).exp();
    let plant = Complex::from((1.0 - a) / m.resistance_ohm) / (z - a);
    let pi = Complex::from(d.kp_v_per_a) + Complex::from(d.ki_v_per_a_s * t) / (z - 1.0);
    pi * plant / z
}

/// The outer (motion) loop's open-loop response at `w` rad/s: the discrete PD on the encoder (filtered
/// difference), the zero-order hold of the admittance rate, the closed current loop, the force per ampere
/// and the moving mass (load and rotor) with the rotor's viscous friction.
pub fn outer_open_loop(cfg: &ActiveStickConfig, w: f64) -> Complex<f64> {
    let a = cfg.admittance;
    let t = 1.0 / a.rate_hz;
    let z = Complex::from_polar(1.0, w * t);
    let alpha = (-std::f64::consts::TAU * a.velocity_filter_hz * t).exp();
    let zi = z.inv();
    let diff = (Complex::from(1.0) - zi) * ((1.0 - alpha) / t) / (Complex::from(1.0) - zi * alpha);
    let pd = Complex::from(a.kp_n_per_m) + diff * a.kd_n_s_per_m;
    let s = Complex::new(0.0, w);
    let zoh = (Complex::from(1.0) - (-s * t).exp()) / (s * t);
    let li = current_open_loop(cfg, w);
    let ti = li / (li + 1.0);
    let mass = cfg.load_mass_kg + cfg.rotor_mass_kg();
    let mech = Complex::from(1.0) / (s * s * mass + s * cfg.rod_damping_n_s_per_m());
    pd / cfg.force_per_amp_n() * zoh * ti * cfg.force_per_amp_n() * mech
}

/// Margins of an open loop `l` from `f_lo_hz` to `f_hi_hz` on a log grid of `n` points (phase unwrapped
/// along the grid).
pub fn margins_of(l: impl Fn(f64) -> Complex<f64>, f_lo_hz: f64, f_hi_hz: f64, n: usize) -> Margins {
    let mut prev: Option<(f64, f64, f64)> = None; // (f, |L|, unwrapped phase deg)
    let mut out = Margins {
        crossover_hz: f64::NAN,
        phase_margin_deg: f64::NAN,
        gain_margin_db: f64::INFINITY,
        phase_crossover_hz: f64::NAN,
    };
    for k in 0..n {
        let f = f_lo_hz * (f_hi_hz / f_lo_hz).powf(k as f64 / (n - 1) as f64);
        let v = l(std::f64::consts::TAU * f);
        let mag = v.norm();
        let mut ph = v.arg().to_degrees();
        if let Some((f0, m0, p0)) = prev {
            ph += 360.0 * ((p0 - ph) / 360.0).round();
            if out.crossover_hz.is_nan() && m0 >= 1.0 && mag < 1.0 {
                let u = m0.ln() / (m0.ln() - mag.ln());
                out.crossover_hz = f0 + u * (f - f0);
                out.phase_margin_deg = 180.0 + p0 + u * (ph - p0);
            }
            if out.phase_crossover_hz.is_nan() && p0 > -180.0 && ph <= -180.0 {
                let u = (p0 + 180.0) / (p0 - ph);
                out.phase_crossover_hz = f0 + u * (f - f0);
                out.gain_margin_db = -20.0 * (m0.ln() + u * (mag.ln() - m0.ln())) / std::f64::consts::LN_10;
            }
        }
        prev = Some((f, mag, ph));
    }
    out
}

/// Both loops' margins, each up to its own Nyquist frequency.
pub fn margins(cfg: &ActiveStickConfig) -> LoopMargins {
    LoopMargins {
        current: margins_of(
            |w| current_open_loop(cfg, w),
            1.0,
            0.5 * cfg.inner_rate_hz(),
            20_000,
        ),
        outer: margins_of(
            |w| outer_open_loop(cfg, w),
            0.1,
            0.5 * cfg.admittance.rate_hz,
            20_000,
        ),
    }
}

/// The motion loop's −3 dB bandwidth from the linearised model (closed loop `L/(1+L)`), Hz.
pub fn model_bandwidth_hz(cfg: &ActiveStickConfig) -> f64 {
    let mut f = 0.1;
    while f < 0.5 * cfg.admittance.rate_hz {
        let l = outer_open_loop(cfg, std::f64::consts::TAU * f);
        if (l / (l + 1.0)).norm() < std::f64::consts::FRAC_1_SQRT_2 {
            return f;
        }
        f *= 1.01;
    }
    f64::NAN
}

/// The motion loop's gain `|x / x_r|` at `freq_hz`, measured on the sampled, nonlinear stick (current
/// loop, voltage and current limits, encoder) driving a free mass (`load_mass_kg`, the rotor's friction)
/// integrated at 8 physics steps per admittance tick; the reference a sine of `amplitude_m`. Fitted over
/// whole cycles after two cycles (and at least 0.2 s) of settling.
pub fn motion_gain(cfg: &ActiveStickConfig, freq_hz: f64, amplitude_m: f64) -> f64 {
    let mut stick = ActiveStick::new(*cfg, 1);
    let dt = 1.0 / cfg.admittance.rate_hz;
    let sub = 8;
    let w = std::f64::consts::TAU * freq_hz;
    let settle = (2.0 / freq_hz).max(0.2);
    let span = (0.5 * freq_hz).ceil().max(4.0) / freq_hz;
    let n = ((settle + span) / dt).round() as usize;
    let (mut x, mut v) = (0.0_f64, 0.0_f64);
    let (mut sc, mut cc, mut ss) = (0.0, 0.0, 0.0);
    let law = FeelLaw::Target { force_n: 0.0 };
    let none = FaultSchedule::none();
    let mass = cfg.load_mass_kg;
    let b = cfg.rod_damping_n_s_per_m();
    for k in 0..n {
        let t = k as f64 * dt;
        // The reference drives the motion loop from outside, bypassing the virtual model.
        stick.x_r_m = amplitude_m * (w * t).sin();
        stick.v_r_m_s = amplitude_m * w * (w * t).cos();
        let rod = RodState {
            grip_force_n: 0.0,
            grip_to_rod: 1.0,
            x_m: x,
            v_m_s: v,
        };
        // The stick's force includes the rotor's inertial force: the free mass is the load alone.
        let f = stick.step(t, dt, &law, &rod, &none);
        let h = dt / sub as f64;
        for _ in 0..sub {
            v += (f - b * v) / mass * h;
            x += v * h;
        }
        if t >= settle {
            let (s, c) = (w * t).sin_cos();
            sc += x * s;
            cc += x * c;
            ss += 1.0;
        }
    }
    // Amplitude of the fitted sinusoid (sine and cosine parts), over the reference's.
    2.0 * (sc * sc + cc * cc).sqrt() / ss / amplitude_m
}

/// The motion loop's −3 dB bandwidth measured by a sine sweep of the sampled stick ([`motion_gain`]) on a
/// log grid from 1 Hz, 0.1 mm amplitude (small signal: no limit reached), Hz (interpolated between grid points; NaN if above 1 kHz).
pub fn motion_bandwidth_hz(cfg: &ActiveStickConfig) -> f64 {
    let target = std::f64::consts::FRAC_1_SQRT_2;
    let (mut f0, mut g0) = (1.0, motion_gain(cfg, 1.0, 1e-4));
    let mut f = f0;
    while f < 1000.0 {
        f *= 1.12;
        let g = motion_gain(cfg, f, 1e-4);
        if g < target {
            let u = (g0 - target) / (g0 - g);
            return f0 * (f / f0).powf(u);
        }
        (f0, g0) = (f, g);
    }
    f64::NAN
}
