//! A discrete PID with output limits and anti-windup, as in the paper's LabVIEW loop (Section 6): the set
//! point is the desired feel force, the measurement the load cell, the output the coil current command.
//!
//! Form (parallel, derivative on the measurement so a set-point step does not kick the output):
//! `u = ff + kp e + I + kd d/dt(-y)_filtered`, clipped to `[out_min, out_max]`, with
//! `I += ki e T` (forward Euler) guarded by the chosen [`AntiWindup`].

/// How the integrator is kept from winding up while the output saturates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AntiWindup {
    /// No protection (for comparison only).
    None,
    /// Conditional integration: the integrator stops while the output is saturated and the error would
    /// drive it further into saturation.
    Clamping,
    /// Back-calculation: the integrator is pulled back by `(u_sat - u) / tracking_time_s`.
    BackCalculation {
        /// Time constant of the pull-back, s.
        tracking_time_s: f64,
    },
}

/// The gains, output limits and anti-windup of a [`Pid`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PidGains {
    /// Output per unit error (A/N for the feel loop).
    pub kp: f64,
    /// Output per unit error-time (A/(N·s)).
    pub ki: f64,
    /// Output per unit error rate (A·s/N).
    pub kd: f64,
    /// Time constant of the first-order filter on the derivative, s (0: unfiltered).
    pub derivative_filter_s: f64,
    /// Lowest output (A for the feel loop).
    pub out_min: f64,
    /// Highest output (A for the feel loop).
    pub out_max: f64,
    /// How the integrator is kept from winding up while the output is clipped.
    pub anti_windup: AntiWindup,
}

/// A PID controller with a filtered derivative, output limits and anti-windup.
#[derive(Debug, Clone)]
pub struct Pid {
    /// Its gains.
    pub gains: PidGains,
    integral: f64,
    last_meas: Option<f64>,
    deriv: f64,
    /// Whether the last output was clipped.
    pub saturated: bool,
}

impl Pid {
    /// A controller of `gains` at rest (zero integral, no previous measurement).
    pub fn new(gains: PidGains) -> Self {
        Self {
            gains,
            integral: 0.0,
            last_meas: None,
            deriv: 0.0,
            saturated: false,
        }
    }

    /// Back to rest: zero integral, no previous measurement.
    pub fn reset(&mut self) {
        self.integral = 0.0;
        self.restart_derivative();
        self.saturated = false;
    }

    /// Forget the derivative's memory (after the loop was idle) without touching the integrator.
    pub(crate) fn restart_derivative(&mut self) {
        self.last_meas = None;
        self.deriv = 0.0;
    }

