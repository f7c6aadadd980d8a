//! Scenario files (`scenarios/*.toml`): one headless run of the stick rig, wiring the rig (the `[rig]` table
//! is [`RigConfig`]: URDF, physics rate, solver settings), the device (a `models/*.toml` device file or a fitted `PARAMS.json`), the sensors and DAQ, the
//! feel loop's controller and feel law, and the pilot (hand model file and task).
//!
//! Every key is checked: unknown keys, wrong types and out-of-range values are errors naming the file, the
//! line, the key and the allowed range. Paths are relative to the scenario file; a file it names that
//! cannot be read, or that is bad, is an error naming the scenario's line and key as well as the file.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use crate::control::feel::{CentringSpring, FeelKind, FeelSprings, FeelSystemConfig};
use crate::control::{AntiWindup, FeelLaw, PidGains};
use crate::input::text::line_of;
use crate::pilot::attitude::{CrossoverPilotConfig, PilotLoop, Schedule};
use crate::pilot::{HandConfig, Signal, Task};
use crate::rig::RigConfig;
use crate::sensors::{DaqConfig, LaserConfig, LoadCellConfig, SensorsConfig};

mod overrides;
pub use overrides::{Origin, Override};

#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("{}: {msg}", path.display())]
    Io { path: PathBuf, msg: String },
    #[error("{}:{line}: {msg}", path.display())]
    Parse { path: PathBuf, line: usize, msg: String },
    /// `[[fault]]` tables (issue 6 hook, read by `crate::faults`).
    #[error(transparent)]
    Faults(#[from] crate::faults::FaultError),
    #[error("{}:{line}: `{key}`: {msg}", path.display())]
    Field {
        path: PathBuf,
        line: usize,
        key: String,
        msg: String,
    },
    /// An override ([`Override`]) refused at the place it was written.
    #[error("{origin}: `{key}`: {msg}")]
    Override {
        origin: Origin,
        key: String,
        msg: String,
    },
    /// An error the overrides caused at another key of the scenario (a DAQ rate above a lowered physics
    /// rate), at the scenario's line.
    #[error("{error} (with the overrides {overrides})")]
    Overridden {
        error: Box<ScenarioError>,
        overrides: String,
    },
}

/// The controller section, validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerConfig {
    pub gains: PidGains,
    pub feedforward: bool,
    pub rest_speed_m_s: f64,
    pub rest_force_n: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct PilotConfig {
    pub hand_path: PathBuf,
    pub hand: HandConfig,
    pub task: Task,
    /// Command in stick angle (rad) for a position task, grip force (N) for a force task.
    pub command: Signal,
}

/// `[aircraft]`: the aircraft whose stick force is the feel target (`feel.law = "aircraft"`).
#[derive(Debug, Clone, PartialEq)]
pub struct AircraftConfig {
    /// `"c172p"`, `"737"` (embedded Rust model) or `"jsbsim:c172p"`, `"jsbsim:737"` (live JSBSim).
    pub model: String,
    /// Trim: true airspeed, m/s, and altitude, m.
    pub airspeed_m_s: f64,
    pub altitude_m: f64,
    /// Aircraft frame rate, Hz (JSBSim's 120 Hz by default; at most the physics rate).
    pub rate_hz: f64,
    /// Throttle as a ratio of the trim throttle (trim throughout by default).
    pub throttle: Schedule,
}

/// `[outer_loop]`: the pilot's compensatory loop on pitch attitude or load factor, whose output is the
/// hand's stick-angle command (`pilot.signal = "outer-loop"`).
#[derive(Debug, Clone, PartialEq)]
pub struct OuterLoopConfig {
    pub loop_kind: PilotLoop,
    /// The crossover pilot, given or adapted to the aircraft; stick limits are set from the rig.
    pub pilot: PilotDesign,
    /// Command in the loop's unit: pitch in **rad** relative to trim (the file gives degrees), or load
    /// factor in g.
    pub command: Schedule,
}

/// How the pilot's outer loop gets its gains.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PilotDesign {
    /// Gains given in the file (`gain`, `lead_s`, `lag_s`, `integral_per_s`, `delay_s`).
    Given(CrossoverPilotConfig),
    /// McRuer's crossover model: the pilot adapts gain and equalisation to the aircraft at its trim so that
    /// the open loop crosses over at `crossover_rad_s` with the effective delay `delay_s`; `stick_lag_s` is
    /// the lag from the pilot's stick command to the stick (hand and feel), part of the controlled element
    /// (`crate::aero::linear::adapted_pilot`).
    Adapted {
        crossover_rad_s: f64,
        delay_s: f64,
        stick_lag_s: f64,
    },
}

/// Most physics steps a run may take ([`Scenario::load`] refuses more): each keeps a row of the results, so
/// this bounds the memory at about 3 GB (an hour at 100 kHz asked for 107 GB and aborted).
pub const MAX_PHYSICS_STEPS: f64 = 1e7;

/// Lines of a scenario's keys that errors found during a run name (the run's own errors: a trim that has
/// no solution, an integration that blows up).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyLines {
    /// `rig.physics_hz`.
    pub physics_hz: usize,
    /// `aircraft.airspeed_m_s`, the trim condition (the `[aircraft]` header where it is not written, 1
    /// without an aircraft).
    pub airspeed: usize,
    /// `aircraft.model`, the aircraft flown (for its errors in flight).
    pub aircraft_model: usize,
    /// `feel.law` (a DAQ sweep needs a step test).
    pub feel_law: usize,
    /// `pilot.frequency_hz` (the `[pilot]` header where it is not written), a likely cause of a run that
    /// breaks an invariant ([`crate::sim::invariants`]).
    pub pilot_frequency: usize,
    /// `device.file` (errors of the plant's device file).
    pub device_file: usize,
    /// `controller.model` (errors of the model file it names), else `device.file`.
    pub controller_model: usize,
}

