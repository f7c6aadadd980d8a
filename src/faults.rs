//! Faults in the feel loop's power and signal path (issue 6, part 3): what can break between the DAQ and
//! the damper, when, and what each does to the signals.
//!
//! A scenario schedules faults in `[[fault]]` tables (any number, any kinds, possibly overlapping):
//!
//! ```toml
//! [[fault]]
//! kind = "coil_open"      # coil_open, driver_stuck, load_cell_stuck, load_cell_zero, load_cell_noisy,
//! start_s = 2.0           # displacement_dropout, latency_spike
//! end_s = 4.0
//! # noise_rms_n = 10.0    # load_cell_noisy only (default 10 N)
//! # extra_latency_s = 0.05 # latency_spike only (default 50 ms)
//! ```
//!
//! What each fault does, applied by a [`FaultInjector`] at three hooks of the loop:
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
//!
//! The active stick's motor driver has the same two driver faults ([`FaultInjector::motor_force_n`]): open
//! gives no force, stuck gives full force in the direction it was pushing.
//!
//! Passive spring feel systems have none of these paths: a fault scheduled for them changes nothing,
//! which is the point of the comparison.

use std::path::{Path, PathBuf};

use crate::input::text::line_of;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Deserialize;
use toml::Spanned;

/// Kinds of fault, in table order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum FaultKind {
    CoilOpen,
    DriverStuck,
    LoadCellStuck,
    LoadCellZero,
    LoadCellNoisy,
    DisplacementDropout,
    LatencySpike,
}

impl FaultKind {
    pub const ALL: [FaultKind; 7] = [
        FaultKind::CoilOpen,
        FaultKind::DriverStuck,
        FaultKind::LoadCellStuck,
        FaultKind::LoadCellZero,
        FaultKind::LoadCellNoisy,
        FaultKind::DisplacementDropout,
        FaultKind::LatencySpike,
    ];

    /// The name used in scenario files and tables.
    pub fn name(self) -> &'static str {
        match self {
            FaultKind::CoilOpen => "coil_open",
            FaultKind::DriverStuck => "driver_stuck",
            FaultKind::LoadCellStuck => "load_cell_stuck",
            FaultKind::LoadCellZero => "load_cell_zero",
            FaultKind::LoadCellNoisy => "load_cell_noisy",
            FaultKind::DisplacementDropout => "displacement_dropout",
            FaultKind::LatencySpike => "latency_spike",
        }
    }

    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }

    pub fn bit(self) -> u8 {
        1 << (self as u8)
    }
}

/// Default RMS of `load_cell_noisy`, N (an ESTIMATE: a loose shield or ground loop on a strain-gauge
/// bridge, 4 % of the cell's 250 N range).
pub const DEFAULT_NOISE_RMS_N: f64 = 10.0;
/// Default extra delay of `latency_spike`, s (an ESTIMATE: a 50 ms stall of a non-real-time host, the
/// order of a Windows/LabVIEW scheduling hiccup).
pub const DEFAULT_EXTRA_LATENCY_S: f64 = 0.05;

/// What is wrong with a fault window `start_s ≤ t < end_s` in a run of `run_s` seconds (`run`: what the
/// run is called in the message, "run" or "task"), if anything: the key at fault and why. A window starts
/// inside the run, before its end (the last step is before `run_s`), and ends after its start, no later
/// than the run's end: otherwise the fault never acts, or acts where the run never goes. One rule for a
/// scenario's `[[fault]]` tables and a comparison's `[fault_test]`.
pub fn window_error(start_s: f64, end_s: f64, run_s: f64, run: &str) -> Option<(&'static str, String)> {
    if !(start_s.is_finite() && (0.0..=run_s).contains(&start_s)) {
        return Some((
            "start_s",
            format!("value {start_s} outside the allowed range [0, {run_s}] s (within the {run})"),
        ));
    }
    if start_s >= run_s {
        return Some((
            "start_s",
            format!("value {start_s} s is where the {run} ends ({run_s} s): the fault would never act"),
        ));
    }
    if !(end_s.is_finite() && end_s >= start_s && end_s <= run_s) {
        return Some((
            "end_s",
            format!(
                "value {end_s} outside the allowed range [{start_s}, {run_s}] s (after start_s, within the \
                 {run}: to last to its end, write {run_s})"
            ),
        ));
    }
    if end_s <= start_s {
        return Some((
            "end_s",
            format!(
                "value {end_s} s is not after start_s = {start_s} s: the fault would never act (it is active \
                 from start_s until end_s)"
            ),
        ));
    }
    None
}

