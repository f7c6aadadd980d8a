//! The multi-rate loop for one scenario: physics at the rig's rate, the DAQ (sensors, latency, zero-order
//! hold) and the feel controller at the DAQ's rate, the pilot's hand at the physics rate.
//!
//! Per physics step (time `t = n·dt`):
//! 1. read the rig's true state; with an `[aircraft]` ([`flight`]), step the aircraft when its frame is
//!    due: its stick force through the linkage is the target of `feel.law = "aircraft"`, its outer loop
//!    (`pilot.signal = "outer-loop"`) the hand's command;
//! 2. on a DAQ tick: sample the load cell and the laser through the latency line and run the feel system
//!    ([`FeelSystem`]) on the sample that comes out; its commands are held until the next tick;
//! 3. the hand reacts to its command and the grip's state;
//! 4. record the row; step the rig with the hand force, the coil command, the spring and the motor force.
//!
//! Faults ([`crate::faults`]) act between transducers and DAQ, DAQ and controller (latency spikes), driver
//! and coil or motor; every row carries the mask of the faults active at its time.

pub mod flight;
pub mod invariants;
pub mod loop_study;
pub mod metrics;
pub(crate) mod plant;
pub mod response;
pub(crate) mod results;

pub use flight::{AeroRow, Flight};
pub use plant::{Plant, PlantState};
#[cfg(feature = "rerun")]
pub use results::{log_rerun, rerun_sample};
pub use results::{FlightInfo, Results, Row, Summary, SummaryAcc};

use std::collections::VecDeque;

use crate::control::feel::Spring;
use crate::control::{FeelController, FeelLaw, FeelSystem, LoopMode, Pid};
use crate::device::{DeviceConfig, DeviceError, ForceInverse};
use crate::pilot::{Hand, Task};
use crate::scenario::Scenario;
use crate::sensors::{Daq, DaqSample};

/// Errors of a run (the scenario itself was validated when loaded).
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The aircraft's error, in the message rather than as a source (`{:#}` would repeat it); `line` is
    /// `aircraft.airspeed_m_s` for a failed trim, `aircraft.model` for an error in flight.
    #[error("{}:{line}: aircraft: {error}", scenario.display())]
    Aero {
        /// The scenario file.
        scenario: std::path::PathBuf,
        /// Line of the key at fault.
        line: usize,
        /// The aircraft's error.
        error: crate::aero::AeroError,
    },
    /// A device file the scenario names (`device.file`, `controller.model`) cannot be loaded.
    #[error("{}:{line}: `{key}`: {error}", scenario.display())]
    Device {
        /// The scenario file.
        scenario: std::path::PathBuf,
        /// Line of `key`.
        line: usize,
        /// The key naming the device file.
        key: &'static str,
        /// Boxed: the error type stays small on the happy path of every run.
        error: Box<crate::device::DeviceError>,
    },
    /// The integration blew up: a run whose numbers would be reported as results is stopped instead.
    #[error(
        "{}:{line}: `rig.physics_hz`: the simulation diverged at t = {t_s} s ({what}); {physics_hz} Hz is too \
         coarse for this rig and loop: raise the physics rate",
        scenario.display()
    )]
    Diverged {
        /// The scenario file.
        scenario: std::path::PathBuf,
        /// The scenario's line of `rig.physics_hz`.
        line: usize,
        /// Time of the divergence, s.
        t_s: f64,
        /// What diverged, in words.
        what: String,
        /// The physics rate, Hz.
        physics_hz: f64,
    },
    /// A finished run breaks an invariant its results must satisfy ([`invariants`]); `key` (at `line`) is
    /// the setting that most likely caused it.
    #[error(
        "{}:{line}: `{key}`: the run breaks an invariant at t = {t_s} s: {invariant}; {advice} (nothing was \
         written)",
        scenario.display()
    )]
    Invariant {
        /// The scenario file.
        scenario: std::path::PathBuf,
        /// Line of `key`.
        line: usize,
        /// The setting that most likely caused the breach.
        key: &'static str,
        /// The invariant broken, in words.
        invariant: String,
        /// Time of the breach, s.
        t_s: f64,
        /// What to change.
        advice: String,
    },
    /// Stopped on request ([`crate::interrupt`]).
    #[error("interrupted")]
    Interrupted,
}

