//! Feel systems compared on the same rig, linkage and pilot task (three spring feel units, the MR damper
//! under a force loop, the hybrid and the active stick; table in `docs/explanation/feel-systems.md`), with and without faults in
//! the power and signal path ([`crate::faults`]). Every system runs in the loop of `mrfeel run`
//! ([`crate::sim::Loop`]) as the scenario's [`crate::control::FeelSystem`]; the pilot's task is fed to the
//! hand sample by sample, letting go a NaN command.

pub mod metrics;

use std::path::PathBuf;

use crate::control::feel::{CentringSpring, FeelSprings, FeelSystemConfig};
use crate::control::FeelLaw;
use crate::faults::{Fault, FaultKind, FaultSchedule};
use crate::pilot::Signal;
use crate::rig::RigConfig;
use crate::scenario::Scenario;
use crate::sim::{Loop, Plant};
use metrics::{fault_metrics, system_metrics, FaultRow, SystemMetrics};

pub use crate::control::feel::FeelKind;

/// Parse a comma-separated list of feel systems (`--feel a,b`), in the order given; an empty name or a
/// system named twice is an error.
pub fn parse_feel_list(s: &str) -> Result<Vec<FeelKind>, CompareError> {
    let names: Vec<&str> = s.split(',').map(str::trim).collect();
    if names.iter().all(|n| n.is_empty()) {
        return Err(CompareError::Feel(format!(
            "no feel system given; name at least one of: {}",
            FeelKind::names()
        )));
    }
    feel_kinds(&names).map_err(CompareError::Feel)
}

/// The feel systems of a list of names, in order: each a known system, named once.
pub(crate) fn feel_kinds(names: &[&str]) -> Result<Vec<FeelKind>, String> {
    let mut out = Vec::with_capacity(names.len());
    for (pos, name) in names.iter().enumerate() {
        if name.is_empty() {
            return Err(format!("empty name at position {}", pos + 1));
        }
        let k = FeelKind::from_name(name)
            .ok_or_else(|| format!("`{name}` is not one of: {}", FeelKind::names()))?;
        if out.contains(&k) {
            return Err(format!("`{name}` named twice; name each system once"));
        }
        out.push(k);
    }
    Ok(out)
}