/// One scheduled fault, active on `start_s ≤ t < end_s`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fault {
    pub kind: FaultKind,
    pub start_s: f64,
    pub end_s: f64,
    /// `load_cell_noisy`: noise RMS, N.
    pub noise_rms_n: f64,
    /// `latency_spike`: extra delay, s.
    pub extra_latency_s: f64,
}

impl Fault {
    pub fn new(kind: FaultKind, start_s: f64, end_s: f64) -> Self {
        Self {
            kind,
            start_s,
            end_s,
            noise_rms_n: DEFAULT_NOISE_RMS_N,
            extra_latency_s: DEFAULT_EXTRA_LATENCY_S,
        }
    }

    pub fn active(&self, t_s: f64) -> bool {
        t_s >= self.start_s && t_s < self.end_s
    }
}

/// Errors reading `[[fault]]` tables: file, line and key.
#[derive(Debug, thiserror::Error)]
pub enum FaultError {
    #[error("{}:{line}: {msg}", path.display())]
    Parse { path: PathBuf, line: usize, msg: String },
    #[error("{}:{line}: [[fault]] #{index}: `{key}`: {msg}", path.display())]
    Field {
        path: PathBuf,
        line: usize,
        index: usize,
        key: String,
        msg: String,
    },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FaultEntry {
    kind: Spanned<String>,
    start_s: Spanned<f64>,
    end_s: Spanned<f64>,
    noise_rms_n: Option<Spanned<f64>>,
    extra_latency_s: Option<Spanned<f64>>,
}

/// A scenario's `fault` key, whatever it holds (other keys are left to their own parsers).
#[derive(Deserialize)]
struct AnyFault {
    fault: Option<Spanned<toml::Value>>,
}

/// A scenario's `[[fault]]` tables, each where it is in the text.
#[derive(Deserialize)]
struct FaultTables<T> {
    fault: Vec<Spanned<T>>,
}

/// The faults of a run.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct FaultSchedule {
    pub faults: Vec<Fault>,
}

impl FaultSchedule {
    pub fn none() -> Self {
        Self::default()
    }

    pub fn single(fault: Fault) -> Self {
        Self { faults: vec![fault] }
    }

    /// Read the `[[fault]]` tables of a scenario file's text (other tables are left to their own
    /// parsers). Times must lie within `[0, duration_s]`, `start_s < end_s`, `start_s < duration_s`. Errors name the line of the
    /// key at fault (from the TOML parser's spans, however the header is spelled: `[[ fault ]]`).
    pub fn from_scenario_text(text: &str, path: &Path, duration_s: f64) -> Result<Self, FaultError> {
        let line = |at: usize| line_of(text, at);
        let parse_err = |e: toml::de::Error| {
            let e = crate::input::text::TomlError::new(text, &e);
            FaultError::Parse {
                path: path.to_path_buf(),
                line: e.line,
                msg: e.message(),
            }
        };
        let any: AnyFault = toml::from_str(text).map_err(parse_err)?;
        let Some(value) = any.fault else {
            return Ok(Self::none());
        };
        if !value.get_ref().is_array() {
            return Err(FaultError::Parse {
                path: path.to_path_buf(),
                line: line(value.span().start),
                msg: "`fault` must be an array of tables: write `[[fault]]`".into(),
            });
        }
        // Where each table is, to name the one a parse error is in.
        let tables: FaultTables<toml::Value> = toml::from_str(text).map_err(parse_err)?;
        let entries: FaultTables<FaultEntry> = toml::from_str(text).map_err(|e| {
            let at = e.span().map(|s| s.start);
            match at.and_then(|a| tables.fault.iter().position(|t| t.span().contains(&a))) {
                Some(k) => {
                    // The key of the value at fault (a wrong type), else the table's (a key missing).
                    let placed = crate::input::text::TomlError::new(text, &e);
                    let key = placed.field.unwrap_or_else(|| "fault".into());
                    FaultError::Field {
                        path: path.to_path_buf(),
                        line: at.map_or(1, line),
                        index: k + 1,
                        key,
                        msg: placed.msg,
                    }
                }
                None => parse_err(e),
            }
        })?;
        let mut faults = Vec::with_capacity(entries.fault.len());
        for (k, e) in entries.fault.iter().enumerate() {
            let e = e.get_ref();
            let field = |key: &str, at: usize, msg: String| FaultError::Field {
                path: path.to_path_buf(),
                line: line(at),
                index: k + 1,
                key: key.to_string(),
                msg,
            };
            let kind = FaultKind::from_name(e.kind.get_ref()).ok_or_else(|| {
                let names: Vec<&str> = FaultKind::ALL.iter().map(|k| k.name()).collect();
                field(
                    "kind",
                    e.kind.span().start,
                    format!("`{}` is not one of: {}", e.kind.get_ref(), names.join(", ")),
                )
            })?;
            let range = |key: &str, v: &Spanned<f64>, lo: f64, hi: f64, unit: &str| {
                let x = *v.get_ref();
                if x.is_finite() && x >= lo && x <= hi {
                    Ok(x)
                } else {
                    Err(field(
                        key,
                        v.span().start,
                        format!("value {x} outside the allowed range [{lo}, {hi}] {unit}")
                            .trim_end()
                            .to_string(),
                    ))
                }
            };
            let (start_s, end_s) = (*e.start_s.get_ref(), *e.end_s.get_ref());
            if let Some((key, msg)) = window_error(start_s, end_s, duration_s, "run") {
                let at = if key == "start_s" { &e.start_s } else { &e.end_s };
                return Err(field(key, at.span().start, msg));
            }
            let mut f = Fault::new(kind, start_s, end_s);
            if let Some(n) = &e.noise_rms_n {
                if kind != FaultKind::LoadCellNoisy {
                    return Err(field(
                        "noise_rms_n",
                        n.span().start,
                        "only used by kind = \"load_cell_noisy\"".into(),
                    ));
                }
                f.noise_rms_n = range("noise_rms_n", n, 0.0, 250.0, "N")?;
            }
            if let Some(d) = &e.extra_latency_s {
                if kind != FaultKind::LatencySpike {
                    return Err(field(
                        "extra_latency_s",
                        d.span().start,
                        "only used by kind = \"latency_spike\"".into(),
                    ));
                }
                f.extra_latency_s = range("extra_latency_s", d, 0.0, 10.0, "s")?;
            }
            faults.push(f);
        }
        Ok(Self { faults })
    }

