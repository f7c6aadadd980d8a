//! What a finished run must satisfy before its results are reported or written (docs/invariants.md): every
//! number finite, the energy balance closed, the load cell within its range. A run that breaks one is an
//! error naming the invariant, the time and the scenario's setting that most likely caused it.

use super::{Results, Row, SimError};
use crate::pilot::Signal;
use crate::scenario::Scenario;

/// Largest |energy residual| of a run (pilot and motor work against the change of kinetic, potential and
/// spring energy plus the energy dissipated, relative to the work done): the rig's shipped scenarios close
/// it within 1 %; a physics step too coarse for the motion leaves tens of per cent.
pub(crate) const ENERGY_RESIDUAL_TOLERANCE: f64 = 0.05;

/// Imbalance, J, below which the energy balance is not judged whatever the work done: a stick held at rest
/// by the damper's yield force does microjoules of work, against which the integrator's rounding is a large
/// share but no error (a millijoule is 10 N over 0.1 mm).
pub(crate) const ENERGY_FLOOR_J: f64 = 1e-3;

/// Physics steps per period of the pilot's command below which the command, rather than the physics rate,
/// is named as the likely cause: the hand's work over a step is `F·Δx` with `F` held, exact only when the
/// motion is smooth on the step.
const STEPS_PER_COMMAND_PERIOD: f64 = 100.0;

/// The hand's neuromuscular bandwidth, Hz: a command faster than `1/(2π·activation_tau_s)` is beyond what a
/// pilot's arm follows.
fn hand_bandwidth_hz(scn: &Scenario) -> f64 {
    1.0 / (std::f64::consts::TAU * scn.pilot.hand.activation_tau_s.max(f64::MIN_POSITIVE))
}

/// The fundamental frequency of the pilot's command, Hz, for the periodic commands.
fn command_frequency_hz(scn: &Scenario) -> Option<f64> {
    match scn.pilot.command {
        Signal::Sine { frequency_hz, .. } | Signal::Triangle { frequency_hz, .. } => Some(frequency_hz),
        _ => None,
    }
}

/// The setting most likely to blame for a broken invariant, with its line, and why: the pilot's command
/// where it is faster than the hand follows or too fast for the physics step; else the physics rate.
fn likely_setting(scn: &Scenario) -> (&'static str, usize, String) {
    let physics_hz = scn.physics_rate_hz();
    if let Some(f) = command_frequency_hz(scn) {
        let bandwidth = hand_bandwidth_hz(scn);
        if f > bandwidth || f * STEPS_PER_COMMAND_PERIOD > physics_hz {
            return (
                "pilot.frequency_hz",
                scn.lines.pilot_frequency,
                format!(
                    "the pilot's command at {f} Hz is beyond the hand's bandwidth ({bandwidth:.2} Hz) or has \
                     fewer than {STEPS_PER_COMMAND_PERIOD} physics steps per period at {physics_hz} Hz: \
                     command a slower motion"
                ),
            );
        }
    }
    (
        "rig.physics_hz",
        scn.lines.physics_hz,
        format!(
            "the physics rate {physics_hz} Hz does not resolve this rig and loop: run it at another rate \
             (the shipped scenarios run at 1–2 kHz) and compare"
        ),
    )
}

fn broken(scn: &Scenario, invariant: String, t_s: f64) -> SimError {
    let (key, line, advice) = likely_setting(scn);
    SimError::Invariant {
        scenario: scn.path.clone(),
        line,
        key,
        invariant,
        t_s,
        advice,
    }
}

/// The first value of a row that is not a number, by its column (the pilot's command excepted: NaN there
/// means hands off the stick).
fn not_finite(r: &Row) -> Option<(&'static str, f64)> {
    let mut cols = vec![
        ("stick_rate_rad_s", r.stick_rate_rad_s),
        ("load_cell_n", r.load_cell_n),
        ("desired_force_n", r.desired_force_n),
        ("current_a", r.current_a),
        ("pilot_force_n", r.pilot_force_n),
        ("damper_force_n", r.damper_force_n),
        ("yield_force_n", r.yield_force_n),
        ("kinetic_energy_j", r.kinetic_energy_j),
        ("potential_energy_j", r.potential_energy_j),
        ("dissipated_j", r.dissipated_j),
        ("pilot_work_j", r.pilot_work_j),
        ("current_applied_a", r.current_applied_a),
        ("coil_current_a", r.coil_current_a),
        ("spring_energy_j", r.spring_energy_j),
        ("actuator_force_n", r.actuator_force_n),
        ("actuator_work_j", r.actuator_work_j),
    ];
    if let Some(a) = &r.aero {
        cols.extend([
            ("qbar_pa", a.qbar_pa),
            ("elevator_rad", a.elevator_rad),
            ("hinge_moment_nm", a.hinge_moment_nm),
            ("pitch_rad", a.pitch_rad),
            ("nz_g", a.nz_g),
            ("stick_force_n", a.stick_force_n),
        ]);
    }
    cols.into_iter().find(|(_, v)| !v.is_finite())
}

