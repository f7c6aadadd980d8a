//! The virtual MTS machine of the paper's Section 4: it drives the piston with a displacement protocol,
//! holds the coil current at one level per block, and records the force the way the tensile machine and
//! its DAQ did (sample rate, load-cell noise and quantisation, displacement sensor noise).
//!
//! The machine is kinematic: the actuator imposes `x(t)` exactly (a servo-hydraulic MTS is far stiffer than
//! the damper), so the recorded force is the damper force, computed by [`crate::device`] — the same code the
//! fitter and the stick rig use. Its output is a [`Measurement`] in the project's CSV format, so it feeds
//! straight back into `mrfeel fit`.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use crate::device::params::TestSignals;
use crate::device::{Damper, DataStats, Inputs, Model, ModelSpec, Registry, Step};
use crate::measurement::{Measurement, MAGNITUDE_LIMIT};

/// Errors configuring a virtual test.
#[derive(Debug, thiserror::Error)]
pub enum MtsError {
    /// A setting out of its range or inconsistent with another.
    #[error("`{field}`: {msg}")]
    Config {
        /// The setting, as named on the command line.
        field: String,
        /// What is wrong with it.
        msg: String,
    },
    /// The device model.
    #[error(transparent)]
    Device(#[from] crate::device::DeviceError),
}

/// Fewest samples a test may have: a record the readers take (a velocity from two samples).
const MIN_SAMPLES: usize = 2;

/// Most samples a test may have: 10⁷, about 3 hours at 1 kHz and a few hundred MB in memory. More than any
/// MTS test; it keeps a mistyped frequency or cycle count from filling the memory.
const MAX_SAMPLES: usize = 10_000_000;

/// Most integration steps of the device model a test may take: 10⁹, about a minute with the costliest
/// effects.
const MAX_PHYSICS_STEPS: f64 = 1e9;

fn cfg_err(field: &str, msg: impl Into<String>) -> MtsError {
    MtsError::Config {
        field: field.to_string(),
        msg: msg.into(),
    }
}

/// `Ok` where `ok`, else the error of `field` with the message `msg` makes.
fn require(ok: bool, field: &str, msg: impl FnOnce() -> String) -> Result<(), MtsError> {
    if ok {
        Ok(())
    } else {
        Err(cfg_err(field, msg()))
    }
}

/// Displacement protocol of the actuator.
#[derive(Debug, Clone, PartialEq)]
pub enum Protocol {
    /// `x = A sin(2π f t)`.
    Sine {
        /// Amplitude A, m.
        amplitude_m: f64,
        /// Frequency f, Hz.
        frequency_hz: f64,
    },
    /// Constant-velocity strokes between ±A (velocity `4 A f`), starting at mid-stroke moving outward.
    Triangle {
        /// Amplitude A, m.
        amplitude_m: f64,
        /// Frequency f, Hz.
        frequency_hz: f64,
    },
    /// A sum of `tones` sines log-spaced from `f_min_hz` to `f_max_hz` with Schroeder phases (low crest
    /// factor, deterministic), scaled so that the peak displacement is A.
    Multisine {
        /// Peak displacement, m.
        amplitude_m: f64,
        /// Lowest tone, Hz.
        f_min_hz: f64,
        /// Highest tone, Hz.
        f_max_hz: f64,
        /// Number of tones.
        tones: usize,
    },
}

impl Protocol {
    /// Parse a protocol name with its amplitude and (lowest) frequency.
    pub fn from_name(name: &str, amplitude_m: f64, frequency_hz: f64) -> Result<Self, MtsError> {
        match name {
            "sine" => Ok(Protocol::Sine {
                amplitude_m,
                frequency_hz,
            }),
            "triangle" => Ok(Protocol::Triangle {
                amplitude_m,
                frequency_hz,
            }),
            "multisine" => Ok(Protocol::Multisine {
                amplitude_m,
                f_min_hz: frequency_hz,
                f_max_hz: 10.0 * frequency_hz,
                tones: 6,
            }),
            other => Err(cfg_err(
                "protocol",
                format!("unknown protocol `{other}` (sine, triangle, multisine)"),
            )),
        }
    }

    /// Peak displacement, m.
    pub fn amplitude_m(&self) -> f64 {
        match *self {
            Protocol::Sine { amplitude_m, .. }
            | Protocol::Triangle { amplitude_m, .. }
            | Protocol::Multisine { amplitude_m, .. } => amplitude_m,
        }
    }

