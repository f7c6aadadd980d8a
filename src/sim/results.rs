//! A run's time series, its CSV form and its summary figures.

use std::io::Write;

use serde::Serialize;

use super::AeroRow;
use crate::aero::AircraftState;
use crate::control::LoopMode;
use crate::faults::FaultKind;
use crate::rig::{BodyPose, LinkVisuals};

/// One physics step: the state at its start and what was applied over it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// Time, s.
    pub t_s: f64,
    /// Stick angle about the pivot, rad, + = aft.
    pub stick_angle_rad: f64,
    /// Stick rate, rad/s.
    pub stick_rate_rad_s: f64,
    /// Piston displacement from mid-stroke, m.
    pub piston_x_m: f64,
    /// Piston velocity, m/s.
    pub piston_v_m_s: f64,
    /// Load-cell force as the controller last saw it (calibrated, noisy, quantised, delayed, held), N.
    pub load_cell_n: f64,
    /// True force in the load cell along +x on the piston, N.
    pub load_cell_true_n: f64,
    /// The feel law's desired force on the piston, N.
    pub desired_force_n: f64,
    /// Coil current command held over the step, A.
    pub current_a: f64,
    /// Hand force on the grip along its path, N.
    pub pilot_force_n: f64,
    /// Pilot command in grip units (m for a position task, N for a force task).
    pub pilot_cmd: f64,
    /// Damper force along +x on the piston, N.
    pub damper_force_n: f64,
    /// Damper yield-force magnitude, N.
    pub yield_force_n: f64,
    /// What the feel loop is doing: tracking, released or holding.
    pub mode: LoopMode,
    /// Kinetic energy of the moving bodies, J.
    pub kinetic_energy_j: f64,
    /// Gravitational potential energy relative to the start, J.
    pub potential_energy_j: f64,
    /// Energy dissipated in the damper since the start, J.
    pub dissipated_j: f64,
    /// Work done by the hand on the grip since the start, J.
    pub pilot_work_j: f64,
    /// Faults active at this time (bit set over `FaultKind::KINDS`, see [`crate::faults::mask_names`]).
    pub faults: u8,
    /// The current the coil actually receives (after driver faults), A.
    pub current_applied_a: f64,
    /// The coil's current (Eq. 3's state), A.
    pub coil_current_a: f64,
    /// Energy stored in a spring feel element, J (0 without one).
    pub spring_energy_j: f64,
    /// The active stick's motor force on the piston along +x, N (0 for the other systems).
    pub actuator_force_n: f64,
    /// The motor's work on the piston so far, J (0 for the other systems).
    pub actuator_work_j: f64,
    /// The aircraft's columns, when the scenario flies one.
    pub aero: Option<AeroRow>,
}

