//! Data-defined effects: an additive force term `F_extra = formula(x, v, a, i, t; parameters)` loaded from
//! a TOML file (or built by the diagnosis's open term search) and registered beside the built-in effects.
//! The formula is parsed by `evalexpr` and compiled into a small tree evaluated at every sample; `lp(expr,
//! tau_s)` is a first-order low-pass state, and the memory features `s` (travel since the last reversal) and
//! `tc` (time since the command last changed) are states the formula keeps when it reads them. Features,
//! functions and file format: `docs/spec/model-discovery.md`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use evalexpr::{DefaultNumericTypes, Node, Operator, Value};
use serde::Deserialize;

use super::bingham::sgn;
use super::effect::{Effect, EffectStage, Inputs, Stage, Step};
use super::model::Registry;
use super::params::{DataStats, ParamSpec};
use super::DeviceError;
use crate::input::{InputError, Source};

/// A signal a formula may read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Feature {
    X,
    V,
    A,
    I,
    T,
    /// Distance travelled since the last velocity reversal, m (a state).
    S,
    /// Time since the current command last changed, s (a state).
    Tc,
}

/// The time since the command last changed at a test's first sample, s: the test starts with its command
/// settled, as if held long before (`exp(-tc/τ)` is then 0 for any time constant a field has).
pub(crate) const TC_SETTLED_S: f64 = 1000.0;

impl Feature {
    /// Every feature with its name, meaning and unit, as the file format documents them.
    pub const ALL: [(Feature, &'static str, &'static str); 7] = [
        (Feature::X, "x", "m"),
        (Feature::V, "v", "m/s"),
        (Feature::A, "a", "m/s^2"),
        (Feature::I, "i", "A"),
        (Feature::T, "t", "s"),
        (Feature::S, "s", "m"),
        (Feature::Tc, "tc", "s"),
    ];

