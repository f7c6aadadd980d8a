//! A composed model: the Bingham base plus named effects, with its parameter and state layout.

use std::collections::BTreeMap;
use std::sync::Arc;

use super::effect::{Effect, EffectStage, Inputs, Stage, Step};
use super::lag::DecayMemo;
use super::params::{DataStats, ParamSpec};
use super::DeviceError;
use super::{bingham, spencer};

/// The seed paper's base model, the default.
pub const BASE: &str = "bingham";

/// The base model a spec starts from: the seed paper's Bingham model with its two lags, or the modified
/// Bouc–Wen model of Spencer et al. (1997), the field's standard ([`spencer`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum Base {
    /// The seed paper's Bingham model with coil and fluid lags.
    #[default]
    Bingham,
    /// The modified Bouc–Wen model of Spencer et al. (1997).
    Spencer,
}

impl Base {
    /// Every base, in the order listed in messages.
    pub const ALL: [Base; 2] = [Base::Bingham, Base::Spencer];

    /// `bingham` for the Bingham base, `spencer` for the Spencer base.
    fn pick<T>(self, bingham: T, spencer: T) -> T {
        match self {
            Base::Bingham => bingham,
            Base::Spencer => spencer,
        }
    }

    /// The base's name in a model spec (`bingham`, `spencer`).
    pub fn name(self) -> &'static str {
        self.pick(BASE, "spencer")
    }

    /// The base named `name`, if any.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|b| b.name() == name)
    }

    /// Parameter declarations, in vector order (the first parameters of every model of this base).
    pub fn params(self) -> &'static [ParamSpec] {
        self.pick(&bingham::PARAMS, &spencer::PARAMS)
    }

    pub(crate) fn n_states(self) -> usize {
        self.pick(bingham::N_STATES, spencer::N_STATES)
    }

    /// Parameters the base's states depend on.
    pub(crate) fn state_params(self) -> &'static [usize] {
        self.pick(&bingham::STATE_PARAMS, &spencer::STATE_PARAMS)
    }

    /// Parameters that act only where the current command changes (the lags' time constants).
    pub(crate) fn lag_params(self) -> &'static [usize] {
        self.pick(&bingham::STATE_PARAMS, &spencer::LAG_PARAMS)
    }

    /// Parameters the force is linear in (a fit's warm start solves for them first).
    pub(crate) fn linear_gains(self) -> &'static [usize] {
        self.pick(&bingham::LINEAR_GAINS, &spencer::LINEAR_GAINS)
    }

    /// Whether an effect acting at `stage` composes with this base: the Spencer model has its own
    /// pre-yield (Bouc–Wen) state, so an effect that replaces the direction function does not.
    pub(crate) fn admits(self, stage: EffectStage) -> bool {
        !(self == Base::Spencer && stage == EffectStage::Direction)
    }

    fn init_states(self, p: &[f64], s: &mut [f64], first: &Inputs, limit_a: f64) {
        match self {
            Base::Bingham => bingham::init_states(s, first.current_cmd_a, limit_a),
            Base::Spencer => spencer::init_states(p, s, first, limit_a),
        }
    }

    fn stage(self, p: &[f64], s: &[f64], inp: &Inputs) -> Stage {
        match self {
            Base::Bingham => bingham::stage(p, s, inp),
            Base::Spencer => spencer::stage(p, s, inp),
        }
    }

    fn advance(self, p: &[f64], s: &mut [f64], inp: &Inputs, limit_a: f64, step: Step, memo: &mut DecayMemo) {
        match self {
            Base::Bingham => bingham::advance_in(p, s, inp.current_cmd_a, limit_a, step.dt_s, memo),
            Base::Spencer => spencer::advance(p, s, inp, limit_a, step),
        }
    }

    fn initial_guess(self, stats: &DataStats) -> Vec<f64> {
        self.pick::<fn(&DataStats) -> Vec<f64>>(bingham::initial_guess, spencer::initial_guess)(stats)
    }
}

/// The driver saturation the paper set (Section 4): 14 A.
pub const PAPER_CURRENT_LIMIT_A: f64 = 14.0;

