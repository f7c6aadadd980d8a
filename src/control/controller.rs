//! The MR feel loop (the paper's Section 6): the desired feel force against the load cell through a PID to
//! the coil current command, with the damper's passivity handled explicitly.
//!
//! Per DAQ tick, from the sensor sample only (never the true state):
//! 1. `F* = law(t, x, v)` ([`super::law`]: why half of each cycle cannot be tracked);
//! 2. direction `s = sgn v` when `|v| ≥ rest_speed`; at rest, the sign of the load cell when it exceeds
//!    `rest_force` (the pilot's push); none if the pilot does not push;
//! 3. `F*·s ≤ 0` (the law would need the stick to push): 0 A, integrator reset;
//! 4. at rest: the static (holding) current for `|F*|`, feedforward only, integrator frozen;
//! 5. moving against the law: `i = PID(|F*|, s·F_meas) + ff(|F*|, |v|)`, clipped to the driver's range.
//!
//! The feedforward is the inverse of the controller's model of the damper ([`ForceInverse`], never the
//! simulated plant). Its force arrives through the model's coil and fluid lags, so with feedforward the
//! PID's set point is `|F*|` through the same lags (a reference model): the feedback corrects only what
//! the feedforward gets wrong instead of winding up on the lag. A target set from outside the loop (the
//! aircraft's stick force) is led by its filtered rate times the lags and the sample period, so that its
//! force arrives on time.

use super::feel::{Spring, SpringElement};
use super::law::{sgn, FeelLaw};
use super::pid::Pid;
use crate::device::lag::advance_two_lags;
use crate::device::ForceInverse;
use crate::sensors::DaqSample;

/// What the loop decided at one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LoopMode {
    /// The law resists the motion: tracking.
    Tracking,
    /// The law would need the stick to push: 0 A.
    Released,
    /// The stick is (nearly) at rest: static holding current.
    Holding,
}

/// The loop's decision at one tick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlOutput {
    /// Force the feel law asks for, N.
    pub desired_force_n: f64,
    /// Coil current command, A.
    pub current_cmd_a: f64,
    /// What the loop is doing: tracking, released or holding.
    pub mode: LoopMode,
}

/// The hybrid (MR damper + centring spring on one joint): the spring gives part of the feel force, the
/// damper the rest on the way out; at rest and on the way back the coil gives only virtual viscous
/// damping, so the spring can re-centre the stick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hybrid {
    /// The spring on the joint.
    pub spring: SpringElement,
    /// Virtual viscous damping the coil gives at rest and on the way back, N·s/m.
    pub return_damping_n_s_per_m: f64,
}

/// The feel loop's controller; see the module documentation.
#[derive(Debug, Clone)]
pub struct FeelController {
    /// The desired-force law.
    pub law: FeelLaw,
    /// The force loop's PID.
    pub pid: Pid,
    /// The controller's model of the damper, when the loop uses its inverse as feedforward.
    pub feedforward: Option<ForceInverse>,
    /// Below this piston speed the stick is at rest, m/s.
    pub rest_speed_m_s: f64,
    /// At rest, load-cell forces below this are "not pushing", N.
    pub rest_force_n: f64,
    /// The spring in parallel with the damper, if the system is the hybrid.
    pub hybrid: Option<Hybrid>,
    last_mode: LoopMode,
    /// Reference-model states (coil, fluid) of the desired force magnitude, N.
    reference: (f64, f64),
    /// A target set from outside the loop (`FeelLaw::Target`): its last value, N, and its filtered rate,
    /// N/s, by which the feedforward leads it through the coil and fluid lags.
    target: (Option<f64>, f64),
}

/// Time constant of the filter on a target's rate, s.
const TARGET_RATE_FILTER_S: f64 = 0.01;

impl FeelController {
    /// A controller in the holding mode, no hybrid spring.
    pub fn new(
        law: FeelLaw,
        pid: Pid,
        feedforward: Option<ForceInverse>,
        rest_speed_m_s: f64,
        rest_force_n: f64,
    ) -> Self {
        Self {
            law,
            pid,
            feedforward,
            rest_speed_m_s,
            rest_force_n,
            hybrid: None,
            last_mode: LoopMode::Holding,
            reference: (0.0, 0.0),
            target: (None, 0.0),
        }
    }

