//! The extension point: a physical effect that composes with the base model. The force is assembled in
//! stages, `F = yield_n · direction + damping_n_s_per_m · v + extra_n`; effects apply in the order of their
//! [`EffectStage`], so `bingham+a+b` is `bingham+b+a`. A new effect is one `impl Effect` and one
//! `Registry::register` call (`docs/reference/effects.md`).

use super::params::{DataStats, ParamSpec};

/// Signals at one sample.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Inputs {
    /// Time since the test's start, s.
    pub t_s: f64,
    /// Piston displacement from mid-stroke, m (positive = extension).
    pub x_m: f64,
    /// Piston velocity, m/s.
    pub v_m_s: f64,
    /// Piston acceleration, m/s² (measured, derived, or from the multibody).
    pub a_m_s2: f64,
    /// Coil current command, A, as the DAQ set it (before the driver's saturation).
    pub current_cmd_a: f64,
}

/// The force assembled so far at one sample. Effects edit it in their `apply`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Stage {
    /// Effective excitation after the driver saturation, coil lag and fluid lag, in amperes.
    pub current_a: f64,
    /// Yield (Coulomb) force magnitude, N, ≥ 0.
    pub yield_n: f64,
    /// The part of `yield_n` the magnetic field produces (`fc_gain·|h|` in the base model), N, for effects
    /// that reshape it (saturation); effects that scale `yield_n` scale this part with it.
    pub yield_field_n: f64,
    /// Direction function in [-1, 1]: `sgn v` for the Bingham model.
    pub direction: f64,
    /// Post-yield viscous damping, N·s/m.
    pub damping_n_s_per_m: f64,
    /// Additive forces (position, inertia, …), N.
    pub extra_n: f64,
}

impl Stage {
    /// The total force on the piston, N, with the sign convention of the measurement format.
    pub fn force_n(&self, v_m_s: f64) -> f64 {
        self.yield_n * self.direction + self.damping_n_s_per_m * v_m_s + self.extra_n
    }
}

/// Where in the force assembly an effect acts; effects are applied in this order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum EffectStage {
    /// Reshapes the yield force as a function of current (replaces the linear map).
    YieldMap,
    /// Scales the yield force (temperature, wear).
    YieldScale,
    /// Replaces or shapes the direction function (pre-yield behaviour).
    Direction,
    /// Makes the yield force depend on the direction of motion.
    DirectionDependence,
    /// Changes the post-yield damping.
    Damping,
    /// Adds a force that does not go through the fluid's yield (springs, inertia).
    Additive,
}

/// Increment between this sample and the next, for advancing internal states.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Step {
    /// Step length, s.
    pub dt_s: f64,
    /// Displacement increment over the step, m (measured where available; `v dt` otherwise).
    pub dx_m: f64,
}

/// A physical effect that composes with the Bingham base model. `p` is this effect's slice of the parameter
/// vector, in [`Effect::params`] order; `s` its slice of the state vector (length [`Effect::n_states`]).
pub trait Effect: Send + Sync {
    /// Canonical name used in model specs (`bingham+NAME`).
    fn name(&self) -> &'static str;
    /// Physics, equation and literature source, in one paragraph.
    fn describe(&self) -> &'static str;
    /// Where in the force assembly it acts.
    fn stage(&self) -> EffectStage;
    /// Parameter declarations (unique names across all effects; prefix them with the effect's tag).
    fn params(&self) -> &'static [ParamSpec];
    /// Data-derived starting values for a fit, one per parameter, inside the bounds.
    fn initial_guess(&self, stats: &DataStats) -> Vec<f64>;
    /// A plausible, clearly visible strength of the effect for data with these statistics: the hidden truth
    /// of synthetic tests (`mrfeel mts --effects NAME`). Differs from [`Effect::initial_guess`] so a fit has
    /// something to find. Defaults to the initial guess for effects that do not say.
    fn typical_params(&self, stats: &DataStats) -> Vec<f64> {
        self.initial_guess(stats)
    }
    /// Number of internal states (hysteresis, temperature, …).
    fn n_states(&self) -> usize {
        0
    }
    /// Whether [`Effect::init_states`] or [`Effect::advance`] read `stage` or `force_n` (through which other
    /// parameters reach this effect's states). `true` is always right; `false` lets the fitter reuse recorded
    /// states for parameters no state depends on (`Model::state_params`), and is wrong if either is read.
    fn states_read_the_force(&self) -> bool {
        true
    }
    /// Which of this effect's parameters its states can depend on, one flag each in [`Effect::params`] order
    /// (read only when [`Effect::states_read_the_force`] is `false`). Every one is always right; leaving out
    /// one a state reads makes the fit's Jacobian wrong.
    fn params_the_states_read(&self) -> Vec<bool> {
        vec![true; self.params().len()]
    }
    /// Initial states at the first sample of a test.
    fn init_states(&self, _p: &[f64], _s: &mut [f64], _inp: &Inputs, _stage: &Stage) {}
    /// Edit the force assembly at this sample.
    fn apply(&self, p: &[f64], s: &[f64], inp: &Inputs, stage: &mut Stage);
    /// Advance internal states from this sample to the next, given the force this sample produced.
    fn advance(&self, _p: &[f64], _s: &mut [f64], _inp: &Inputs, _stage: &Stage, _force_n: f64, _step: Step) {
    }
    /// Words a diagnosis can use: how its absence shows in a residual (from the effect vocabulary).
    fn residual_signature(&self) -> &'static str {
        ""
    }
}