/// The largest damper force, N, a model may give anywhere in [`PROBE_ENVELOPE`]: not a physical limit but
/// the one where numbers stop working. The sum of squared forces (or residuals) over 10⁸ samples of ±10¹⁵⁰ N
/// is 10³⁰⁸, still below `f64::MAX` (1.8·10³⁰⁸); beyond it error figures become infinite and their ratios NaN.
pub(crate) const FORCE_LIMIT_N: f64 = 1e150;

/// Where [`Model::unusable_force`] looks: piston speed, displacement from mid-stroke and acceleration up to
/// (100 m/s, 10 m, 10⁴ m/s²), each far past any damper's (the paper's device: ±2 in of stroke, tested at
/// 0.08 m/s), at zero current and at the driver's saturation either way.
pub(crate) const PROBE_ENVELOPE: (f64, f64, f64) = (100.0, 10.0, 1e4);

/// Effects that can be named in a model spec. [`Registry::builtin`] holds the canonical vocabulary.
#[derive(Clone, Default)]
pub struct Registry {
    effects: BTreeMap<&'static str, Arc<dyn Effect>>,
}

impl Registry {
    /// An empty registry (base model only).
    pub fn empty() -> Self {
        Self::default()
    }

    /// The canonical effect vocabulary of the model-discovery contract.
    pub fn builtin() -> Self {
        let mut r = Self::empty();
        super::effects::register_builtin(&mut r);
        r
    }

    /// Add an effect; a later registration under the same name replaces the earlier one.
    pub fn register<E: Effect + 'static>(&mut self, effect: E) -> &mut Self {
        self.effects.insert(effect.name(), Arc::new(effect));
        self
    }

    /// The effect registered as `name`.
    pub fn get(&self, name: &str) -> Option<Arc<dyn Effect>> {
        self.effects.get(name).cloned()
    }

    /// Registered effect names, sorted.
    pub fn names(&self) -> Vec<&'static str> {
        self.effects.keys().copied().collect()
    }
}

impl std::fmt::Debug for Registry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Registry")
            .field("effects", &self.names())
            .finish()
    }
}

/// A parsed model spec: a base (`bingham`, `spencer`) and effects, `bingham+effect+effect`.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ModelSpec {
    /// The base model.
    pub base: Base,
    /// The effects' names, in spec order.
    pub effects: Vec<String>,
}

impl ModelSpec {
    /// Parse `bingham+hysteresis+asymmetry`. Names are checked against the registry when a [`Model`] is built.
    pub fn parse(spec: &str) -> Result<Self, DeviceError> {
        let mut parts = spec.split('+').map(str::trim);
        let base_name = parts.next().unwrap_or_default();
        let base = Base::from_name(base_name).ok_or_else(|| DeviceError::UnknownBase {
            spec: spec.to_string(),
            base: base_name.to_string(),
        })?;
        let mut effects: Vec<String> = Vec::new();
        for p in parts {
            if p.is_empty() {
                return Err(DeviceError::bad_spec(spec, "empty effect name"));
            }
            if effects.iter().any(|e| e == p) {
                return Err(DeviceError::bad_spec(spec, format!("effect `{p}` named twice")));
            }
            effects.push(p.to_string());
        }
        Ok(Self { base, effects })
    }

    /// The spec with one more effect.
    pub fn with(&self, effect: &str) -> Self {
        let mut spec = self.clone();
        spec.effects.push(effect.to_string());
        spec
    }

    /// Whether the spec names `effect`.
    pub fn has(&self, effect: &str) -> bool {
        self.effects.iter().any(|e| e == effect)
    }
}

impl std::fmt::Display for ModelSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.base.name())?;
        for e in &self.effects {
            write!(f, "+{e}")?;
        }
        Ok(())
    }
}

struct Slot {
    effect: Arc<dyn Effect>,
    /// The effect's [`Effect::stage`].
    stage: EffectStage,
    params: std::ops::Range<usize>,
    states: std::ops::Range<usize>,
}

/// The base model plus effects, with the parameter layout `[base params, effect params in spec order]`
/// and the state layout `[coil current, fluid excitation, effect states in spec order]`.
pub struct Model {
    spec: ModelSpec,
    slots: Vec<Slot>,
    /// Indices into `slots` in the order of application (by stage, then spec order).
    apply_order: Vec<usize>,
    param_specs: Vec<ParamSpec>,
    n_states: usize,
    /// Driver saturation of the current command, A (a property of the driver, not fitted).
    pub current_limit_a: f64,
}