    fn of(name: &str) -> Option<Self> {
        Self::ALL.iter().find(|f| f.1 == name).map(|f| f.0)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fn1 {
    Abs,
    Sign,
    Tanh,
    Exp,
    Ln,
    Sqrt,
    Sin,
    Cos,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op2 {
    Add,
    Sub,
    Mul,
    Div,
    Pow,
    Min,
    Max,
}

/// A compiled formula.
#[derive(Debug, Clone, PartialEq)]
enum Expr {
    Const(f64),
    Feature(Feature),
    Param(usize),
    /// The low-pass state of this index.
    State(usize),
    Neg(Box<Expr>),
    Fn1(Fn1, Box<Expr>),
    Op2(Op2, Box<Expr>, Box<Expr>),
}

/// The signals at one sample, indexed by [`Feature`] (in the order of [`Feature::ALL`]).
type Signals = [f64; 7];

impl Expr {
    fn eval(&self, p: &[f64], s: &[f64], sig: &Signals) -> f64 {
        match self {
            Expr::Const(c) => *c,
            Expr::Feature(f) => sig[*f as usize],
            Expr::Param(k) => p[*k],
            Expr::State(k) => s[*k],
            Expr::Neg(e) => -e.eval(p, s, sig),
            Expr::Fn1(f, e) => {
                let u = e.eval(p, s, sig);
                match f {
                    Fn1::Abs => u.abs(),
                    Fn1::Sign => sgn(u),
                    Fn1::Tanh => u.tanh(),
                    Fn1::Exp => u.exp(),
                    Fn1::Ln => u.ln(),
                    Fn1::Sqrt => u.sqrt(),
                    Fn1::Sin => u.sin(),
                    Fn1::Cos => u.cos(),
                }
            }
            Expr::Op2(op, a, b) => {
                let (a, b) = (a.eval(p, s, sig), b.eval(p, s, sig));
                match op {
                    Op2::Add => a + b,
                    Op2::Sub => a - b,
                    Op2::Mul => a * b,
                    Op2::Div => a / b,
                    Op2::Pow => a.powf(b),
                    Op2::Min => a.min(b),
                    Op2::Max => a.max(b),
                }
            }
        }
    }

    fn reads(&self, what: &dyn Fn(&Expr) -> bool) -> bool {
        what(self)
            || match self {
                Expr::Neg(e) | Expr::Fn1(_, e) => e.reads(what),
                Expr::Op2(_, a, b) => a.reads(what) || b.reads(what),
                _ => false,
            }
    }
}

/// A formula compiled against its parameter names, with its states: the low-pass states first, then the
/// memory features' (two each: `s` keeps the travel and the direction of motion it was counted in; `tc` the
/// time held and the command held).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Formula {
    text: String,
    expr: Expr,
    /// Input and time constant of each low-pass state, in the order their indices were given (inner first).
    lowpass: Vec<(Expr, f64)>,
    /// Index of the travel state when the formula reads `s`.
    travel: Option<usize>,
    /// Index of the held-time state when the formula reads `tc`.
    held: Option<usize>,
}

impl Formula {
    /// Parse `text` over the features and the parameters `params` (index = position). The error says what
    /// is wrong in words (an unknown name lists the features and parameters).
    pub fn parse(text: &str, params: &[&str]) -> Result<Self, String> {
        let tree: Node<DefaultNumericTypes> =
            evalexpr::build_operator_tree(text).map_err(|e| format!("formula does not parse: {e}"))?;
        let mut c = Compiler {
            params,
            lowpass: Vec::new(),
        };
        let expr = c.compile(&tree)?;
        let reads = |f: Feature| {
            let is = |x: &Expr| *x == Expr::Feature(f);
            expr.reads(&is) || c.lowpass.iter().any(|(e, _)| e.reads(&is))
        };
        let n = c.lowpass.len();
        let travel = reads(Feature::S).then_some(n);
        let held = reads(Feature::Tc).then_some(n + 2 * usize::from(travel.is_some()));
        Ok(Self {
            text: text.trim().to_string(),
            expr,
            lowpass: c.lowpass,
            travel,
            held,
        })
    }

    /// The formula as written.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Number of states: the low-pass states and two per memory feature read.
    pub(crate) fn n_states(&self) -> usize {
        self.lowpass.len() + 2 * (usize::from(self.travel.is_some()) + usize::from(self.held.is_some()))
    }

    /// The signals at a sample, the memory features read from the states `s` as they stand before it: the
    /// travel restarts at 0 at the first sample moving the other way, the held time at the first sample of a
    /// new command.
    fn signals(&self, s: &[f64], inp: &Inputs, current_a: f64) -> Signals {
        let travel = self.travel.map_or(0.0, |k| {
            let d = sgn(inp.v_m_s);
            if d != 0.0 && d != s[k + 1] {
                0.0
            } else {
                s[k]
            }
        });
        let held = self
            .held
            .map_or(0.0, |k| if inp.current_cmd_a != s[k + 1] { 0.0 } else { s[k] });
        [inp.x_m, inp.v_m_s, inp.a_m_s2, current_a, inp.t_s, travel, held]
    }

    /// The memory states at a test's first sample: no travel yet in the first direction of motion (a start
    /// from rest), the first command settled.
    fn init_memory(&self, s: &mut [f64], inp: &Inputs) {
        if let Some(k) = self.travel {
            s[k] = 0.0;
            s[k + 1] = sgn(inp.v_m_s);
        }
        if let Some(k) = self.held {
            s[k] = TC_SETTLED_S;
            s[k + 1] = inp.current_cmd_a;
        }
    }

    /// Advance the memory states over `dt_s` from a sample whose signals are `sig`: the travel grows by
    /// `|v| dt`, the held time by `dt`.
    fn advance_memory(&self, s: &mut [f64], inp: &Inputs, sig: &Signals, dt_s: f64) {
        let dt = dt_s.max(0.0);
        if let Some(k) = self.travel {
            let d = sgn(inp.v_m_s);
            if d != 0.0 {
                s[k + 1] = d;
            }
            s[k] = sig[Feature::S as usize] + inp.v_m_s.abs() * dt;
        }
        if let Some(k) = self.held {
            s[k + 1] = inp.current_cmd_a;
            s[k] = sig[Feature::Tc as usize] + dt;
        }
    }

    /// Does any low-pass state read the lagged current (whose lags are the base model's parameters)?
    fn states_read_the_current(&self) -> bool {
        self.lowpass
            .iter()
            .any(|(e, _)| e.reads(&|x| *x == Expr::Feature(Feature::I)))
    }

    /// Which of the parameters (by index, `n` of them) the low-pass states read.
    fn params_the_states_read(&self, n: usize) -> Vec<bool> {
        (0..n)
            .map(|k| {
                self.lowpass
                    .iter()
                    .any(|(e, _)| e.reads(&|x| *x == Expr::Param(k)))
            })
            .collect()
    }

    /// States at a test's first sample: the memory features' (`init_memory`), then each low-pass state at
    /// its input's value.
    fn init(&self, p: &[f64], s: &mut [f64], inp: &Inputs, current_a: f64) {
        self.init_memory(s, inp);
        let sig = self.signals(s, inp, current_a);
        for k in 0..self.lowpass.len() {
            s[k] = self.lowpass[k].0.eval(p, s, &sig);
        }
    }

    /// Advance the states over `dt_s`: the low-pass states with their inputs held (exact for a first-order
    /// lag), then the memory features'.
    fn advance(&self, p: &[f64], s: &mut [f64], inp: &Inputs, current_a: f64, dt_s: f64) {
        let sig = self.signals(s, inp, current_a);
        for k in 0..self.lowpass.len() {
            let (input, tau) = &self.lowpass[k];
            let u = input.eval(p, s, &sig);
            s[k] += (1.0 - (-dt_s.max(0.0) / tau).exp()) * (u - s[k]);
        }
        self.advance_memory(s, inp, &sig, dt_s);
    }

    /// The formula's value at a sample with the states `s`.
    fn eval(&self, p: &[f64], s: &[f64], inp: &Inputs, current_a: f64) -> f64 {
        self.expr.eval(p, s, &self.signals(s, inp, current_a))
    }

    /// The formula (over features only, no parameters) at every sample of one test, its low-pass states
    /// run exactly as the effect runs them; `current_a` is the lagged current at each sample.
    pub fn series(&self, inputs: &[Inputs], current_a: &[f64]) -> Vec<f64> {
        let mut s = vec![0.0; self.n_states()];
        let mut out = Vec::with_capacity(inputs.len());
        for (k, inp) in inputs.iter().enumerate() {
            if k == 0 {
                self.init(&[], &mut s, inp, current_a[k]);
            }
            out.push(self.eval(&[], &s, inp, current_a[k]));
            if let Some(next) = inputs.get(k + 1) {
                self.advance(&[], &mut s, inp, current_a[k], next.t_s - inp.t_s);
            }
        }
        out
    }
}

struct Compiler<'a> {
    params: &'a [&'a str],
    lowpass: Vec<(Expr, f64)>,
}