/// Why a step's row shows the integration has blown up, if it does: a state that is not a number, or the
/// piston beyond twice its stroke (the stops hold it within the stroke, give or take a fraction of a mm).
fn diverged(row: &Row, stroke_half_m: f64) -> Option<String> {
    let states = [
        ("piston position", row.piston_x_m),
        ("piston velocity", row.piston_v_m_s),
        ("stick angle", row.stick_angle_rad),
        ("load-cell force", row.load_cell_true_n),
    ];
    if let Some((name, v)) = states.iter().find(|(_, v)| !v.is_finite()) {
        return Some(format!("the {name} is {v}"));
    }
    (row.piston_x_m.abs() > 2.0 * stroke_half_m).then(|| {
        format!(
            "the piston at {:.3e} m, beyond twice its ±{stroke_half_m} m stroke",
            row.piston_x_m
        )
    })
}

/// The damper the rig simulates (the plant) and the model the feel controller believes: the controller
/// computes its feedforward from `controller` only, never from `plant`.
#[derive(Debug, Clone)]
pub struct Devices {
    /// The damper the rig simulates.
    pub plant: DeviceConfig,
    /// The model the feel controller believes.
    pub controller: DeviceConfig,
    /// Whether the controller's model is the plant's own file (no `[controller] model`).
    pub controller_is_plant: bool,
}

/// A device file the scenario names at `key` (line `line`) refused.
fn device_error<'a>(
    scn: &'a Scenario,
    line: usize,
    key: &'static str,
) -> impl FnOnce(DeviceError) -> SimError + 'a {
    move |error| SimError::Device {
        scenario: scn.path.clone(),
        line,
        key,
        error: Box::new(error),
    }
}

impl Devices {
    /// The plant a scenario names (`[device] file`) and the model its controller believes
    /// (`[controller] model`, else the plant's file).
    pub fn load(scn: &Scenario) -> Result<Self, SimError> {
        let registry = crate::device::Registry::builtin();
        let load = |path: &std::path::Path, line: usize, key: &'static str| {
            DeviceConfig::load(path, &registry).map_err(device_error(scn, line, key))
        };
        let plant = load(&scn.device_path, scn.lines.device_file, "device.file")?;
        match &scn.controller_model_path {
            None => Ok(Self::same(plant)),
            Some(p) => Ok(Self {
                controller: load(p, scn.lines.controller_model, "controller.model")?,
                plant,
                controller_is_plant: false,
            }),
        }
    }

    /// The controller believes the plant's own file.
    pub fn same(plant: DeviceConfig) -> Self {
        Self {
            controller: plant.clone(),
            plant,
            controller_is_plant: true,
        }
    }

    /// What the controller believes, for the run's summary: its model and file.
    pub(crate) fn controller_label(&self) -> String {
        let own = if self.controller_is_plant {
            " (the plant's file)"
        } else {
            ""
        };
        format!(
            "{} from {}{own}",
            self.controller.model.name(),
            self.controller.path.display()
        )
    }
}

/// Options of one run that are not part of the scenario.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RunOptions {
    /// Record body poses for drawing at this rate (Hz); `None`: no poses.
    pub frames_hz: Option<f64>,
}

/// Everything that is stepped, wired from a scenario; [`Loop::step`] is one physics step.
pub struct Loop<P: Plant> {
    /// The rig.
    pub plant: P,
    /// The DAQ between the rig's sensors and the controller.
    pub daq: Daq,
    /// The feel system on the rig: its controller, spring and actuators.
    pub feel: FeelSystem,
    /// The pilot's hand.
    pub hand: Hand,
    scenario_command: crate::pilot::Signal,
    command_scale: f64,
    step_index: u64,
    desired_force_n: f64,
    measured_force_n: f64,
    mode: LoopMode,
    pilot_work_j: f64,
    /// The hand's force on the grip over the last step, N (a fly-by-wire stick's force sensor reads it).
    hand_force_n: f64,
    /// Scheduled faults in the driver and sensor path.
    faults: crate::faults::FaultInjector,
    current_limit_a: f64,
    /// Samples out of the DAQ waiting for a latency spike to pass: (arrival time, sample).
    late: VecDeque<(f64, DaqSample)>,
    has_latency_faults: bool,
    last_delivered_t_s: f64,
    /// The aircraft in the loop, if the scenario has one.
    pub flight: Option<Flight>,
    /// The motor's work on the piston so far, J.
    actuator_work_j: f64,
    scenario_path: std::path::PathBuf,
    scenario_lines: crate::scenario::KeyLines,
}

