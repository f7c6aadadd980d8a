//! Feel laws: the force the pilot should feel, as a function of stick deflection and velocity, expressed as
//! the force along +x on the piston (the load cell's sign convention, the measurement format's `f_n`).
//!
//! An MR damper is passive (`F·v ≥ 0`, Eq. 2), so a centring spring law `F = breakout·sgn(x) + k x` can be
//! tracked only moving **away** from centre (`x v > 0`); moving **back** the law would need the stick to push
//! the hand, so the controller commands 0 A. At rest the damper holds up to its yield force either way and
//! the direction the pilot pushes stands in for the velocity's ([`super::controller`]): the feel of a spring
//! with no stored energy, as a passive device must give.

/// Desired-force law.
#[derive(Debug, Clone, PartialEq)]
pub enum FeelLaw {
    /// `F = breakout_n·sgn(x) + gradient_n_per_m·x + damping_n_s_per_m·v`, clipped to ±`max_force_n`.
    Spring {
        /// Force at the first motion off centre, N.
        breakout_n: f64,
        /// Force per piston displacement, N/m.
        gradient_n_per_m: f64,
        /// Force per piston velocity, N·s/m.
        damping_n_s_per_m: f64,
        /// Largest force, N.
        max_force_n: f64,
    },
    /// A force magnitude stepping between `low_n` and `high_n` every `period_s` from `start_s`, with the
    /// sign of the velocity (always resisting): the response-time test signal.
    ForceSteps {
        /// Lower force magnitude, N.
        low_n: f64,
        /// Higher force magnitude, N.
        high_n: f64,
        /// Time of the first step, s.
        start_s: f64,
        /// Time between steps, s.
        period_s: f64,
    },
    /// A force set from outside the feel loop at every physics step (`feel.law = "aircraft"`: the
    /// aircraft's stick force, from its hinge moment or feel computer, mapped to the piston through the
    /// linkage), N along +x on the piston.
    Target {
        /// The force, N.
        force_n: f64,
    },
}

impl FeelLaw {
    /// Desired force at time `t_s`, deflection `x_m`, velocity `v_m_s`; `dir` is the direction of motion
    /// (or of the pilot's push at rest), used by laws that always resist. With `breakout_band_m` a spring's
    /// breakout ramps over ±this deflection instead of stepping at the centre (for a model that integrates it).
    pub fn force_n(&self, t_s: f64, x_m: f64, v_m_s: f64, dir: f64, breakout_band_m: Option<f64>) -> f64 {
        match *self {
            FeelLaw::Spring {
                breakout_n,
                gradient_n_per_m,
                damping_n_s_per_m,
                max_force_n,
            } => {
                let s = match breakout_band_m {
                    Some(band) => (x_m / band).clamp(-1.0, 1.0),
                    None => sgn(x_m),
                };
                let f = breakout_n * s + gradient_n_per_m * x_m + damping_n_s_per_m * v_m_s;
                f.clamp(-max_force_n, max_force_n)
            }
            FeelLaw::ForceSteps { .. } => self.step_level_n(t_s) * dir,
            FeelLaw::Target { force_n } => force_n,
        }
    }

    /// The force magnitude to hold the stick with at rest (where the direction of the next motion is
    /// unknown and the damper's yield force acts either way).
    pub(crate) fn holding_force_n(&self, t_s: f64, x_m: f64) -> f64 {
        match self {
            FeelLaw::Spring { .. } => self.force_n(t_s, x_m, 0.0, 0.0, None).abs(),
            FeelLaw::ForceSteps { .. } => self.step_level_n(t_s),
            FeelLaw::Target { force_n } => force_n.abs(),
        }
    }