impl Compiler<'_> {
    fn compile(&mut self, node: &Node<DefaultNumericTypes>) -> Result<Expr, String> {
        let ch = node.children();
        let two = |c: &mut Self, op: Op2| -> Result<Expr, String> {
            match ch {
                [a, b] => Ok(Expr::Op2(op, Box::new(c.compile(a)?), Box::new(c.compile(b)?))),
                _ => Err(format!("`{}` needs two operands", node.operator())),
            }
        };
        match node.operator() {
            Operator::RootNode => match ch {
                [one] => self.compile(one),
                [] => Err("empty formula (or empty brackets)".into()),
                _ => Err("several expressions where one is expected".into()),
            },
            Operator::Add => two(self, Op2::Add),
            Operator::Sub => two(self, Op2::Sub),
            Operator::Mul => two(self, Op2::Mul),
            Operator::Div => two(self, Op2::Div),
            Operator::Exp => two(self, Op2::Pow),
            Operator::Neg => match ch {
                [a] => Ok(Expr::Neg(Box::new(self.compile(a)?))),
                _ => Err("`-` needs one operand".into()),
            },
            Operator::Const { value } => match value {
                Value::Float(f) => Ok(Expr::Const(*f)),
                Value::Int(i) => Ok(Expr::Const(*i as f64)),
                other => Err(format!("`{other}` is not a number")),
            },
            Operator::VariableIdentifierRead { identifier } => {
                if let Some(f) = Feature::of(identifier) {
                    Ok(Expr::Feature(f))
                } else if let Some(k) = self.params.iter().position(|p| p == identifier) {
                    Ok(Expr::Param(k))
                } else {
                    Err(format!(
                        "unknown feature `{identifier}` (features: {}; parameters: {})",
                        Feature::ALL
                            .iter()
                            .map(|f| format!("{} [{}]", f.1, f.2))
                            .collect::<Vec<_>>()
                            .join(", "),
                        if self.params.is_empty() {
                            "none declared".to_string()
                        } else {
                            self.params.join(", ")
                        }
                    ))
                }
            }
            Operator::FunctionIdentifier { identifier } => {
                let args = arguments(ch);
                let name = identifier.as_str();
                let one = |c: &mut Self, f: Fn1| -> Result<Expr, String> {
                    match args.as_slice() {
                        [a] => Ok(Expr::Fn1(f, Box::new(c.compile(a)?))),
                        _ => Err(format!("`{name}` takes one argument, not {}", args.len())),
                    }
                };
                match name {
                    "abs" => one(self, Fn1::Abs),
                    "sign" | "sgn" => one(self, Fn1::Sign),
                    "tanh" => one(self, Fn1::Tanh),
                    "exp" => one(self, Fn1::Exp),
                    "ln" => one(self, Fn1::Ln),
                    "sqrt" => one(self, Fn1::Sqrt),
                    "sin" => one(self, Fn1::Sin),
                    "cos" => one(self, Fn1::Cos),
                    "min" | "max" => match args.as_slice() {
                        [a, b] => Ok(Expr::Op2(
                            if name == "min" { Op2::Min } else { Op2::Max },
                            Box::new(self.compile(a)?),
                            Box::new(self.compile(b)?),
                        )),
                        _ => Err(format!("`{name}` takes two arguments, not {}", args.len())),
                    },
                    "lp" => match args.as_slice() {
                        [a, tau] => {
                            let input = self.compile(a)?;
                            let tau = match self.compile(tau)? {
                                Expr::Const(c) if c.is_finite() && c > 0.0 => c,
                                _ => return Err(
                                    "`lp(expr, tau_s)`: the time constant is a positive number of seconds"
                                        .into(),
                                ),
                            };
                            self.lowpass.push((input, tau));
                            Ok(Expr::State(self.lowpass.len() - 1))
                        }
                        _ => Err(format!(
                            "`lp` takes two arguments (expr, tau_s), not {}",
                            args.len()
                        )),
                    },
                    other => Err(format!(
                        "unknown function `{other}` (functions: abs, sign, tanh, exp, ln, sqrt, sin, cos, \
                         min, max, lp)"
                    )),
                }
            }
            other => Err(format!(
                "`{other}` is not allowed in a force formula (numbers, features, parameters, + - * / ^ and \
                 functions)"
            )),
        }
    }
}