impl<P: Plant> Loop<P> {
    /// Wire a scenario onto a plant; fails only when the aircraft cannot be opened or trimmed.
    pub fn new(scn: &Scenario, devices: &Devices, plant: P) -> Result<Self, SimError> {
        let feedforward = if scn.controller.feedforward {
            let (line, key) = if devices.controller_is_plant {
                (scn.lines.device_file, "device.file")
            } else {
                (scn.lines.controller_model, "controller.model")
            };
            Some(ForceInverse::new(&devices.controller).map_err(device_error(scn, line, key))?)
        } else {
            None
        };
        let controller = FeelController::new(
            scn.feel.clone(),
            Pid::new(scn.controller.gains),
            feedforward,
            scn.controller.rest_speed_m_s,
            scn.controller.rest_force_n,
        );
        let command_scale = match scn.pilot.task {
            Task::Position => plant.grip_arm_m(),
            Task::Force => 1.0,
        };
        let flight = scn
            .aircraft
            .as_ref()
            .map(|a| {
                let force_task = scn.pilot.task == Task::Force;
                Flight::open(a, scn.outer_loop.as_ref(), plant.stick_limits_rad(), force_task)
            })
            .transpose()
            .map_err(|error| SimError::Aero {
                scenario: scn.path.clone(),
                line: scn.lines.airspeed,
                error,
            })?;
        let has_latency_faults = scn
            .faults
            .faults
            .iter()
            .any(|f| f.kind == crate::faults::FaultKind::LatencySpike);
        Ok(Self {
            daq: Daq::new(scn.sensors, scn.seed),
            feel: FeelSystem::new(&scn.feel_system, controller, scn.seed),
            hand: Hand::new(scn.pilot.hand, scn.pilot.task),
            scenario_command: scn.pilot.command.clone(),
            command_scale,
            plant,
            step_index: 0,
            desired_force_n: 0.0,
            measured_force_n: 0.0,
            mode: LoopMode::Holding,
            pilot_work_j: 0.0,
            hand_force_n: 0.0,
            faults: crate::faults::FaultInjector::new(scn.faults.clone(), scn.seed),
            current_limit_a: devices.plant.model.current_limit_a,
            late: VecDeque::new(),
            has_latency_faults,
            last_delivered_t_s: f64::NEG_INFINITY,
            flight,
            scenario_path: scn.path.clone(),
            scenario_lines: scn.lines,
            actuator_work_j: 0.0,
        })
    }

    /// The sample the controller gets now from the one just out of the DAQ: itself, or during a latency
    /// spike the newest sample that has waited the extra latency (none if nothing new has).
    fn deliver(&mut self, t: f64, sample: DaqSample) -> Option<DaqSample> {
        if !self.has_latency_faults {
            return Some(sample);
        }
        self.late.push_back((t, sample));
        let extra = self.faults.extra_latency_s(t);
        let ready = self
            .late
            .iter()
            .rposition(|(arrived, _)| arrived + extra <= t + 1e-9)?;
        let (_, s) = self.late[ready];
        self.late.drain(..=ready);
        (s.sampled_t_s > self.last_delivered_t_s).then(|| {
            self.last_delivered_t_s = s.sampled_t_s;
            s
        })
    }