/// A validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    pub path: PathBuf,
    /// Where the keys a run's errors name are in the file.
    pub lines: KeyLines,
    pub name: String,
    pub duration_s: f64,
    pub seed: u64,
    /// The rig's settings, with the URDF path resolved against the scenario's directory.
    pub rig: RigConfig,
    pub device_path: PathBuf,
    /// The model the feel controller believes (`[controller] model`): a device file or a fitted
    /// `PARAMS.json`; `None`: the plant's own device file.
    pub controller_model_path: Option<PathBuf>,
    pub sensors: SensorsConfig,
    pub controller: ControllerConfig,
    pub feel: FeelLaw,
    pub pilot: PilotConfig,
    /// Scheduled faults (`[[fault]]` tables; issue 6 hook, see `crate::faults`).
    pub faults: crate::faults::FaultSchedule,
    /// The aircraft in the loop, if any (issue 5).
    pub aircraft: Option<AircraftConfig>,
    /// The pilot's outer loop on the aircraft, if any.
    pub outer_loop: Option<OuterLoopConfig>,
    /// The feel system on the rig (`[feel_system]`; the paper's MR damper alone by default).
    pub feel_system: FeelSystemConfig,
    /// The feel-spring file `[feel_system] springs` names, if any (resolved against the scenario's
    /// directory).
    pub springs_path: Option<PathBuf>,
}

impl Scenario {
    pub fn load(path: &Path) -> Result<Self, ScenarioError> {
        let text = read(path)?;
        Self::parse(&text, path)
    }

    pub fn physics_rate_hz(&self) -> f64 {
        self.rig.physics_hz
    }

    /// The same scenario flown by another aircraft backend (`"jsbsim:c172p"`); `None` if the scenario has
    /// no aircraft.
    pub fn with_aircraft_model(&self, model: &str) -> Option<Self> {
        let mut s = self.clone();
        s.aircraft.as_mut()?.model = model.to_string();
        Some(s)
    }

    /// The files other than the scenario itself that a run of it reads, each with what it is (for errors):
    /// the device file, the rig's URDF, the pilot model, the feel-spring file, and the aircraft model it
    /// flies, those on disk (not built in). An output must not be one of them.
    pub fn named_files(&self) -> Vec<(&'static str, PathBuf)> {
        let mut files = vec![
            ("device file", self.device_path.clone()),
            ("URDF", self.rig.urdf.clone()),
            ("pilot model", self.pilot.hand_path.clone()),
        ];
        if let Some(p) = &self.controller_model_path {
            files.push(("controller model", p.clone()));
        }
        if let Some(p) = &self.springs_path {
            files.push(("feel-spring file", p.clone()));
        }
        if let Some(a) = &self.aircraft {
            // As the flight reads the spec (`sim::flight`): `jsbsim:<name>` flies the model `<name>` live.
            let file = match a.model.strip_prefix("jsbsim:") {
                Some(live) => crate::aero::backend::model_file(live),
                None => crate::aero::AircraftModel::builtin(&a.model),
            };
            if let Ok(p) = file {
                files.push(("aircraft model", p));
            }
        }
        // A built-in file is never an output's path.
        files.retain(|(_, p)| !crate::builtin::is_builtin(p));
        files
    }

    /// The same scenario with another DAQ rate (for the DAQ-rate sweep).
    pub fn with_daq_rate(&self, rate_hz: f64) -> Self {
        let mut s = self.clone();
        s.sensors.daq.sample_rate_hz = rate_hz;
        s
    }