/// The arguments of a function call: its one child, unwrapped of brackets, split at the commas.
fn arguments(ch: &[Node<DefaultNumericTypes>]) -> Vec<&Node<DefaultNumericTypes>> {
    let mut node = match ch {
        [one] => one,
        _ => return ch.iter().collect(),
    };
    while matches!(node.operator(), Operator::RootNode) && node.children().len() == 1 {
        node = &node.children()[0];
    }
    match node.operator() {
        Operator::Tuple => node.children().iter().collect(),
        Operator::RootNode if node.children().is_empty() => Vec::new(),
        _ => vec![node],
    }
}

/// One parameter of a data-defined effect.
#[derive(Debug, Clone, PartialEq)]
pub struct FormulaParam {
    /// Name, as the formula writes it.
    pub name: String,
    /// Unit, for messages and files.
    pub unit: String,
    /// Lower bound of a fit.
    pub lower: f64,
    /// Upper bound of a fit.
    pub upper: f64,
    /// Starting value of a fit.
    pub guess: f64,
    /// What it means.
    pub doc: String,
}

/// A data-defined additive force term: see the module documentation.
#[derive(Debug, Clone)]
pub struct FormulaEffect {
    name: &'static str,
    describe: &'static str,
    resembles: String,
    formula: Formula,
    params: &'static [ParamSpec],
    declared: Vec<FormulaParam>,
}

/// A `'static` copy of a string: the registry's effects name themselves and their parameters for the
/// program's run, and a data-defined effect is loaded once.
fn leak(s: &str) -> &'static str {
    Box::leak(s.to_string().into_boxed_str())
}

impl FormulaEffect {
    /// An effect named `name` whose force is `formula` over the features and `params`.
    pub fn new(
        name: &str,
        describe: &str,
        resembles: &str,
        formula: &str,
        params: Vec<FormulaParam>,
    ) -> Result<Self, String> {
        if !valid_name(name) {
            return Err(format!(
                "effect name `{name}`: letters, digits and `_`, starting with a letter (it is written in model \
                 specs as bingham+{name})"
            ));
        }
        let names: Vec<&str> = params.iter().map(|p| p.name.as_str()).collect();
        for p in &params {
            if Feature::of(&p.name).is_some() {
                return Err(format!("parameter `{}` has the name of a feature", p.name));
            }
            if p.lower.partial_cmp(&p.upper).is_none_or(|o| o.is_gt()) {
                return Err(format!(
                    "parameter `{}`: lower bound {} above upper bound {}",
                    p.name, p.lower, p.upper
                ));
            }
            if !(p.lower <= p.guess && p.guess <= p.upper) {
                return Err(format!(
                    "parameter `{}`: guess {} outside its bounds [{}, {}]",
                    p.name, p.guess, p.lower, p.upper
                ));
            }
        }
        let formula = Formula::parse(formula, &names)?;
        let specs: Vec<ParamSpec> = params
            .iter()
            .map(|p| ParamSpec::new(leak(&p.name), leak(&p.unit), p.lower, p.upper, leak(&p.doc)))
            .collect();
        Ok(Self {
            name: leak(name),
            describe: leak(describe),
            resembles: resembles.to_string(),
            formula,
            params: Box::leak(specs.into_boxed_slice()),
            declared: params,
        })
    }