    /// One physics step; returns the row describing the state at the start of the step and what was
    /// applied over it.
    pub fn step(&mut self) -> Result<Row, SimError> {
        let dt = self.plant.dt_s();
        let t = self.step_index as f64 * dt;
        let s = self.plant.state();
        if let Some(f) = self.flight.as_mut() {
            f.update(t, s.stick_angle_rad, self.hand_force_n)
                .map_err(|error| SimError::Aero {
                    scenario: self.scenario_path.clone(),
                    line: self.scenario_lines.aircraft_model,
                    error,
                })?;
            if let FeelLaw::Target { .. } = self.feel.controller.law {
                // Grip → piston by virtual work at the present linkage angle.
                let force_n = f.stick_force_n() * self.plant.grip_arm_m()
                    / self.plant.gearing_m_per_rad(s.stick_angle_rad);
                self.feel.controller.law = FeelLaw::Target { force_n };
            }
        }
        let aero = self.flight.as_ref().map(|f| f.row(t));
        if let Some(a) = aero {
            self.feel.set_dynamic_pressure(a.qbar_pa);
        }
        if self.daq.due(t) {
            let load_cell_n = self.faults.load_cell_n(t, s.load_cell_n);
            let piston_x_m = self.faults.displacement_m(t, s.piston_x_m);
            let out = self.daq.acquire(t, load_cell_n, piston_x_m);
            if let Some(sample) = out.and_then(|x| self.deliver(t, x)) {
                // The controller runs on the sample's own time: with the latency line this is the same as
                // computing at the sampling instant and writing the command `latency_samples` ticks later.
                let out = self.feel.update(sample.sampled_t_s, &sample, self.daq.period_s());
                self.desired_force_n = out.desired_force_n;
                self.measured_force_n = sample.force_n;
                self.mode = out.mode;
            }
        }
        let cmd = match self.flight.as_ref() {
            Some(f) if f.has_outer_loop() => f.stick_cmd_rad() * self.command_scale,
            _ => self.scenario_command.value(t) * self.command_scale,
        };
        // A NaN command or a `hands_off` fault: hands off the stick.
        let hand_force = if cmd.is_nan() || self.faults.hands_off(t) {
            self.hand.release();
            0.0
        } else {
            self.hand.step(cmd, s.grip_x_m, s.grip_v_m_s, dt)
        };
        // Driver faults between the commands and the coil or motor (no coil: nothing to drive).
        let coil_cmd_a = self
            .feel
            .coil_command_a()
            .map_or(0.0, |i| self.faults.coil_command_a(t, i, self.current_limit_a));
        if self.feel.motor.is_some() {
            // The active stick's grip sensor measures the hand; its motor acts on the push rod.
            let rod = crate::control::active::RodState {
                grip_force_n: hand_force,
                grip_to_rod: self.plant.grip_arm_m() / self.plant.gearing_m_per_rad(s.stick_angle_rad),
                x_m: s.piston_x_m,
                v_m_s: s.piston_v_m_s,
            };
            self.feel.step_motor(t, dt, &rod, &self.faults);
        }
        self.hand_force_n = hand_force;
        let actuator_force_n = self.feel.motor_force_n();
        let row = Row {
            t_s: t,
            stick_angle_rad: s.stick_angle_rad,
            stick_rate_rad_s: s.stick_rate_rad_s,
            piston_x_m: s.piston_x_m,
            piston_v_m_s: s.piston_v_m_s,
            load_cell_n: self.measured_force_n,
            load_cell_true_n: s.load_cell_n,
            desired_force_n: self.desired_force_n,
            current_a: self.feel.current_cmd_a(),
            pilot_force_n: hand_force,
            pilot_cmd: cmd,
            damper_force_n: s.damper_force_n,
            yield_force_n: s.yield_force_n,
            mode: self.mode,
            kinetic_energy_j: s.kinetic_energy_j,
            potential_energy_j: s.potential_energy_j,
            dissipated_j: s.dissipated_j,
            pilot_work_j: self.pilot_work_j,
            faults: self.faults.schedule.active_mask(t),
            current_applied_a: coil_cmd_a,
            coil_current_a: s.coil_current_a,
            spring_energy_j: self.feel.spring_energy_j(s.piston_x_m),
            actuator_force_n,
            actuator_work_j: self.actuator_work_j,
            aero,
        };
        self.plant
            .set_feel_spring(self.feel.spring().map(|sp| sp as &dyn Spring));
        if self.feel.motor.is_some() {
            self.plant.set_actuator_force_n(actuator_force_n);
        }
        self.plant.step(hand_force, coil_cmd_a);
        let after = self.plant.state();
        // Forces held over the step do F·Δx: the motor's on the piston, the hand's along the grip path.
        self.actuator_work_j += actuator_force_n * (after.piston_x_m - s.piston_x_m);
        self.pilot_work_j += hand_force * (after.grip_x_m - s.grip_x_m);
        self.step_index += 1;
        if let Some(what) = diverged(&row, self.plant.stroke_half_m()) {
            return Err(SimError::Diverged {
                scenario: self.scenario_path.clone(),
                line: self.scenario_lines.physics_hz,
                t_s: row.t_s,
                what,
                physics_hz: 1.0 / self.plant.dt_s(),
            });
        }
        Ok(row)
    }
}