    pub fn parse(text: &str, path: &Path) -> Result<Self, ScenarioError> {
        let f: File = from_toml(text, path)?;
        let c = Ctx { path, text };
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut rig = f.rig.clone();
        let rig_line = |key: &str| crate::input::text::toml_key_line(text, "rig", key);
        // The files the run reads later: named here, with the line that names them, when they are missing.
        rig.urdf = c.named_file(rig_line("urdf"), "rig.urdf", &f.rig.urdf)?;
        let device_path = c.named_file(
            line_of(text, f.device.file.span().start),
            "device.file",
            Path::new(f.device.file.get_ref()),
        )?;
        let controller_model_path = match &f.controller.model {
            Some(m) => Some(c.named_file(
                line_of(text, m.span().start),
                "controller.model",
                Path::new(m.get_ref()),
            )?),
            None => None,
        };
        let physics_rate_hz = rig.physics_hz;
        if !(physics_rate_hz.is_finite() && (100.0..=100_000.0).contains(&physics_rate_hz)) {
            return Err(ScenarioError::Field {
                path: path.to_path_buf(),
                line: rig_line("physics_hz"),
                key: "rig.physics_hz".into(),
                msg: format!("value {physics_rate_hz} outside the allowed range [100, 100000] Hz"),
            });
        }
        let duration_s = c.num(&f.duration_s, "duration_s", 1e-3, 3600.0, "s")?;
        let steps = duration_s * physics_rate_hz;
        if steps > MAX_PHYSICS_STEPS {
            return Err(c.err(
                &f.duration_s,
                "duration_s",
                &format!(
                    "{duration_s} s at rig.physics_hz = {physics_rate_hz} Hz is {steps:.0} physics steps: at most \
                     {MAX_PHYSICS_STEPS:e} (a run keeps a row of ~300 bytes per step: 3 GB); shorten the run or \
                     lower the physics rate"
                ),
            ));
        }
        let seed = c.int(&f.seed, "seed", 0, i64::MAX)? as u64;

        let sensors = SensorsConfig {
            load_cell: LoadCellConfig {
                range_n: c.num(&f.load_cell.range_n, "load_cell.range_n", 1.0, 1e5, "N")?,
                gain: c.num(&f.load_cell.gain, "load_cell.gain", 0.5, 2.0, "")?,
                offset_n: c.num(&f.load_cell.offset_n, "load_cell.offset_n", -50.0, 50.0, "N")?,
                noise_rms_n: c.num(&f.load_cell.noise_rms_n, "load_cell.noise_rms_n", 0.0, 50.0, "N")?,
            },
            laser: LaserConfig {
                range_m: c.num(&f.laser.range_m, "laser.range_m", 1e-3, 1.0, "m")?,
                noise_rms_m: c.num(&f.laser.noise_rms_m, "laser.noise_rms_m", 0.0, 1e-2, "m")?,
                velocity_cutoff_hz: c.num(
                    &f.laser.velocity_cutoff_hz,
                    "laser.velocity_cutoff_hz",
                    0.1,
                    1e4,
                    "Hz",
                )?,
            },
            daq: DaqConfig {
                sample_rate_hz: c.num(
                    &f.daq.sample_rate_hz,
                    "daq.sample_rate_hz",
                    1.0,
                    physics_rate_hz,
                    "Hz (at most rig.physics_hz)",
                )?,
                latency_samples: c.int(&f.daq.latency_samples, "daq.latency_samples", 0, 1000)? as usize,
                adc_bits: c.int(&f.daq.adc_bits, "daq.adc_bits", 0, 32)? as u32,
            },
        };
        let k = &f.controller;
        let anti_windup = match k.anti_windup.get_ref().as_str() {
            "none" => AntiWindup::None,
            "clamping" => AntiWindup::Clamping,
            "back-calculation" => AntiWindup::BackCalculation {
                tracking_time_s: match &k.tracking_time_s {
                    Some(v) => c.num(v, "controller.tracking_time_s", 1e-5, 10.0, "s")?,
                    None => {
                        return Err(c.err(
                            &k.anti_windup,
                            "controller.tracking_time_s",
                            "required with anti_windup = \"back-calculation\"",
                        ))
                    }
                },
            },
            other => {
                return Err(c.err(
                    &k.anti_windup,
                    "controller.anti_windup",
                    &format!("`{other}` is not one of: none, clamping, back-calculation"),
                ))
            }
        };
        let out_min = c.num(&k.current_min_a, "controller.current_min_a", 0.0, 14.0, "A")?;
        let out_max = c.num(
            &k.current_max_a,
            "controller.current_max_a",
            out_min,
            14.0,
            "A (the driver saturates at 14 A)",
        )?;
        let controller = ControllerConfig {
            gains: PidGains {
                kp: c.num(&k.kp_a_per_n, "controller.kp_a_per_n", 0.0, 10.0, "A/N")?,
                ki: c.num(&k.ki_a_per_n_s, "controller.ki_a_per_n_s", 0.0, 1000.0, "A/(N·s)")?,
                kd: c.num(&k.kd_a_s_per_n, "controller.kd_a_s_per_n", 0.0, 1.0, "A·s/N")?,
                derivative_filter_s: c.num(
                    &k.derivative_filter_s,
                    "controller.derivative_filter_s",
                    0.0,
                    1.0,
                    "s",
                )?,
                out_min,
                out_max,
                anti_windup,
            },
            feedforward: *k.feedforward.get_ref(),
            rest_speed_m_s: c.num(&k.rest_speed_m_s, "controller.rest_speed_m_s", 0.0, 1.0, "m/s")?,
            rest_force_n: c.num(&k.rest_force_n, "controller.rest_force_n", 0.0, 250.0, "N")?,
        };

        let fl = &f.feel;
        let feel = match fl.law.get_ref().as_str() {
            "spring" => FeelLaw::Spring {
                breakout_n: c.req(&fl.breakout_n, &fl.law, "feel.breakout_n", 0.0, 250.0, "N")?,
                gradient_n_per_m: c.req(
                    &fl.gradient_n_per_m,
                    &fl.law,
                    "feel.gradient_n_per_m",
                    0.0,
                    1e6,
                    "N/m",
                )?,
                damping_n_s_per_m: c.req(
                    &fl.damping_n_s_per_m,
                    &fl.law,
                    "feel.damping_n_s_per_m",
                    0.0,
                    1e5,
                    "N·s/m",
                )?,
                max_force_n: c.req(&fl.max_force_n, &fl.law, "feel.max_force_n", 0.0, 250.0, "N")?,
            },
            "force-steps" => FeelLaw::ForceSteps {
                low_n: c.req(&fl.low_n, &fl.law, "feel.low_n", 0.0, 250.0, "N")?,
                high_n: c.req(&fl.high_n, &fl.law, "feel.high_n", 0.0, 250.0, "N")?,
                start_s: c.req(
                    &fl.start_s,
                    &fl.law,
                    "feel.start_s",
                    0.0,
                    duration_s,
                    "s (within duration_s)",
                )?,
                period_s: c.req(&fl.period_s, &fl.law, "feel.period_s", 1e-3, 3600.0, "s")?,
            },
            "aircraft" => {
                if f.aircraft.is_none() {
                    return Err(c.err(
                        &fl.law,
                        "feel.law",
                        "`aircraft` needs an `[aircraft]` section (the aircraft whose stick force is felt)",
                    ));
                }
                FeelLaw::Target { force_n: 0.0 }
            }
            other => {
                return Err(c.err(
                    &fl.law,
                    "feel.law",
                    &format!("`{other}` is not one of: spring, force-steps, aircraft"),
                ))
            }
        };
        c.unused(
            &fl.law,
            &[
                (
                    "spring",
                    &[
                        ("low_n", fl.low_n.as_ref()),
                        ("high_n", fl.high_n.as_ref()),
                        ("start_s", fl.start_s.as_ref()),
                        ("period_s", fl.period_s.as_ref()),
                    ],
                ),
                (
                    "force-steps",
                    &[
                        ("breakout_n", fl.breakout_n.as_ref()),
                        ("gradient_n_per_m", fl.gradient_n_per_m.as_ref()),
                        ("damping_n_s_per_m", fl.damping_n_s_per_m.as_ref()),
                        ("max_force_n", fl.max_force_n.as_ref()),
                    ],
                ),
                (
                    "aircraft",
                    &[
                        ("breakout_n", fl.breakout_n.as_ref()),
                        ("gradient_n_per_m", fl.gradient_n_per_m.as_ref()),
                        ("damping_n_s_per_m", fl.damping_n_s_per_m.as_ref()),
                        ("max_force_n", fl.max_force_n.as_ref()),
                        ("low_n", fl.low_n.as_ref()),
                        ("high_n", fl.high_n.as_ref()),
                        ("start_s", fl.start_s.as_ref()),
                        ("period_s", fl.period_s.as_ref()),
                    ],
                ),
            ],
            "feel",
        )?;
        let aircraft = f
            .aircraft
            .as_ref()
            .map(|a| parse_aircraft(a, &c, physics_rate_hz))
            .transpose()?;
        let outer_loop = f
            .outer_loop
            .as_ref()
            .map(|o| parse_outer_loop(o, &c))
            .transpose()?;
        let feel_system = match &f.feel_system {
            Some(fs) => parse_feel_system(fs, &c, aircraft.is_some())?,
            None => FeelSystemConfig::default(),
        };
        let wants_outer = f.pilot.signal.get_ref() == "outer-loop";
        match (&f.outer_loop, wants_outer) {
            (Some(o), false) => {
                return Err(c.err(
                    &o.loop_kind,
                    "outer_loop",
                    "an `[outer_loop]` section needs `pilot.signal = \"outer-loop\"`",
                ))
            }
            (None, true) => {
                return Err(c.err(
                    &f.pilot.signal,
                    "pilot.signal",
                    "`outer-loop` needs an `[outer_loop]` section (the pilot's loop on the aircraft)",
                ))
            }
            _ => {}
        }
        if let Some(o) = &f.outer_loop {
            if aircraft.is_none() {
                return Err(c.err(
                    &o.loop_kind,
                    "outer_loop",
                    "the pilot's outer loop needs an `[aircraft]` section to fly",
                ));
            }
            if f.pilot.task.get_ref() != "position" {
                return Err(c.err(
                    &f.pilot.task,
                    "pilot.task",
                    "the outer loop commands a stick angle: `pilot.task` must be \"position\"",
                ));
            }
        }

        let pilot = parse_pilot(&f.pilot, &c, duration_s, 1.0 / physics_rate_hz, seed)?;
        Ok(Scenario {
            path: path.to_path_buf(),
            lines: KeyLines {
                physics_hz: crate::input::text::toml_key_line(text, "rig", "physics_hz"),
                airspeed: crate::input::text::toml_key_line(text, "aircraft", "airspeed_m_s"),
                aircraft_model: crate::input::text::toml_key_line(text, "aircraft", "model"),
                feel_law: crate::input::text::toml_key_line(text, "feel", "law"),
                pilot_frequency: crate::input::text::toml_key_line(text, "pilot", "frequency_hz"),
                device_file: line_of(text, f.device.file.span().start),
                controller_model: match &f.controller.model {
                    Some(m) => line_of(text, m.span().start),
                    None => line_of(text, f.device.file.span().start),
                },
            },
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
            // issue 6 hook: `[[fault]]` tables.
            faults: crate::faults::FaultSchedule::from_scenario_text(text, path, duration_s)?,
            aircraft,
            outer_loop,
            feel_system,
            springs_path: f
                .feel_system
                .as_ref()
                .and_then(|fs| fs.springs.as_ref())
                .map(|p| crate::builtin::resolve(dir, Path::new(p.get_ref()))),
        })
    }

