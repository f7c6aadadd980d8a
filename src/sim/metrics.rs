//! Figures of merit of a flight run: how well the pilot flew the task, the stick force per g the pilot
//! felt, and how well the load cell follows the desired force where the damper can provide it.

use serde::Serialize;

use super::Results;
use crate::control::LoopMode;
use crate::pilot::attitude::PilotLoop;
use crate::scenario::Scenario;
use crate::signal::slope;

/// How well a flight's feel followed the aircraft, and the pilot the task.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FlightMetrics {
    /// RMS of (command − response) from the first command change to the end: rad (pitch) or g (load
    /// factor); NaN without an outer loop.
    pub tracking_rms: f64,
    /// Largest command change of the schedule, same unit (the scale of the task).
    pub command_span: f64,
    /// The stick force per g the pilot felt, N/g: the least-squares slope of the hand's force against the
    /// load factor from the first command change (all rows without an outer loop); NaN where nz is constant.
    pub hand_force_per_g_n: f64,
    /// Where the loop tracks (the desired force resists the motion), the stick moves, and the desired
    /// force is inside the damper's range: RMS of (true load cell − desired), N.
    pub follow_rms_n: f64,
    /// The RMS desired force in that condition, N.
    pub follow_desired_rms_n: f64,
    /// The fraction of the run in that condition.
    pub follow_fraction: f64,
    /// Peak |stick force| the aircraft asked for at the grip, N.
    pub stick_force_peak_n: f64,
    /// The damper's ceiling at the grip at centre stick, N (its largest yield force through the linkage).
    pub ceiling_at_grip_n: f64,
    /// Live JSBSim: mean round trip of an aircraft frame's request, µs (NaN for the embedded model).
    pub round_trip_mean_us: f64,
    /// Live JSBSim: longest round trip of an aircraft frame's request, µs (NaN for the embedded model).
    pub round_trip_max_us: f64,
}

impl FlightMetrics {
    /// `None` when the scenario flies no aircraft.
    pub fn of(res: &Results, scn: &Scenario) -> Option<Self> {
        let flight = res.flight.as_ref()?;
        let rows = &res.rows;
        // NaN for an empty set (nothing to judge), not 0.
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        // Judged from the first command change (every row without an outer loop).
        let (tracking_rms, command_span, t_judged) = match &scn.outer_loop {
            Some(o) => {
                let t0 = o.command.first_change_s();
                let e: Vec<f64> = rows
                    .iter()
                    .filter(|r| r.t_s >= t0)
                    .filter_map(|r| r.aero)
                    .map(|a| match o.loop_kind {
                        PilotLoop::Pitch => a.pitch_cmd_rad - a.pitch_rad,
                        PilotLoop::LoadFactor => a.nz_cmd_g - a.nz_g,
                    })
                    .collect();
                let v: Vec<f64> = o.command.points.iter().map(|p| p.1).collect();
                let span = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
                    - v.iter().cloned().fold(f64::INFINITY, f64::min);
                (rms(&e), span, t0)
            }
            None => (f64::NAN, f64::NAN, f64::NEG_INFINITY),
        };
        let (nz, hand): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .filter(|r| r.t_s >= t_judged)
            .filter_map(|r| r.aero.map(|a| (a.nz_g, r.pilot_force_n)))
            .unzip();
        let rest = res.rest_speed_m_s;
        let ceiling = res.feel_ceiling_n;
        let (e, d): (Vec<f64>, Vec<f64>) = rows
            .iter()
            .filter(|r| {
                r.mode == LoopMode::Tracking
                    && r.desired_force_n * r.piston_v_m_s > 0.0
                    && r.piston_v_m_s.abs() > 2.0 * rest
                    && r.desired_force_n.abs() < 0.9 * ceiling
            })
            .map(|r| (r.load_cell_true_n - r.desired_force_n, r.desired_force_n))
            .unzip();
        let (_, mean_rt, max_rt) = flight.round_trip_us.unwrap_or((0, f64::NAN, f64::NAN));
        Some(Self {
            tracking_rms,
            command_span,
            hand_force_per_g_n: slope(nz.iter().copied().zip(hand.iter().copied())),
            follow_rms_n: rms(&e),
            follow_desired_rms_n: rms(&d),
            follow_fraction: e.len() as f64 / rows.len().max(1) as f64,
            stick_force_peak_n: rows
                .iter()
                .map(|r| r.aero.map_or(0.0, |a| a.stick_force_n))
                .fold(0.0, |m: f64, x| m.max(x.abs())),
            ceiling_at_grip_n: ceiling * res.gearing_at_centre_m_per_rad / res.grip_arm_m,
            round_trip_mean_us: mean_rt,
            round_trip_max_us: max_rt,
        })
    }
}

impl std::fmt::Display for FlightMetrics {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "  flight: tracking RMS {:.4} (command span {:.4}); hand force per g felt {:.1} N/g (slope over the \
             load factor flown)",
            self.tracking_rms, self.command_span, self.hand_force_per_g_n
        )?;
        if self.follow_fraction > 0.0 {
            write!(
                f,
                "  load cell vs desired where the damper can provide it: RMS {:.2} N of {:.2} N over {:.1} % of the run;",
                self.follow_rms_n,
                self.follow_desired_rms_n,
                100.0 * self.follow_fraction,
            )?;
        } else {
            // An empty set has no RMS: say why nothing was judged instead of printing NaN.
            write!(
                f,
                "  load cell vs desired: not judged, at no sample did the loop track a desired force that resisted \
                 the stick's motion, under 90 % of the damper's ceiling, while the stick moved;"
            )?;
        }
        write!(
            f,
            " peak stick force {:.1} N at the grip (damper ceiling there {:.1} N)",
            self.stick_force_peak_n, self.ceiling_at_grip_n
        )?;
        if self.round_trip_mean_us.is_finite() {
            write!(
                f,
                "\n  JSBSim round trip per aircraft frame: mean {:.1} µs, max {:.1} µs",
                self.round_trip_mean_us, self.round_trip_max_us
            )?;
        }
        Ok(())
    }
}