/// The scenario's rig with the damper its feel system puts on it
/// ([`crate::control::feel::FeelSystemConfig::damper`]), checked against the device's stroke.
pub fn build_rig(scn: &Scenario, device: &DeviceConfig) -> anyhow::Result<crate::rig::Rig> {
    use anyhow::Context;
    let rig = crate::rig::Rig::new(&scn.rig, scn.feel_system.damper(device));
    let rig = rig.and_then(|rig| match device.geometry {
        Some(g) => rig
            .check_device_stroke(g.stroke_half_m, || {
                format!(
                    "`geometry.stroke_half_in` at {}:{}",
                    device.path.display(),
                    stroke_line(device)
                )
            })
            .map(|()| rig),
        None => Ok(rig),
    });
    rig.with_context(|| format!("rig of scenario {}", scn.path.display()))
}

/// The line of a device file's `geometry.stroke_half_in` (1 where it cannot be read again).
fn stroke_line(device: &DeviceConfig) -> usize {
    #[derive(serde::Deserialize)]
    struct File {
        geometry: Geometry,
    }
    #[derive(serde::Deserialize)]
    struct Geometry {
        stroke_half_in: toml::Spanned<f64>,
    }
    let src = crate::input::Source::read(&device.path);
    src.ok()
        .and_then(|src| {
            let f = src.toml::<File>().ok()?;
            Some(src.line_of(f.geometry.stroke_half_in.span().start))
        })
        .unwrap_or(1)
}

/// Load a scenario, the plant it names with the model its controller believes, and build its rig.
pub fn load(path: &std::path::Path) -> anyhow::Result<(Scenario, Devices, crate::rig::Rig)> {
    let scn = Scenario::load(path)?;
    let devices = Devices::load(&scn)?;
    let rig = build_rig(&scn, &devices.plant)?;
    Ok((scn, devices, rig))
}