    /// The slowest frequency: one "cycle" of the protocol.
    pub fn base_frequency_hz(&self) -> f64 {
        match *self {
            Protocol::Sine { frequency_hz, .. } | Protocol::Triangle { frequency_hz, .. } => frequency_hz,
            Protocol::Multisine { f_min_hz, .. } => f_min_hz,
        }
    }

    fn name(&self) -> &'static str {
        match self {
            Protocol::Sine { .. } => "sine",
            Protocol::Triangle { .. } => "triangle",
            Protocol::Multisine { .. } => "multisine",
        }
    }

    fn validate(&self) -> Result<(), MtsError> {
        let (a, f) = (self.amplitude_m(), self.base_frequency_hz());
        require(a.is_finite() && a > 0.0, "amplitude_m", || {
            format!("{a} must be a positive length in metres")
        })?;
        require(f.is_finite() && f > 0.0 && f <= 200.0, "frequency_hz", || {
            format!("{f} must be in (0, 200] Hz")
        })?;
        let multisine_ok = match *self {
            Protocol::Multisine {
                f_min_hz,
                f_max_hz,
                tones,
                ..
            } => f_max_hz > f_min_hz && tones > 0,
            _ => true,
        };
        require(multisine_ok, "multisine", || {
            "needs f_max_hz > f_min_hz and at least one tone".into()
        })
    }

    /// The highest frequency of the motion's fundamentals, Hz (a multisine's top tone).
    fn highest_frequency_hz(&self) -> f64 {
        match *self {
            Protocol::Multisine { f_max_hz, .. } => f_max_hz,
            _ => self.base_frequency_hz(),
        }
    }

    /// Tones `(amplitude, angular frequency, phase)` of a multisine, scaled to peak amplitude A.
    fn tones(&self) -> Vec<(f64, f64, f64)> {
        match *self {
            Protocol::Multisine {
                amplitude_m,
                f_min_hz,
                f_max_hz,
                tones,
            } => {
                let n = tones;
                let raw: Vec<(f64, f64, f64)> = (0..n)
                    .map(|k| {
                        let f = if n == 1 {
                            f_min_hz
                        } else {
                            f_min_hz * (f_max_hz / f_min_hz).powf(k as f64 / (n - 1) as f64)
                        };
                        // Amplitude falling as 1/f keeps the velocity content flat across tones.
                        let a = f_min_hz / f;
                        let phase = -PI * (k * (k + 1)) as f64 / n as f64; // Schroeder
                        (a, 2.0 * PI * f, phase)
                    })
                    .collect();
                // Peak over one slow period, on a fine grid.
                let period = 1.0 / f_min_hz;
                let grid = 20_000;
                let peak = (0..grid)
                    .map(|j| {
                        let t = period * j as f64 / grid as f64;
                        raw.iter()
                            .map(|(a, w, p)| a * (w * t + p).sin())
                            .sum::<f64>()
                            .abs()
                    })
                    .fold(0.0f64, f64::max)
                    .max(1e-300);
                raw.into_iter()
                    .map(|(a, w, p)| (a * amplitude_m / peak, w, p))
                    .collect()
            }
            _ => Vec::new(),
        }
    }
}

/// Kinematics `(x, v, a)` of a protocol at time `t` (tones precomputed for a multisine).
fn kinematics(p: &Protocol, tones: &[(f64, f64, f64)], t: f64) -> (f64, f64, f64) {
    match *p {
        Protocol::Sine {
            amplitude_m: a,
            frequency_hz: f,
        } => {
            let w = 2.0 * PI * f;
            (
                a * (w * t).sin(),
                a * w * (w * t).cos(),
                -a * w * w * (w * t).sin(),
            )
        }
        Protocol::Triangle {
            amplitude_m: a,
            frequency_hz: f,
        } => {
            // Phase in [0, 1): 0→¼ rising 0→A, ¼→¾ falling A→−A, ¾→1 rising −A→0.
            let ph = (t * f).rem_euclid(1.0);
            let v = 4.0 * a * f;
            if ph < 0.25 {
                (v * ph / f, v, 0.0)
            } else if ph < 0.75 {
                (a - v * (ph - 0.25) / f, -v, 0.0)
            } else {
                (-a + v * (ph - 0.75) / f, v, 0.0)
            }
        }
        Protocol::Multisine { .. } => {
            let (mut x, mut v, mut acc) = (0.0, 0.0, 0.0);
            for &(a, w, ph) in tones {
                let s = (w * t + ph).sin();
                let c = (w * t + ph).cos();
                x += a * s;
                v += a * w * c;
                acc -= a * w * w * s;
            }
            (x, v, acc)
        }
    }
}

