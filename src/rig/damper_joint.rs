//! The MR damper as a force element on the piston's prismatic joint, computed every physics step by the
//! same [`crate::device::Damper`] the fitter integrates.
//!
//! The paper's Eq. (2), `Fd = Fc sgn(ẋ) + C0 ẋ`, is split by how stiff each part is:
//!
//! * the **yield part** `Fc sgn(ẋ)`, set-valued at `ẋ = 0`, would chatter or creep written explicitly: it is
//!   the multibody's implicit dry-friction constraint on the piston DoF (rapier's per-DoF `frictions`), which
//!   holds the piston below `Fc` and slides with exactly `Fc` above it, only removing energy;
//! * the **viscous part** `C0 ẋ` is the per-DoF implicit damping (backward Euler, dissipative);
//! * **additive forces** of effects (`extra_n`) are smooth and applied explicitly, as is `yield_n · direction`
//!   of a model whose direction is a state (an effect at [`EffectStage::Direction`], e.g. hysteresis).

use crate::device::{Damper, EffectStage, Inputs, Stage, Step};

/// What the rig applies on the piston DoF for one physics step.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct JointForce {
    /// Bound of the implicit dry-friction (yield) constraint, N (≥ 0).
    pub friction_n: f64,
    /// Implicit viscous coefficient, N·s/m (≥ 0).
    pub damping_n_s_per_m: f64,
    /// Explicit force the damper exerts on the piston along +x, N.
    pub explicit_on_piston_n: f64,
}

/// A [`Damper`] stepped as the piston joint's force element.
#[derive(Debug, Clone)]
pub struct DamperJoint {
    damper: Damper,
    implicit_yield: bool,
    inp: Inputs,
    stage: Stage,
}

impl DamperJoint {
    /// The joint of `damper`, at rest.
    pub fn new(damper: Damper) -> Self {
        let implicit_yield = !damper
            .model()
            .effects()
            .any(|e| e.stage() == EffectStage::Direction);
        Self {
            damper,
            implicit_yield,
            inp: Inputs::default(),
            stage: Stage::default(),
        }
    }

    /// True when the yield force is the implicit friction constraint (no direction-shaping effect).
    pub fn implicit_yield(&self) -> bool {
        self.implicit_yield
    }

    /// The damper.
    pub fn damper(&self) -> &Damper {
        &self.damper
    }

    /// The force assembly at the start of the step (Eq. 2 with Eq. 6's yield force and any effects).
    pub fn stage(&self) -> &Stage {
        &self.stage
    }

    /// Evaluate the device at the step's start and split it into implicit and explicit parts.
    pub(crate) fn begin_step(&mut self, inp: Inputs) -> JointForce {
        self.inp = inp;
        self.stage = self.damper.eval(&inp);
        let s = &self.stage;
        // The device's force has the sign of velocity (the force needed to move the piston, the paper's Fd);
        // the fluid pushes the piston the other way.
        let (friction_n, yield_explicit) = if self.implicit_yield {
            (s.yield_n.max(0.0), 0.0)
        } else {
            (0.0, s.yield_n * s.direction)
        };
        JointForce {
            friction_n,
            damping_n_s_per_m: s.damping_n_s_per_m.max(0.0),
            explicit_on_piston_n: -(yield_explicit + s.extra_n),
        }
    }

    /// Advance the device's states (coil and fluid lags, effect states) over the step.
    pub(crate) fn end_step(&mut self, dt_s: f64, dx_m: f64) {
        let (inp, stage) = (self.inp, self.stage);
        self.damper.advance(&inp, &stage, Step { dt_s, dx_m });
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::device::{DataStats, Effect, Model, ParamSpec, Registry};

    /// A smooth direction function (a pre-yield state in [-1, 1]), standing in for hysteresis.
    struct SmoothDirection;
    impl Effect for SmoothDirection {
        fn name(&self) -> &'static str {
            "smooth_direction"
        }
        fn describe(&self) -> &'static str {
            "test: direction = tanh(v / 0.01 m/s)"
        }
        fn stage(&self) -> EffectStage {
            EffectStage::Direction
        }
        fn params(&self) -> &'static [ParamSpec] {
            &[]
        }
        fn initial_guess(&self, _: &DataStats) -> Vec<f64> {
            Vec::new()
        }
        fn apply(&self, _: &[f64], _: &[f64], inp: &Inputs, stage: &mut Stage) {
            stage.direction = (inp.v_m_s / 0.01).tanh();
        }
    }

    fn damper(spec: &str) -> Damper {
        let mut reg = Registry::builtin();
        reg.register(SmoothDirection);
        let model = Arc::new(Model::from_spec(spec, &reg, 14.0).unwrap());
        // fc0 2 N, 5 N/A, C0 300 N·s/m, no lags.
        let mut p = vec![2.0, 5.0, 300.0, 0.0, 0.0];
        p.truncate(model.n_params());
        Damper::new(model, p).unwrap()
    }

    #[test]
    fn bingham_yield_is_the_implicit_friction_bound_and_c0_the_implicit_damping() {
        let mut j = DamperJoint::new(damper("bingham"));
        assert!(j.implicit_yield());
        // At rest (sgn 0 = 0): the bound is still the full yield force, 2 + 5·3 = 17 N.
        let f = j.begin_step(Inputs {
            v_m_s: 0.0,
            current_cmd_a: 3.0,
            ..Default::default()
        });
        assert!((f.friction_n - 17.0).abs() < 1e-12 && (f.damping_n_s_per_m - 300.0).abs() < 1e-12);
        assert_eq!(f.explicit_on_piston_n, 0.0);
    }

    #[test]
    fn a_state_direction_function_is_applied_explicitly_against_the_motion() {
        let mut j = DamperJoint::new(damper("bingham+smooth_direction"));
        assert!(!j.implicit_yield());
        let f = j.begin_step(Inputs {
            v_m_s: 0.01,
            current_cmd_a: 3.0,
            ..Default::default()
        });
        assert_eq!(f.friction_n, 0.0);
        // The fluid pushes the piston back: −17 · tanh(1).
        assert!((f.explicit_on_piston_n + 17.0 * 1f64.tanh()).abs() < 1e-12);
    }
}
