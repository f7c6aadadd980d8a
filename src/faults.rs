//! Faults in the feel loop's power and signal path: what can break between the DAQ and the damper, when,
//! and what each does to the signals. A scenario schedules them in `[[fault]]` tables; a
//! `FaultInjector` applies them at three hooks of the loop:
//!
//! | kind | hook | effect |
//! |---|---|---|
//! | `coil_open` | driver → coil | the coil carries no current whatever the command (the command into the device's Eq. 3 lag is 0: the field decays with Te) |
//! | `driver_stuck` | driver → coil | the driver delivers its full-scale current (the device's `current_limit_a`, 14 A) whatever the command |
//! | `load_cell_stuck` | load cell → DAQ | the reading freezes at its value when the fault starts |
//! | `load_cell_zero` | load cell → DAQ | the reading is 0 N (broken wire, amplifier off) |
//! | `load_cell_noisy` | load cell → DAQ | Gaussian noise of `noise_rms_n` added (seeded) |
//! | `displacement_dropout` | laser → DAQ | the DAQ holds the last valid position (the differentiated velocity falls to 0) |
//! | `latency_spike` | DAQ → controller | the controller sees samples `extra_latency_s` older than normal |
//! | `hands_off` | hand → grip | the pilot lets go: no force on the grip (the hand grips again where the stick is when the fault ends) |
//!
//! `hands_off` is the pilot's, not the feel system's: the feel comparison's fault runs (`FaultKind::ALL`)
//! leave it out (its task has a hands-off period of its own), a scenario schedules it like any other.
//!
//! The active stick's motor driver has the same two driver faults (`FaultInjector::motor_force_n`): open
//! gives no force, stuck gives full force in the direction it was pushing. Passive spring feel systems have
//! none of these paths: a fault scheduled for them changes nothing, which is the point of the comparison.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Deserialize;