/// The CSV columns of a row type: `$names` lists them (a column is named after its field, or given a value
/// by `name = expr` over `$s`, the row), and `$ty::values` gives the row's numbers in that order.
macro_rules! csv_columns {
    ($(#[$doc:meta])* $names:ident, $ty:ty, $s:ident: $($col:ident $(= $e:expr)?),* $(,)?) => {
        $(#[$doc])*
        pub(crate) const $names: [&str; [$(stringify!($col)),*].len()] = [$(stringify!($col)),*];

        impl $ty {
            /// The row's values in the order of the columns.
            fn values(&self) -> [f64; $names.len()] {
                let $s = self;
                [$(csv_columns!(@value $s $col $($e)?)),*]
            }
        }
    };
    (@value $s:ident $col:ident) => {
        $s.$col
    };
    (@value $s:ident $col:ident $e:expr) => {
        $e
    };
}

csv_columns!(
    /// The CSV's columns of every run (the loop mode and the fault mask as the integers they are, which print
    /// alike as `f64`).
    CSV_COLUMNS, Row, r:
    t_s,
    stick_angle_rad,
    stick_rate_rad_s,
    piston_x_m,
    piston_v_m_s,
    load_cell_n,
    load_cell_true_n,
    desired_force_n,
    current_a,
    pilot_force_n,
    pilot_cmd,
    damper_force_n,
    yield_force_n,
    loop_mode = f64::from(mode_code(r.mode)),
    kinetic_energy_j,
    potential_energy_j,
    dissipated_j,
    pilot_work_j,
    fault_mask = f64::from(r.faults),
    current_applied_a,
    coil_current_a,
    spring_energy_j,
    actuator_force_n,
    actuator_work_j,
);

csv_columns!(
    /// Columns added when the scenario flies an aircraft.
    AERO_COLUMNS, AeroRow, a:
    qbar_pa,
    elevator_rad,
    hinge_moment_nm,
    pitch_rad,
    pitch_cmd_rad,
    nz_g,
    nz_cmd_g,
    q_rad_s,
    alpha_rad,
    airspeed_m_s,
    altitude_m,
    stick_force_n,
    stick_cmd_rad,
);

/// Columns where NaN means none rather than a failed number: the pilot's command (hands off the stick)
/// and the outer loop's commands (the other loop's, or no outer loop).
pub(crate) const NAN_MEANS_NONE: [&str; 4] = ["pilot_cmd", "pitch_cmd_rad", "nz_cmd_g", "stick_cmd_rad"];

/// The aircraft of a flight run.
#[derive(Debug, Clone)]
pub struct FlightInfo {
    /// Backend label (`"c172p"`, `"jsbsim:c172p"`).
    pub aircraft: String,
    /// The aircraft's mrfeel model file the flight flew.
    pub model_file: std::path::PathBuf,
    /// The trimmed state the run starts from.
    pub trim: AircraftState,
    /// Stick angle of the trim (aircraft convention), rad: the rig's neutral.
    pub trim_stick_rad: f64,
    /// Live JSBSim: (requests, mean µs, max µs) of the step round trips.
    pub round_trip_us: Option<(u64, f64, f64)>,
    /// The aircraft model's parameters marked `[EST]` in its file (estimates without a source).
    pub estimates: Vec<String>,
}

pub(crate) fn mode_code(m: LoopMode) -> u8 {
    match m {
        LoopMode::Holding => 0,
        LoopMode::Tracking => 1,
        LoopMode::Released => 2,
    }
}

/// A run kept whole: its rows, drawing frames and the facts needed to read them.
#[derive(Debug, Clone)]
pub struct Results {
    /// The scenario's name.
    pub scenario: String,
    /// Below this piston speed the controller holds, m/s.
    pub rest_speed_m_s: f64,
    /// Half stroke of the piston, m.
    pub stroke_half_m: f64,
    /// One row per physics step.
    pub rows: Vec<Row>,
    /// Link shapes for drawing (empty unless poses were recorded).
    pub visuals: Vec<LinkVisuals>,
    /// Body poses at the drawing rate: (time, bodies).
    pub frames: Vec<(f64, Vec<BodyPose>)>,
    /// The largest yield force the controller can ask for (`fc0 + fc_gain · current_max`), N on the
    /// piston: the ceiling of the feel the damper can render.
    pub feel_ceiling_n: f64,
    /// The model the controller believed, with its file.
    pub controller_model: String,
    /// The grip's arm about the pivot, m (to express piston forces at the grip).
    pub grip_arm_m: f64,
    /// The linkage's gearing at centre stick, m/rad.
    pub gearing_at_centre_m_per_rad: f64,
    /// The aircraft, when the scenario flies one.
    pub flight: Option<FlightInfo>,
    /// Energy taken by the stick's end stops at impacts over the run, J (counted by the run's checks).
    pub stops_j: f64,
}

/// Summary figures of a run.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct Summary {
    /// The scenario's name.
    pub scenario: String,
    /// Length of the run, s.
    pub duration_s: f64,
    /// The model the controller believed (`bingham from models/paper-device.toml (the plant's file)`).
    pub controller_model: String,
    /// Samples where the target resists the motion (loop tracking and `F*·v > 0`).
    pub resisting_samples: usize,
    /// RMS of (true load-cell force − desired) over the resisting samples, N; `None` (JSON `null`) where no sample resists, or the desired force there is zero: nothing was tracked.
    pub tracking_rmse_n: Option<f64>,
    /// `tracking_rmse_n` over the RMS desired force on the same samples.
    pub tracking_nrmse: Option<f64>,
    /// Largest |piston displacement|, m.
    pub max_abs_piston_x_m: f64,
    /// Half stroke of the piston, m.
    pub stroke_half_m: f64,
    /// Smallest coil current command, A.
    pub current_min_a: f64,
    /// Largest coil current command, A.
    pub current_max_a: f64,
    /// Largest |true load-cell force|, N.
    pub max_abs_load_cell_n: f64,
    /// Work done by the hand on the grip, J.
    pub pilot_work_j: f64,
    /// Kinetic energy at the end minus at the start, J.
    pub kinetic_energy_change_j: f64,
    /// Potential energy at the end minus at the start, J.
    pub potential_energy_change_j: f64,
    /// Change of the energy stored in a spring feel element, J.
    pub spring_energy_change_j: f64,
    /// Work of the active stick's motor, J (0 for the passive systems).
    pub actuator_work_j: f64,
    /// Energy dissipated in the damper, J.
    pub dissipated_j: f64,
    /// Energy taken by the stick's end stops at impacts, J (0 where not counted).
    pub stops_j: f64,
    /// Work the hand and the motor exchanged with the rig, J: each step's work of each counted whatever
    /// its sign, so that the energy a rendered spring takes in and gives back both count. The scale of the
    /// balance's residual: the integrator's error grows with the energy that flows, not with its net.
    pub work_exchanged_j: f64,
    /// (pilot work + motor work − ΔKE − ΔPE − Δspring − dissipated − stops) / `work_exchanged_j`; `None`
    /// where no work was done.
    pub energy_residual: Option<f64>,
}

impl Summary {
    /// The summary with `stops_j` of energy taken by the stick's stops counted in its balance.
    pub fn with_stops_j(mut self, stops_j: f64) -> Self {
        let work = self.work_exchanged_j;
        self.energy_residual = self.energy_residual.map(|e| e - (stops_j - self.stops_j) / work);
        self.stops_j = stops_j;
        self
    }
}

/// The work the hand and the motor exchanged with the rig between rows `a` and `b`, J, each whatever its
/// sign.
pub(crate) fn work_exchanged_j(a: &Row, b: &Row) -> f64 {
    (b.pilot_work_j - a.pilot_work_j).abs() + (b.actuator_work_j - a.actuator_work_j).abs()
}

/// A run's [`Summary`] gathered row by row, so that a run streamed to its outputs needs no rows kept.
#[derive(Debug, Clone, Default)]
pub struct SummaryAcc {
    se: f64,
    sd: f64,
    n: usize,
    max_abs_x: f64,
    current_min: Option<f64>,
    current_max: Option<f64>,
    max_abs_load_cell: f64,
    exchanged_j: f64,
    first: Option<Row>,
    last: Option<Row>,
}

impl SummaryAcc {
    /// Count row `r` in.
    pub fn push(&mut self, r: &Row) {
        if r.mode == LoopMode::Tracking && r.desired_force_n * r.piston_v_m_s > 0.0 {
            self.se += (r.load_cell_true_n - r.desired_force_n).powi(2);
            self.sd += r.desired_force_n.powi(2);
            self.n += 1;
        }
        self.max_abs_x = self.max_abs_x.max(r.piston_x_m.abs());
        self.current_min = Some(self.current_min.map_or(r.current_a, |c| c.min(r.current_a)));
        self.current_max = Some(self.current_max.map_or(r.current_a, |c| c.max(r.current_a)));
        self.max_abs_load_cell = self.max_abs_load_cell.max(r.load_cell_true_n.abs());
        if let Some(prev) = &self.last {
            self.exchanged_j += work_exchanged_j(prev, r);
        }
        self.first.get_or_insert(*r);
        self.last = Some(*r);
    }

    /// The summary of the rows pushed, of the run whose facts `head` holds.
    pub fn finish(&self, head: &Results) -> Summary {
        let (se, sd, n) = (self.se, self.sd, self.n);
        let rmse = (n > 0).then(|| (se / n as f64).sqrt());
        let nrmse = (n > 0 && sd > 0.0).then(|| (se / sd).sqrt());
        // A quantity's change from the first row to the last (0 without rows).
        let change = |f: fn(&Row) -> f64| self.first.zip(self.last).map_or(0.0, |(a, b)| f(&b) - f(&a));
        let w = change(|r| r.pilot_work_j);
        let dke = change(|r| r.kinetic_energy_j);
        let dpe = change(|r| r.potential_energy_j);
        let diss = change(|r| r.dissipated_j);
        let dspring = change(|r| r.spring_energy_j);
        let wa = change(|r| r.actuator_work_j);
        Summary {
            scenario: head.scenario.clone(),
            duration_s: change(|r| r.t_s),
            controller_model: head.controller_model.clone(),
            resisting_samples: n,
            tracking_rmse_n: rmse,
            tracking_nrmse: nrmse,
            max_abs_piston_x_m: self.max_abs_x,
            stroke_half_m: head.stroke_half_m,
            current_min_a: self.current_min.unwrap_or(0.0),
            current_max_a: self.current_max.unwrap_or(0.0),
            max_abs_load_cell_n: self.max_abs_load_cell,
            pilot_work_j: w,
            kinetic_energy_change_j: dke,
            potential_energy_change_j: dpe,
            spring_energy_change_j: dspring,
            actuator_work_j: wa,
            dissipated_j: diss,
            stops_j: 0.0,
            work_exchanged_j: self.exchanged_j,
            energy_residual: (self.exchanged_j > 0.0)
                .then(|| (w + wa - dke - dpe - dspring - diss) / self.exchanged_j),
        }
    }
}

impl Results {
    /// The run's summary figures.
    pub fn summary(&self) -> Summary {
        let mut acc = SummaryAcc::default();
        for r in &self.rows {
            acc.push(r);
        }
        acc.finish(self).with_stops_j(self.stops_j)
    }

    /// Write the CSV: a `# key: value` metadata block, the header, one row per physics step. Numbers are
    /// printed with Rust's shortest round-trip formatting, so the same run gives the same bytes.
    pub fn write_csv(&self, mut w: impl Write) -> std::io::Result<()> {
        self.write_csv_head(&mut w)?;
        for r in &self.rows {
            self.write_csv_row(&mut w, r)?;
        }
        Ok(())
    }

    /// The CSV's metadata block and header ([`Results::write_csv`]), from the run's facts alone (no rows).
    pub fn write_csv_head(&self, mut w: impl Write) -> std::io::Result<()> {
        writeln!(w, "# source: mrfeel run")?;
        writeln!(w, "# scenario: {}", self.scenario)?;
        writeln!(
            w,
            "# forces: along +x on the piston (load cell, desired, damper); pilot force along the grip path"
        )?;
        let bits: Vec<String> = FaultKind::KINDS
            .iter()
            .map(|f| format!("{}={}", f.bit(), f.name()))
            .collect();
        writeln!(
            w,
            "# fault_mask: sum of the active faults' bits: {}",
            bits.join(", ")
        )?;
        if let Some(f) = &self.flight {
            writeln!(
                w,
                "# aircraft: {}, trim {} m/s at {} m, trim stick {} rad; stick_force_n at the grip (pull +)",
                f.aircraft, f.trim.airspeed_m_s, f.trim.altitude_m, f.trim_stick_rad
            )?;
            writeln!(
                w,
                "# aircraft estimates ([EST], no source): {}",
                f.estimates.join(", ")
            )?;
        }
        writeln!(w, "{}", self.column_names().collect::<Vec<_>>().join(","))
    }

    /// One row of the CSV ([`Results::write_csv`]).
    pub fn write_csv_row(&self, mut w: impl Write, r: &Row) -> std::io::Result<()> {
        for (k, v) in self.csv_values(r).enumerate() {
            if k > 0 {
                w.write_all(b",")?;
            }
            write!(w, "{v}")?;
        }
        writeln!(w)
    }

    /// The CSV's column names: `CSV_COLUMNS`, then `AERO_COLUMNS` when the scenario flies an aircraft.
    fn column_names(&self) -> impl Iterator<Item = &'static str> {
        let aero = self.flight.is_some().then_some(AERO_COLUMNS);
        CSV_COLUMNS.into_iter().chain(aero.into_iter().flatten())
    }

    /// A row's numbers in the CSV's columns (the aircraft's zero where a flight's row has none).
    fn csv_values(&self, r: &Row) -> impl Iterator<Item = f64> {
        let aero = self.flight.is_some().then(|| r.aero.unwrap_or_default().values());
        r.values().into_iter().chain(aero.into_iter().flatten())
    }

    /// The CSV's columns ([`Results::write_csv`]) by name, with the same values the CSV prints.
    pub fn columns(&self) -> Vec<(&'static str, Vec<f64>)> {
        let mut cols: Vec<(&'static str, Vec<f64>)> = self
            .column_names()
            .map(|name| (name, Vec::with_capacity(self.rows.len())))
            .collect();
        for r in &self.rows {
            for ((_, col), v) in cols.iter_mut().zip(self.csv_values(r)) {
                col.push(v);
            }
        }
        cols
    }
}

impl Row {
    /// Every number of the row by its CSV column: [`CSV_COLUMNS`], then [`AERO_COLUMNS`] where the row has
    /// the aircraft's.
    pub(crate) fn named_values(&self) -> impl Iterator<Item = (&'static str, f64)> {
        let aero = self.aero.map(|a| AERO_COLUMNS.into_iter().zip(a.values()));
        CSV_COLUMNS
            .into_iter()
            .zip(self.values())
            .chain(aero.into_iter().flatten())
    }
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(f, "scenario {}: {:.3} s", self.scenario, self.duration_s)?;
        writeln!(f, "  controller model: {}", self.controller_model)?;
        match (self.tracking_rmse_n, self.tracking_nrmse) {
            (Some(e), Some(n)) => writeln!(
                f,
                "  force tracking where the target resists motion: RMS error {e:.2} N ({:.1} % of RMS desired) over {} samples",
                100.0 * n,
                self.resisting_samples
            )?,
            _ => writeln!(
                f,
                "  force tracking: none to measure (the desired force resisted the motion at {} samples, with an \
                 RMS of 0 N)",
                self.resisting_samples
            )?,
        }
        writeln!(
            f,
            "  max stroke |x| {:.4} m of ±{:.4} m ({:.2} in of ±{:.2} in)",
            self.max_abs_piston_x_m,
            self.stroke_half_m,
            self.max_abs_piston_x_m / crate::units::IN_TO_M,
            self.stroke_half_m / crate::units::IN_TO_M
        )?;
        writeln!(
            f,
            "  current command {:.2} .. {:.2} A",
            self.current_min_a, self.current_max_a
        )?;
        writeln!(f, "  max |load cell| {:.1} N", self.max_abs_load_cell_n)?;
        write!(
            f,
            "  energy: pilot work {:.4} J{} = ΔKE {:.4} J + ΔPE {:.4} J + Δspring {:.4} J + dissipated {:.4} J{} (residual {} of {:.4} J exchanged)",
            self.pilot_work_j,
            if self.actuator_work_j != 0.0 {
                format!(" + motor work {:.4} J", self.actuator_work_j)
            } else {
                String::new()
            },
            self.kinetic_energy_change_j,
            self.potential_energy_change_j,
            self.spring_energy_change_j,
            self.dissipated_j,
            if self.stops_j != 0.0 {
                format!(" + taken by the stops {:.4} J", self.stops_j)
            } else {
                String::new()
            },
            self.energy_residual
                .map_or("none: no work done".into(), |e| format!("{:.3} %", 100.0 * e)),
            self.work_exchanged_j
        )
    }
}