impl std::fmt::Debug for Model {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Model")
            .field("spec", &self.spec.to_string())
            .finish()
    }
}

impl Model {
    /// Build a model from a spec; unknown effects are an error that lists the known ones.
    pub fn new(spec: &ModelSpec, registry: &Registry, current_limit_a: f64) -> Result<Self, DeviceError> {
        if !(current_limit_a.is_finite() && current_limit_a > 0.0) {
            let why = format!(
                "current limit {current_limit_a} A: the driver's saturation limits the command to \
                 ±current_limit_a, a positive, finite number of amperes"
            );
            return Err(DeviceError::bad_spec(spec, why));
        }
        let base = spec.base;
        let mut param_specs: Vec<ParamSpec> = base.params().to_vec();
        let mut n_states = base.n_states();
        let mut slots = Vec::new();
        for name in &spec.effects {
            let effect = registry.get(name).ok_or_else(|| DeviceError::UnknownEffect {
                name: name.clone(),
                known: registry.names().join(", "),
            })?;
            if !base.admits(effect.stage()) {
                let why = format!(
                    "`{name}` replaces the direction of the yield force, which the `{}` base takes from its \
                     own Bouc–Wen state: the two do not compose",
                    base.name()
                );
                return Err(DeviceError::bad_spec(spec, why));
            }
            let p0 = param_specs.len();
            for ps in effect.params() {
                if param_specs.iter().any(|q| q.name == ps.name) {
                    let p = ps.name;
                    let why = format!("parameter `{p}` of `{name}` clashes with another element's");
                    return Err(DeviceError::bad_spec(spec, why));
                }
                param_specs.push(ps.clone());
            }
            let s0 = n_states;
            n_states += effect.n_states();
            slots.push(Slot {
                stage: effect.stage(),
                params: p0..param_specs.len(),
                states: s0..n_states,
                effect,
            });
        }
        let mut apply_order: Vec<usize> = (0..slots.len()).collect();
        apply_order.sort_by_key(|&k| slots[k].stage);
        Ok(Self {
            spec: spec.clone(),
            slots,
            apply_order,
            param_specs,
            n_states,
            current_limit_a,
        })
    }

    /// Parse and build in one call.
    pub fn from_spec(spec: &str, registry: &Registry, current_limit_a: f64) -> Result<Self, DeviceError> {
        Self::new(&ModelSpec::parse(spec)?, registry, current_limit_a)
    }

    /// The spec the model was built from.
    pub fn spec(&self) -> &ModelSpec {
        &self.spec
    }

    /// The base model.
    pub fn base(&self) -> Base {
        self.spec.base
    }