    /// The first active fault of a kind at `t_s`.
    pub fn active(&self, kind: FaultKind, t_s: f64) -> Option<&Fault> {
        self.faults.iter().find(|f| f.kind == kind && f.active(t_s))
    }

    /// Bit set of the kinds active at `t_s` (bit `k` = `FaultKind::ALL[k]`), for result columns.
    pub fn active_mask(&self, t_s: f64) -> u8 {
        self.faults
            .iter()
            .filter(|f| f.active(t_s))
            .fold(0, |m, f| m | f.kind.bit())
    }

    pub fn is_empty(&self) -> bool {
        self.faults.is_empty()
    }
}

/// Names of the kinds in a mask, joined by `+` (empty string for none).
pub fn mask_names(mask: u8) -> String {
    FaultKind::ALL
        .iter()
        .filter(|k| mask & k.bit() != 0)
        .map(|k| k.name())
        .collect::<Vec<_>>()
        .join("+")
}

/// Applies a schedule to the signals at the hooks (see the module table). Seeded: the same schedule and
/// seed give the same noise.
#[derive(Debug, Clone)]
pub struct FaultInjector {
    pub schedule: FaultSchedule,
    rng: ChaCha8Rng,
    held_force_n: Option<f64>,
    last_force_n: f64,
    last_x_m: f64,
}