/// A sensor's noise and resolution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorSpec {
    /// Standard deviation of white noise, in the sensor's unit.
    pub noise_std: f64,
    /// Full-scale range ±`range`, in the sensor's unit; readings saturate there.
    pub range: f64,
    /// ADC resolution in bits over the full range (0 = no quantisation).
    pub bits: u32,
}

impl SensorSpec {
    /// A 16-bit channel of noise `noise_std` over ±`range`.
    const fn adc16(noise_std: f64, range: f64) -> Self {
        Self {
            noise_std,
            range,
            bits: 16,
        }
    }

    /// A reading: add noise, saturate at the range, quantise to the ADC's LSB.
    pub fn read(&self, truth: f64, rng: &mut ChaCha8Rng) -> f64 {
        let mut y = truth;
        if self.noise_std > 0.0 {
            y += Normal::new(0.0, self.noise_std)
                .map(|n| n.sample(rng))
                .unwrap_or(0.0);
        }
        crate::signal::quantise(y, self.range, self.bits) + 0.0 // no negative zero in the record
    }
}

/// A virtual test: protocol, current schedule, DAQ and sensors.
#[derive(Debug, Clone)]
pub struct MtsTest {
    /// The actuator's displacement protocol.
    pub protocol: Protocol,
    /// One current level per block, A; the current steps at block boundaries.
    pub currents_a: Vec<f64>,
    /// Protocol cycles per current block.
    pub cycles_per_block: f64,
    /// DAQ sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Internal integration rate of the device model, Hz (rounded up to a multiple of the sample rate).
    pub physics_hz: f64,
    /// Load cell (N): the paper's 250 N cell, 16-bit.
    pub load_cell: SensorSpec,
    /// Displacement sensor (m).
    pub displacement: SensorSpec,
    /// Velocity channel (m/s), recorded when `record_velocity`.
    pub velocity: SensorSpec,
    /// Record the velocity channel `v_m_s`.
    pub record_velocity: bool,
    /// Also record the coil current (the Eq. 3 state) as `i_meas_a`.
    pub record_coil_current: bool,
    /// The device's half stroke, m: a protocol that would drive the piston past it is refused.
    pub stroke_limit_m: Option<f64>,
    /// Seed of the sensor noise.
    pub seed: u64,
}

impl MtsTest {
    /// The paper's bench: 250 N load cell, 16-bit DAQ at 1 kHz, ±2 in stroke sensor.
    pub fn paper(protocol: Protocol, currents_a: Vec<f64>) -> Self {
        Self {
            protocol,
            currents_a,
            cycles_per_block: 3.0,
            sample_rate_hz: 1000.0,
            physics_hz: 10_000.0,
            load_cell: SensorSpec::adc16(0.15, 250.0),
            displacement: SensorSpec::adc16(2e-6, 0.0508),
            velocity: SensorSpec::adc16(2e-4, 2.0),
            record_velocity: true,
            record_coil_current: false,
            stroke_limit_m: None,
            seed: 1,
        }
    }