/// The invariants checked row by row as a run goes ([`Checker::push`]) and over the whole run at its end
/// ([`Checker::finish`]), so that a run streamed to its outputs keeps no rows.
pub(crate) struct Checker<'a> {
    scn: &'a Scenario,
    first: Option<Row>,
    /// The first time the running energy imbalance exceeded the tolerance of the work done so far.
    energy_first_off_s: Option<f64>,
    most_work_j: f64,
    /// The first time the load cell's force left its range, and the most it reached.
    range_off: Option<(f64, f64)>,
}

impl<'a> Checker<'a> {
    pub fn new(scn: &'a Scenario) -> Self {
        Self {
            scn,
            first: None,
            energy_first_off_s: None,
            most_work_j: 0.0,
            range_off: None,
        }
    }

    /// Check one row: every number finite (at once); the load cell's range and the energy balance are
    /// judged at the end ([`Checker::finish`]), so that a run that diverges later is named as diverged.
    pub fn push(&mut self, r: &Row) -> Result<(), SimError> {
        let scn = self.scn;
        if let Some((col, v)) = not_finite(r) {
            return Err(broken(scn, format!("every number finite: `{col}` is {v}"), r.t_s));
        }
        let range = scn.sensors.load_cell.range_n;
        let f = r.load_cell_true_n.abs();
        if f > range {
            let first_t = self.range_off.map_or(r.t_s, |(t, _)| t);
            let most = self.range_off.map_or(f, |(_, m)| m.max(f));
            self.range_off = Some((first_t, most));
        }
        let first = *self.first.get_or_insert(*r);
        let work =
            (r.pilot_work_j - first.pilot_work_j).abs() + (r.actuator_work_j - first.actuator_work_j).abs();
        self.most_work_j = self.most_work_j.max(work);
        if self.energy_first_off_s.is_none() {
            let gap = (r.pilot_work_j - first.pilot_work_j) + (r.actuator_work_j - first.actuator_work_j)
                - (r.kinetic_energy_j - first.kinetic_energy_j)
                - (r.potential_energy_j - first.potential_energy_j)
                - (r.spring_energy_j - first.spring_energy_j)
                - (r.dissipated_j - first.dissipated_j);
            if gap.abs() > ENERGY_RESIDUAL_TOLERANCE * self.most_work_j + ENERGY_FLOOR_J {
                self.energy_first_off_s = Some(r.t_s);
            }
        }
        Ok(())
    }

    /// Check the whole run: the load cell within its range, then the energy balance of its summary.
    pub fn finish(&self, s: &super::Summary) -> Result<(), SimError> {
        if let Some((t_s, most)) = self.range_off {
            let range = self.scn.sensors.load_cell.range_n;
            return Err(broken(
                self.scn,
                format!(
                    "load cell within its ±{range} N range (`load_cell.range_n`): the force in it reaches {most:.1} N"
                ),
                t_s,
            ));
        }
        if let Some(e) = s.energy_residual {
            let work = s.pilot_work_j.abs() + s.actuator_work_j.abs();
            if e.abs() > ENERGY_RESIDUAL_TOLERANCE && e.abs() * work > ENERGY_FLOOR_J {
                return Err(broken(
                    self.scn,
                    format!(
                        "energy balance within {} %: the work done and the energy stored and dissipated \
                         differ by {:.1} % over the run",
                        100.0 * ENERGY_RESIDUAL_TOLERANCE,
                        100.0 * e
                    ),
                    self.energy_first_off_s.unwrap_or(s.duration_s),
                ));
            }
        }
        Ok(())
    }
}

/// Check a finished run of `scn` (`Checker`).
pub fn check(res: &Results, scn: &Scenario) -> Result<(), SimError> {
    let mut c = Checker::new(scn);
    for r in &res.rows {
        c.push(r)?;
    }
    c.finish(&res.summary())
}