    /// One DAQ tick: `t_s` is the controller's clock (the sample's time), `dt_s` the DAQ period.
    pub fn update(&mut self, t_s: f64, s: &DaqSample, dt_s: f64) -> ControlOutput {
        let (lo, hi) = (self.pid.gains.out_min, self.pid.gains.out_max);
        let moving = s.v_m_s.abs() >= self.rest_speed_m_s;
        // Direction of the motion, or at rest the direction the pilot pushes (the load cell's sign).
        let dir = if moving {
            sgn(s.v_m_s)
        } else if s.force_n.abs() > self.rest_force_n {
            sgn(s.force_n)
        } else {
            0.0
        };
        let desired = self.law.force_n(t_s, s.x_m, s.v_m_s, dir, None);
        if let FeelLaw::Target { .. } = self.law {
            let (last, rate) = &mut self.target;
            if let Some(f0) = *last {
                *rate += ((desired - f0) / dt_s - *rate) * dt_s / (TARGET_RATE_FILTER_S + dt_s);
            }
            *last = Some(desired);
        }
        if let Some(inv) = self.feedforward.as_mut() {
            inv.observe(s.sampled_t_s, s.x_m, s.v_m_s);
        }
        let inv = self.feedforward.as_ref();
        let hold = |force: f64| inv.map_or(0.0, |m| m.holding_current_a(force, dir, s.x_m));
        // Hybrid: the spring's share of the force (it resists displacement from centre) is not the damper's.
        let spring_n = self
            .hybrid
            .map_or(0.0, |h| h.spring.force_on_piston_n(s.x_m).abs());
        let damper_share = |f: f64| (f.abs() - spring_n).max(0.0);
        let hybrid_returning = self.hybrid.is_some() && (dir == 0.0 || desired * dir <= 0.0 || !moving);
        let (mode, current) = if hybrid_returning {
            // Never hold against the spring: a speed-proportional yield force only.
            self.pid.reset();
            let c = self.hybrid.map_or(0.0, |h| h.return_damping_n_s_per_m);
            let i = inv.map_or(0.0, |m| m.damping_current_a(c, s.v_m_s.abs(), s.x_m));
            (LoopMode::Released, i.clamp(lo, hi))
        } else if dir == 0.0 {
            let f = self.law.holding_force_n(t_s, s.x_m);
            (LoopMode::Holding, hold(f).clamp(lo, hi))
        } else if desired * dir <= 0.0 {
            self.pid.reset();
            (LoopMode::Released, lo)
        } else if !moving {
            (LoopMode::Holding, hold(desired.abs()).clamp(lo, hi))
        } else {
            let measured = dir * s.force_n;
            if self.last_mode != LoopMode::Tracking {
                self.pid.restart_derivative();
                self.reference = (measured, measured);
            }
            // A target's force leads through the lags (and the sample's delay) by its rate; the reference
            // model then follows the target itself.
            let lead = |m: &ForceInverse| {
                let (te_s, tm_s) = m.lags_s();
                (desired.abs() + dir * self.target.1 * (te_s + tm_s + dt_s)).max(0.0)
            };
            let setpoint = match inv {
                Some(m) => {
                    let (te_s, tm_s) = m.lags_s();
                    self.reference =
                        advance_two_lags(self.reference.0, self.reference.1, lead(m), te_s, tm_s, dt_s);
                    self.reference.1
                }
                None => desired.abs(),
            };
            let ff = inv.map_or(0.0, |m| {
                m.current_a(damper_share(lead(m)), dir, s.v_m_s.abs(), s.x_m, false)
            });
            let u = self.pid.update(setpoint, measured, ff, dt_s);
            (LoopMode::Tracking, u)
        };
        if let Some(m) = self.feedforward.as_mut() {
            m.commanded(current);
        }
        self.last_mode = mode;
        ControlOutput {
            desired_force_n: desired,
            current_cmd_a: current,
            mode,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::pid::{tests::gains, AntiWindup};
    use super::*;

    fn ctl() -> FeelController {
        let law = FeelLaw::Spring {
            breakout_n: 5.0,
            gradient_n_per_m: 1000.0,
            damping_n_s_per_m: 0.0,
            max_force_n: 70.0,
        };
        let pid = Pid::new(gains(AntiWindup::Clamping));
        // The controller's model: fc0 1 N, 5 N/A, C0 20 N·s/m.
        let text = "model = \"bingham\"\n[params]\nfc0_n = 1.0\nfc_gain_n_per_a = 5.0\n\
                    c0_n_s_per_m = 20.0\nte_s = 0.01\ntm_s = 0.008\n";
        let device = crate::device::DeviceConfig::from_toml(
            text,
            std::path::Path::new("controller.toml"),
            &crate::device::Registry::builtin(),
        )
        .unwrap();
        let ff = ForceInverse::new(&device).unwrap();
        FeelController::new(law, pid, Some(ff), 0.002, 1.0)
    }

    fn sample(force_n: f64, x_m: f64, v_m_s: f64) -> DaqSample {
        DaqSample {
            sampled_t_s: 0.0,
            force_n,
            x_m,
            v_m_s,
        }
    }

    #[test]
    fn returning_to_centre_commands_zero_current() {
        // x > 0 moving back (v < 0): the spring law asks for +F, the damper can only give -F.
        let mut c = ctl();
        let out = c.update(0.0, &sample(-3.0, 0.03, -0.05), 1e-3);
        assert_eq!(out.mode, LoopMode::Released);
        assert_eq!(out.current_cmd_a, 0.0);
    }

    #[test]
    fn moving_away_tracks_with_feedforward_from_the_models_inverse() {
        let mut c = ctl();
        // x = 0.03 m: F* = 5 + 30 = 35 N; measured exactly 35 N: output = feedforward (35-1-20·0.05)/5 = 6.6 A.
        let out = c.update(0.0, &sample(35.0, 0.03, 0.05), 1e-3);
        assert_eq!(out.mode, LoopMode::Tracking);
        assert!((out.current_cmd_a - 6.6).abs() < 1e-9, "{}", out.current_cmd_a);
    }

    #[test]
    fn at_rest_holds_with_the_static_current() {
        let mut c = ctl();
        // x = -0.02 m: F* = -25 N. The pilot pushes outwards (load cell -2 N): hold with (25 - 1)/5 = 4.8 A.
        let out = c.update(0.0, &sample(-2.0, -0.02, 0.0005), 1e-3);
        assert_eq!(out.mode, LoopMode::Holding);
        assert!((out.current_cmd_a - 4.8).abs() < 1e-9);
        // Not pushing (0.5 N < rest force): hold the same.
        let out = c.update(0.0, &sample(0.5, -0.02, 0.0), 1e-3);
        assert!((out.current_cmd_a - 4.8).abs() < 1e-9);
        // Pushing back towards centre (+2 N) from rest: release, so the stick can return.
        let out = c.update(0.0, &sample(2.0, -0.02, 0.0), 1e-3);
        assert_eq!(out.mode, LoopMode::Released);
        assert_eq!(out.current_cmd_a, 0.0);
    }
}
