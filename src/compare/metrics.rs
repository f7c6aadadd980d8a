//! What the pilot feels, from a run's rows: force–deflection against the target, breakout, gradient,
//! re-centring, phase lag, energy, coil power, peak force against the certification limits, and the
//! pilot's tracking; and, for a run with a fault, the same quantities inside the fault's window.
//!
//! Forces are the pilot's force at the grip (N, tangential, + = aft), angles the stick's (rad).

use serde::Serialize;

use super::{CompareScenario, FeelKind, Row, Segment, Trace};
use crate::faults::FaultKind;
use crate::signal::slope;

/// The comparison figures of one feel system.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SystemMetrics {
    /// RMS of (pilot's force − feel target at the grip) over the sinusoidal motion after its first cycle, N.
    pub force_rms_error_n: f64,
    /// Grip force at which the stick first moves by the breakout threshold in a slow force ramp, N (NaN:
    /// never within the ramp).
    pub breakout_n: f64,
    /// Least-squares slope of grip force against stick angle over the sinusoidal motion, N/rad.
    pub force_gradient_n_per_rad: f64,
    /// Stick angle left at the end of the hands-off period, |rad|.
    pub recentre_offset_rad: f64,
    /// Time from letting go until the stick stays inside the band, s (NaN: it does not).
    pub recentre_time_s: f64,
    /// Phase by which the grip force's fundamental lags the stick angle's, deg (spring 0, damper −90).
    pub phase_lag_deg: f64,
    /// Largest excess of the stored mechanical energy (kinetic + potential + spring) over the hand's work
    /// so far, J: the energy the feel system put in (0 for a passive system).
    pub energy_injected_j: f64,
    /// Hand's work minus the energy left stored at the end, J.
    pub energy_dissipated_j: f64,
    /// Mean coil power I²R, W.
    pub coil_power_mean_w: f64,
    /// Peak coil power I²R, W.
    pub coil_power_peak_w: f64,
    /// The coil's energy over the run, J.
    pub coil_energy_j: f64,
    /// Largest |grip force| in the main task (sinusoidal motion, deflect and hold), N.
    pub peak_force_n: f64,
    /// Peak force within 14 CFR 23.143(c) stick pitch, temporary application.
    pub within_part23_temporary: bool,
    /// Peak force within 14 CFR 25.143 pitch, one hand.
    pub within_part25_one_hand: bool,
    /// RMS of (stick angle − commanded angle) over the sinusoidal motion after its first cycle, deg.
    pub tracking_rms_deg: f64,
}

/// Rows of the sinusoidal segment (index 0) after its first cycle.
fn sweep_rows(tr: &Trace) -> (&[Row], f64) {
    let f = match tr.task.segments.first() {
        Some(Segment::Sine { frequency_hz, .. }) => *frequency_hz,
        _ => return (&[], 0.0),
    };
    let inside = |r: &Row| r.segment == 0 && r.t_s >= 1.0 / f;
    match (tr.rows.iter().position(inside), tr.rows.iter().rposition(inside)) {
        (Some(a), Some(b)) => (&tr.rows[a..=b], f),
        _ => (&[], f),
    }
}

fn rms(it: impl Iterator<Item = f64>) -> f64 {
    let (s, n) = it.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
    if n == 0 {
        f64::NAN
    } else {
        (s / n as f64).sqrt()
    }
}

/// Phase (rad) of the fundamental at `freq_hz` of samples `(t, y)` (over whole cycles).
fn fundamental_phase(pts: impl Iterator<Item = (f64, f64)>, freq_hz: f64) -> f64 {
    let w = 2.0 * std::f64::consts::PI * freq_hz;
    let (re, im) = pts.fold((0.0, 0.0), |(re, im), (t, y)| {
        (re + y * (w * t).sin(), im + y * (w * t).cos())
    });
    // y = A sin(wt + φ): Σ y sin = A/2 cos φ · N, Σ y cos = A/2 sin φ · N.
    im.atan2(re)
}

/// Wrap an angle in degrees to (−180, 180].
fn wrap_deg(a: f64) -> f64 {
    let mut a = a % 360.0;
    if a <= -180.0 {
        a += 360.0;
    }
    if a > 180.0 {
        a -= 360.0;
    }
    a
}

/// Phase lag of force behind angle over rows, deg.
pub fn phase_lag_deg(rows: &[Row], freq_hz: f64) -> f64 {
    let pa = fundamental_phase(rows.iter().map(|r| (r.t_s, r.theta_rad)), freq_hz);
    let pf = fundamental_phase(rows.iter().map(|r| (r.t_s, r.hand_force_n)), freq_hz);
    wrap_deg((pa - pf).to_degrees())
}