    /// Indices of the base's parameters that act only where the current command changes.
    pub(crate) fn lag_params(&self) -> &'static [usize] {
        self.spec.base.lag_params()
    }

    /// Indices of the base's parameters the force is linear in.
    pub(crate) fn linear_gains(&self) -> &'static [usize] {
        self.spec.base.linear_gains()
    }

    /// The model spec as text, `bingham+effect+…`.
    pub fn name(&self) -> String {
        self.spec.to_string()
    }

    /// Parameter declarations, in vector order.
    pub fn param_specs(&self) -> &[ParamSpec] {
        &self.param_specs
    }

    /// Number of parameters.
    pub fn n_params(&self) -> usize {
        self.param_specs.len()
    }

    pub(crate) fn n_states(&self) -> usize {
        self.n_states
    }

    /// Index of a parameter by name.
    pub fn param_index(&self, name: &str) -> Option<usize> {
        self.param_specs.iter().position(|p| p.name == name)
    }

    /// The effects in spec order.
    pub fn effects(&self) -> impl Iterator<Item = &Arc<dyn Effect>> {
        self.slots.iter().map(|s| &s.effect)
    }

    /// Data-derived starting values for every parameter, clamped into the bounds.
    pub fn initial_guess(&self, stats: &DataStats) -> Vec<f64> {
        let mut p = self.spec.base.initial_guess(stats);
        for slot in &self.slots {
            let g = slot.effect.initial_guess(stats);
            debug_assert_eq!(
                g.len(),
                slot.params.len(),
                "{} initial guess length",
                slot.effect.name()
            );
            p.extend(g);
        }
        self.clamped(&p)
    }

    /// `p` clamped into the parameters' bounds.
    fn clamped(&self, p: &[f64]) -> Vec<f64> {
        p.iter()
            .zip(&self.param_specs)
            .map(|(v, s)| s.clamp(*v))
            .collect()
    }

    /// Base parameters followed by each effect's [`Effect::typical_params`], clamped into the bounds: the hidden
    /// truth of a synthetic test of this model. `base` holds the base model's parameters.
    pub fn typical_params(&self, base: &[f64], stats: &DataStats) -> Result<Vec<f64>, DeviceError> {
        let n_base = self.spec.base.params().len();
        if base.len() != n_base {
            let n = base.len();
            let why = format!("{n} base parameter values for {n_base} base parameters");
            return Err(DeviceError::bad_spec(self.name(), why));
        }
        let mut p = base.to_vec();
        for slot in &self.slots {
            let g = slot.effect.typical_params(stats);
            if g.len() != slot.params.len() {
                let (name, got, n) = (slot.effect.name(), g.len(), slot.params.len());
                let why = format!("effect `{name}` gives {got} typical values for {n} parameters");
                return Err(DeviceError::bad_spec(self.name(), why));
            }
            p.extend(g);
        }
        Ok(self.clamped(&p))
    }

    /// Whether the force is a usable number everywhere a damper may be driven: the first inputs of
    /// [`PROBE_ENVELOPE`] (each state at rest, as at a test's first sample) where the force is not finite or
    /// exceeds [`FORCE_LIMIT_N`], with that force; `None` when there is none. Parameters inside their bounds
    /// can still be absurd (a damping of 10³⁰⁰ N·s/m): this is what keeps them from giving infinite or NaN
    /// error figures.
    pub(crate) fn unusable_force(&self, p: &[f64]) -> Option<(Inputs, f64)> {
        let (v_max, x_max, a_max) = PROBE_ENVELOPE;
        let limit = self.current_limit_a;
        let speeds = [0.0, 1e-3, -1e-3, 1.0, -1.0, v_max, -v_max];
        for i in [0.0, limit, -limit] {
            for v in speeds {
                for x in [0.0, x_max, -x_max] {
                    for a in [0.0, a_max, -a_max] {
                        let inp = Inputs {
                            t_s: 0.0,
                            x_m: x,
                            v_m_s: v,
                            a_m_s2: a,
                            current_cmd_a: i,
                        };
                        let s = self.init_state(p, &inp);
                        let f = self.eval(p, &s, &inp).force_n(v);
                        if f.is_nan() || f.abs() > FORCE_LIMIT_N {
                            return Some((inp, f));
                        }
                    }
                }
            }
        }
        None
    }

    /// States at the first sample of a test: lags at rest for the first command, effects initialised.
    pub(crate) fn init_state(&self, p: &[f64], first: &Inputs) -> Vec<f64> {
        let mut s = vec![0.0; self.n_states];
        let base = self.spec.base;
        base.init_states(p, &mut s, first, self.current_limit_a);
        let stage = base.stage(p, &s, first);
        for slot in &self.slots {
            let states = &mut s[slot.states.clone()];
            slot.effect
                .init_states(&p[slot.params.clone()], states, first, &stage);
        }
        s
    }

    /// The force assembly at one sample (base, then each effect in stage order). A loop of its own, not one
    /// shared with `eval_yielded` through a stage filter: the feel loop's step ran 2 % slower so
    /// (`cargo bench --bench sim -- full_loop_1000_steps`).
    pub fn eval(&self, p: &[f64], s: &[f64], inp: &Inputs) -> Stage {
        let mut stage = self.spec.base.stage(p, s, inp);
        for &k in &self.apply_order {
            let slot = &self.slots[k];
            slot.effect
                .apply(&p[slot.params.clone()], &s[slot.states.clone()], inp, &mut stage);
        }
        stage
    }

    /// [`Model::eval`] with the direction function set to `direction` (the fluid fully yielded that way):
    /// the effects that shape the direction ([`EffectStage::Direction`]) are skipped. A controller's
    /// holding force: the damper holds up to its yield force.
    pub(crate) fn eval_yielded(&self, p: &[f64], s: &[f64], inp: &Inputs, direction: f64) -> Stage {
        let mut stage = Stage {
            direction,
            ..bingham::stage(p, s, inp)
        };
        for slot in self.apply_order.iter().map(|&k| &self.slots[k]) {
            if slot.stage != EffectStage::Direction {
                slot.effect
                    .apply(&p[slot.params.clone()], &s[slot.states.clone()], inp, &mut stage);
            }
        }
        stage
    }

    /// Whether any effect keeps a state of its own (beyond the base model's coil and fluid lags).
    pub(crate) fn has_effect_states(&self) -> bool {
        self.n_states > bingham::N_STATES
    }

    /// Advance every state from this sample to the next.
    pub fn advance(&self, p: &[f64], s: &mut [f64], inp: &Inputs, stage: &Stage, force_n: f64, step: Step) {
        self.advance_in(p, s, inp, stage, force_n, step, &mut DecayMemo::default());
    }

    /// [`Model::advance`] over `step` from `inp` with the force the states give there.
    pub(crate) fn step(&self, p: &[f64], s: &mut [f64], inp: &Inputs, step: Step) {
        let stage = self.eval(p, s, inp);
        self.advance(p, s, inp, &stage, stage.force_n(inp.v_m_s), step);
    }

    /// [`Model::advance`] with the base's lag decays from `memo` (an integration's).
    #[allow(clippy::too_many_arguments)]
    fn advance_in(
        &self,
        p: &[f64],
        s: &mut [f64],
        inp: &Inputs,
        stage: &Stage,
        force_n: f64,
        step: Step,
        memo: &mut DecayMemo,
    ) {
        for slot in self.apply_order.iter().map(|&k| &self.slots[k]) {
            slot.effect.advance(
                &p[slot.params.clone()],
                &mut s[slot.states.clone()],
                inp,
                stage,
                force_n,
                step,
            );
        }
        self.spec
            .base
            .advance(p, s, inp, self.current_limit_a, step, memo);
    }

    /// Integrate one test from its own start and write the force at every sample into `out`.
    pub(crate) fn simulate_into(&self, p: &[f64], inputs: &[Inputs], out: &mut [f64]) {
        self.integrate(p, inputs, out, None);
    }

    /// [`Model::simulate_into`], also keeping the state at every sample in `states` (cleared first;
    /// [`Model::n_states`] values a sample, sample after sample) for [`Model::forces_on_states`].
    pub(crate) fn simulate_recording(
        &self,
        p: &[f64],
        inputs: &[Inputs],
        out: &mut [f64],
        states: &mut Vec<f64>,
    ) {
        states.clear();
        states.reserve(inputs.len() * self.n_states);
        self.integrate(p, inputs, out, Some(states));
    }

    /// Which parameters the states can depend on ([`Effect::states_read_the_force`]): the lags' time
    /// constants and the parameters the effects' states read ([`Effect::params_the_states_read`]), or every parameter when one of those effects
    /// reads the force. A parameter marked `false` acts on the force only through the sample's force
    /// assembly, so [`Model::forces_on_states`] gives the force it makes without a new integration.
    pub(crate) fn state_params(&self) -> Vec<bool> {
        let stateful = || self.slots.iter().filter(|s| !s.states.is_empty());
        if stateful().any(|s| s.effect.states_read_the_force()) {
            return vec![true; self.n_params()];
        }
        let mut out = vec![false; self.n_params()];
        for &k in self.spec.base.state_params() {
            out[k] = true;
        }
        for slot in stateful() {
            let read = slot.effect.params_the_states_read();
            for (k, r) in slot.params.clone().zip(read) {
                out[k] |= r;
            }
        }
        out
    }

    /// The force at every sample assembled from states kept by [`Model::simulate_recording`]: for parameters
    /// that differ from the recording's only where [`Model::state_params`] is `false`, the same numbers as
    /// [`Model::simulate_into`], at the cost of the force assembly alone.
    pub(crate) fn forces_on_states(&self, p: &[f64], inputs: &[Inputs], states: &[f64], out: &mut [f64]) {
        assert_eq!(inputs.len(), out.len());
        assert_eq!(states.len(), inputs.len() * self.n_states);
        for (k, inp) in inputs.iter().enumerate() {
            let s = &states[k * self.n_states..(k + 1) * self.n_states];
            out[k] = self.eval(p, s, inp).force_n(inp.v_m_s);
        }
    }

    fn integrate(&self, p: &[f64], inputs: &[Inputs], out: &mut [f64], record: Option<&mut Vec<f64>>) {
        assert_eq!(inputs.len(), out.len());
        let Some(first) = inputs.first() else { return };
        let mut run = self.start(p, first);
        self.carry(p, &mut run, inputs, out, record);
    }

    /// An integration of a test at its first sample, to be carried on piece by piece with
    /// [`Model::carry`].
    pub(crate) fn start(&self, p: &[f64], first: &Inputs) -> Integration {
        Integration {
            state: self.init_state(p, first),
            memo: DecayMemo::default(),
            next: 0,
        }
    }

    /// Carry `run` on over the next `out.len()` samples of `inputs` (the whole test's inputs, from its
    /// first sample), writing the force at each into `out` and, with `record`, appending the state at
    /// each. Pieces taken one after another give the same numbers as one integration of the whole, so a
    /// caller can integrate many runs side by side without holding any of them whole.
    pub(crate) fn carry(
        &self,
        p: &[f64],
        run: &mut Integration,
        inputs: &[Inputs],
        out: &mut [f64],
        mut record: Option<&mut Vec<f64>>,
    ) {
        let s = &mut run.state;
        for (k, f_out) in (run.next..).zip(out.iter_mut()) {
            let inp = &inputs[k];
            if let Some(r) = record.as_deref_mut() {
                r.extend_from_slice(s);
            }
            let stage = self.eval(p, s, inp);
            let f = stage.force_n(inp.v_m_s);
            *f_out = f;
            if let Some(next) = inputs.get(k + 1) {
                let step = Step {
                    dt_s: next.t_s - inp.t_s,
                    dx_m: next.x_m - inp.x_m,
                };
                self.advance_in(p, s, inp, &stage, f, step, &mut run.memo);
            }
        }
        run.next += out.len();
    }

    /// Integrate one test and return the force at every sample.
    pub fn simulate(&self, p: &[f64], inputs: &[Inputs]) -> Vec<f64> {
        let mut out = vec![0.0; inputs.len()];
        self.simulate_into(p, inputs, &mut out);
        out
    }
}