    fn validate(&self) -> Result<(), MtsError> {
        self.protocol.validate()?;
        let currents = &self.currents_a;
        require(!currents.is_empty(), "current", || {
            "give at least one current level".into()
        })?;
        if let Some(c) = currents.iter().find(|c| !c.is_finite() || **c < 0.0) {
            return Err(cfg_err(
                "current",
                format!("{c} A: current levels must be finite and ≥ 0"),
            ));
        }
        if let Some(c) = currents.iter().find(|c| **c > MAGNITUDE_LIMIT) {
            return Err(cfg_err(
                "current",
                format!("{c:e} A: beyond the ±{MAGNITUDE_LIMIT:e} a measurement file may hold"),
            ));
        }
        let (cycles, rate, physics) = (self.cycles_per_block, self.sample_rate_hz, self.physics_hz);
        require(cycles.is_finite() && cycles > 0.0, "cycles", || {
            "must be positive".into()
        })?;
        require(
            rate.is_finite() && (1.0..=1e6).contains(&rate),
            "sample_rate_hz",
            || format!("{rate} must be in [1, 1e6] Hz"),
        )?;
        require(
            physics.is_finite() && physics > 0.0 && physics <= 1e7,
            "physics_hz",
            || format!("{physics} must be in (0, 1e7] Hz"),
        )?;
        require(physics >= rate, "physics_hz", || {
            format!(
                "{physics} Hz is below the sample rate {rate} Hz: the device model is integrated at least once a \
                 sample (give a physics rate ≥ the sample rate)"
            )
        })?;
        let top = self.protocol.highest_frequency_hz();
        require(rate >= 2.0 * top, "sample_rate_hz", || {
            format!(
                "{rate} Hz cannot record a motion of {top} Hz: at least two samples a period are needed (the \
                 Nyquist rate, {} Hz)",
                2.0 * top
            )
        })?;
        let n = self.samples();
        require(
            n >= MIN_SAMPLES as f64 && n <= MAX_SAMPLES as f64,
            "cycles",
            || {
                format!(
                "{cycles} cycles a block × {} blocks at {rate} Hz give {n:.0} samples: a test holds {MIN_SAMPLES} to \
                 {MAX_SAMPLES:e} samples (change the cycles, the frequency or the sample rate)",
                currents.len()
            )
            },
        )?;
        let steps = n * self.substeps();
        require(steps <= MAX_PHYSICS_STEPS, "physics_hz", || {
            format!(
                "{physics} Hz over {n:.0} samples is {steps:.0} integration steps: at most {MAX_PHYSICS_STEPS:e} \
                 (hours of computing); lower the physics rate or shorten the test"
            )
        })?;
        for (name, s) in [
            ("load_cell", &self.load_cell),
            ("displacement", &self.displacement),
            ("velocity", &self.velocity),
        ] {
            crate::sensors::check_channel(name, s.noise_std, s.range, s.bits)
                .map_err(|e| cfg_err(&format!("{name}.{}", e.field), format!("{}: {}", e.value, e.why)))?;
        }
        Ok(())
    }

    /// Samples the test records (a whole number, as an `f64`: checked against the bounds before it is used
    /// as a count).
    fn samples(&self) -> f64 {
        (self.block_s() * self.currents_a.len() as f64 * self.sample_rate_hz).round()
    }

    /// Integration steps of the device model per sample (at least one).
    fn substeps(&self) -> f64 {
        (self.physics_hz / self.sample_rate_hz).ceil().max(1.0)
    }

    /// The same test with noise-free sensors.
    fn noise_free(mut self) -> Self {
        for s in [&mut self.load_cell, &mut self.displacement, &mut self.velocity] {
            s.noise_std = 0.0;
        }
        self
    }

    /// Duration of one current block, s.
    pub fn block_s(&self) -> f64 {
        self.cycles_per_block / self.protocol.base_frequency_hz()
    }