/// The hands-off period: (first row index, stick angle when let go).
fn let_go(tr: &Trace) -> Option<(usize, f64)> {
    let k = tr
        .task
        .segments
        .iter()
        .position(|s| matches!(s, Segment::LetGo { .. }))?;
    let i = tr.rows.iter().position(|r| r.segment == k)?;
    Some((i, tr.rows[i].theta_rad))
}

/// (offset at the end, |rad|; time to stay inside `band_rad`, s, NaN if never).
pub(crate) fn recentring(tr: &Trace, band_rad: f64) -> (f64, f64) {
    let Some((i0, _)) = let_go(tr) else {
        return (f64::NAN, f64::NAN);
    };
    let rows = &tr.rows[i0..];
    let Some(last) = rows.last() else {
        return (f64::NAN, f64::NAN);
    };
    let offset = last.theta_rad.abs();
    if offset > band_rad {
        return (offset, f64::NAN);
    }
    let out = rows.iter().rposition(|r| r.theta_rad.abs() > band_rad);
    let t = match out {
        Some(k) => rows[(k + 1).min(rows.len() - 1)].t_s - rows[0].t_s,
        None => 0.0,
    };
    (offset, t)
}

/// Largest excess of stored energy over the hand's work, J (≥ 0).
pub fn energy_injected_j(rows: &[Row]) -> f64 {
    rows.iter()
        .map(|r| r.stored_j - r.hand_work_j)
        .fold(0.0, f64::max)
}

/// Grip force at breakout, N: the hand's force when the stick has moved `threshold_rad` (NaN if it never does).
pub fn breakout_n(tr: &Trace, threshold_rad: f64) -> f64 {
    let Some(first) = tr.rows.first() else {
        return f64::NAN;
    };
    tr.rows
        .iter()
        .find(|r| (r.theta_rad - first.theta_rad).abs() > threshold_rad)
        .map(|r| r.hand_force_n.abs())
        .unwrap_or(f64::NAN)
}

/// All figures of one system from its main and breakout runs.
pub fn system_metrics(scn: &CompareScenario, main: &Trace, breakout: &Trace) -> SystemMetrics {
    let (sweep, f) = sweep_rows(main);
    let r_ohm = if main.system.has_coil() {
        scn.coil_resistance_ohm
    } else {
        0.0
    };
    let power = |r: &Row| r.coil_current_a * r.coil_current_a * r_ohm;
    let all = || main.rows.iter().chain(breakout.rows.iter());
    let n_all = (main.rows.len() + breakout.rows.len()).max(1) as f64;
    let coil_energy_j = all().map(power).sum::<f64>() * main.dt_s;
    // The breakout run's force is prescribed (a ramp to its end), so the peak is the main task's.
    let peak_force_n = main.rows.iter().map(|r| r.hand_force_n.abs()).fold(0.0, f64::max);
    let (lim23, _, lim25) = scn.limits.newtons();
    let (recentre_offset_rad, recentre_time_s) = recentring(main, scn.task.recentre_band_rad);
    let last = main.rows.last().copied().unwrap_or_default();
    SystemMetrics {
        force_rms_error_n: rms(sweep.iter().map(|r| r.hand_force_n - r.target_grip_n)),
        breakout_n: breakout_n(breakout, scn.task.breakout_threshold_rad),
        force_gradient_n_per_rad: slope(sweep.iter().map(|r| (r.theta_rad, r.hand_force_n))),
        recentre_offset_rad,
        recentre_time_s,
        phase_lag_deg: phase_lag_deg(sweep, f),
        energy_injected_j: energy_injected_j(&main.rows).max(energy_injected_j(&breakout.rows)),
        energy_dissipated_j: last.hand_work_j - last.stored_j,
        coil_power_mean_w: all().map(power).sum::<f64>() / n_all,
        coil_power_peak_w: all().map(power).fold(0.0, f64::max),
        coil_energy_j,
        peak_force_n,
        within_part23_temporary: peak_force_n <= lim23,
        within_part25_one_hand: peak_force_n <= lim25,
        tracking_rms_deg: rms(sweep.iter().map(|r| (r.theta_rad - r.theta_cmd_rad).to_degrees())),
    }
}