    /// The formula as written.
    pub fn formula(&self) -> &str {
        self.formula.text()
    }

    /// The same effect with these parameter values as its starting values (clamped into the bounds).
    pub(crate) fn with_values(&self, values: &[f64]) -> Self {
        let mut e = self.clone();
        for (k, v) in values.iter().enumerate().take(e.declared.len()) {
            if v.is_finite() {
                let p = &mut e.declared[k];
                p.guess = v.max(p.lower).min(p.upper);
            }
        }
        e
    }

    /// The physical family it resembles (empty when none).
    pub fn resembles(&self) -> &str {
        &self.resembles
    }

    /// The same effect with another physical family named.
    pub(crate) fn with_resembles(mut self, family: &str) -> Self {
        self.resembles = family.to_string();
        self
    }

    pub(crate) fn declared_params(&self) -> &[FormulaParam] {
        &self.declared
    }

    /// Load an effect file; errors name the file, the line and the field.
    pub fn load(path: &Path) -> Result<Self, DeviceError> {
        Ok(Self::from_source(&Source::read(path)?)?)
    }

    /// Parse an effect file's text (`path` for messages).
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, DeviceError> {
        Ok(Self::from_source(&Source::new(path, text))?)
    }

    fn from_source(src: &Source) -> Result<Self, InputError> {
        let file: EffectFile = src.toml()?;
        let field = |span: std::ops::Range<usize>, field: &str, msg: String| {
            InputError::field(&src.path, src.line_of(span.start), field, msg)
        };
        let mut params = Vec::new();
        for (name, p) in &file.params {
            let span = p.span();
            let p = p.get_ref();
            let (lower, upper) = (*p.lower.get_ref(), *p.upper.get_ref());
            let guess = match &p.guess {
                Some(g) => *g.get_ref(),
                None => 0f64.max(lower).min(upper),
            };
            if !(lower.is_finite() && upper.is_finite() && lower < upper) {
                return Err(field(
                    p.lower.span(),
                    &format!("params.{name}.lower"),
                    format!("bounds [{lower}, {upper}]: two finite numbers, lower below upper"),
                ));
            }
            if !(lower <= guess && guess <= upper) {
                let at = p.guess.as_ref().map_or(span.clone(), |g| g.span());
                return Err(field(
                    at,
                    &format!("params.{name}.guess"),
                    format!("{guess} is outside the bounds [{lower}, {upper}]"),
                ));
            }
            params.push(FormulaParam {
                name: name.clone(),
                unit: p.unit.clone(),
                lower,
                upper,
                guess,
                doc: p.doc.clone().unwrap_or_default(),
            });
        }
        let name_span = file.name.span();
        let formula_span = file.formula.span();
        let e = Self::new(
            file.name.get_ref(),
            file.describe.as_deref().unwrap_or("data-defined force term"),
            file.resembles.as_deref().unwrap_or(""),
            file.formula.get_ref(),
            params,
        );
        e.map_err(|msg| {
            if msg.starts_with("effect name") {
                field(name_span, "name", msg)
            } else if msg.starts_with("parameter") {
                field(formula_span.clone(), "params", msg)
            } else {
                field(formula_span.clone(), "formula", msg)
            }
        })
    }

    /// The effect as an effect file (loads back to the same effect), values as given.
    pub fn to_toml(&self) -> String {
        let q = |s: &str| toml::Value::String(s.to_string()).to_string();
        let mut out = format!(
            "# A data-defined effect for mrfeel (docs/spec/model-discovery.md): use it as bingham+{name}\n\
             # with --effects FILE, or name the file in the spec (bingham+FILE.toml).\n\
             name = {}\ndescribe = {}\nresembles = {}\nformula = {}\n",
            q(self.name),
            q(self.describe),
            q(&self.resembles),
            q(self.formula.text()),
            name = self.name
        );
        for p in &self.declared {
            out.push_str(&format!(
                "\n[params.{}]\nunit = {}\nlower = {:e}\nupper = {:e}\nguess = {:e}\ndoc = {}\n",
                p.name,
                q(&p.unit),
                p.lower,
                p.upper,
                p.guess,
                q(&p.doc)
            ));
        }
        out
    }
}

