//! Feel systems compared on the same rig and linkage (issue 6): three spring feel units, the paper's MR
//! damper under a force loop, and a hybrid MR damper + centring spring, all driven by the same pilot task;
//! plus the same runs with faults in the loop's power and signal path ([`crate::faults`]).
//!
//! # Systems
//! | name | force element on the piston joint | electrical path |
//! |---|---|---|
//! | `centring_spring` | Hanlon's centring spring + the feel unit's viscous damper | none |
//! | `variable_gradient_spring` | Griffith's variable-gradient spring + damper | none |
//! | `q_feel` | q-feel spring at the scenario's q̄ + damper | none |
//! | `mr` | the paper's MR damper (Eq. 2–6), force loop on the load cell | DAQ → PI → driver → coil |
//! | `mr_spring` | MR damper + a lighter centring spring (hybrid) | as `mr` |
//!
//! The springs are `crate::control::feel` elements (implicit joint springs). A spring feel unit has no
//! MR damper: its damper is the device with the coil never energised (`fc_gain` irrelevant at 0 A, `C0`
//! replaced by the unit's `damping_n_s_per_m`).
//!
//! # The MR force loop (stand-in)
//! The loop engineer's `control::FeelController` (branch `loop`) is the loop of record; until it lands on
//! this branch, [`MrController`] is a compact version of the same logic from the sampled signals only:
//! the target `F* = breakout·sgn x + k x` (clipped) is tracked in magnitude while the stick moves away
//! from centre (`i = PI(|F*|, s·F_meas) + i_ff`, clamping anti-windup, 0–14 A), the coil is released
//! (0 A) when the target would need the stick to push (moving back), and at rest the static current for
//! `|F*|` holds the stick (`mr`) — for the hybrid, at rest or returning, the coil gives only a
//! velocity-proportional current (`return_damping_n_s_per_m`), so the spring can re-centre the stick.
//! The feedforward inverts the static Bingham force (Eq. 2 with Eq. 6 at steady state):
//! `i_ff = (|F*| − F_spring − fc0 − C0 |v|) / (bH kH)`.
//!
//! # Pilot (stand-in)
//! An impedance hand at the grip, `F = k e + c ė + ∫ g k e dt` (`e` the grip-path error, m), for position
//! segments; a prescribed force for force segments; nothing when the pilot lets go. The loop's
//! `pilot::Hand` (neuromuscular lag, palm compliance) replaces it when it lands.

pub mod cli;
pub mod metrics;

use std::collections::VecDeque;
use std::path::{Path, PathBuf};

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Deserialize;

use crate::control::feel::{self, CentringSpring, FeelSprings, FeelSystem};
use crate::device::{DeviceConfig, Registry};
use crate::faults::{FaultInjector, FaultSchedule};
use crate::rig::{Rig, RigConfig};

/// The feel systems, in table order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum FeelKind {
    CentringSpring,
    VariableGradientSpring,
    QFeel,
    Mr,
    MrSpring,
}

impl FeelKind {
    pub const ALL: [FeelKind; 5] = [
        FeelKind::CentringSpring,
        FeelKind::VariableGradientSpring,
        FeelKind::QFeel,
        FeelKind::Mr,
        FeelKind::MrSpring,
    ];

    pub fn name(self) -> &'static str {
        match self {
            FeelKind::CentringSpring => "centring_spring",
            FeelKind::VariableGradientSpring => "variable_gradient_spring",
            FeelKind::QFeel => "q_feel",
            FeelKind::Mr => "mr",
            FeelKind::MrSpring => "mr_spring",
        }
    }

    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }

    /// Whether the system has the MR damper and its electrical loop.
    pub fn has_coil(self) -> bool {
        matches!(self, FeelKind::Mr | FeelKind::MrSpring)
    }

    /// Parse a comma-separated list (`--feel a,b`), in the order given, without duplicates.
    pub fn parse_list(s: &str) -> Result<Vec<Self>, CompareError> {
        let mut out = Vec::new();
        for name in s.split(',').map(str::trim).filter(|n| !n.is_empty()) {
            let k = Self::from_name(name).ok_or_else(|| CompareError::Feel(unknown_feel(name)))?;
            if !out.contains(&k) {
                out.push(k);
            }
        }
        if out.is_empty() {
            return Err(CompareError::Feel("no feel system given".into()));
        }
        Ok(out)
    }
}

fn unknown_feel(name: &str) -> String {
    let names: Vec<&str> = FeelKind::ALL.iter().map(|k| k.name()).collect();
    format!("`{name}` is not one of: {}", names.join(", "))
}