    /// The same scenario with another feel system.
    pub fn with_feel_system(&self, feel_system: FeelSystemConfig) -> Self {
        let mut s = self.clone();
        s.feel_system = feel_system;
        s
    }
}

fn parse_feel_system(
    fs: &FeelSystemSection,
    c: &Ctx,
    has_aircraft: bool,
) -> Result<FeelSystemConfig, ScenarioError> {
    let kind = FeelKind::from_name(fs.kind.get_ref()).ok_or_else(|| {
        c.err(
            &fs.kind,
            "feel_system.kind",
            &format!("`{}` is not one of: {}", fs.kind.get_ref(), FeelKind::names()),
        )
    })?;
    let forbid = |v: &Option<Spanned<f64>>, key: &str| -> Result<(), ScenarioError> {
        match v {
            Some(v) => Err(c.err(
                v,
                &format!("feel_system.{key}"),
                &format!("not used by `{}`", kind.name()),
            )),
            None => Ok(()),
        }
    };
    let need = |v: &Option<Spanned<f64>>, key: &str, hi: f64, unit: &str| -> Result<f64, ScenarioError> {
        match v {
            Some(v) => c.num(v, &format!("feel_system.{key}"), 0.0, hi, unit),
            None => Err(c.err(
                &fs.kind,
                &format!("feel_system.{key}"),
                &format!("required by `{}`", kind.name()),
            )),
        }
    };
    if kind == FeelKind::Active {
        if let Some(p) = &fs.springs {
            return Err(c.err(p, "feel_system.springs", "not used by `active`"));
        }
        for (v, key) in [
            (&fs.qbar_pa, "qbar_pa"),
            (&fs.hybrid_k_n_per_m, "hybrid_k_n_per_m"),
            (&fs.return_damping_n_s_per_m, "return_damping_n_s_per_m"),
        ] {
            forbid(v, key)?;
        }
        return Ok(FeelSystemConfig::active(
            need(&fs.motor_max_force_n, "motor_max_force_n", 1e4, "N")?,
            need(&fs.damping_n_s_per_m, "damping_n_s_per_m", 1e5, "N·s/m")?,
        ));
    }
    forbid(&fs.motor_max_force_n, "motor_max_force_n")?;
    let springs = match (&fs.springs, kind) {
        (None, FeelKind::Mr) => None,
        (Some(p), FeelKind::Mr) => {
            return Err(c.err(p, "feel_system.springs", "not used by `mr`"));
        }
        (Some(p), _) => Some(
            FeelSprings::load(&c.named_file(
                line_of(c.text, p.span().start),
                "feel_system.springs",
                Path::new(p.get_ref()),
            )?)
            .map_err(|e| c.err(p, "feel_system.springs", &e.to_string()))?,
        ),
        (None, _) => {
            return Err(c.err(
                &fs.kind,
                "feel_system.springs",
                &format!(
                    "required by `{}` (a feel-spring file such as models/feel-springs.toml)",
                    kind.name()
                ),
            ))
        }
    };
    let spring_unit = !kind.has_coil();
    let damping = if spring_unit {
        need(&fs.damping_n_s_per_m, "damping_n_s_per_m", 1e5, "N·s/m")?
    } else {
        forbid(&fs.damping_n_s_per_m, "damping_n_s_per_m")?;
        0.0
    };
    let (q_from_aircraft, qbar) =
        if kind == FeelKind::QFeel {
            match &fs.qbar_pa {
                Some(q) => (false, c.num(q, "feel_system.qbar_pa", 0.0, 1e6, "Pa")?),
                None if has_aircraft => (true, 0.0),
                None => return Err(c.err(
                    &fs.kind,
                    "feel_system.qbar_pa",
                    "required by `q_feel` without an `[aircraft]` (whose dynamic pressure it would follow)",
                )),
            }
        } else {
            forbid(&fs.qbar_pa, "qbar_pa")?;
            (false, 0.0)
        };
    let (hybrid_k, ret) = if kind == FeelKind::MrSpring {
        (
            need(&fs.hybrid_k_n_per_m, "hybrid_k_n_per_m", 1e6, "N/m")?,
            need(
                &fs.return_damping_n_s_per_m,
                "return_damping_n_s_per_m",
                1e5,
                "N·s/m",
            )?,
        )
    } else {
        forbid(&fs.hybrid_k_n_per_m, "hybrid_k_n_per_m")?;
        forbid(&fs.return_damping_n_s_per_m, "return_damping_n_s_per_m")?;
        (0.0, 0.0)
    };
    let mut out = match &springs {
        Some(sp) => FeelSystemConfig::from_springs(
            kind,
            sp,
            qbar,
            CentringSpring { k_n_per_m: hybrid_k },
            damping,
            ret,
        ),
        None => FeelSystemConfig::default(),
    };
    out.q_from_aircraft = q_from_aircraft;
    Ok(out)
}