fn valid_name(name: &str) -> bool {
    let mut c = name.chars();
    c.next().is_some_and(|f| f.is_ascii_alphabetic()) && c.all(|ch| ch.is_ascii_alphanumeric() || ch == '_')
}

/// The TOML schema of an effect file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EffectFile {
    name: toml::Spanned<String>,
    describe: Option<String>,
    resembles: Option<String>,
    formula: toml::Spanned<String>,
    #[serde(default)]
    params: BTreeMap<String, toml::Spanned<ParamFile>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ParamFile {
    unit: String,
    lower: toml::Spanned<f64>,
    upper: toml::Spanned<f64>,
    guess: Option<toml::Spanned<f64>>,
    doc: Option<String>,
}

impl Effect for FormulaEffect {
    fn name(&self) -> &'static str {
        self.name
    }

    fn describe(&self) -> &'static str {
        self.describe
    }

    fn stage(&self) -> EffectStage {
        EffectStage::Additive
    }

    fn params(&self) -> &'static [ParamSpec] {
        self.params
    }

    fn initial_guess(&self, _stats: &DataStats) -> Vec<f64> {
        self.declared.iter().map(|p| p.guess).collect()
    }

    fn n_states(&self) -> usize {
        self.formula.n_states()
    }

    fn states_read_the_force(&self) -> bool {
        self.formula.states_read_the_current()
    }

    fn params_the_states_read(&self) -> Vec<bool> {
        self.formula.params_the_states_read(self.params.len())
    }

    fn init_states(&self, p: &[f64], s: &mut [f64], inp: &Inputs, stage: &Stage) {
        self.formula.init(p, s, inp, stage.current_a);
    }

    fn apply(&self, p: &[f64], s: &[f64], inp: &Inputs, stage: &mut Stage) {
        stage.extra_n += self.formula.eval(p, s, inp, stage.current_a);
    }

    fn advance(&self, p: &[f64], s: &mut [f64], inp: &Inputs, stage: &Stage, _force_n: f64, step: Step) {
        self.formula.advance(p, s, inp, stage.current_a, step.dt_s);
    }

    fn residual_signature(&self) -> &'static str {
        "the residual follows the formula's features"
    }
}

/// Load the effect file `path` into `registry` (replacing an effect of the same name); returns its name.
pub fn register_file(registry: &mut Registry, path: &Path) -> Result<&'static str, DeviceError> {
    let e = FormulaEffect::load(path)?;
    let name = e.name;
    registry.register(e);
    Ok(name)
}