/// A comparison refused: its file, a feel-system list, or what it loads.
#[derive(Debug, thiserror::Error)]
pub enum CompareError {
    /// A bad comparison file or a file it names.
    #[error(transparent)]
    Input(#[from] crate::input::InputError),
    /// A bad feel-system list (`--feel` or `systems`).
    #[error("feel systems: {0}")]
    Feel(String),
    /// The base scenario's damper model.
    #[error(transparent)]
    Device(#[from] crate::device::DeviceError),
    /// The stick rig.
    #[error(transparent)]
    Rig(#[from] crate::rig::RigError),
    /// A run that failed.
    #[error(transparent)]
    Sim(#[from] crate::sim::SimError),
    /// A run that broke an invariant: which system, under which faults.
    #[error("{system}{faults}")]
    Run {
        /// The feel system.
        system: &'static str,
        /// The faults of the run (`, with driver_stuck from 3 s to 5 s`), or nothing.
        faults: String,
        /// What it broke.
        source: Box<crate::sim::SimError>,
    },
}

/// `[active]`: the motor-driven stick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActiveSection {
    /// The motor's force limit on the piston, N.
    pub max_force_n: f64,
    /// The actuator's own viscous friction (back-EMF, gearbox), N·s/m.
    pub damping_n_s_per_m: f64,
    /// The modelled stick (`model = FILE`: motor, current loop, grip sensor, admittance loop); `None`: an
    /// ideal force source of `max_force_n`.
    pub model: Option<crate::control::active::ActiveStickConfig>,
    /// The rig's physics rate for this system's runs, Hz; `None`: the base scenario's. A stiff position
    /// loop driving the stick into its stops needs a finer mechanical step than the passive systems.
    pub physics_hz: Option<f64>,
}

/// The feel target, at the piston (force along +x): `F* = breakout·sgn x + gradient·x`, clipped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetLaw {
    /// Force at the first motion off centre, N.
    pub breakout_n: f64,
    /// Force per piston displacement beyond the breakout, N/m.
    pub gradient_n_per_m: f64,
    /// Largest target force, N (the law is clipped to ±this).
    pub max_force_n: f64,
}

impl TargetLaw {
    /// Target force at `x_m`; at the centre the breakout acts in `dir` (the motion or push direction).
    pub fn force_n(&self, x_m: f64, dir: f64) -> f64 {
        let s = if x_m.abs() > 1e-6 { x_m.signum() } else { dir };
        (self.breakout_n * s + self.gradient_n_per_m * x_m).clamp(-self.max_force_n, self.max_force_n)
    }
}

/// `[task]`: the pilot's standard task (sinusoidal motion, deflect-hold-release, breakout push).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TaskSection {
    /// Sinusoidal stick motion: amplitude, rad.
    pub sweep_amplitude_rad: f64,
    /// Sinusoidal stick motion: frequency, Hz.
    pub sweep_frequency_hz: f64,
    /// Sinusoidal stick motion: whole cycles.
    pub sweep_cycles: usize,
    /// Deflect, hold, let go: the deflection, rad.
    pub release_angle_rad: f64,
    /// Deflect, hold, let go: ramp time to the deflection, s.
    pub release_ramp_s: f64,
    /// Deflect, hold, let go: hold time, s.
    pub release_hold_s: f64,
    /// Observation after letting go, s.
    pub release_observe_s: f64,
    /// Re-centred when the stick stays within this band, rad.
    pub recentre_band_rad: f64,
    /// Breakout: grip force ramp rate, N/s.
    pub breakout_ramp_n_per_s: f64,
    /// Breakout: length of the force ramp, s.
    pub breakout_duration_s: f64,
    /// Breakout: the stick motion that counts as breaking out, rad.
    pub breakout_threshold_rad: f64,
}

/// Certification force limits at the stick, lbf (converted once to N in [`Limits::newtons`]).
#[derive(Debug, Clone, Copy, PartialEq)]
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
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultTest {
    /// Start of each fault's window, s into the standard task.
    pub start_s: f64,
    /// End of each fault's window, s.
    pub end_s: f64,
}

/// A validated comparison scenario with its files loaded.
#[derive(Debug, Clone)]
pub struct CompareScenario {
    /// The comparison file.
    pub path: PathBuf,
    /// Name of the comparison (`name`), used in outputs.
    pub name: String,
    /// Seed of the sensor noise, the same for every system.
    pub seed: u64,
    /// Feel systems compared, in order.
    pub systems: Vec<FeelKind>,
    /// The stick rig every system runs on.
    pub rig: RigConfig,
    /// The plant and the model its controller believes, as the base scenario names them.
    pub devices: crate::sim::Devices,
    /// Coil resistance for the coil's power and energy, Ω.
    pub coil_resistance_ohm: f64,
    /// The passive feel springs (centring and variable gradient).
    pub springs: FeelSprings,
    /// The feel-spring file `[springs] file` names.
    pub springs_path: PathBuf,
    /// Viscous damping of the spring systems, N·s/m.
    pub spring_damping_n_s_per_m: f64,
    /// Dynamic pressure of the q-feel system, Pa.
    pub qbar_pa: f64,
    /// The hybrid system's centring spring beside its MR damper.
    pub hybrid_spring: CentringSpring,
    /// The hybrid system's damping while the stick returns to centre, N·s/m.
    pub hybrid_return_damping_n_s_per_m: f64,
    /// The feel every system aims at.
    pub target: TargetLaw,
    /// The loop scenario every system runs in (`base`): rig, device, sensors, DAQ, the feel loop's
    /// controller and the pilot's hand; its feel law, pilot command, faults and feel system are replaced
    /// per run.
    pub base: Scenario,
    /// The pilot's standard task.
    pub task: TaskSection,
    /// Certification stick-force limits.
    pub limits: Limits,
    /// The fault table's window.
    pub fault_test: FaultTest,
    /// The active stick's motor, if the file describes one (`[active]`).
    pub active: Option<ActiveSection>,
    /// Faults scheduled in the file (`[[fault]]`), applied to every run of `mrfeel compare`.
    pub faults: FaultSchedule,
}

impl CompareScenario {
    /// The feel system `kind` as this comparison sets it up (the q-feel spring at the scenario's q̄); the
    /// active stick needs the file's `[active]` motor.
    pub fn feel_system(&self, kind: FeelKind) -> Result<FeelSystemConfig, CompareError> {
        match (kind, self.active) {
            (FeelKind::Active, Some(a)) => Ok(match a.model {
                Some(m) => FeelSystemConfig::active_stick(m),
                None => FeelSystemConfig::active(a.max_force_n, a.damping_n_s_per_m),
            }),
            (FeelKind::Active, None) => Err(CompareError::Feel(format!(
                "{}: `active` needs an `[active]` section (model, or max_force_n and damping_n_s_per_m)",
                self.path.display()
            ))),
            _ => Ok(FeelSystemConfig::from_springs(
                kind,
                &self.springs,
                self.qbar_pa,
                self.hybrid_spring,
                self.spring_damping_n_s_per_m,
                self.hybrid_return_damping_n_s_per_m,
            )),
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

pub(crate) fn main_task(k: &TaskSection) -> Task {
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
        /// Amplitude, rad.
        amplitude_rad: f64,
        /// Frequency, Hz.
        frequency_hz: f64,
        /// Length, s.
        duration_s: f64,
    },
    /// Move from the centre to `angle_rad` (smooth ramp) and hold it.
    MoveHold {
        /// Target deflection, rad.
        angle_rad: f64,
        /// Ramp time to the deflection, s.
        ramp_s: f64,
        /// Hold time, s.
        hold_s: f64,
    },
    /// Hands off the stick.
    LetGo {
        /// Length, s.
        duration_s: f64,
    },
    /// Push the grip with a force rising at `rate_n_per_s` from 0.
    ForceRamp {
        /// Rate of rise of the grip force, N/s.
        rate_n_per_s: f64,
        /// Length, s.
        duration_s: f64,
    },
}

impl Segment {
    /// Length of the segment, s.
    pub fn duration_s(&self) -> f64 {
        match *self {
            Segment::MoveHold { ramp_s, hold_s, .. } => ramp_s + hold_s,
            Segment::Sine { duration_s, .. }
            | Segment::LetGo { duration_s }
            | Segment::ForceRamp { duration_s, .. } => duration_s,
        }
    }
}

/// What the pilot does at one instant.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PilotCmd {
    /// Follow this stick angle, rad.
    Angle(f64),
    /// Push the grip with this force, N.
    Force(f64),
    /// Hands off.
    Off,
}

/// The pilot's task: segments run one after the other.
#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    /// The segments, in order.
    pub segments: Vec<Segment>,
}

impl Task {
    /// Length of the task, s.
    pub fn duration_s(&self) -> f64 {
        self.segments.iter().map(Segment::duration_s).sum()
    }