    /// One controller step of length `dt_s` with a feedforward term; returns the clipped output.
    pub fn update(&mut self, setpoint: f64, measurement: f64, feedforward: f64, dt_s: f64) -> f64 {
        let g = self.gains;
        let e = setpoint - measurement;
        if let Some(y0) = self.last_meas {
            let raw = -(measurement - y0) / dt_s;
            let a = if g.derivative_filter_s > 0.0 {
                (-dt_s / g.derivative_filter_s).exp()
            } else {
                0.0
            };
            self.deriv = a * self.deriv + (1.0 - a) * raw;
        }
        self.last_meas = Some(measurement);
        let unclipped_before = feedforward + g.kp * e + self.integral + g.kd * self.deriv;
        let di = g.ki * e * dt_s;
        match g.anti_windup {
            AntiWindup::None => self.integral += di,
            AntiWindup::Clamping => {
                let pushing_up = unclipped_before >= g.out_max && di > 0.0;
                let pushing_down = unclipped_before <= g.out_min && di < 0.0;
                if !(pushing_up || pushing_down) {
                    self.integral += di;
                }
            }
            AntiWindup::BackCalculation { tracking_time_s } => {
                let sat = unclipped_before.clamp(g.out_min, g.out_max);
                self.integral += di + (sat - unclipped_before) * dt_s / tracking_time_s.max(dt_s);
            }
        }
        let u = feedforward + g.kp * e + self.integral + g.kd * self.deriv;
        let out = u.clamp(g.out_min, g.out_max);
        self.saturated = out != u;
        out
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// The feel loop's gains in the tests: 0.05 A/N, 2 A/(N·s), no derivative, 0 to 14 A.
    pub(crate) fn gains(aw: AntiWindup) -> PidGains {
        PidGains {
            kp: 0.05,
            ki: 2.0,
            kd: 0.0,
            derivative_filter_s: 0.0,
            out_min: 0.0,
            out_max: 14.0,
            anti_windup: aw,
        }
    }

    /// A first-order plant like the damper's yield force: y' = (5 N/A · u - y) / 20 ms.
    fn run(aw: AntiWindup, sp: impl Fn(f64) -> f64, t_end: f64) -> Vec<(f64, f64, f64)> {
        let dt = 1e-3;
        let mut pid = Pid::new(gains(aw));
        let mut y = 0.0;
        let mut out = Vec::new();
        let n = (t_end / dt) as usize;
        for k in 0..n {
            let t = k as f64 * dt;
            let r = sp(t);
            let u = pid.update(r, y, 0.0, dt);
            y += (5.0 * u - y) * dt / 0.02;
            out.push((t, r, y));
        }
        out
    }

    #[test]
    fn integral_action_removes_the_steady_state_error() {
        let tr = run(AntiWindup::Clamping, |_| 40.0, 2.0);
        let (_, r, y) = tr[tr.len() - 1];
        assert!((y - r).abs() < 0.01 * r, "y {y}");
    }

    #[test]
    fn output_stays_within_0_to_14_a() {
        let dt = 1e-3;
        let mut pid = Pid::new(gains(AntiWindup::None));
        for k in 0..2000 {
            let sp = if k < 1000 { 500.0 } else { -500.0 };
            let u = pid.update(sp, 0.0, 0.0, dt);
            assert!((0.0..=14.0).contains(&u));
        }
    }

    /// Set point `first` for 1 s, then 30 N: time from the switch until the output stays within 5 % of
    /// 30 N.
    fn recovery_s(aw: AntiWindup, first: f64) -> f64 {
        let tr = run(aw, |t| if t < 1.0 { first } else { 30.0 }, 4.0);
        let settled = tr
            .iter()
            .rev()
            .take_while(|(t, r, y)| *t < 1.0 || (y - r).abs() <= 0.05 * r)
            .last()
            .map(|(t, _, _)| *t)
            .unwrap_or(f64::INFINITY);
        settled - 1.0
    }

    #[test]
    fn anti_windup_recovers_quickly_after_saturation() {
        // Reference: the same loop stepping down from 65 N, reachable without saturating (13 A).
        let own = recovery_s(AntiWindup::None, 65.0);
        // 100 N is beyond the 70 N reachable at 14 A: the output saturates for 1 s.
        let none = recovery_s(AntiWindup::None, 100.0);
        let clamp = recovery_s(AntiWindup::Clamping, 100.0);
        let back = recovery_s(
            AntiWindup::BackCalculation {
                tracking_time_s: 0.02,
            },
            100.0,
        );
        // Without protection the integrator gains ≈ ki·(100 − 70)·1 s = 60 A of excess that unwinds at
        // ki·(30 − 70) = −80 A/s: ≈ 0.75 s lost. With protection the loop recovers in about its own time.
        assert!(clamp < 1.2 * own + 0.01, "clamping {clamp} s vs own step {own} s");
        assert!(
            back < 1.2 * own + 0.01,
            "back-calculation {back} s vs own step {own} s"
        );
        assert!(
            none > 0.6 + own,
            "without anti-windup {none} s vs own step {own} s"
        );
    }

    #[test]
    fn derivative_on_measurement_does_not_kick_on_set_point_steps() {
        let mut g = gains(AntiWindup::Clamping);
        g.kd = 0.01;
        g.ki = 0.0;
        let mut pid = Pid::new(g);
        let u0 = pid.update(10.0, 5.0, 0.0, 1e-3);
        let u1 = pid.update(60.0, 5.0, 0.0, 1e-3);
        // Only the proportional term moves: Δu = kp·Δr.
        assert!((u1 - u0 - 0.05 * 50.0).abs() < 1e-12);
    }
}