/// A model spec whose parts may name effect files (`bingham+drag.toml`, relative to `dir`): each file is
/// loaded into `registry` and the spec returned with the effects' names in its place (`bingham+drag`).
pub fn resolve_spec(spec: &str, registry: &mut Registry, dir: Option<&Path>) -> Result<String, DeviceError> {
    let mut parts = Vec::new();
    for part in spec.split('+') {
        let part = part.trim();
        if part.ends_with(".toml") {
            let p = PathBuf::from(part);
            let p = match dir {
                Some(d) if p.is_relative() => d.join(p),
                _ => p,
            };
            parts.push(register_file(registry, &p)?.to_string());
        } else {
            parts.push(part.to_string());
        }
    }
    Ok(parts.join("+"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Model;

    fn param(name: &str, guess: f64) -> FormulaParam {
        FormulaParam {
            name: name.into(),
            unit: "N s^2/m^2".into(),
            lower: -1e6,
            upper: 1e6,
            guess,
            doc: String::new(),
        }
    }

    /// `bingham+NAME` with the effect `e` (named NAME) registered beside the built-in ones.
    fn model_with(e: FormulaEffect) -> Model {
        let spec = format!("bingham+{}", e.name());
        let mut r = Registry::builtin();
        r.register(e);
        Model::from_spec(&spec, &r, 14.0).expect("model")
    }

    fn at(x: f64, v: f64) -> (Inputs, Stage) {
        (
            Inputs {
                t_s: 0.5,
                x_m: x,
                v_m_s: v,
                a_m_s2: 2.0,
                current_cmd_a: 3.0,
            },
            Stage {
                current_a: 1.5,
                ..Stage::default()
            },
        )
    }

    /// Precedence, functions, features and parameters evaluate as ordinary algebra says.
    #[test]
    fn a_formula_evaluates_as_written() {
        let e = FormulaEffect::new(
            "drag",
            "",
            "",
            "c * v*abs(v) + 2^3 * x - max(a, 1) / i + tanh(0) + sign(-v) * t",
            vec![param("c", 0.0)],
        )
        .expect("parses");
        let (inp, mut st) = at(0.25, -0.5);
        e.apply(&[4.0], &[], &inp, &mut st);
        let want = 4.0 * -0.5 * 0.5 + 8.0 * 0.25 - 2.0 / 1.5 + 0.0 + 1.0 * 0.5;
        assert!((st.extra_n - want).abs() < 1e-12, "{} vs {want}", st.extra_n);
    }

    /// `lp(v, tau)` follows a step of velocity as `1 − exp(−t/τ)`, exactly at the sample times.
    #[test]
    fn a_low_pass_state_follows_a_step_with_its_time_constant() {
        let m = model_with(FormulaEffect::new("lag", "", "", "lp(v, 0.1)", vec![]).expect("parses"));
        let dt = 1e-3;
        let inputs: Vec<Inputs> = (0..400)
            .map(|k| Inputs {
                t_s: k as f64 * dt,
                v_m_s: if k == 0 { 0.0 } else { 1.0 },
                ..Inputs::default()
            })
            .collect();
        // Base parameters that give no force of their own (no yield, no damping).
        let p = vec![0.0, 0.0, 0.0, 0.015, 0.008];
        let f = m.simulate(&p, &inputs);
        for k in [1usize, 100, 300] {
            let want = 1.0 - (-((k - 1) as f64) * dt / 0.1).exp();
            assert!((f[k] - want).abs() < 1e-9, "sample {k}: {} vs {want}", f[k]);
        }
    }

    /// A file with an unknown feature, a formula that does not parse, or a parameter without bounds is
    /// refused at the line of the field that is wrong.
    #[test]
    fn bad_effect_files_are_refused_with_line_and_field() {
        let good = "name = \"drag\"\nformula = \"c * v * abs(v)\"\n\n[params.c]\nunit = \"N s^2/m^2\"\nlower = 0\nupper = 1e6\n";
        let path = Path::new("drag.toml");
        let e = FormulaEffect::from_toml(good, path).expect("good file");
        assert_eq!(e.name(), "drag");
        let cases = [
            (
                good.replace("abs(v)", "abs(q)"),
                2,
                "formula",
                "unknown feature `q`",
            ),
            (good.replace("abs(v)", "abs(v"), 2, "formula", "does not parse"),
            (
                good.replace("lower = 0\n", ""),
                4,
                "lower",
                "missing field `lower`",
            ),
        ];
        for (text, line, fld, msg) in cases {
            match FormulaEffect::from_toml(&text, path) {
                Err(DeviceError::Input(e)) => {
                    let (l, m) = (e.line.unwrap_or(0), &e.msg);
                    assert_eq!(l, line, "{text}: {m}");
                    match &e.field {
                        Some(field) => assert!(field.contains(fld) || m.contains(fld), "{field}: {m}"),
                        None => assert!(m.contains(fld), "{m}"),
                    }
                    assert!(m.contains(msg), "{m}");
                }
                other => panic!("{text}: {other:?}"),
            }
        }
    }

    /// `s` is the distance travelled since the last reversal: on a sine it is `|x − x_turn|` (the turning
    /// point's displacement) to within the rectangle rule's error, and it restarts at each reversal.
    #[test]
    fn the_travel_feature_restarts_at_each_reversal() {
        let f = Formula::parse("s", &[]).expect("parses");
        assert_eq!(f.n_states(), 2);
        let (a, w, dt) = (0.01, std::f64::consts::TAU, 1e-3);
        let inputs = crate::device::effects::testkit::sine(a, 1.0, 0.0, dt, 2.499);
        let s = f.series(&inputs, &vec![0.0; inputs.len()]);
        // From rest at the start (x = 0, moving up), then from each turning point x = ±a (at t = 0.25 s +
        // half periods); samples within two steps of a turn are skipped (the turn falls between samples).
        let tol = 2.0 * a * w * dt;
        let mut turns = 0;
        for k in 0..inputs.len() {
            let t = k as f64 * dt;
            let phase = (t - 0.25).rem_euclid(0.5);
            let want = if t < 0.25 {
                inputs[k].x_m
            } else {
                let turn = t - phase;
                (inputs[k].x_m - a * (w * turn).sin()).abs()
            };
            if phase.min(0.5 - phase) > 2.0 * dt {
                assert!((s[k] - want).abs() <= tol, "t = {t}: s = {} against {want}", s[k]);
            }
            if k > 0 && s[k] < s[k - 1] {
                turns += 1;
            }
        }
        assert_eq!(turns, 5, "one restart per reversal");
    }

    /// `tc` is the time since the command last changed, settled before the first change.
    #[test]
    fn the_held_time_feature_counts_from_each_command_change() {
        let f = Formula::parse("tc", &[]).expect("parses");
        let dt = 1e-3;
        let inputs: Vec<Inputs> = (0..900)
            .map(|k| Inputs {
                t_s: k as f64 * dt,
                current_cmd_a: [1.0, 2.0, 0.5][k / 300],
                ..Inputs::default()
            })
            .collect();
        let tc = f.series(&inputs, &vec![0.0; inputs.len()]);
        assert_eq!(tc.len(), inputs.len());
        for (k, got) in tc.iter().enumerate() {
            let want = if k < 300 {
                TC_SETTLED_S + k as f64 * dt
            } else {
                (k % 300) as f64 * dt
            };
            assert!((got - want).abs() < 1e-9, "sample {k}: {got} against {want}");
        }
    }

    /// An effect reading the memory features (inside a low-pass state too) gives, run by the model, the
    /// force its formula's series gives: the model keeps its states where the formula reads them.
    #[test]
    fn memory_features_run_by_the_model_as_by_the_formula() {
        let text = "m_c1 * sign(v)*exp(-s/0.002) + m_c2 * lp(exp(-tc/0.05), 0.01)";
        let e = FormulaEffect::new("mem", "", "", text, vec![param("m_c1", 1.0), param("m_c2", 1.0)])
            .expect("builds");
        let m = model_with(e);
        let dt = 1e-3;
        let inputs: Vec<Inputs> = (0..1200)
            .map(|k| {
                let t = k as f64 * dt;
                Inputs {
                    t_s: t,
                    x_m: 0.01 * (9.0 * t).sin(),
                    v_m_s: 0.09 * (9.0 * t).cos(),
                    current_cmd_a: if k < 500 { 0.0 } else { 2.0 },
                    ..Inputs::default()
                }
            })
            .collect();
        let p = vec![0.0, 0.0, 0.0, 0.015, 0.008, 3.0, -2.0];
        let got = m.simulate(&p, &inputs);
        let zero = vec![0.0; inputs.len()];
        let a = Formula::parse("sign(v)*exp(-s/0.002)", &[])
            .expect("parses")
            .series(&inputs, &zero);
        let b = Formula::parse("lp(exp(-tc/0.05), 0.01)", &[])
            .expect("parses")
            .series(&inputs, &zero);
        for k in 0..inputs.len() {
            let want = 3.0 * a[k] - 2.0 * b[k];
            assert!(
                (got[k] - want).abs() < 1e-9,
                "sample {k}: {} against {want}",
                got[k]
            );
        }
        // The step of the command shows: the lagged exponential rises from 0 after it.
        assert!(b[499].abs() < 1e-12 && b[520] > 0.5, "{} {}", b[499], b[520]);
    }

    /// What `to_toml` writes loads back to the same formula and parameters.
    #[test]
    fn a_written_effect_loads_back_the_same() {
        let e = FormulaEffect::new(
            "term1",
            "found",
            "quadratic damping",
            "term1_c1 * v*abs(v) + term1_c2 * lp(x, 0.05) + term1_c3 * sign(v)*exp(-s/0.0003) + term1_c4 * \
             i*exp(-tc/0.02)",
            vec![
                param("term1_c1", 310.5),
                param("term1_c2", -2.25e-3),
                param("term1_c3", 1.5),
                param("term1_c4", -0.25),
            ],
        )
        .expect("builds");
        let back = FormulaEffect::from_toml(&e.to_toml(), Path::new("t.toml")).expect("loads back");
        assert_eq!(back.formula(), e.formula());
        assert_eq!(back.declared_params(), e.declared_params());
        assert_eq!(back.resembles(), "quadratic damping");
    }
}