/// What a fault did to one system, measured inside its window.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FaultMetrics {
    /// Rows (physics steps) during which the fault was active on this system's electrical path (0 for a
    /// system without one: the fault has nothing to act on).
    pub fault_steps: usize,
    /// Largest |grip force| in the window, N.
    pub peak_force_n: f64,
    /// RMS of (grip force − target) in the window while the pilot moves the stick, N.
    pub force_rms_error_n: f64,
    /// The same figure for the healthy run over the same rows, N.
    pub healthy_force_rms_error_n: f64,
    /// Pilot's tracking error in the window (sinusoidal part), deg RMS.
    pub tracking_rms_deg: f64,
    /// Smallest coil current command in the window, A.
    pub current_cmd_min_a: f64,
    /// Largest coil current command in the window, A.
    pub current_cmd_max_a: f64,
    /// Mean applied coil current in the window, A.
    pub current_applied_mean_a: f64,
    /// Mean yield force of the damper in the window, N.
    pub yield_mean_n: f64,
    /// Hands off (inside the window): the largest motion from where the pilot let go, rad.
    pub hands_off_moved_rad: f64,
    /// Hands off: the largest motion away from the centre beyond that point, rad.
    pub hands_off_away_rad: f64,
    /// Whether the stick moved away from the centre by more than the re-centring band without the pilot.
    pub moves_without_pilot: bool,
}

/// Metrics of the `faulty` run against the `healthy` one over the window `start_s`..`end_s`.
pub fn fault_metrics(
    scn: &CompareScenario,
    faulty: &Trace,
    healthy: &Trace,
    start_s: f64,
    end_s: f64,
) -> FaultMetrics {
    let win = |r: &&Row| r.t_s >= start_s && r.t_s < end_s;
    let rows: Vec<&Row> = faulty.rows.iter().filter(win).collect();
    let hrows: Vec<&Row> = healthy.rows.iter().filter(win).collect();
    let moving = |r: &&&Row| r.hands_on && r.segment == 0;
    let n = rows.len().max(1) as f64;
    let (mut moved, mut away) = (0.0f64, 0.0f64);
    if let Some((i0, th0)) = let_go(faulty) {
        for r in faulty.rows[i0..]
            .iter()
            .filter(|r| r.t_s >= start_s && r.t_s < end_s)
        {
            moved = moved.max((r.theta_rad - th0).abs());
            away = away.max(r.theta_rad.abs() - th0.abs());
        }
    }
    FaultMetrics {
        fault_steps: faulty.rows.iter().filter(|r| r.faults != 0).count(),
        peak_force_n: rows.iter().map(|r| r.hand_force_n.abs()).fold(0.0, f64::max),
        force_rms_error_n: rms(rows
            .iter()
            .filter(moving)
            .map(|r| r.hand_force_n - r.target_grip_n)),
        healthy_force_rms_error_n: rms(hrows
            .iter()
            .filter(moving)
            .map(|r| r.hand_force_n - r.target_grip_n)),
        tracking_rms_deg: rms(rows
            .iter()
            .filter(moving)
            .map(|r| (r.theta_rad - r.theta_cmd_rad).to_degrees())),
        current_cmd_min_a: rows.iter().map(|r| r.current_cmd_a).fold(f64::INFINITY, f64::min),
        current_cmd_max_a: rows
            .iter()
            .map(|r| r.current_cmd_a)
            .fold(f64::NEG_INFINITY, f64::max),
        current_applied_mean_a: rows.iter().map(|r| r.current_applied_a).sum::<f64>() / n,
        yield_mean_n: rows.iter().map(|r| r.yield_force_n).sum::<f64>() / n,
        hands_off_moved_rad: moved,
        hands_off_away_rad: away.max(0.0),
        moves_without_pilot: away > scn.task.recentre_band_rad,
    }
}

/// One row of the fault table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FaultRow {
    /// The feel system.
    pub system: FeelKind,
    /// The fault injected.
    pub fault: FaultKind,
    /// What the fault did.
    pub m: FaultMetrics,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phase_of_a_damper_force_leads_the_angle_by_90_degrees() {
        let f = 0.5;
        let w = 2.0 * std::f64::consts::PI * f;
        let rows: Vec<Row> = (0..4000)
            .map(|k| {
                let t = k as f64 * 1e-3;
                Row {
                    t_s: t,
                    theta_rad: 0.2 * (w * t).sin(),
                    hand_force_n: 3.0 * (w * t).cos(),
                    ..Row::default()
                }
            })
            .collect();
        assert!(
            (phase_lag_deg(&rows, f) + 90.0).abs() < 0.5,
            "{}",
            phase_lag_deg(&rows, f)
        );
        let spring: Vec<Row> = rows
            .iter()
            .map(|r| Row {
                hand_force_n: 40.0 * r.theta_rad,
                ..*r
            })
            .collect();
        assert!(phase_lag_deg(&spring, f).abs() < 0.5);
    }
}