fn parse_aircraft(
    a: &AircraftSection,
    c: &Ctx,
    physics_rate_hz: f64,
) -> Result<AircraftConfig, ScenarioError> {
    let throttle = match &a.throttle {
        None => Schedule {
            points: vec![(0.0, 1.0)],
        },
        Some(pts) => c.schedule(pts, "aircraft.throttle", 0.0, 3.0, "(ratio of the trim throttle)")?,
    };
    let model = match a.model.get_ref().split_once(':') {
        // A JSBSim aircraft folder is found as the scenario's other files are (beside it first).
        Some(("jsbsim", name)) if crate::aero::backend::jsbsim_folder(name).is_some() => {
            let dir = c.path.parent().unwrap_or(Path::new("."));
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
            return Err(c.err(
                &a.model,
                "aircraft.model",
                &format!("unknown backend `{other}` (use `<name>` or `jsbsim:<name>`)"),
            ))
        }
        None => crate::aero::AircraftModel::builtin(&model),
    };
    file.map_err(|e| c.err(&a.model, "aircraft.model", &e.to_string()))?;
    Ok(AircraftConfig {
        model: model.clone(),
        airspeed_m_s: c.num(&a.airspeed_m_s, "aircraft.airspeed_m_s", 10.0, 300.0, "m/s")?,
        altitude_m: c.num(&a.altitude_m, "aircraft.altitude_m", 0.0, 11_000.0, "m")?,
        rate_hz: match &a.rate_hz {
            Some(r) => c.num(
                r,
                "aircraft.rate_hz",
                10.0,
                physics_rate_hz,
                "Hz (at most rig.physics_hz)",
            )?,
            None => 120.0_f64.min(physics_rate_hz),
        },
        throttle,
    })
}

fn parse_outer_loop(o: &OuterLoopSection, c: &Ctx) -> Result<OuterLoopConfig, ScenarioError> {
    let loop_kind = match o.loop_kind.get_ref().as_str() {
        "pitch" => PilotLoop::Pitch,
        "load-factor" => PilotLoop::LoadFactor,
        other => {
            return Err(c.err(
                &o.loop_kind,
                "outer_loop.loop",
                &format!("`{other}` is not one of: pitch, load-factor"),
            ))
        }
    };
    let opt = |v: &Option<Spanned<f64>>, key: &str, hi: f64, unit: &str| -> Result<f64, ScenarioError> {
        v.as_ref().map_or(Ok(0.0), |v| c.num(v, key, 0.0, hi, unit))
    };
    let delay_s = c.num(&o.delay_s, "outer_loop.delay_s", 0.0, 1.0, "s")?;
    let pilot = match (&o.gain, &o.crossover_rad_s) {
        (Some(gain), None) => {
            if let Some(v) = &o.stick_lag_s {
                return Err(c.err(
                    v,
                    "outer_loop.stick_lag_s",
                    "only with `crossover_rad_s` (an adapted pilot)",
                ));
            }
            PilotDesign::Given(CrossoverPilotConfig {
                gain: c.num(
                    gain,
                    "outer_loop.gain",
                    0.0,
                    100.0,
                    "stick rad per rad (or per g)",
                )?,
                lead_s: opt(&o.lead_s, "outer_loop.lead_s", 10.0, "s")?,
                lag_s: opt(&o.lag_s, "outer_loop.lag_s", 100.0, "s")?,
                delay_s,
                integral_per_s: opt(
                    &o.integral_per_s,
                    "outer_loop.integral_per_s",
                    100.0,
                    "stick rad per (unit·s)",
                )?,
                stick_min_rad: f64::NEG_INFINITY,
                stick_max_rad: f64::INFINITY,
            })
        }
        (None, Some(wc)) => {
            for (v, key) in [
                (&o.lead_s, "lead_s"),
                (&o.lag_s, "lag_s"),
                (&o.integral_per_s, "integral_per_s"),
            ] {
                if let Some(v) = v {
                    return Err(c.err(
                        v,
                        &format!("outer_loop.{key}"),
                        "the adapted pilot (`crossover_rad_s`) chooses its own equalisation; give `gain` instead to set it",
                    ));
                }
            }
            PilotDesign::Adapted {
                crossover_rad_s: c.num(wc, "outer_loop.crossover_rad_s", 0.1, 10.0, "rad/s")?,
                delay_s,
                stick_lag_s: match &o.stick_lag_s {
                    Some(v) => c.num(v, "outer_loop.stick_lag_s", 0.0, 10.0, "s")?,
                    None => {
                        return Err(c.err(
                            wc,
                            "outer_loop.stick_lag_s",
                            "required with `crossover_rad_s` (the lag from stick command to stick, s)",
                        ))
                    }
                },
            }
        }
        (Some(g), Some(_)) => {
            return Err(c.err(
                g,
                "outer_loop.gain",
                "give either `gain` (a pilot with given gains) or `crossover_rad_s` (adapted), not both",
            ))
        }
        (None, None) => {
            return Err(c.err(
                &o.loop_kind,
                "outer_loop.gain",
                "needs `gain` (given gains) or `crossover_rad_s` (a pilot adapted to the aircraft)",
            ))
        }
    };
    let command = match loop_kind {
        PilotLoop::Pitch => {
            let s = c.schedule(&o.command, "outer_loop.command", -30.0, 30.0, "deg")?;
            Schedule {
                points: s.points.iter().map(|&(t, v)| (t, v.to_radians())).collect(),
            }
        }
        PilotLoop::LoadFactor => c.schedule(&o.command, "outer_loop.command", -1.0, 4.0, "g")?,
    };
    Ok(OuterLoopConfig {
        loop_kind,
        pilot,
        command,
    })
}