#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    #[error("{}: {msg}", path.display())]
    Io { path: PathBuf, msg: String },
    #[error("{}:{line}: {msg}", path.display())]
    Parse { path: PathBuf, line: usize, msg: String },
    #[error("{}:{line}: `{key}`: {msg}", path.display())]
    Field {
        path: PathBuf,
        line: usize,
        key: String,
        msg: String,
    },
    #[error("feel systems: {0}")]
    Feel(String),
    #[error(transparent)]
    Faults(#[from] crate::faults::FaultError),
    #[error(transparent)]
    Device(#[from] crate::device::DeviceError),
    #[error(transparent)]
    Springs(#[from] crate::control::feel::FeelError),
    #[error(transparent)]
    Rig(#[from] crate::rig::RigError),
}

// ---------------------------------------------------------------------------------------------------
// Scenario file (`scenarios/compare-*.toml`)

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    #[serde(default)]
    #[allow(dead_code)]
    description: String,
    seed: u64,
    systems: Vec<String>,
    rig: RigConfig,
    device: DeviceSection,
    springs: SpringsSection,
    target: TargetLaw,
    controller: ControllerSection,
    pilot: PilotGains,
    task: TaskSection,
    limits: Limits,
    fault_test: FaultTest,
    /// `[[fault]]` tables, read by [`FaultSchedule::from_scenario_text`].
    #[serde(default)]
    #[allow(dead_code)]
    fault: Option<toml::Value>,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceSection {
    file: PathBuf,
    coil_resistance_ohm: f64,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct SpringsSection {
    file: PathBuf,
    damping_n_s_per_m: f64,
    qbar_pa: f64,
    hybrid_k_n_per_m: f64,
    hybrid_return_damping_n_s_per_m: f64,
}

/// The feel target, at the piston (force along +x): `F* = breakout·sgn x + gradient·x`, clipped.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetLaw {
    pub breakout_n: f64,
    pub gradient_n_per_m: f64,
    pub max_force_n: f64,
}

impl TargetLaw {
    /// Target force at `x_m`; at the centre the breakout acts in `dir` (the motion or push direction).
    pub fn force_n(&self, x_m: f64, dir: f64) -> f64 {
        let s = if x_m.abs() > 1e-6 { x_m.signum() } else { dir };
        (self.breakout_n * s + self.gradient_n_per_m * x_m).clamp(-self.max_force_n, self.max_force_n)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ControllerSection {
    pub kp_a_per_n: f64,
    pub ki_a_per_n_s: f64,
    pub rest_speed_m_s: f64,
    pub rest_force_n: f64,
    pub latency_samples: usize,
    pub velocity_cutoff_hz: f64,
    pub load_cell_noise_rms_n: f64,
}

/// The stand-in pilot's grip impedance.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PilotGains {
    pub stiffness_n_per_m: f64,
    pub damping_n_s_per_m: f64,
    pub integral_gain_per_s: f64,
}

#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TaskSection {
    /// Sinusoidal stick motion: amplitude, rad; frequency, Hz; whole cycles.
    pub sweep_amplitude_rad: f64,
    pub sweep_frequency_hz: f64,
    pub sweep_cycles: usize,
    /// Deflect, hold, let go: angle, rad; ramp and hold times, s; observation after letting go, s.
    pub release_angle_rad: f64,
    pub release_ramp_s: f64,
    pub release_hold_s: f64,
    pub release_observe_s: f64,
    /// Re-centred when the stick stays within this band, rad.
    pub recentre_band_rad: f64,
    /// Breakout: grip force ramp rate, N/s, and the stick motion that counts as breaking out, rad.
    pub breakout_ramp_n_per_s: f64,
    pub breakout_duration_s: f64,
    pub breakout_threshold_rad: f64,
}

/// Certification force limits at the stick, lbf (converted once to N in [`Limits::newtons`]).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limits {
    /// 14 CFR 23.143(c): stick, pitch, temporary application.
    pub part23_stick_pitch_temporary_lbf: f64,
    /// 14 CFR 23.143(c) / 25.143: pitch, prolonged (long-term) application.
    pub pitch_prolonged_lbf: f64,
    /// 14 CFR 25.143: pitch, short term, one hand available for control.
    pub part25_pitch_one_hand_lbf: f64,
}

impl Limits {
    /// (temporary stick, prolonged, one hand) in N.
    pub fn newtons(&self) -> (f64, f64, f64) {
        use crate::units::LBF_TO_N;
        (
            self.part23_stick_pitch_temporary_lbf * LBF_TO_N,
            self.pitch_prolonged_lbf * LBF_TO_N,
            self.part25_pitch_one_hand_lbf * LBF_TO_N,
        )
    }
}

/// The fault table's runs: each fault active from `start_s` to `end_s` of the standard task.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FaultTest {
    pub start_s: f64,
    pub end_s: f64,
}

/// A validated comparison scenario with its files loaded.
#[derive(Debug, Clone)]
pub struct CompareScenario {
    pub path: PathBuf,
    pub name: String,
    pub seed: u64,
    pub systems: Vec<FeelKind>,
    pub rig: RigConfig,
    pub device: DeviceConfig,
    pub coil_resistance_ohm: f64,
    pub springs: FeelSprings,
    pub spring_damping_n_s_per_m: f64,
    pub qbar_pa: f64,
    pub hybrid_spring: CentringSpring,
    pub hybrid_return_damping_n_s_per_m: f64,
    pub target: TargetLaw,
    pub controller: ControllerSection,
    pub pilot: PilotGains,
    pub task: TaskSection,
    pub limits: Limits,
    pub fault_test: FaultTest,
    /// Faults scheduled in the file (`[[fault]]`), applied to every run of `mrfeel compare`.
    pub faults: FaultSchedule,
}

impl CompareScenario {
    pub fn load(path: &Path) -> Result<Self, CompareError> {
        let text = std::fs::read_to_string(path).map_err(|e| CompareError::Io {
            path: path.to_path_buf(),
            msg: e.to_string(),
        })?;
        Self::parse(&text, path)
    }

    pub fn parse(text: &str, path: &Path) -> Result<Self, CompareError> {
        let f: File = toml::from_str(text).map_err(|e| CompareError::Parse {
            path: path.to_path_buf(),
            line: e.span().map(|s| line_of(text, s.start)).unwrap_or(0),
            msg: e.message().trim().to_string(),
        })?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let chk =
            |section: &str, key: &str, v: f64, lo: f64, hi: f64, unit: &str| -> Result<f64, CompareError> {
                if v.is_finite() && v >= lo && v <= hi {
                    Ok(v)
                } else {
                    Err(CompareError::Field {
                        path: path.to_path_buf(),
                        line: line_of_key(text, section, key),
                        key: if section.is_empty() {
                            key.to_string()
                        } else {
                            format!("{section}.{key}")
                        },
                        msg: format!("value {v} outside the allowed range [{lo}, {hi}] {unit}"),
                    })
                }
            };
        let mut systems = Vec::new();
        for s in &f.systems {
            let k = FeelKind::from_name(s).ok_or_else(|| CompareError::Field {
                path: path.to_path_buf(),
                line: line_of_key(text, "", "systems"),
                key: "systems".into(),
                msg: unknown_feel(s),
            })?;
            if !systems.contains(&k) {
                systems.push(k);
            }
        }
        let mut rig = f.rig.clone();
        rig.urdf = dir.join(&rig.urdf);
        chk("rig", "physics_hz", rig.physics_hz, 100.0, 100_000.0, "Hz")?;
        let device = DeviceConfig::load(&dir.join(&f.device.file), &Registry::builtin())?;
        chk(
            "device",
            "coil_resistance_ohm",
            f.device.coil_resistance_ohm,
            0.0,
            1000.0,
            "Ω",
        )?;
        let springs = FeelSprings::load(&dir.join(&f.springs.file))?;
        let s = &f.springs;
        chk(
            "springs",
            "damping_n_s_per_m",
            s.damping_n_s_per_m,
            0.0,
            1e5,
            "N·s/m",
        )?;
        chk("springs", "qbar_pa", s.qbar_pa, 0.0, 1e6, "Pa")?;
        chk("springs", "hybrid_k_n_per_m", s.hybrid_k_n_per_m, 0.0, 1e6, "N/m")?;
        chk(
            "springs",
            "hybrid_return_damping_n_s_per_m",
            s.hybrid_return_damping_n_s_per_m,
            0.0,
            1e5,
            "N·s/m",
        )?;
        let t = &f.target;
        chk("target", "breakout_n", t.breakout_n, 0.0, 250.0, "N")?;
        chk("target", "gradient_n_per_m", t.gradient_n_per_m, 0.0, 1e6, "N/m")?;
        chk("target", "max_force_n", t.max_force_n, 0.0, 250.0, "N")?;
        let c = &f.controller;
        chk("controller", "kp_a_per_n", c.kp_a_per_n, 0.0, 10.0, "A/N")?;
        chk(
            "controller",
            "ki_a_per_n_s",
            c.ki_a_per_n_s,
            0.0,
            1000.0,
            "A/(N·s)",
        )?;
        chk("controller", "rest_speed_m_s", c.rest_speed_m_s, 0.0, 1.0, "m/s")?;
        chk("controller", "rest_force_n", c.rest_force_n, 0.0, 250.0, "N")?;
        chk(
            "controller",
            "latency_samples",
            c.latency_samples as f64,
            0.0,
            1000.0,
            "",
        )?;
        chk(
            "controller",
            "velocity_cutoff_hz",
            c.velocity_cutoff_hz,
            0.1,
            1e4,
            "Hz",
        )?;
        chk(
            "controller",
            "load_cell_noise_rms_n",
            c.load_cell_noise_rms_n,
            0.0,
            50.0,
            "N",
        )?;
        let p = &f.pilot;
        chk("pilot", "stiffness_n_per_m", p.stiffness_n_per_m, 0.0, 1e5, "N/m")?;
        chk(
            "pilot",
            "damping_n_s_per_m",
            p.damping_n_s_per_m,
            0.0,
            1e4,
            "N·s/m",
        )?;
        chk(
            "pilot",
            "integral_gain_per_s",
            p.integral_gain_per_s,
            0.0,
            100.0,
            "1/s",
        )?;
        let k = &f.task;
        chk(
            "task",
            "sweep_amplitude_rad",
            k.sweep_amplitude_rad,
            0.0,
            1.0,
            "rad",
        )?;
        chk(
            "task",
            "sweep_frequency_hz",
            k.sweep_frequency_hz,
            0.01,
            20.0,
            "Hz",
        )?;
        chk(
            "task",
            "sweep_cycles",
            k.sweep_cycles as f64,
            2.0,
            100.0,
            "(the first cycle is a run-in)",
        )?;
        chk("task", "release_angle_rad", k.release_angle_rad, -1.0, 1.0, "rad")?;
        chk("task", "release_ramp_s", k.release_ramp_s, 0.01, 60.0, "s")?;
        chk("task", "release_hold_s", k.release_hold_s, 0.0, 60.0, "s")?;
        chk("task", "release_observe_s", k.release_observe_s, 0.1, 60.0, "s")?;
        chk("task", "recentre_band_rad", k.recentre_band_rad, 1e-5, 0.5, "rad")?;
        chk(
            "task",
            "breakout_ramp_n_per_s",
            k.breakout_ramp_n_per_s,
            0.1,
            1000.0,
            "N/s",
        )?;
        chk(
            "task",
            "breakout_duration_s",
            k.breakout_duration_s,
            0.1,
            60.0,
            "s",
        )?;
        chk(
            "task",
            "breakout_threshold_rad",
            k.breakout_threshold_rad,
            1e-5,
            0.5,
            "rad",
        )?;
        let l = &f.limits;
        chk(
            "limits",
            "part23_stick_pitch_temporary_lbf",
            l.part23_stick_pitch_temporary_lbf,
            0.0,
            500.0,
            "lbf",
        )?;
        chk(
            "limits",
            "pitch_prolonged_lbf",
            l.pitch_prolonged_lbf,
            0.0,
            500.0,
            "lbf",
        )?;
        chk(
            "limits",
            "part25_pitch_one_hand_lbf",
            l.part25_pitch_one_hand_lbf,
            0.0,
            500.0,
            "lbf",
        )?;
        let task_s = main_task(k).duration_s();
        chk(
            "fault_test",
            "start_s",
            f.fault_test.start_s,
            0.0,
            task_s,
            "s (within the task)",
        )?;
        chk(
            "fault_test",
            "end_s",
            f.fault_test.end_s,
            f.fault_test.start_s,
            f64::MAX,
            "s (after start_s)",
        )?;
        let faults = FaultSchedule::from_scenario_text(text, path, task_s)?;
        Ok(Self {
            path: path.to_path_buf(),
            name: f.name,
            seed: f.seed,
            systems,
            rig,
            device,
            coil_resistance_ohm: f.device.coil_resistance_ohm,
            springs,
            spring_damping_n_s_per_m: s.damping_n_s_per_m,
            qbar_pa: s.qbar_pa,
            hybrid_spring: CentringSpring {
                k_n_per_m: s.hybrid_k_n_per_m,
            },
            hybrid_return_damping_n_s_per_m: s.hybrid_return_damping_n_s_per_m,
            target: f.target,
            controller: f.controller,
            pilot: f.pilot,
            task: f.task,
            limits: f.limits,
            fault_test: f.fault_test,
            faults,
        })
    }

    /// The spring element of a system (with the q-feel spring at the scenario's q̄), if any.
    pub fn spring(&self, kind: FeelKind) -> Option<Box<dyn FeelSystem>> {
        match kind {
            FeelKind::CentringSpring => Some(Box::new(self.springs.centring)),
            FeelKind::VariableGradientSpring => Some(Box::new(self.springs.variable_gradient)),
            FeelKind::QFeel => {
                let mut q = self.springs.q_feel;
                q.set_dynamic_pressure(self.qbar_pa);
                Some(Box::new(q))
            }
            FeelKind::Mr => None,
            FeelKind::MrSpring => Some(Box::new(self.hybrid_spring)),
        }
    }

    /// The standard task: sinusoidal stick motion, then deflect–hold–let go.
    pub fn main_task(&self) -> Task {
        main_task(&self.task)
    }

    /// The breakout task: a slow grip-force ramp from rest at the centre.
    pub fn breakout_task(&self) -> Task {
        Task {
            segments: vec![Segment::ForceRamp {
                rate_n_per_s: self.task.breakout_ramp_n_per_s,
                duration_s: self.task.breakout_duration_s,
            }],
        }
    }
}

fn main_task(k: &TaskSection) -> Task {
    Task {
        segments: vec![
            Segment::Sine {
                amplitude_rad: k.sweep_amplitude_rad,
                frequency_hz: k.sweep_frequency_hz,
                duration_s: k.sweep_cycles as f64 / k.sweep_frequency_hz,
            },
            Segment::MoveHold {
                angle_rad: k.release_angle_rad,
                ramp_s: k.release_ramp_s,
                hold_s: k.release_hold_s,
            },
            Segment::LetGo {
                duration_s: k.release_observe_s,
            },
        ],
    }
}

// ---------------------------------------------------------------------------------------------------
// Tasks

/// One part of the pilot's task.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Segment {
    /// Follow `A sin(2π f t)` (rad), position task.
    Sine {
        amplitude_rad: f64,
        frequency_hz: f64,
        duration_s: f64,
    },
    /// Move from the centre to `angle_rad` (smooth ramp) and hold it.
    MoveHold {
        angle_rad: f64,
        ramp_s: f64,
        hold_s: f64,
    },
    /// Hands off the stick.
    LetGo { duration_s: f64 },
    /// Push the grip with a force rising at `rate_n_per_s` from 0.
    ForceRamp { rate_n_per_s: f64, duration_s: f64 },
}