/// Why a collected run stopped ([`Collector::run`]): the run itself, or one of its outputs.
#[derive(Debug, thiserror::Error)]
pub enum CollectError {
    /// The run failed.
    #[error(transparent)]
    Run(#[from] SimError),
    /// Writing the CSV failed.
    #[error("writing the CSV")]
    Csv(#[source] std::io::Error),
    /// Writing the recording failed.
    #[cfg(feature = "rerun")]
    #[error(transparent)]
    Recording(#[from] crate::viz::rerun_rig::VizError),
}

/// What a run keeps and writes as it goes ([`Collector::run`]): its rows streamed to a CSV, kept in
/// memory, or neither (then memory does not grow with the run); its drawing frames kept for a viewer;
/// with the `rerun` feature, a recording made as it goes.
#[derive(Default)]
pub struct Collector<'a> {
    csv: Option<&'a mut dyn std::io::Write>,
    keep_rows: bool,
    keep_frames: bool,
    #[cfg(feature = "rerun")]
    recording: Option<&'a rerun::RecordingStream>,
    /// The run's facts from its start, with the rows and frames kept so far.
    head: Option<Results>,
}

impl<'a> Collector<'a> {
    /// A collector that keeps the rows where `rows`, and the drawing frames where `frames`.
    pub fn keeping(rows: bool, frames: bool) -> Self {
        Self {
            keep_rows: rows,
            keep_frames: frames,
            ..Self::default()
        }
    }

    /// Also write the run's CSV ([`Results::write_csv`]) to `w` as it goes, flushed at the end.
    pub fn with_csv(self, w: &'a mut dyn std::io::Write) -> Self {
        Self { csv: Some(w), ..self }
    }

    /// Also log the run to the recording `rec` as it goes.
    #[cfg(feature = "rerun")]
    pub fn with_recording(self, rec: &'a rerun::RecordingStream) -> Self {
        Self {
            recording: Some(rec),
            ..self
        }
    }

    /// Run a scenario on a plant to its end; each row is checked (`invariants::Checker`) before it is
    /// written or kept. Returns the run with the rows and frames kept, and its summary; `progress` gets
    /// the fraction done.
    pub fn run<P: Plant>(
        &mut self,
        scn: &Scenario,
        devices: &Devices,
        plant: P,
        opts: RunOptions,
        mut progress: impl FnMut(f64),
    ) -> Result<(Results, Summary), CollectError> {
        let mut lp = Loop::new(scn, devices, plant)?;
        let dt = lp.plant.dt_s();
        let n = (scn.duration_s / dt).round() as usize;
        let frame_every = opts
            .frames_hz
            .map(|hz| ((1.0 / (hz * dt)).round() as usize).max(1));
        let flight_info = |lp: &Loop<P>| {
            lp.flight.as_ref().map(|f| FlightInfo {
                aircraft: f.label().to_string(),
                model_file: f.model_file().to_path_buf(),
                trim: f.trim,
                trim_stick_rad: f.trim_stick_rad,
                round_trip_us: f.round_trip_us(),
                estimates: f.estimates().to_vec(),
            })
        };
        let head = self.head.insert(Results {
            scenario: scn.name.clone(),
            rest_speed_m_s: scn.controller.rest_speed_m_s,
            stroke_half_m: lp.plant.stroke_half_m(),
            rows: Vec::with_capacity(if self.keep_rows { n + 1 } else { 0 }),
            visuals: frame_every.map_or_else(Vec::new, |_| lp.plant.visuals()),
            frames: Vec::new(),
            feel_ceiling_n: devices.plant.ceiling_force_n(scn.controller.gains.out_max),
            controller_model: if scn.feel_system.kind.has_coil() {
                devices.controller_label()
            } else {
                format!(
                    "none: the {} has no MR damper controller",
                    scn.feel_system.kind.name()
                )
            },
            grip_arm_m: lp.plant.grip_arm_m(),
            gearing_at_centre_m_per_rad: lp.plant.gearing_m_per_rad(0.0),
            flight: flight_info(&lp),
            stops_j: 0.0,
        });
        if let Some(w) = self.csv.as_mut() {
            head.write_csv_head(&mut **w).map_err(CollectError::Csv)?;
        }
        #[cfg(feature = "rerun")]
        let mut logger = self
            .recording
            .map(|rec| crate::viz::rerun_rig::RunLogger::new(rec, &head.visuals, head.flight.is_some()))
            .transpose()?;
        let mut check = invariants::Checker::new(scn).with_stops(lp.plant.stick_limits_rad());
        let mut summary = results::SummaryAcc::default();
        let report_every = (n / 200).max(1);
        for k in 0..n {
            if frame_every.is_some_and(|every| k % every == 0) {
                let (t, poses) = (k as f64 * dt, lp.plant.poses());
                #[cfg(feature = "rerun")]
                if let Some(l) = logger.as_mut() {
                    l.frame(t, &poses);
                }
                if self.keep_frames {
                    head.frames.push((t, poses));
                }
            }
            let row = lp.step()?;
            check.push(&row)?;
            summary.push(&row);
            if let Some(w) = self.csv.as_mut() {
                head.write_csv_row(&mut **w, &row).map_err(CollectError::Csv)?;
            }
            #[cfg(feature = "rerun")]
            if let Some(l) = logger.as_mut() {
                l.sample(&rerun_sample(&row))?;
            }
            if self.keep_rows {
                head.rows.push(row);
            }
            if k % report_every == 0 {
                if crate::interrupt::requested() {
                    return Err(SimError::Interrupted.into());
                }
                progress(k as f64 / n as f64);
            }
        }
        progress(1.0);
        let summary = check.finish(summary.finish(head))?;
        #[cfg(feature = "rerun")]
        if let Some(l) = logger {
            l.finish()?;
        }
        if let Some(w) = self.csv.as_mut() {
            // A buffered writer drops its last failure: flush it here, where the error can be reported.
            w.flush().map_err(CollectError::Csv)?;
        }
        let mut res = self.head.take().expect("set at the start of the run");
        res.flight = flight_info(&lp);
        res.stops_j = summary.stops_j;
        Ok((res, summary))
    }

    /// The run's facts and the rows kept up to the error that stopped it ([`Collector::run`]).
    pub(crate) fn stopped(self) -> Option<Results> {
        self.head
    }
}

/// Run a scenario on a plant to its end, keeping every row and drawing frame ([`Collector`]);
/// `progress` is called with the fraction done.
pub fn run<P: Plant>(
    scn: &Scenario,
    devices: &Devices,
    plant: P,
    opts: RunOptions,
    progress: impl FnMut(f64),
) -> Result<Results, SimError> {
    match Collector::keeping(true, true).run(scn, devices, plant, opts, progress) {
        Ok((res, _)) => Ok(res),
        Err(CollectError::Run(e)) => Err(e),
        // Nothing is written: no output can fail.
        Err(e) => unreachable!("{e}"),
    }
}