/// The state of one integration of a test between pieces ([`Model::start`], [`Model::carry`]).
#[derive(Debug, Clone)]
pub(crate) struct Integration {
    state: Vec<f64>,
    memo: DecayMemo,
    /// The next sample to integrate.
    next: usize,
}

/// A model with its parameters and running state: the force element that the MTS machine and the stick
/// rig step in time. The same code the fitter integrates.
#[derive(Debug, Clone)]
pub struct Damper {
    model: Arc<Model>,
    params: Vec<f64>,
    state: Vec<f64>,
    started: bool,
}

impl Damper {
    /// A damper of `model` with parameter values `params` (in [`Model::param_specs`] order), at rest.
    pub fn new(model: Arc<Model>, params: Vec<f64>) -> Result<Self, DeviceError> {
        if params.len() != model.n_params() {
            let (got, n) = (params.len(), model.n_params());
            let why = format!("{got} parameter values for {n} parameters");
            return Err(DeviceError::bad_spec(model.name(), why));
        }
        let state = vec![0.0; model.n_states()];
        Ok(Self {
            model,
            params,
            state,
            started: false,
        })
    }

    /// The damper's model.
    pub fn model(&self) -> &Model {
        &self.model
    }

    /// Parameter values, in [`Model::param_specs`] order.
    pub fn params(&self) -> &[f64] {
        &self.params
    }