impl Segment {
    pub fn duration_s(&self) -> f64 {
        match *self {
            Segment::Sine { duration_s, .. } => duration_s,
            Segment::MoveHold { ramp_s, hold_s, .. } => ramp_s + hold_s,
            Segment::LetGo { duration_s } => duration_s,
            Segment::ForceRamp { duration_s, .. } => duration_s,
        }
    }
}

/// What the pilot does at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PilotCmd {
    /// Follow this stick angle (rad) and rate (rad/s).
    Angle { theta_rad: f64, rate_rad_s: f64 },
    /// Push the grip with this force, N.
    Force(f64),
    /// Hands off.
    Off,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    pub segments: Vec<Segment>,
}

impl Task {
    pub fn duration_s(&self) -> f64 {
        self.segments.iter().map(Segment::duration_s).sum()
    }

    /// Segment index and time into it at `t_s` (the last segment past the end).
    pub fn segment_at(&self, t_s: f64) -> (usize, f64) {
        let mut t0 = 0.0;
        for (k, s) in self.segments.iter().enumerate() {
            if t_s < t0 + s.duration_s() || k + 1 == self.segments.len() {
                return (k, t_s - t0);
            }
            t0 += s.duration_s();
        }
        (0, t_s)
    }

    /// Start time of segment `k`, s.
    pub fn segment_start_s(&self, k: usize) -> f64 {
        self.segments[..k].iter().map(Segment::duration_s).sum()
    }