    /// Run the test on a damper (restarted from rest at the first current) and record it.
    pub fn run(&self, damper: &mut Damper) -> Result<Measurement, MtsError> {
        self.validate()?;
        if let Some(g) = self.stroke_limit_m {
            if self.protocol.amplitude_m() > g + 1e-12 {
                return Err(cfg_err(
                    "amplitude_m",
                    format!(
                        "{} m exceeds the device's ±{g} m stroke",
                        self.protocol.amplitude_m()
                    ),
                ));
            }
        }
        let tones = self.protocol.tones();
        let substeps = self.substeps() as usize;
        let dt_sample = 1.0 / self.sample_rate_hz;
        let dt = dt_sample / substeps as f64;
        let block_s = self.block_s();
        let n_samples = self.samples() as usize;
        let current_at = |t: f64| {
            let k = ((t / block_s).floor() as usize).min(self.currents_a.len() - 1);
            self.currents_a[k]
        };
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        let mut m = Measurement {
            velocity_measured: self.record_velocity,
            ..Default::default()
        };
        let mut coil = Vec::new();
        let inputs_at = |t: f64| {
            let (x, v, a) = kinematics(&self.protocol, &tones, t);
            Inputs {
                t_s: t,
                x_m: x,
                v_m_s: v,
                a_m_s2: a,
                current_cmd_a: current_at(t),
            }
        };
        damper.reset(&inputs_at(0.0));
        for k in 0..n_samples {
            let t = k as f64 * dt_sample;
            let inp = inputs_at(t);
            let stage = damper.eval(&inp);
            let f = stage.force_n(inp.v_m_s);
            m.t_s.push(t);
            m.x_m.push(self.displacement.read(inp.x_m, &mut rng));
            m.v_m_s.push(self.velocity.read(inp.v_m_s, &mut rng));
            m.i_a.push(inp.current_cmd_a);
            m.f_n.push(self.load_cell.read(f, &mut rng));
            coil.push(damper.coil_current_a());
            // Advance to the next sample in substeps, the command held (ZOH) within each substep.
            let mut cur = inp;
            let mut cur_stage = stage;
            for j in 0..substeps {
                let tn = t + (j + 1) as f64 * dt;
                let next = inputs_at(tn);
                damper.advance(
                    &cur,
                    &cur_stage,
                    Step {
                        dt_s: dt,
                        dx_m: next.x_m - cur.x_m,
                    },
                );
                if j + 1 < substeps {
                    cur = next;
                    cur_stage = damper.eval(&cur);
                }
            }
        }
        if !self.record_velocity {
            m.v_m_s = crate::measurement::smooth_derivative(&m.t_s, &m.x_m);
        }
        if self.record_coil_current {
            m.i_meas_a = Some(coil);
        }
        // No `model`: data made with hidden effects must not name them (the device file keeps the truth).
        let test = format!(
            "{} displacement, amplitude {} m, frequency {} Hz, {} cycles per block, currents {:?} A",
            self.protocol.name(),
            self.protocol.amplitude_m(),
            self.protocol.base_frequency_hz(),
            self.cycles_per_block,
            self.currents_a
        );
        m.meta = BTreeMap::from([
            (
                "source".into(),
                format!("mrfeel {} virtual MTS machine", env!("CARGO_PKG_VERSION")),
            ),
            ("test".into(), test),
            ("sample_rate_hz".into(), self.sample_rate_hz.to_string()),
            ("seed".into(), self.seed.to_string()),
        ]);
        Ok(m)
    }
}