    /// For `ForceSteps`, the magnitude at `t_s`; for other laws 0.
    pub(crate) fn step_level_n(&self, t_s: f64) -> f64 {
        match *self {
            FeelLaw::ForceSteps {
                low_n,
                high_n,
                start_s,
                period_s,
            } => {
                if t_s < start_s {
                    low_n
                } else if ((t_s - start_s) / period_s).floor() as i64 % 2 == 0 {
                    high_n
                } else {
                    low_n
                }
            }
            _ => 0.0,
        }
    }

    /// Step times of a `ForceSteps` law within `[0, t_end_s)`.
    pub(crate) fn step_times_s(&self, t_end_s: f64) -> Vec<f64> {
        match *self {
            FeelLaw::ForceSteps {
                start_s, period_s, ..
            } => (0..)
                .map(|k| start_s + k as f64 * period_s)
                .take_while(|&t| t < t_end_s)
                .collect(),
            _ => Vec::new(),
        }
    }
}

pub(crate) use crate::device::bingham::sgn;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spring_law_reaches_70_n_at_full_stroke_and_clips() {
        // 70 N at 2 in = 0.0508 m with 5 N breakout: gradient = 65/0.0508.
        let law = FeelLaw::Spring {
            breakout_n: 5.0,
            gradient_n_per_m: 65.0 / 0.0508,
            damping_n_s_per_m: 0.0,
            max_force_n: 70.0,
        };
        assert!((law.force_n(0.0, 0.0508, 0.0, sgn(0.0), None) - 70.0).abs() < 1e-9);
        assert!((law.force_n(0.0, -0.0508, 0.0, sgn(0.0), None) + 70.0).abs() < 1e-9);
        assert_eq!(law.force_n(0.0, 0.08, 0.0, sgn(0.0), None), 70.0);
        assert_eq!(law.force_n(0.0, 0.0, 0.3, sgn(0.3), None), 0.0);
    }

    #[test]
    fn a_breakout_band_ramps_the_breakout_and_leaves_the_law_beyond_it() {
        let law = FeelLaw::Spring {
            breakout_n: 5.0,
            gradient_n_per_m: 1000.0,
            damping_n_s_per_m: 20.0,
            max_force_n: 70.0,
        };
        let band = Some(0.001);
        // Half-way into the band: half the breakout, plus the gradient and damping terms.
        let f = law.force_n(0.0, 0.0005, 0.1, 1.0, band);
        assert!((f - (2.5 + 0.5 + 2.0)).abs() < 1e-12, "{f}");
        assert!((law.force_n(0.0, -0.0005, 0.0, -1.0, band) + 3.0).abs() < 1e-12);
        // Beyond the band, the stepped law exactly; at the centre no breakout either way.
        for x in [0.002, -0.03, 0.06] {
            assert_eq!(
                law.force_n(0.0, x, 0.1, 1.0, band),
                law.force_n(0.0, x, 0.1, 1.0, None)
            );
        }
        assert_eq!(law.force_n(0.0, 0.0, 0.0, 1.0, band), 0.0);
        // The stepped law jumps by twice the breakout across the centre.
        let jump = law.force_n(0.0, 1e-9, 0.0, 1.0, None) - law.force_n(0.0, -1e-9, 0.0, -1.0, None);
        assert!((jump - 10.0).abs() < 1e-5);
    }

    #[test]
    fn force_steps_alternate_and_follow_velocity_sign() {
        let law = FeelLaw::ForceSteps {
            low_n: 20.0,
            high_n: 50.0,
            start_s: 0.5,
            period_s: 0.3,
        };
        assert_eq!(law.force_n(0.4, 0.0, 0.1, sgn(0.1), None), 20.0);
        assert_eq!(law.force_n(0.6, 0.0, 0.1, sgn(0.1), None), 50.0);
        assert_eq!(law.force_n(0.9, 0.0, -0.1, sgn(-0.1), None), -20.0);
        let steps = law.step_times_s(1.2);
        assert_eq!(steps.len(), 3);
        assert!((steps[2] - 1.1).abs() < 1e-12);
    }
}