    pub fn command(&self, t_s: f64) -> PilotCmd {
        let (k, tau) = self.segment_at(t_s);
        match self.segments[k] {
            Segment::Sine {
                amplitude_rad,
                frequency_hz,
                ..
            } => {
                let w = 2.0 * std::f64::consts::PI * frequency_hz;
                PilotCmd::Angle {
                    theta_rad: amplitude_rad * (w * tau).sin(),
                    rate_rad_s: amplitude_rad * w * (w * tau).cos(),
                }
            }
            Segment::MoveHold {
                angle_rad, ramp_s, ..
            } => {
                // Smoothstep ramp: zero rate at both ends.
                let u = (tau / ramp_s).clamp(0.0, 1.0);
                let s = u * u * (3.0 - 2.0 * u);
                let ds = if u < 1.0 {
                    6.0 * u * (1.0 - u) / ramp_s
                } else {
                    0.0
                };
                PilotCmd::Angle {
                    theta_rad: angle_rad * s,
                    rate_rad_s: angle_rad * ds,
                }
            }
            Segment::LetGo { .. } => PilotCmd::Off,
            Segment::ForceRamp { rate_n_per_s, .. } => PilotCmd::Force(rate_n_per_s * tau),
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// The MR force loop (stand-in for the loop's FeelController, see the module doc)

/// What the loop decided at one sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Mode {
    Tracking,
    Released,
    Holding,
}

/// A DAQ sample as the controller sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub t_s: f64,
    pub force_n: f64,
    pub x_m: f64,
    pub v_m_s: f64,
}

#[derive(Debug, Clone)]
pub struct MrController {
    pub target: TargetLaw,
    pub kp: f64,
    pub ki: f64,
    pub limit_a: f64,
    pub rest_speed_m_s: f64,
    pub rest_force_n: f64,
    /// Bingham base parameters for the feedforward.
    pub fc0_n: f64,
    pub fc_gain_n_per_a: f64,
    pub c0_n_s_per_m: f64,
    /// Hybrid: the spring on the same joint (its force is subtracted from the damper's share), and the
    /// virtual damping given at rest or on the way back; `None` for the MR damper alone.
    pub hybrid: Option<(CentringSpring, f64)>,
    integral: f64,
}

impl MrController {
    pub fn new(scn: &CompareScenario, hybrid: bool) -> Self {
        let p = |n: &str| scn.device.param(n).unwrap_or(0.0);
        Self {
            target: scn.target,
            kp: scn.controller.kp_a_per_n,
            ki: scn.controller.ki_a_per_n_s,
            limit_a: scn.device.model.current_limit_a,
            rest_speed_m_s: scn.controller.rest_speed_m_s,
            rest_force_n: scn.controller.rest_force_n,
            fc0_n: p("fc0_n"),
            fc_gain_n_per_a: p("fc_gain_n_per_a"),
            c0_n_s_per_m: p("c0_n_s_per_m"),
            hybrid: hybrid.then_some((scn.hybrid_spring, scn.hybrid_return_damping_n_s_per_m)),
            integral: 0.0,
        }
    }