/// Declares [`FaultKind`], its [`FaultKind::KINDS`] and its names from one list, in table order.
macro_rules! fault_kinds {
    ($($(#[doc = $doc:literal])* $kind:ident = $name:literal,)*) => {
        /// Kinds of fault, in table order.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Deserialize)]
        pub enum FaultKind {
            $($(#[doc = $doc])* #[serde(rename = $name)] $kind,)*
        }

        impl FaultKind {
            /// Every kind, in table order: the feel path's, then the pilot's.
            pub const KINDS: [FaultKind; 8] = [$(FaultKind::$kind),*];

            /// The name used in scenario files and tables.
            pub fn name(self) -> &'static str {
                match self {
                    $(FaultKind::$kind => $name,)*
                }
            }
        }
    };
}

fault_kinds! {
    /// The coil carries no current (the active stick's motor no force).
    CoilOpen = "coil_open",
    /// The driver gives its full-scale current (force) whatever the command.
    DriverStuck = "driver_stuck",
    /// The load-cell reading freezes at its value when the fault starts.
    LoadCellStuck = "load_cell_stuck",
    /// The load-cell reading is 0 N.
    LoadCellZero = "load_cell_zero",
    /// Gaussian noise on the load-cell reading.
    LoadCellNoisy = "load_cell_noisy",
    /// The DAQ holds the last valid position.
    DisplacementDropout = "displacement_dropout",
    /// The controller sees older samples.
    LatencySpike = "latency_spike",
    /// The pilot lets go of the grip.
    HandsOff = "hands_off",
}

impl FaultKind {
    /// Every kind of fault in the feel system's path, in table order (all but [`FaultKind::HandsOff`]).
    pub const ALL: &'static [FaultKind] = Self::KINDS.split_last().expect("kinds").1;

    /// The kind's bit in a mask of active faults.
    pub fn bit(self) -> u8 {
        1 << (self as u8)
    }
}

/// Default RMS of `load_cell_noisy`, N (an ESTIMATE: a loose shield or ground loop on a strain-gauge
/// bridge, 4 % of the cell's 250 N range).
const DEFAULT_NOISE_RMS_N: f64 = 10.0;
/// Default extra delay of `latency_spike`, s (an ESTIMATE: a 50 ms stall of a non-real-time host, the
/// order of a Windows/LabVIEW scheduling hiccup).
const DEFAULT_EXTRA_LATENCY_S: f64 = 0.05;

/// One scheduled fault, active on `start_s ≤ t < end_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fault {
    /// What breaks.
    pub kind: FaultKind,
    /// Start, s.
    pub start_s: f64,
    /// End, s.
    pub end_s: f64,
    /// `load_cell_noisy`: noise RMS, N.
    pub noise_rms_n: f64,
    /// `latency_spike`: extra delay, s.
    pub extra_latency_s: f64,
}

impl Fault {
    /// A fault with the default noise and latency.
    pub fn new(kind: FaultKind, start_s: f64, end_s: f64) -> Self {
        Self {
            kind,
            start_s,
            end_s,
            noise_rms_n: DEFAULT_NOISE_RMS_N,
            extra_latency_s: DEFAULT_EXTRA_LATENCY_S,
        }
    }

    /// Whether the fault acts at `t_s`.
    pub fn active(&self, t_s: f64) -> bool {
        t_s >= self.start_s && t_s < self.end_s
    }
}

/// The faults of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FaultSchedule {
    /// The faults, in file order.
    pub faults: Vec<Fault>,
}

impl FaultSchedule {
    /// No faults.
    pub fn none() -> Self {
        Self::default()
    }

    /// One fault.
    pub fn single(fault: Fault) -> Self {
        Self { faults: vec![fault] }
    }

    /// The first active fault of a kind at `t_s`.
    pub fn active(&self, kind: FaultKind, t_s: f64) -> Option<&Fault> {
        self.faults.iter().find(|f| f.kind == kind && f.active(t_s))
    }

    /// Whether a fault of `kind` acts at `t_s`.
    fn on(&self, kind: FaultKind, t_s: f64) -> bool {
        self.active(kind, t_s).is_some()
    }

    /// Bit set of the kinds active at `t_s` (bit `k` = `FaultKind::ALL[k]`), for result columns.
    pub(crate) fn active_mask(&self, t_s: f64) -> u8 {
        self.faults
            .iter()
            .filter(|f| f.active(t_s))
            .fold(0, |m, f| m | f.kind.bit())
    }

    /// Whether no fault is scheduled.
    pub fn is_empty(&self) -> bool {
        self.faults.is_empty()
    }

    /// The schedule for messages: `, with driver_stuck from 4 s to 6 s`, or nothing when empty.
    pub fn describe(&self) -> String {
        let each: Vec<String> = self
            .faults
            .iter()
            .map(|f| format!("{} from {} s to {} s", f.kind.name(), f.start_s, f.end_s))
            .collect();
        if each.is_empty() {
            String::new()
        } else {
            format!(", with {}", each.join(" and "))
        }
    }
}

/// Names of the kinds in a mask, joined by `+` (empty string for none).
pub fn mask_names(mask: u8) -> String {
    FaultKind::KINDS
        .iter()
        .filter(|k| mask & k.bit() != 0)
        .map(|k| k.name())
        .collect::<Vec<_>>()
        .join("+")
}

/// Applies a schedule to the signals at the hooks (see the module table). Seeded: the same schedule and
/// seed give the same noise.
#[derive(Debug, Clone)]
pub(crate) struct FaultInjector {
    pub(crate) schedule: FaultSchedule,
    rng: ChaCha8Rng,
    held_force_n: Option<f64>,
    last_force_n: f64,
    last_x_m: f64,
}

impl FaultInjector {
    /// An injector of `schedule`, its noise seeded by `seed`.
    pub(crate) fn new(schedule: FaultSchedule, seed: u64) -> Self {
        Self {
            schedule,
            rng: ChaCha8Rng::seed_from_u64(seed ^ 0xfa_017),
            held_force_n: None,
            last_force_n: 0.0,
            last_x_m: 0.0,
        }
    }

    /// Hook driver → coil: the current command the coil actually receives, A (`limit_a`: the driver's
    /// full scale).
    pub(crate) fn coil_command_a(&self, t_s: f64, cmd_a: f64, limit_a: f64) -> f64 {
        if self.schedule.on(FaultKind::CoilOpen, t_s) {
            0.0
        } else if self.schedule.on(FaultKind::DriverStuck, t_s) {
            limit_a
        } else {
            cmd_a
        }
    }

    /// Hook driver → motor (the active stick): the force the motor actually gives, N, from the commanded
    /// one; `last_n` is the force it gave over the previous step, `limit_n` its full scale. An open driver
    /// gives nothing; a stuck one gives full force in the direction it was pushing.
    pub(crate) fn motor_force_n(&self, t_s: f64, cmd_n: f64, last_n: f64, limit_n: f64) -> f64 {
        if self.schedule.on(FaultKind::CoilOpen, t_s) {
            0.0
        } else if self.schedule.on(FaultKind::DriverStuck, t_s) {
            let dir = if last_n != 0.0 { last_n } else { cmd_n };
            limit_n * dir.signum()
        } else {
            cmd_n
        }
    }

    /// Hook load cell → DAQ: the reading the DAQ digitises, N, from the healthy reading.
    pub(crate) fn load_cell_n(&mut self, t_s: f64, reading_n: f64) -> f64 {
        let out = if self.schedule.on(FaultKind::LoadCellZero, t_s) {
            0.0
        } else if self.schedule.on(FaultKind::LoadCellStuck, t_s) {
            *self.held_force_n.get_or_insert(self.last_force_n)
        } else {
            self.held_force_n = None;
            reading_n
        };
        // Draw every call, so the noise sequence does not depend on when other faults are active.
        let n: f64 = StandardNormal.sample(&mut self.rng);
        let out = match self.schedule.active(FaultKind::LoadCellNoisy, t_s) {
            Some(f) => out + f.noise_rms_n * n,
            None => out,
        };
        self.last_force_n = reading_n;
        out
    }

    /// Hook laser → DAQ: the position the DAQ sees, m (held at the last valid value during a dropout).
    pub(crate) fn displacement_m(&mut self, t_s: f64, x_m: f64) -> f64 {
        if self.schedule.on(FaultKind::DisplacementDropout, t_s) {
            self.last_x_m
        } else {
            self.last_x_m = x_m;
            x_m
        }
    }

    /// Hook hand → grip: whether the pilot's hand is off the grip at `t_s`.
    pub(crate) fn hands_off(&self, t_s: f64) -> bool {
        self.schedule.on(FaultKind::HandsOff, t_s)
    }

    /// Hook DAQ → controller: extra delay of the samples the controller sees, s.
    pub(crate) fn extra_latency_s(&self, t_s: f64) -> f64 {
        self.schedule
            .active(FaultKind::LatencySpike, t_s)
            .map(|f| f.extra_latency_s)
            .unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stuck_load_cell_holds_the_reading_at_onset_and_recovers() {
        let mut inj = FaultInjector::new(
            FaultSchedule::single(Fault::new(FaultKind::LoadCellStuck, 1.0, 2.0)),
            1,
        );
        assert_eq!(inj.load_cell_n(0.9, 12.0), 12.0);
        assert_eq!(inj.load_cell_n(1.0, 30.0), 12.0);
        assert_eq!(inj.load_cell_n(1.5, 55.0), 12.0);
        assert_eq!(inj.load_cell_n(2.0, 40.0), 40.0);
    }

    #[test]
    fn driver_faults_override_the_command() {
        let open = FaultInjector::new(
            FaultSchedule::single(Fault::new(FaultKind::CoilOpen, 0.0, 1.0)),
            1,
        );
        assert_eq!(open.coil_command_a(0.5, 9.0, 14.0), 0.0);
        assert_eq!(open.coil_command_a(1.5, 9.0, 14.0), 9.0);
        let stuck = FaultInjector::new(
            FaultSchedule::single(Fault::new(FaultKind::DriverStuck, 0.0, 1.0)),
            1,
        );
        assert_eq!(stuck.coil_command_a(0.5, 0.0, 14.0), 14.0);
    }

    #[test]
    fn noisy_load_cell_has_the_scheduled_rms() {
        let mut inj = FaultInjector::new(
            FaultSchedule::single(Fault::new(FaultKind::LoadCellNoisy, 0.0, 100.0)),
            3,
        );
        let n = 20_000;
        let xs: Vec<f64> = (0..n)
            .map(|k| inj.load_cell_n(k as f64 * 1e-3, 20.0) - 20.0)
            .collect();
        let rms = (xs.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt();
        assert!(
            (rms - DEFAULT_NOISE_RMS_N).abs() < 0.03 * DEFAULT_NOISE_RMS_N,
            "rms {rms}"
        );
    }
}