    /// Value of a named parameter.
    pub fn param(&self, name: &str) -> Option<f64> {
        self.model.param_index(name).map(|k| self.params[k])
    }

    /// Restart from rest at the given inputs (lags settled at its current command).
    pub fn reset(&mut self, first: &Inputs) {
        self.state = self.model.init_state(&self.params, first);
        self.started = true;
    }

    /// The force assembly at these inputs with the present state; the first call starts from rest.
    pub fn eval(&mut self, inp: &Inputs) -> Stage {
        if !self.started {
            self.reset(inp);
        }
        self.model.eval(&self.params, &self.state, inp)
    }

    /// Advance the state over a step after `eval` at `inp` produced `stage`.
    pub fn advance(&mut self, inp: &Inputs, stage: &Stage, step: Step) {
        let f = stage.force_n(inp.v_m_s);
        self.model
            .advance(&self.params, &mut self.state, inp, stage, f, step);
    }

    /// Coil current (Eq. 3 state; the filtered command of the Spencer base), A.
    pub fn coil_current_a(&self) -> f64 {
        self.state.first().copied().unwrap_or(0.0)
    }

    /// Fluid excitation (Eq. 4 state; the filtered command of the Spencer base), A.
    pub(crate) fn fluid_excitation_a(&self) -> f64 {
        match self.model.base() {
            Base::Bingham => self.state.get(1).copied().unwrap_or(0.0),
            Base::Spencer => self.coil_current_a(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_current_limit_that_is_not_a_positive_number_is_refused() {
        let r = Registry::builtin();
        for bad in [0.0, -14.0, f64::NAN, f64::INFINITY] {
            match Model::from_spec("bingham", &r, bad) {
                Err(DeviceError::BadSpec { why, .. }) => assert!(why.contains("current limit"), "{why}"),
                other => panic!("limit {bad}: {other:?}"),
            }
        }
        assert!(Model::from_spec("bingham", &r, PAPER_CURRENT_LIMIT_A).is_ok());
    }

    /// An integration carried on in pieces of any size gives, to the bit, the force and states of one
    /// integration of the whole (hysteresis and the lags carry state across the pieces' joins).
    #[test]
    fn an_integration_in_pieces_is_the_integration_of_the_whole() {
        let model = Model::from_spec("bingham+hysteresis", &Registry::builtin(), 14.0).unwrap();
        let mut p = vec![20.0, 4.83, 60.0, 0.015, 0.008];
        p.extend([2.5e-4, 0.016, 0.5, 0.3]);
        assert_eq!(p.len(), model.n_params());
        let mut inputs = crate::device::effects::testkit::sine(0.02, 1.0, 0.0, 1e-3, 2.0);
        for (k, inp) in inputs.iter_mut().enumerate() {
            inp.current_cmd_a = [0.0, 14.0, 3.5, 7.0][(k / 130) % 4];
        }
        let (mut whole, mut whole_states) = (vec![0.0; inputs.len()], Vec::new());
        model.simulate_recording(&p, &inputs, &mut whole, &mut whole_states);
        assert!(whole.iter().any(|f| f.abs() > 10.0));
        let mut run = model.start(&p, &inputs[0]);
        let (mut pieces, mut states) = (vec![0.0; inputs.len()], Vec::new());
        let mut at = 0;
        for len in [1, 0, 129, 2, 600].into_iter().cycle() {
            let end = (at + len).min(inputs.len());
            model.carry(&p, &mut run, &inputs, &mut pieces[at..end], Some(&mut states));
            at = end;
            if at == inputs.len() {
                break;
            }
        }
        assert_eq!(pieces, whole);
        assert_eq!(states, whole_states);
    }

    /// The paper's device gives a usable force everywhere; a damping of 10³⁰⁰ N·s/m (inside its bounds)
    /// does not, and neither does a NaN.
    #[test]
    fn absurd_parameters_give_an_unusable_force_and_the_papers_do_not() {
        let model = Model::from_spec("bingham+stiffness+inertia", &Registry::builtin(), 14.0).unwrap();
        let mut p = vec![0.0, 4.83, 1.0, 0.015, 0.008];
        p.extend([1e3, 0.0, 1e4, 0.5]);
        assert_eq!(p.len(), model.n_params());
        assert_eq!(model.unusable_force(&p), None);
        let mut huge = p.clone();
        huge[bingham::C0] = 1e300;
        let (inp, f) = model.unusable_force(&huge).expect("1e300 N·s/m");
        assert!(
            (f.is_nan() || f.abs() > FORCE_LIMIT_N) && inp.v_m_s != 0.0,
            "{f} at {inp:?}"
        );
        let mut nan = p.clone();
        nan[bingham::FC_GAIN] = f64::NAN;
        assert!(model.unusable_force(&nan).is_some());
    }
}