    /// Static inverse of Eq. (2) with Eq. (6) at steady state: current for a damper force at a speed, A.
    fn feedforward_a(&self, force_n: f64, speed_m_s: f64) -> f64 {
        if self.fc_gain_n_per_a <= 0.0 {
            return 0.0;
        }
        ((force_n - self.fc0_n - self.c0_n_s_per_m * speed_m_s) / self.fc_gain_n_per_a)
            .clamp(0.0, self.limit_a)
    }

    pub fn integral_a(&self) -> f64 {
        self.integral
    }

    /// One sample, `dt_s` the sample period: (current command A, target force N, mode).
    pub fn update(&mut self, s: &Sample, dt_s: f64) -> (f64, f64, Mode) {
        let moving = s.v_m_s.abs() >= self.rest_speed_m_s;
        let dir = if moving {
            s.v_m_s.signum()
        } else if s.force_n.abs() > self.rest_force_n {
            s.force_n.signum()
        } else {
            0.0
        };
        let desired = self.target.force_n(s.x_m, dir);
        let spring_n = self
            .hybrid
            .map(|(k, _)| -k.force_on_piston_n(s.x_m))
            .unwrap_or(0.0);
        let damper_share = |f: f64| (f.abs() - spring_n.abs()).max(0.0);
        if let Some((_, c)) = self.hybrid {
            // Hybrid: never hold against the spring; at rest or returning, a velocity-proportional yield.
            if dir == 0.0 || desired * dir <= 0.0 || !moving {
                self.integral = 0.0;
                let i = self.feedforward_a(c * s.v_m_s.abs() + self.fc0_n, 0.0);
                return (i, desired, Mode::Released);
            }
        } else if dir == 0.0 {
            let i = self.feedforward_a(self.target.force_n(s.x_m, 0.0).abs(), 0.0);
            return (i, desired, Mode::Holding);
        } else if desired * dir <= 0.0 {
            self.integral = 0.0;
            return (0.0, desired, Mode::Released);
        } else if !moving {
            return (
                self.feedforward_a(damper_share(desired), 0.0),
                desired,
                Mode::Holding,
            );
        }
        // Tracking in magnitude, clamping anti-windup.
        let ff = self.feedforward_a(damper_share(desired), s.v_m_s.abs());
        let e = desired.abs() - dir * s.force_n;
        let before = ff + self.kp * e + self.integral;
        let di = self.ki * e * dt_s;
        if !((before >= self.limit_a && di > 0.0) || (before <= 0.0 && di < 0.0)) {
            self.integral += di;
        }
        let u = (ff + self.kp * e + self.integral).clamp(0.0, self.limit_a);
        (u, desired, Mode::Tracking)
    }
}

// ---------------------------------------------------------------------------------------------------
// One run

/// One physics step of a run (state at the start of the step, and what was applied over it).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Row {
    pub t_s: f64,
    pub segment: usize,
    pub theta_rad: f64,
    pub theta_cmd_rad: f64,
    pub rate_rad_s: f64,
    pub piston_x_m: f64,
    /// Pilot's force at the grip (what the pilot feels), N; 0 hands off.
    pub hand_force_n: f64,
    pub hands_on: bool,
    /// The feel target at the grip at this deflection, N.
    pub target_grip_n: f64,
    pub load_cell_true_n: f64,
    /// Load cell as the controller saw it (after faults, delay), N; NaN without a loop.
    pub load_cell_seen_n: f64,
    /// Controller's current command, A, and what the coil received (after driver faults), A.
    pub current_cmd_a: f64,
    pub current_applied_a: f64,
    /// Coil current (Eq. 3 state), A.
    pub coil_current_a: f64,
    pub yield_force_n: f64,
    /// Mechanical energy stored (kinetic + potential + feel spring), J; the hand's work so far, J; the
    /// damper's dissipated energy so far, J.
    pub stored_j: f64,
    pub hand_work_j: f64,
    pub damper_dissipated_j: f64,
    /// Active faults (bit set over `FaultKind::ALL`).
    pub faults: u8,
}