/// A run's row as its recording shows it.
#[cfg(feature = "rerun")]
pub fn rerun_sample(r: &Row) -> crate::viz::rerun_rig::Sample {
    crate::viz::rerun_rig::Sample {
        t_s: r.t_s,
        series: [
            r.desired_force_n,
            r.load_cell_n,
            r.load_cell_true_n,
            r.damper_force_n,
            r.current_a,
            r.piston_x_m,
            r.pilot_force_n,
            r.stick_angle_rad,
            r.dissipated_j,
            f64::from(r.faults),
        ],
        aircraft: r.aero.map(|a| {
            [
                a.pitch_rad,
                a.pitch_cmd_rad,
                a.nz_g,
                a.nz_cmd_g,
                a.elevator_rad,
                a.hinge_moment_nm,
                a.qbar_pa,
                a.stick_force_n,
                a.stick_cmd_rad,
            ]
        }),
    }
}

/// Log a run whose rows and frames are all in memory to a Rerun recording.
#[cfg(feature = "rerun")]
pub fn log_rerun(rec: &rerun::RecordingStream, res: &Results) -> Result<(), crate::viz::rerun_rig::VizError> {
    let samples: Vec<_> = res.rows.iter().map(rerun_sample).collect();
    crate::viz::rerun_rig::log_run(rec, &res.visuals, res.flight.is_some(), &samples, &res.frames)
}