fn parse_pilot(
    p: &PilotSection,
    c: &Ctx,
    duration_s: f64,
    dt_s: f64,
    seed: u64,
) -> Result<PilotConfig, ScenarioError> {
    let hand_path = c.named_file(
        line_of(c.text, p.model.span().start),
        "pilot.model",
        Path::new(p.model.get_ref()),
    )?;
    let hand = load_hand(&hand_path).map_err(|e| c.err(&p.model, "pilot.model", &e.to_string()))?;
    let task = match p.task.get_ref().as_str() {
        "position" => Task::Position,
        "force" => Task::Force,
        other => {
            return Err(c.err(
                &p.task,
                "pilot.task",
                &format!("`{other}` is not one of: position, force"),
            ))
        }
    };
    // Command values carry the task's unit: `_rad` (stick angle) for position, `_n` (grip force) for force.
    let (unit, lim, other_unit) = match task {
        Task::Position => ("rad", 1.0, "n"),
        Task::Force => ("n", 250.0, "rad"),
    };
    let val = |name: &str| -> Result<Option<f64>, ScenarioError> {
        let (mine, theirs) = p.value_pair(name, unit);
        if let Some(t) = theirs {
            return Err(c.err(
                t,
                &format!("pilot.{name}_{other_unit}"),
                &format!("a {} task takes `{name}_{unit}`", p.task.get_ref()),
            ));
        }
        mine.map(|v| c.num(v, &format!("pilot.{name}_{unit}"), -lim, lim, unit))
            .transpose()
    };
    let need = |name: &str| -> Result<f64, ScenarioError> {
        val(name)?.ok_or_else(|| {
            c.err(
                &p.signal,
                &format!("pilot.{name}_{unit}"),
                &format!("required by signal = \"{}\"", p.signal.get_ref()),
            )
        })
    };
    let need_t =
        |v: &Option<Spanned<f64>>, key: &str, lo: f64, hi: f64, u: &str| -> Result<f64, ScenarioError> {
            match v {
                Some(v) => c.num(v, key, lo, hi, u),
                None => Err(c.err(
                    &p.signal,
                    key,
                    &format!("required by signal = \"{}\"", p.signal.get_ref()),
                )),
            }
        };
    let command = match p.signal.get_ref().as_str() {
        "hold" => Signal::Hold {
            value: need("value")?,
        },
        "step" => Signal::Step {
            initial: need("initial")?,
            last: need("final")?,
            at_s: need_t(&p.at_s, "pilot.at_s", 0.0, duration_s, "s")?,
        },
        "ramp" => Signal::Ramp {
            from: need("from")?,
            to: need("to")?,
            start_s: need_t(&p.start_s, "pilot.start_s", 0.0, duration_s, "s")?,
            duration_s: need_t(&p.ramp_duration_s, "pilot.ramp_duration_s", 1e-3, 3600.0, "s")?,
        },
        "sine" => Signal::Sine {
            offset: val("offset")?.unwrap_or(0.0),
            amplitude: need("amplitude")?,
            frequency_hz: need_t(&p.frequency_hz, "pilot.frequency_hz", 1e-3, 100.0, "Hz")?,
        },
        "triangle" => Signal::Triangle {
            offset: val("offset")?.unwrap_or(0.0),
            amplitude: need("amplitude")?,
            frequency_hz: need_t(&p.frequency_hz, "pilot.frequency_hz", 1e-3, 100.0, "Hz")?,
        },
        "random" => Signal::random(
            val("offset")?.unwrap_or(0.0),
            need("rms")?,
            need_t(&p.cutoff_hz, "pilot.cutoff_hz", 1e-3, 100.0, "Hz")?,
            duration_s,
            dt_s,
            seed ^ 0x005e_ed0f_9170,
        ),
        // The stick command comes from `[outer_loop]` (checked by the caller); the signal is unused.
        "outer-loop" => Signal::Hold { value: 0.0 },
        other => {
            return Err(c.err(
                &p.signal,
                "pilot.signal",
                &format!("`{other}` is not one of: hold, step, ramp, sine, triangle, random, outer-loop"),
            ))
        }
    };
    // Keys of another signal are errors, not silently ignored (the first one in the file is named).
    let used: &[&str] = match p.signal.get_ref().as_str() {
        "hold" => &["value"],
        "step" => &["initial", "final", "at_s"],
        "ramp" => &["from", "to", "start_s", "ramp_duration_s"],
        "sine" | "triangle" => &["offset", "amplitude", "frequency_hz"],
        _ => &["offset", "rms", "cutoff_hz"],
    };
    if let Some((key, v)) = p
        .signal_keys()
        .into_iter()
        .filter_map(|(k, v)| v.map(|v| (k, v)))
        .filter(|(k, _)| {
            let base = k
                .strip_suffix("_rad")
                .or_else(|| k.strip_suffix("_n"))
                .unwrap_or(k);
            !used.contains(&base)
        })
        .min_by_key(|(_, v)| v.span().start)
    {
        return Err(c.err(
            v,
            &format!("pilot.{key}"),
            &format!(
                "not used by signal = \"{}\" (it takes: {})",
                p.signal.get_ref(),
                used.join(", ")
            ),
        ));
    }
    Ok(PilotConfig {
        hand_path,
        hand,
        task,
        command,
    })
}

/// Load `models/pilot-hand.toml`.
pub fn load_hand(path: &Path) -> Result<HandConfig, ScenarioError> {
    let text = read(path)?;
    let h: HandFile = from_toml(&text, path)?;
    let c = Ctx { path, text: &text };
    Ok(HandConfig {
        mass_kg: c.num(&h.mass_kg, "mass_kg", 0.05, 20.0, "kg")?,
        stiffness_n_per_m: c.num(&h.stiffness_n_per_m, "stiffness_n_per_m", 0.0, 1e5, "N/m")?,
        damping_n_s_per_m: c.num(&h.damping_n_s_per_m, "damping_n_s_per_m", 0.0, 1e4, "N·s/m")?,
        activation_tau_s: c.num(&h.activation_tau_s, "activation_tau_s", 1e-3, 1.0, "s")?,
        grip_stiffness_n_per_m: c.num(
            &h.grip_stiffness_n_per_m,
            "grip_stiffness_n_per_m",
            10.0,
            1e6,
            "N/m",
        )?,
        grip_damping_n_s_per_m: c.num(
            &h.grip_damping_n_s_per_m,
            "grip_damping_n_s_per_m",
            0.0,
            1e4,
            "N·s/m",
        )?,
        tracking_gain_per_s: c.num(&h.tracking_gain_per_s, "tracking_gain_per_s", 0.0, 100.0, "1/s")?,
    })
}

fn read(path: &Path) -> Result<String, ScenarioError> {
    crate::input::text::read_text(path).map_err(|msg| ScenarioError::Io {
        path: path.to_path_buf(),
        msg,
    })
}

fn from_toml<T: serde::de::DeserializeOwned>(text: &str, path: &Path) -> Result<T, ScenarioError> {
    crate::input::text::parse_toml(text).map_err(|e| ScenarioError::Parse {
        path: path.to_path_buf(),
        line: e.line,
        msg: e.message(),
    })
}

/// A variant's optional key and its value, if given.
type KeyValue<'a> = (&'a str, Option<&'a Spanned<f64>>);

struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Ctx<'_> {
    fn err<T>(&self, at: &Spanned<T>, key: &str, msg: &str) -> ScenarioError {
        ScenarioError::Field {
            path: self.path.to_path_buf(),
            line: line_of(self.text, at.span().start),
            key: key.to_string(),
            msg: msg.to_string(),
        }
    }

    /// The file the scenario names at `line` (`key`) as `named`, found as [`crate::builtin::resolve`] says:
    /// a built-in file or a regular file that exists.
    fn named_file(&self, line: usize, key: &str, named: &Path) -> Result<PathBuf, ScenarioError> {
        let dir = self.path.parent().unwrap_or(Path::new("."));
        let file = crate::builtin::resolve(dir, named);
        if crate::builtin::is_builtin(&file) {
            return Ok(file);
        }
        // A regular file only: the rig's URDF and the device are read again for every run of a comparison
        // or a DAQ sweep, which a pipe cannot give twice.
        use crate::input::text::NotAFile;
        let msg = match std::fs::metadata(&file).map(|m| NotAFile::of(&m)) {
            Ok(None) => return Ok(file),
            Ok(Some(NotAFile::Directory)) => format!("{}: a directory, not a file", file.display()),
            Ok(Some(kind)) => format!(
                "{}: not a regular file ({}); this file is read once per run, so it must be one",
                file.display(),
                kind.noun()
            ),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                format!("{}: {e}; {}", file.display(), crate::builtin::not_found_hint())
            }
            Err(e) => format!("{}: {e}", file.display()),
        };
        Err(ScenarioError::Field {
            path: self.path.to_path_buf(),
            line,
            key: key.to_string(),
            msg,
        })
    }

    fn num(&self, v: &Spanned<f64>, key: &str, lo: f64, hi: f64, unit: &str) -> Result<f64, ScenarioError> {
        let x = *v.get_ref();
        if !x.is_finite() || x < lo || x > hi {
            return Err(self.err(
                v,
                key,
                format!("value {x} outside the allowed range [{lo}, {hi}] {unit}").trim_end(),
            ));
        }
        Ok(x)
    }

    fn int(&self, v: &Spanned<i64>, key: &str, lo: i64, hi: i64) -> Result<i64, ScenarioError> {
        let x = *v.get_ref();
        if x < lo || x > hi {
            return Err(self.err(
                v,
                key,
                &format!("value {x} outside the allowed range [{lo}, {hi}]"),
            ));
        }
        Ok(x)
    }

    /// A piecewise-linear schedule `[[t_s, value], ...]`: at least one point, times finite and
    /// increasing, values within `[lo, hi]`.
    fn schedule(
        &self,
        pts: &Spanned<Vec<Point>>,
        key: &str,
        lo: f64,
        hi: f64,
        unit: &str,
    ) -> Result<Schedule, ScenarioError> {
        let p: Vec<[f64; 2]> = pts.get_ref().iter().map(|q| q.0).collect();
        if p.is_empty() {
            return Err(self.err(pts, key, "needs at least one [t_s, value] point"));
        }
        for (i, q) in p.iter().enumerate() {
            if !q[1].is_finite() || q[1] < lo || q[1] > hi {
                return Err(self.err(
                    pts,
                    key,
                    format!(
                        "point {i}: value {} outside the allowed range [{lo}, {hi}] {unit}",
                        q[1]
                    )
                    .trim_end(),
                ));
            }
            if !q[0].is_finite() || (i > 0 && q[0] <= p[i - 1][0]) {
                return Err(self.err(
                    pts,
                    key,
                    &format!("point {i}: times must be finite and increasing"),
                ));
            }
        }
        Ok(Schedule {
            points: p.iter().map(|q| (q[0], q[1])).collect(),
        })
    }

    /// A key required by the selected variant `sel`.
    fn req(
        &self,
        v: &Option<Spanned<f64>>,
        sel: &Spanned<String>,
        key: &str,
        lo: f64,
        hi: f64,
        unit: &str,
    ) -> Result<f64, ScenarioError> {
        match v {
            Some(v) => self.num(v, key, lo, hi, unit),
            None => Err(self.err(sel, key, &format!("required by `{}`", sel.get_ref()))),
        }
    }

    /// Keys that belong to another variant than the selected one are errors, not silently ignored.
    fn unused(
        &self,
        sel: &Spanned<String>,
        by_variant: &[(&str, &[KeyValue<'_>])],
        section: &str,
    ) -> Result<(), ScenarioError> {
        for (variant, keys) in by_variant {
            if sel.get_ref() == variant {
                for (k, v) in keys.iter() {
                    if let Some(v) = v {
                        return Err(self.err(
                            v,
                            &format!("{section}.{k}"),
                            &format!("not used by `{}`", sel.get_ref()),
                        ));
                    }
                }
            }
        }
        Ok(())
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    #[serde(default)]
    #[allow(dead_code)]
    description: String,
    duration_s: Spanned<f64>,
    seed: Spanned<i64>,
    /// Not `Spanned`: the toml crate cannot give a span to a table written with dotted keys
    /// (`rig.physics_hz = …` at the top level, valid TOML), and refused it; its keys' lines are found by name.
    rig: RigConfig,
    device: DeviceSection,
    load_cell: LoadCellSection,
    laser: LaserSection,
    daq: DaqSection,
    controller: ControllerSection,
    feel: FeelSection,
    pilot: PilotSection,
    /// `[[fault]]` tables, parsed by `crate::faults` (issue 6 hook).
    #[serde(default)]
    #[allow(dead_code)]
    fault: Option<toml::Value>,
    aircraft: Option<AircraftSection>,
    outer_loop: Option<OuterLoopSection>,
    feel_system: Option<FeelSystemSection>,
}

/// A point `[t_s, value]` of a schedule: exactly two numbers. (serde's `[f64; 2]` reads the first two
/// elements of a longer array and drops the rest: `[3.0, 5.0, "junk", 7]` passed as `[3.0, 5.0]`.)
#[derive(Clone, Copy)]
struct Point([f64; 2]);

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
                    .next_element::<f64>()?
                    .ok_or_else(|| A::Error::invalid_length(0, &self))?;
                let v = seq
                    .next_element::<f64>()?
                    .ok_or_else(|| A::Error::invalid_length(1, &self))?;
                let mut n = 2;
                while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                    n += 1;
                }
                if n > 2 {
                    return Err(A::Error::invalid_length(n, &self));
                }
                Ok(Point([t, v]))
            }
        }
        d.deserialize_seq(Two)
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FeelSystemSection {
    kind: Spanned<String>,
    springs: Option<Spanned<PathBuf>>,
    damping_n_s_per_m: Option<Spanned<f64>>,
    qbar_pa: Option<Spanned<f64>>,
    hybrid_k_n_per_m: Option<Spanned<f64>>,
    return_damping_n_s_per_m: Option<Spanned<f64>>,
    motor_max_force_n: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AircraftSection {
    model: Spanned<String>,
    airspeed_m_s: Spanned<f64>,
    altitude_m: Spanned<f64>,
    rate_hz: Option<Spanned<f64>>,
    throttle: Option<Spanned<Vec<Point>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct OuterLoopSection {
    #[serde(rename = "loop")]
    loop_kind: Spanned<String>,
    gain: Option<Spanned<f64>>,
    lead_s: Option<Spanned<f64>>,
    lag_s: Option<Spanned<f64>>,
    delay_s: Spanned<f64>,
    integral_per_s: Option<Spanned<f64>>,
    crossover_rad_s: Option<Spanned<f64>>,
    stick_lag_s: Option<Spanned<f64>>,
    /// `[[t_s, value], ...]`: pitch in degrees relative to trim, or load factor in g.
    command: Spanned<Vec<Point>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceSection {
    file: Spanned<PathBuf>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LoadCellSection {
    range_n: Spanned<f64>,
    gain: Spanned<f64>,
    offset_n: Spanned<f64>,
    noise_rms_n: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LaserSection {
    range_m: Spanned<f64>,
    noise_rms_m: Spanned<f64>,
    velocity_cutoff_hz: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DaqSection {
    sample_rate_hz: Spanned<f64>,
    latency_samples: Spanned<i64>,
    adc_bits: Spanned<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ControllerSection {
    kp_a_per_n: Spanned<f64>,
    ki_a_per_n_s: Spanned<f64>,
    kd_a_s_per_n: Spanned<f64>,
    derivative_filter_s: Spanned<f64>,
    anti_windup: Spanned<String>,
    tracking_time_s: Option<Spanned<f64>>,
    feedforward: Spanned<bool>,
    rest_speed_m_s: Spanned<f64>,
    rest_force_n: Spanned<f64>,
    current_min_a: Spanned<f64>,
    current_max_a: Spanned<f64>,
    /// The model the controller believes (a device file or a `PARAMS.json`); the plant's file if absent.
    model: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FeelSection {
    law: Spanned<String>,
    breakout_n: Option<Spanned<f64>>,
    gradient_n_per_m: Option<Spanned<f64>>,
    damping_n_s_per_m: Option<Spanned<f64>>,
    max_force_n: Option<Spanned<f64>>,
    low_n: Option<Spanned<f64>>,
    high_n: Option<Spanned<f64>>,
    start_s: Option<Spanned<f64>>,
    period_s: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PilotSection {
    model: Spanned<PathBuf>,
    task: Spanned<String>,
    signal: Spanned<String>,
    value_rad: Option<Spanned<f64>>,
    value_n: Option<Spanned<f64>>,
    initial_rad: Option<Spanned<f64>>,
    initial_n: Option<Spanned<f64>>,
    final_rad: Option<Spanned<f64>>,
    final_n: Option<Spanned<f64>>,
    from_rad: Option<Spanned<f64>>,
    from_n: Option<Spanned<f64>>,
    to_rad: Option<Spanned<f64>>,
    to_n: Option<Spanned<f64>>,
    offset_rad: Option<Spanned<f64>>,
    offset_n: Option<Spanned<f64>>,
    amplitude_rad: Option<Spanned<f64>>,
    amplitude_n: Option<Spanned<f64>>,
    rms_rad: Option<Spanned<f64>>,
    rms_n: Option<Spanned<f64>>,
    at_s: Option<Spanned<f64>>,
    start_s: Option<Spanned<f64>>,
    ramp_duration_s: Option<Spanned<f64>>,
    frequency_hz: Option<Spanned<f64>>,
    cutoff_hz: Option<Spanned<f64>>,
}

impl PilotSection {
    /// Every signal key and its value, if given.
    fn signal_keys(&self) -> [KeyValue<'_>; 21] {
        [
            ("value_rad", self.value_rad.as_ref()),
            ("value_n", self.value_n.as_ref()),
            ("initial_rad", self.initial_rad.as_ref()),
            ("initial_n", self.initial_n.as_ref()),
            ("final_rad", self.final_rad.as_ref()),
            ("final_n", self.final_n.as_ref()),
            ("from_rad", self.from_rad.as_ref()),
            ("from_n", self.from_n.as_ref()),
            ("to_rad", self.to_rad.as_ref()),
            ("to_n", self.to_n.as_ref()),
            ("offset_rad", self.offset_rad.as_ref()),
            ("offset_n", self.offset_n.as_ref()),
            ("amplitude_rad", self.amplitude_rad.as_ref()),
            ("amplitude_n", self.amplitude_n.as_ref()),
            ("rms_rad", self.rms_rad.as_ref()),
            ("rms_n", self.rms_n.as_ref()),
            ("at_s", self.at_s.as_ref()),
            ("start_s", self.start_s.as_ref()),
            ("ramp_duration_s", self.ramp_duration_s.as_ref()),
            ("frequency_hz", self.frequency_hz.as_ref()),
            ("cutoff_hz", self.cutoff_hz.as_ref()),
        ]
    }

    /// The `(name_unit, name_other)` pair of a command value.
    fn value_pair(&self, name: &str, unit: &str) -> (Option<&Spanned<f64>>, Option<&Spanned<f64>>) {
        let (rad, n) = match name {
            "value" => (&self.value_rad, &self.value_n),
            "initial" => (&self.initial_rad, &self.initial_n),
            "final" => (&self.final_rad, &self.final_n),
            "from" => (&self.from_rad, &self.from_n),
            "to" => (&self.to_rad, &self.to_n),
            "offset" => (&self.offset_rad, &self.offset_n),
            "amplitude" => (&self.amplitude_rad, &self.amplitude_n),
            _ => (&self.rms_rad, &self.rms_n),
        };
        if unit == "rad" {
            (rad.as_ref(), n.as_ref())
        } else {
            (n.as_ref(), rad.as_ref())
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct HandFile {
    mass_kg: Spanned<f64>,
    stiffness_n_per_m: Spanned<f64>,
    damping_n_s_per_m: Spanned<f64>,
    activation_tau_s: Spanned<f64>,
    grip_stiffness_n_per_m: Spanned<f64>,
    grip_damping_n_s_per_m: Spanned<f64>,
    tracking_gain_per_s: Spanned<f64>,
}