impl FaultInjector {
    pub fn new(schedule: FaultSchedule, seed: u64) -> Self {
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
    pub fn coil_command_a(&self, t_s: f64, cmd_a: f64, limit_a: f64) -> f64 {
        if self.schedule.active(FaultKind::CoilOpen, t_s).is_some() {
            0.0
        } else if self.schedule.active(FaultKind::DriverStuck, t_s).is_some() {
            limit_a
        } else {
            cmd_a
        }
    }

    /// Hook driver → motor (the active stick): the force the motor actually gives, N, from the commanded
    /// one; `last_n` is the force it gave over the previous step, `limit_n` its full scale. An open driver
    /// gives nothing; a stuck one gives full force in the direction it was pushing.
    pub fn motor_force_n(&self, t_s: f64, cmd_n: f64, last_n: f64, limit_n: f64) -> f64 {
        if self.schedule.active(FaultKind::CoilOpen, t_s).is_some() {
            0.0
        } else if self.schedule.active(FaultKind::DriverStuck, t_s).is_some() {
            let dir = if last_n != 0.0 { last_n } else { cmd_n };
            limit_n * dir.signum()
        } else {
            cmd_n
        }
    }

    /// Hook load cell → DAQ: the reading the DAQ digitises, N, from the healthy reading.
    pub fn load_cell_n(&mut self, t_s: f64, reading_n: f64) -> f64 {
        let out = if self.schedule.active(FaultKind::LoadCellZero, t_s).is_some() {
            0.0
        } else if self.schedule.active(FaultKind::LoadCellStuck, t_s).is_some() {
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
    pub fn displacement_m(&mut self, t_s: f64, x_m: f64) -> f64 {
        if self
            .schedule
            .active(FaultKind::DisplacementDropout, t_s)
            .is_some()
        {
            self.last_x_m
        } else {
            self.last_x_m = x_m;
            x_m
        }
    }

    /// Hook DAQ → controller: extra delay of the samples the controller sees, s.
    pub fn extra_latency_s(&self, t_s: f64) -> f64 {
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
    fn schedule_parses_and_windows_are_half_open() {
        let text = "name = \"x\"\n[other]\na = 1\n\n[[fault]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\n\n[[fault]]\nkind = \"load_cell_noisy\"\nstart_s = 0.5\nend_s = 3.0\nnoise_rms_n = 4.0\n";
        let s = FaultSchedule::from_scenario_text(text, Path::new("s.toml"), 5.0).unwrap();
        assert_eq!(s.faults.len(), 2);
        assert!(s.active(FaultKind::CoilOpen, 0.999).is_none());
        assert!(s.active(FaultKind::CoilOpen, 1.0).is_some());
        assert!(s.active(FaultKind::CoilOpen, 2.0).is_none());
        assert_eq!(s.faults[1].noise_rms_n, 4.0);
        assert_eq!(mask_names(s.active_mask(1.5)), "coil_open+load_cell_noisy");
    }

    #[test]
    fn bad_fault_entries_name_line_and_key() {
        let bad_kind = "[[fault]]\nkind = \"coil_shorted\"\nstart_s = 1.0\nend_s = 2.0\n";
        let e = FaultSchedule::from_scenario_text(bad_kind, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml:2: [[fault]] #1: `kind`") && e.contains("coil_open"),
            "{e}"
        );
        // The header spelled with spaces (valid TOML), the bad table the second: its own `kind` line.
        let spaced = format!(
            "[[ fault ]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\n\n[[ fault ]]\n{}",
            &bad_kind[10..]
        );
        let e = FaultSchedule::from_scenario_text(&spaced, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("s.toml:7: [[fault]] #2: `kind`"), "{e}");
        let late = "a = 1\n[[fault]]\nkind = \"coil_open\"\nstart_s = 9.0\nend_s = 10.0\n";
        let e = FaultSchedule::from_scenario_text(late, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml:4") && e.contains("start_s") && e.contains("[0, 5]"),
            "{e}"
        );
        // A fault that starts where the run ends, or ends after it: never acting, or acting on a time the
        // run does not reach (the file says something the run would not do).
        let at_end = "[[fault]]\nkind = \"coil_open\"\nstart_s = 5.0\nend_s = 6.0\n";
        let e = FaultSchedule::from_scenario_text(at_end, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml:3: [[fault]] #1: `start_s`") && e.contains("never act"),
            "{e}"
        );
        let past = "[[fault]]\nkind = \"coil_open\"\nstart_s = 4.0\nend_s = 6.0\n";
        let e = FaultSchedule::from_scenario_text(past, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml:4: [[fault]] #1: `end_s`") && e.contains("[4, 5]"),
            "{e}"
        );
        let to_the_end = "[[fault]]\nkind = \"coil_open\"\nstart_s = 4.0\nend_s = 5.0\n";
        assert!(FaultSchedule::from_scenario_text(to_the_end, Path::new("s.toml"), 5.0).is_ok());
        // A value of the wrong type is named by its key (it was named `fault`); a missing key by the table.
        let typed = "[[fault]]\nkind = \"coil_open\"\nstart_s = \"x\"\nend_s = 2.0\n";
        let e = FaultSchedule::from_scenario_text(typed, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml:3: [[fault]] #1: `start_s`") && e.contains("invalid type"),
            "{e}"
        );
        let missing = "[[fault]]\nkind = \"coil_open\"\nstart_s = 1.0\n";
        let e = FaultSchedule::from_scenario_text(missing, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("[[fault]] #1: `fault`") && e.contains("end_s"), "{e}");
        let empty = "[[fault]]\nkind = \"coil_open\"\nstart_s = 2.0\nend_s = 2.0\n";
        let e = FaultSchedule::from_scenario_text(empty, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml:4: [[fault]] #1: `end_s`") && e.contains("never act"),
            "{e}"
        );
        let wrong_param = "[[fault]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\nnoise_rms_n = 1.0\n";
        let e = FaultSchedule::from_scenario_text(wrong_param, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains("noise_rms_n"), "{e}");
        let unknown = "[[fault]]\nkind = \"coil_open\"\nstart_s = 1.0\nend_s = 2.0\nseverity = 1\n";
        let e = FaultSchedule::from_scenario_text(unknown, Path::new("s.toml"), 5.0)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("s.toml:5: [[fault]] #1") && e.contains("severity"),
            "{e}"
        );
    }

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