    /// Segment index and time into it at `t_s` (the last segment past the end).
    pub(crate) fn segment_at(&self, t_s: f64) -> (usize, f64) {
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

    /// The pilot's command at `t_s` (the last segment's past the end).
    pub fn command(&self, t_s: f64) -> PilotCmd {
        let (k, tau) = self.segment_at(t_s);
        match self.segments[k] {
            Segment::Sine {
                amplitude_rad,
                frequency_hz,
                ..
            } => PilotCmd::Angle(amplitude_rad * (2.0 * std::f64::consts::PI * frequency_hz * tau).sin()),
            Segment::MoveHold {
                angle_rad, ramp_s, ..
            } => {
                // Smoothstep ramp: zero rate at both ends.
                let u = (tau / ramp_s).clamp(0.0, 1.0);
                PilotCmd::Angle(angle_rad * (u * u * (3.0 - 2.0 * u)))
            }
            Segment::LetGo { .. } => PilotCmd::Off,
            Segment::ForceRamp { rate_n_per_s, .. } => PilotCmd::Force(rate_n_per_s * tau),
        }
    }
}

// ---------------------------------------------------------------------------------------------------
// One run

/// One physics step of a run (state at the start of the step, and what was applied over it).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Row {
    /// Time, s.
    pub t_s: f64,
    /// Index of the task segment.
    pub segment: usize,
    /// Stick angle, rad.
    pub theta_rad: f64,
    /// Stick angle the pilot aims at, rad.
    pub theta_cmd_rad: f64,
    /// Stick rate, rad/s.
    pub rate_rad_s: f64,
    /// Piston displacement, m.
    pub piston_x_m: f64,
    /// Pilot's force at the grip (what the pilot feels), N; 0 hands off.
    pub hand_force_n: f64,
    /// Whether the pilot's hand is on the grip.
    pub hands_on: bool,
    /// The feel target at the grip at this deflection, N.
    pub target_grip_n: f64,
    /// True force through the load cell, N.
    pub load_cell_true_n: f64,
    /// Load cell as the controller saw it (after faults, delay), N; NaN without a loop.
    pub load_cell_seen_n: f64,
    /// Controller's current command, A.
    pub current_cmd_a: f64,
    /// Current the coil received (after driver faults), A.
    pub current_applied_a: f64,
    /// Coil current (Eq. 3 state), A.
    pub coil_current_a: f64,
    /// Damper yield force, N.
    pub yield_force_n: f64,
    /// Mechanical energy stored (kinetic + potential + feel spring), J.
    pub stored_j: f64,
    /// The hand's work so far, J.
    pub hand_work_j: f64,
    /// The damper's dissipated energy so far, J.
    pub damper_dissipated_j: f64,
    /// Active faults (bit set over `FaultKind::ALL`).
    pub faults: u8,
}

/// A run's rows and what is needed to read them.
#[derive(Debug, Clone)]
pub struct Trace {
    /// The feel system run.
    pub system: FeelKind,
    /// The task flown.
    pub task: Task,
    /// Physics step, s.
    pub dt_s: f64,
    /// One row per physics step.
    pub rows: Vec<Row>,
}

/// The pilot's command over a task on the physics grid `dt_s`: the hand's task (position or force), and
/// the command per step (stick rad for position, grip N for force; NaN hands off).
fn pilot_command(task: &Task, dt_s: f64) -> Result<(crate::pilot::Task, Vec<f64>), CompareError> {
    let n = (task.duration_s() / dt_s).round() as usize;
    let mut kind = None;
    let mut samples = Vec::with_capacity(n + 1);
    for k in 0..=n {
        let (v, this) = match task.command(k as f64 * dt_s) {
            PilotCmd::Angle(theta_rad) => (theta_rad, Some(crate::pilot::Task::Position)),
            PilotCmd::Force(f) => (f, Some(crate::pilot::Task::Force)),
            PilotCmd::Off => (f64::NAN, None),
        };
        if let Some(t) = this {
            if kind.is_some_and(|k| k != t) {
                return Err(CompareError::Feel(
                    "a task mixes position and force segments; the hand follows one kind per run".into(),
                ));
            }
            kind = Some(t);
        }
        samples.push(v);
    }
    Ok((kind.unwrap_or(crate::pilot::Task::Position), samples))
}

/// Run one task with one feel system and a fault schedule, in the loop of [`crate::sim`]: the base
/// scenario's rig, sensors, DAQ, PID feel controller and pilot hand, with the comparison's target as the
/// feel law and the system's spring (if any) on the piston joint.
pub fn run(
    scn: &CompareScenario,
    kind: FeelKind,
    task: &Task,
    faults: &FaultSchedule,
) -> Result<Trace, CompareError> {
    let mut s = scn.base.with_feel_system(scn.feel_system(kind)?);
    if let (FeelKind::Active, Some(hz)) = (kind, scn.active.as_ref().and_then(|a| a.physics_hz)) {
        s.rig.physics_hz = hz;
    }
    let dt = 1.0 / s.rig.physics_hz;
    let (pilot_task, samples) = pilot_command(task, dt)?;
    s.name = format!("{}/{}", scn.name, kind.name());
    s.seed = scn.seed;
    s.duration_s = task.duration_s();
    s.feel = FeelLaw::Spring {
        breakout_n: scn.target.breakout_n,
        gradient_n_per_m: scn.target.gradient_n_per_m,
        damping_n_s_per_m: 0.0,
        max_force_n: scn.target.max_force_n,
    };
    s.pilot.task = pilot_task;
    s.pilot.command = Signal::Sampled {
        samples: samples.clone(),
        dt_s: dt,
    };
    s.faults = faults.clone();
    s.aircraft = None;
    s.outer_loop = None;
    let rig =
        crate::sim::build_rig(&s, &scn.devices.plant).map_err(|e| CompareError::Feel(format!("{e:#}")))?;
    let lever = Plant::grip_arm_m(&rig);
    let mut lp = Loop::new(&s, &scn.devices, rig)?;
    // Each run is checked as `mrfeel run` checks its own (every number finite, the energy balance closed),
    // and the load cell's range where it is a design limit: on a healthy system with a load cell. Where a
    // fault drives the force past it, or the system has no load cell to overload, the force reached is a
    // result of the comparison, not a broken run.
    let mut check = crate::sim::invariants::Checker::new(&s).with_stops(lp.plant.stick_limits_rad());
    if !(kind.has_coil() && faults.is_empty()) {
        check = check.without_range();
    }
    let broke = |source| CompareError::Run {
        system: kind.name(),
        faults: faults.describe(),
        source: Box::new(source),
    };
    let n = (task.duration_s() / dt).round() as usize;
    let mut rows = Vec::with_capacity(n);
    let mut e0 = None;
    for (step, &cmd) in samples.iter().enumerate().take(n) {
        let t = step as f64 * dt;
        let r = lp.step()?;
        check.push(&r).map_err(broke)?;
        let stored = r.kinetic_energy_j + r.potential_energy_j + r.spring_energy_j;
        let e0 = *e0.get_or_insert(stored);
        let gear = Plant::gearing_m_per_rad(&lp.plant, r.stick_angle_rad);
        let dir = if r.piston_v_m_s.abs() > 1e-4 {
            r.piston_v_m_s.signum()
        } else {
            0.0
        };
        rows.push(Row {
            t_s: t,
            segment: task.segment_at(t).0,
            theta_rad: r.stick_angle_rad,
            theta_cmd_rad: if pilot_task == crate::pilot::Task::Position {
                cmd
            } else {
                f64::NAN
            },
            rate_rad_s: r.stick_rate_rad_s,
            piston_x_m: r.piston_x_m,
            hand_force_n: r.pilot_force_n,
            hands_on: !cmd.is_nan(),
            target_grip_n: scn.target.force_n(r.piston_x_m, dir) * gear / lever,
            load_cell_true_n: r.load_cell_true_n,
            load_cell_seen_n: if kind.has_coil() { r.load_cell_n } else { f64::NAN },
            current_cmd_a: r.current_a,
            current_applied_a: r.current_applied_a,
            coil_current_a: r.coil_current_a,
            yield_force_n: r.yield_force_n,
            stored_j: stored - e0,
            hand_work_j: r.pilot_work_j,
            damper_dissipated_j: r.dissipated_j,
            faults: if kind.has_electrical_path() { r.faults } else { 0 },
        });
    }
    check.judge().map_err(broke)?;
    Ok(Trace {
        system: kind,
        task: task.clone(),
        dt_s: dt,
        rows,
    })
}

/// A comparison's results: per system its metrics and its task and breakout traces; per fault run its row
/// and trace.
pub struct Comparison {
    /// Per system: its metrics, its standard-task trace and its breakout trace.
    pub systems: Vec<(FeelKind, SystemMetrics, Trace, Trace)>,
    /// Per fault run: its table row and trace.
    pub faults: Vec<(FaultRow, Trace)>,
}

/// Run the comparison (and the fault runs when `with_faults`); `progress` gets (done, total).
pub fn compare(
    scn: &CompareScenario,
    systems: &[FeelKind],
    with_faults: bool,
    mut progress: impl FnMut(usize, usize),
) -> anyhow::Result<Comparison> {
    let main_task = scn.main_task();
    let total = systems.len() * (2 + if with_faults { 1 + FaultKind::ALL.len() } else { 0 });
    let mut done = 0;
    let mut out = Comparison {
        systems: Vec::new(),
        faults: Vec::new(),
    };
    for &k in systems {
        let main = run(scn, k, &main_task, &scn.faults)?;
        let brk = run(scn, k, &scn.breakout_task(), &scn.faults)?;
        done += 2;
        progress(done, total);
        let m = system_metrics(scn, &main, &brk);
        if with_faults {
            let healthy = if scn.faults.is_empty() {
                main.clone()
            } else {
                run(scn, k, &main_task, &FaultSchedule::none())?
            };
            done += 1;
            for &f in FaultKind::ALL {
                let (a, b) = (scn.fault_test.start_s, scn.fault_test.end_s);
                let tr = run(scn, k, &main_task, &FaultSchedule::single(Fault::new(f, a, b)))?;
                let fm = fault_metrics(scn, &tr, &healthy, a, b);
                out.faults.push((
                    FaultRow {
                        system: k,
                        fault: f,
                        m: fm,
                    },
                    tr,
                ));
                done += 1;
                progress(done, total);
            }
        }
        out.systems.push((k, m, main, brk));
    }
    Ok(out)
}