/// A run's rows and what is needed to read them.
#[derive(Debug, Clone)]
pub struct Trace {
    pub system: FeelKind,
    pub task: Task,
    pub dt_s: f64,
    pub rows: Vec<Row>,
}

/// Run one task with one feel system and a fault schedule.
pub fn run(
    scn: &CompareScenario,
    kind: FeelKind,
    task: &Task,
    faults: &FaultSchedule,
) -> Result<Trace, CompareError> {
    let mut damper = scn.device.damper();
    if !kind.has_coil() {
        // A spring feel unit: no MR element, its own viscous damper.
        let mut p = damper.params().to_vec();
        for (name, v) in [
            ("fc0_n", 0.0),
            ("fc_gain_n_per_a", 0.0),
            ("c0_n_s_per_m", scn.spring_damping_n_s_per_m),
        ] {
            if let Some(k) = damper.model().param_index(name) {
                p[k] = v;
            }
        }
        damper = crate::device::Damper::new(scn.device.model.clone(), p)?;
    }
    let mut rig = Rig::new(&scn.rig, damper)?;
    let dt = rig.dt_s();
    let lever = rig.grip_lever_m();
    let gear0 = rig.gearing_m_per_rad();
    let linkage = *rig.linkage();
    let spring = scn.spring(kind);
    let mut ctl = kind
        .has_coil()
        .then(|| MrController::new(scn, kind == FeelKind::MrSpring));
    let limit_a = scn.device.model.current_limit_a;
    let mut inj = FaultInjector::new(faults.clone(), scn.seed);
    let mut noise = ChaCha8Rng::seed_from_u64(scn.seed);
    let tau_v = 1.0 / (2.0 * std::f64::consts::PI * scn.controller.velocity_cutoff_hz);
    let alpha_v = (-dt / tau_v).exp();
    let (mut x_prev, mut v_filt) = (None::<f64>, 0.0);
    let mut line: VecDeque<Sample> = VecDeque::new();
    let (mut cmd_a, mut seen_n) = (0.0, f64::NAN);
    let pg = scn.pilot;
    let mut pilot_integral_n = 0.0;
    let n = (task.duration_s() / dt).round() as usize;
    let mut rows = Vec::with_capacity(n);
    let stored = |rig: &Rig| {
        let s = rig.state();
        s.kinetic_energy_j
            + s.potential_energy_j
            + spring
                .as_ref()
                .map(|f| f.stored_energy_j(s.piston_x_m))
                .unwrap_or(0.0)
    };
    let e0 = stored(&rig);
    for step in 0..n {
        let t = step as f64 * dt;
        let s = rig.state();
        let (seg, _) = task.segment_at(t);
        let cmd = task.command(t);
        // Pilot.
        let (hand_n, theta_cmd, hands_on) = match cmd {
            PilotCmd::Angle {
                theta_rad,
                rate_rad_s,
            } => {
                let e = lever * (theta_rad - s.stick_angle_rad);
                let de = lever * (rate_rad_s - s.stick_rate_rad_s);
                pilot_integral_n += pg.integral_gain_per_s * pg.stiffness_n_per_m * e * dt;
                (
                    pg.stiffness_n_per_m * e + pg.damping_n_s_per_m * de + pilot_integral_n,
                    theta_rad,
                    true,
                )
            }
            PilotCmd::Force(f) => (f, f64::NAN, true),
            PilotCmd::Off => {
                pilot_integral_n = 0.0;
                (0.0, f64::NAN, false)
            }
        };
        // The MR loop: sample, fault hooks, delay line, controller.
        if let Some(c) = ctl.as_mut() {
            let nf: f64 = StandardNormal.sample(&mut noise);
            let f_read = inj.load_cell_n(t, s.load_cell_n + scn.controller.load_cell_noise_rms_n * nf);
            let x_read = inj.displacement_m(t, s.piston_x_m);
            if let Some(x0) = x_prev {
                v_filt = alpha_v * v_filt + (1.0 - alpha_v) * (x_read - x0) / dt;
            }
            x_prev = Some(x_read);
            line.push_back(Sample {
                t_s: t,
                force_n: f_read,
                x_m: x_read,
                v_m_s: v_filt,
            });
            let delay = scn.controller.latency_samples as f64 * dt + inj.extra_latency_s(t);
            let newest_ok = line.iter().rposition(|q| q.t_s <= t - delay + 1e-9 * dt);
            if let Some(k) = newest_ok {
                let q = line[k];
                let (i, _, _) = c.update(&q, dt);
                cmd_a = i;
                seen_n = q.force_n;
            }
            // Keep one second (or the longest delay) of history.
            let keep = ((delay + 1.0) / dt) as usize + 2;
            while line.len() > keep {
                line.pop_front();
            }
        }
        let applied = if kind.has_coil() {
            inj.coil_command_a(t, cmd_a, limit_a)
        } else {
            0.0
        };
        if let Some(f) = spring.as_ref() {
            feel::apply(f.as_ref(), &mut rig);
        }
        let gear = linkage.gearing_m_per_rad(s.stick_angle_rad).unwrap_or(gear0);
        let dir = if s.piston_v_m_s.abs() > 1e-4 {
            s.piston_v_m_s.signum()
        } else {
            0.0
        };
        rows.push(Row {
            t_s: t,
            segment: seg,
            theta_rad: s.stick_angle_rad,
            theta_cmd_rad: theta_cmd,
            rate_rad_s: s.stick_rate_rad_s,
            piston_x_m: s.piston_x_m,
            hand_force_n: hand_n,
            hands_on,
            target_grip_n: scn.target.force_n(s.piston_x_m, dir) * gear / lever,
            load_cell_true_n: s.load_cell_n,
            load_cell_seen_n: seen_n,
            current_cmd_a: cmd_a,
            current_applied_a: applied,
            coil_current_a: s.coil_current_a,
            yield_force_n: s.yield_n,
            stored_j: stored(&rig) - e0,
            hand_work_j: s.hand_work_j,
            damper_dissipated_j: s.damper_dissipated_j,
            faults: if kind.has_coil() { faults.active_mask(t) } else { 0 },
        });
        rig.step(hand_n, applied);
    }
    Ok(Trace {
        system: kind,
        task: task.clone(),
        dt_s: dt,
        rows,
    })
}

/// 1-based line of a byte offset.
fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// Line of `key = ...` inside `[section]` (top level for an empty section); 0 if not found.
fn line_of_key(text: &str, section: &str, key: &str) -> usize {
    let mut in_section = section.is_empty();
    for (k, l) in text.lines().enumerate() {
        let l = l.trim();
        if l.starts_with('[') {
            in_section = l.trim_matches(|c| c == '[' || c == ']').trim() == section;
            continue;
        }
        if in_section && l.split('=').next().map(str::trim) == Some(key) {
            return k + 1;
        }
    }
    0
}
