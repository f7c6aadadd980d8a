//! Scenario files (`scenarios/*.toml`): one headless run of the stick rig (rig, device, sensors, feel
//! controller and law, pilot, faults, and optionally an aircraft, the pilot's outer loop and the feel
//! system), read and checked by `input::scenario`; paths in it are relative to it.

use std::path::{Path, PathBuf};

use crate::control::feel::FeelSystemConfig;
use crate::control::{FeelLaw, PidGains};
use crate::input::{InputError, Source};
use crate::pilot::attitude::{CrossoverPilotConfig, PilotLoop, Schedule};
use crate::pilot::{HandConfig, Signal, Task};
use crate::rig::RigConfig;
use crate::sensors::SensorsConfig;

mod overrides;
pub use crate::input::hand::load as load_hand;
pub use overrides::{Origin, Override};

/// The controller section, validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControllerConfig {
    /// PID gains on the force error.
    pub gains: PidGains,
    /// Whether the law's static inverse feeds the coil command forward.
    pub feedforward: bool,
    /// Below this stick speed, m/s, the stick is at rest.
    pub rest_speed_m_s: f64,
    /// Below this grip force, N, the stick is at rest.
    pub rest_force_n: f64,
}

/// `[pilot]`: the hand model and its task.
#[derive(Debug, Clone, PartialEq)]
pub struct PilotConfig {
    /// The hand model's file.
    pub hand_path: PathBuf,
    /// The hand model.
    pub hand: HandConfig,
    /// Position or force task.
    pub task: Task,
    /// Command in stick angle (rad) for a position task, grip force (N) for a force task.
    pub command: Signal,
}

/// `[aircraft]`: the aircraft whose stick force is the feel target (`feel.law = "aircraft"`).
#[derive(Debug, Clone, PartialEq)]
pub struct AircraftConfig {
    /// `"c172p"`, `"737"` (embedded Rust model) or `"jsbsim:c172p"`, `"jsbsim:737"` (live JSBSim).
    pub model: String,
    /// Trim true airspeed, m/s.
    pub airspeed_m_s: f64,
    /// Trim altitude, m.
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
    /// Pitch attitude or load factor.
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
    /// McRuer's crossover model: gain and equalisation adapted to the aircraft at its trim so that the open
    /// loop crosses over at `crossover_rad_s` (`crate::aero::linear::adapted_pilot`).
    Adapted {
        /// Open-loop crossover, rad/s.
        crossover_rad_s: f64,
        /// Effective pilot delay, s.
        delay_s: f64,
        /// Lag from stick command to stick, s.
        stick_lag_s: f64,
    },
}

/// Most physics steps a run may take ([`Scenario::load`] refuses more): a run that keeps its rows holds ~300
/// bytes a step, 3 GB here.
pub(crate) const MAX_PHYSICS_STEPS: f64 = 1e7;

/// Lines of the scenario's keys that a run's own errors name (a trim with no solution, an integration that
/// blows up); a key not written: a line of its table, 1 without the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyLines {
    /// `rig.physics_hz`.
    pub physics_hz: usize,
    /// `aircraft.airspeed_m_s`, the trim condition.
    pub airspeed: usize,
    /// `aircraft.model`, the aircraft flown (for its errors in flight).
    pub aircraft_model: usize,
    /// `feel.law` (a DAQ sweep needs a step test).
    pub feel_law: usize,
    /// `pilot.frequency_hz`, a likely cause of a run that breaks an invariant ([`crate::sim::invariants`]).
    pub pilot_frequency: usize,
    /// `device.file` (errors of the plant's device file).
    pub device_file: usize,
    /// `controller.model` (errors of the model file it names), else `device.file`.
    pub controller_model: usize,
}

/// A validated scenario.
#[derive(Debug, Clone, PartialEq)]
pub struct Scenario {
    /// The scenario file.
    pub path: PathBuf,
    /// Where the keys a run's errors name are in the file.
    pub lines: KeyLines,
    /// The scenario's name.
    pub name: String,
    /// Simulated time, s.
    pub duration_s: f64,
    /// Seed of every random draw of the run.
    pub seed: u64,
    /// The rig's settings, with the URDF path resolved against the scenario's directory.
    pub rig: RigConfig,
    /// The plant's device file (or `PARAMS.json`).
    pub device_path: PathBuf,
    /// The model the feel controller believes (`[controller] model`): a device file or a fitted
    /// `PARAMS.json`; `None`: the plant's own device file.
    pub controller_model_path: Option<PathBuf>,
    /// Sensors and DAQ.
    pub sensors: SensorsConfig,
    /// The feel loop's controller.
    pub controller: ControllerConfig,
    /// The feel law: the force the stick should give.
    pub feel: FeelLaw,
    /// The pilot's hand and task.
    pub pilot: PilotConfig,
    /// Scheduled faults (`[[fault]]` tables).
    pub faults: crate::faults::FaultSchedule,
    /// The aircraft in the loop, if any.
    pub aircraft: Option<AircraftConfig>,
    /// The pilot's outer loop on the aircraft, if any.
    pub outer_loop: Option<OuterLoopConfig>,
    /// The feel system on the rig (`[feel_system]`; the paper's MR damper alone by default).
    pub feel_system: FeelSystemConfig,
    /// The file `[feel_system]` names, if any (its `springs` or its active stick's `model`; resolved
    /// against the scenario's directory).
    pub feel_system_file: Option<PathBuf>,
}

impl Scenario {
    /// Read and check the scenario file at `path`.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        crate::input::scenario::scenario(&Source::read(path)?)
    }

    /// Check a scenario text read from `path`.
    pub fn parse(text: &str, path: &Path) -> Result<Self, InputError> {
        crate::input::scenario::scenario(&Source::new(path, text))
    }

    /// The physics rate, Hz.
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
        if let Some(p) = &self.feel_system_file {
            let what = match self.feel_system.kind {
                crate::control::feel::FeelKind::Active => "active-stick file",
                _ => "feel-spring file",
            };
            files.push((what, p.clone()));
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
    pub(crate) fn with_daq_rate(&self, rate_hz: f64) -> Self {
        let mut s = self.clone();
        s.sensors.daq.sample_rate_hz = rate_hz;
        s
    }

    /// The same scenario with another feel system.
    pub fn with_feel_system(&self, feel_system: FeelSystemConfig) -> Self {
        let mut s = self.clone();
        s.feel_system = feel_system;
        s
    }
}