/// A damper model with hidden effects added to a base device: the truth for synthetic data. Each effect's
/// parameters are its `typical_params` for statistics of the base model run through the same test (so the
/// effect is clearly visible at that device's scale); `overrides` set any parameter by name afterwards.
pub fn with_hidden_effects(
    base_model: &Model,
    base_params: &[f64],
    effects: &[String],
    overrides: &[(String, f64)],
    test: &MtsTest,
    registry: &Registry,
) -> Result<Damper, MtsError> {
    let mut spec: ModelSpec = base_model.spec().clone();
    for e in effects {
        if !spec.has(e) {
            spec = spec.with(e);
        }
    }
    let model = Model::new(&spec, registry, base_model.current_limit_a)?;
    // Statistics of the base device under this test, noise-free.
    let quiet = test.clone().noise_free();
    let mut base = Damper::new(
        std::sync::Arc::new(Model::new(
            base_model.spec(),
            registry,
            base_model.current_limit_a,
        )?),
        base_params.to_vec(),
    )?;
    let m = quiet.run(&mut base)?;
    let a = m.acceleration();
    let stats = DataStats::from_tests(&[TestSignals {
        t_s: &m.t_s,
        x_m: &m.x_m,
        v_m_s: &m.v_m_s,
        a_m_s2: &a,
        i_a: &m.i_a,
        f_n: &m.f_n,
    }]);
    let mut params = base_params.to_vec();
    // Effect parameters: the base model's ones come from the device, effect ones from typical values.
    for e in model.effects().skip(base_model.effects().count()) {
        params.extend(e.typical_params(&stats));
    }
    for (name, v) in overrides {
        let k = model.param_index(name).ok_or_else(|| {
            cfg_err(
                "set",
                format!("model `{}` has no parameter `{name}`", model.name()),
            )
        })?;
        let s = &model.param_specs()[k];
        if !(v.is_finite() && *v >= s.lower && *v <= s.upper) {
            return Err(cfg_err(
                "set",
                format!("{name} = {v} outside [{}, {}] {}", s.lower, s.upper, s.unit),
            ));
        }
        params[k] = *v;
    }
    Ok(Damper::new(std::sync::Arc::new(model), params)?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::DeviceConfig;
    use std::path::Path;

    fn paper() -> DeviceConfig {
        DeviceConfig::from_toml(
            crate::builtin::PAPER_DEVICE,
            Path::new("paper-device.toml"),
            &Registry::builtin(),
        )
        .unwrap()
    }

    fn sine(amplitude_m: f64, frequency_hz: f64) -> Protocol {
        Protocol::Sine {
            amplitude_m,
            frequency_hz,
        }
    }

    fn triangle(amplitude_m: f64, frequency_hz: f64) -> Protocol {
        Protocol::Triangle {
            amplitude_m,
            frequency_hz,
        }
    }

    fn quiet(t: MtsTest) -> MtsTest {
        let mut t = t.noise_free();
        for s in [&mut t.load_cell, &mut t.displacement, &mut t.velocity] {
            s.bits = 0;
        }
        t
    }

    /// Mean |F| over the constant-velocity part of each block, after the lags settle (> 10 Te + 10 Tm).
    fn steady(m: &Measurement, block_s: f64, n_blocks: usize, settle_s: f64) -> Vec<f64> {
        (0..n_blocks)
            .map(|b| {
                let (t0, t1) = (b as f64 * block_s + settle_s, (b + 1) as f64 * block_s);
                let f: Vec<f64> = (0..m.len())
                    .filter(|&k| m.t_s[k] >= t0 && m.t_s[k] < t1)
                    .map(|k| m.f_n[k].abs())
                    .collect();
                f.iter().sum::<f64>() / f.len() as f64
            })
            .collect()
    }

    #[test]
    fn steady_velocity_force_matches_the_papers_measurements() {
        // Constant 10 mm/s, each current held for an eighth of a triangle cycle: no reversal inside a block.
        let dev = paper();
        let mut t = quiet(MtsTest::paper(
            triangle(0.0254, 0.098_425),
            vec![2.2, 5.0, 14.0, 17.0],
        ));
        t.cycles_per_block = 0.0625;
        let m = t.run(&mut dev.damper()).unwrap();
        assert!(
            m.v_m_s
                .iter()
                .all(|v| (v - 0.01).abs() < 1e-6 && *v == m.v_m_s[0]),
            "velocity must stay constant"
        );
        let f = steady(&m, t.block_s(), 4, 0.3);
        for ((i, paper_n), got) in crate::builtin::PAPER_POINTS.iter().zip(&f) {
            assert!(
                (got - paper_n).abs() <= 0.10 * paper_n,
                "{i} A: {got:.2} N vs paper {paper_n} N ± 10 %"
            );
        }
        // The driver saturates at 14 A: a 17 A command gives the 14 A force.
        assert!(
            (f[3] - f[2]).abs() < 1e-9 * f[2],
            "17 A gave {} N, 14 A gave {} N",
            f[3],
            f[2]
        );
    }

    #[test]
    fn current_step_reaches_63_percent_after_the_two_lags_time() {
        let dev = paper();
        let (te, tm) = (dev.param("te_s").unwrap(), dev.param("tm_s").unwrap());
        // Independent prediction: bisection on the closed-form step response of two first-order lags.
        let resp = |t: f64| 1.0 - (te * (-t / te).exp() - tm * (-t / tm).exp()) / (te - tm);
        let (mut lo, mut hi) = (0.0, 1.0);
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if resp(mid) < 0.632_120_558_8 {
                lo = mid
            } else {
                hi = mid
            }
        }
        let t63_pred = lo;
        let mut t = quiet(MtsTest::paper(triangle(0.0254, 0.1), vec![0.0, 5.0]));
        t.cycles_per_block = 0.125;
        t.sample_rate_hz = 20_000.0;
        t.physics_hz = 20_000.0;
        let m = t.run(&mut dev.damper()).unwrap();
        let t_step = t.block_s();
        let v = m.v_m_s[0];
        let c0 = dev.param("c0_n_s_per_m").unwrap();
        let yield_at = |k: usize| m.f_n[k] - c0 * v; // remove the viscous part to leave the yield force
        let f_final = 5.0 * dev.param("fc_gain_n_per_a").unwrap();
        let k63 = (0..m.len())
            .find(|&k| m.t_s[k] > t_step && yield_at(k) >= 0.632_120_558_8 * f_final)
            .unwrap();
        let t63 = m.t_s[k63] - t_step;
        assert!(
            (t63 - t63_pred).abs() <= 0.05 * t63_pred,
            "t63 {t63:.5} s vs predicted {t63_pred:.5} s"
        );
        // A single lag (either one) would reach 63 % much earlier: the test can tell them apart.
        assert!(t63 > 1.2 * te.max(tm));
    }

    #[test]
    fn damper_force_has_the_sign_of_velocity_and_never_injects_energy() {
        let dev = paper();
        for p in [
            sine(0.04, 1.3),
            triangle(0.03, 0.7),
            Protocol::Multisine {
                amplitude_m: 0.05,
                f_min_hz: 0.2,
                f_max_hz: 4.0,
                tones: 7,
            },
        ] {
            let mut t = quiet(MtsTest::paper(p.clone(), vec![0.0, 3.0, 14.0, 7.5, 17.0]));
            t.cycles_per_block = 1.5;
            let m = t.run(&mut dev.damper()).unwrap();
            for k in 0..m.len() {
                let (f, v) = (m.f_n[k], m.v_m_s[k]);
                assert!(f * v >= 0.0, "{p:?}: F·v = {} < 0 at t = {}", f * v, m.t_s[k]);
                if v.abs() > 1e-9 && m.i_a[k] > 0.0 {
                    assert_eq!(f.signum(), v.signum(), "{p:?}: force sign at t = {}", m.t_s[k]);
                }
            }
        }
    }

    #[test]
    fn same_seed_gives_identical_records_and_another_seed_does_not() {
        let dev = paper();
        let t = MtsTest::paper(sine(0.02, 1.0), vec![2.2, 5.0]);
        let a = t.run(&mut dev.damper()).unwrap().to_csv_string();
        let b = t.run(&mut dev.damper()).unwrap().to_csv_string();
        assert_eq!(a, b);
        let mut t2 = t.clone();
        t2.seed = 2;
        assert_ne!(a, t2.run(&mut dev.damper()).unwrap().to_csv_string());
    }

    #[test]
    fn load_cell_quantises_to_its_adc_step() {
        let s = SensorSpec::adc16(0.0, 250.0);
        let lsb = 500.0 / 65536.0;
        let mut rng = ChaCha8Rng::seed_from_u64(0);
        let y = s.read(12.3456, &mut rng);
        assert!((y / lsb - (y / lsb).round()).abs() < 1e-9 && (y - 12.3456).abs() <= lsb / 2.0);
        assert_eq!(s.read(400.0, &mut rng), 250.0, "saturates at the range");
    }

    #[test]
    fn amplitude_beyond_the_stroke_is_refused() {
        let dev = paper();
        let mut t = MtsTest::paper(sine(0.06, 1.0), vec![1.0]);
        t.stroke_limit_m = dev.geometry.map(|g| g.stroke_half_m);
        let e = t.run(&mut dev.damper()).unwrap_err().to_string();
        assert!(e.contains("amplitude_m") && e.contains("0.0508"), "{e}");
    }

    #[test]
    fn a_sensor_setting_that_cannot_be_simulated_is_refused_naming_the_field() {
        let dev = paper();
        let base = MtsTest::paper(sine(0.01, 1.0), vec![1.0]);
        let mut t = base.clone();
        t.load_cell.range = -250.0;
        let e = t.run(&mut dev.damper()).unwrap_err().to_string();
        assert!(e.contains("`load_cell.range`") && e.contains("-250"), "{e}");
        let mut t = base.clone();
        t.velocity.noise_std = f64::NAN;
        let e = t.run(&mut dev.damper()).unwrap_err().to_string();
        assert!(e.contains("`velocity.noise_rms`"), "{e}");
        let mut t = base;
        t.displacement.bits = 33;
        let e = t.run(&mut dev.damper()).unwrap_err().to_string();
        assert!(e.contains("`displacement.adc_bits`") && e.contains("33"), "{e}");
    }

    #[test]
    fn multisine_peak_is_the_amplitude_and_velocity_is_the_derivative() {
        let p = Protocol::Multisine {
            amplitude_m: 0.03,
            f_min_hz: 0.5,
            f_max_hz: 5.0,
            tones: 5,
        };
        let tones = p.tones();
        let mut peak = 0.0f64;
        let h = 1e-6;
        for j in 0..20_000 {
            let t = 2.0 * j as f64 / 20_000.0;
            let (x, v, _) = kinematics(&p, &tones, t);
            peak = peak.max(x.abs());
            let (x2, _, _) = kinematics(&p, &tones, t + h);
            assert!(((x2 - x) / h - v).abs() < 1e-3 * (1.0 + v.abs()));
        }
        assert!((peak - 0.03).abs() < 1e-4, "peak {peak}");
    }
}
