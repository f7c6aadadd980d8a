//! Beyond the vocabulary: a force term found in a library of candidates, and an honest verdict on what the
//! final model leaves.
//!
//! **Term search.** A library of candidate force terms built from the measured and derived signals
//! (`library`) is searched by forward-regression orthogonal least squares (FROLS, Billings' error-reduction
//! ratio) on the residual of the current model fitted to all the data: its criterion, the share of the
//! residual's energy each term explains once orthogonalised against the model's own directions of change
//! and the terms already chosen, does not depend on the terms' unrelated units and scales, as a threshold on
//! coefficients or an L1 penalty would. The few terms it keeps become one data-defined effect
//! ([`crate::device::formula::FormulaEffect`]) judged exactly as a named effect is.
//!
//! **Verdict.** A ridge regression on smooth functions, shifted copies, low-pass states and bins of the
//! signals (`verdict`) is fitted to the final model's held-out residual on training folds and scored on the
//! held-out fold: the share of the residual it predicts out of sample is structure; noise is not predictable.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use super::diagnose::Fold;
use super::residual::direction_weights;
use super::validate::evaluate;
use super::Test;
use crate::device::formula::{Formula, FormulaEffect, FormulaParam};
use crate::device::{Inputs, Model};
use crate::signal::quantile;

/// One candidate force term of the library.
#[derive(Debug, Clone)]
pub(crate) struct LibraryTerm {
    /// The term as a formula over the features (no parameters), e.g. `v*abs(v)`.
    pub feature: String,
    /// Unit of the coefficient that multiplies it into newtons.
    pub coef_unit: String,
    /// The physical family it most resembles.
    pub family: &'static str,
}

/// A positive number to two significant digits in plain decimal notation (the formula parser reads no
/// exponents).
fn num(x: f64) -> String {
    plain(x, 2.0)
}

/// A positive number to `digits` significant digits in plain decimal notation.
fn plain(x: f64, digits: f64) -> String {
    let x = if x.is_finite() && x > 0.0 { x } else { 1.0 };
    let decimals = (digits - 1.0 - x.log10().floor()).max(0.0) as usize;
    format!("{x:.decimals$}")
}

/// Data scales the library's terms are written at.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Scales {
    /// 99th percentile of |v|, m/s.
    v: f64,
    /// 99th percentile of |x|, m.
    x: f64,
    /// Characteristic time of the motion, `x_rms / v_rms`, s (`1/ω` on a sine).
    tau: f64,
    /// Median sample interval, s.
    dt: f64,
}

impl Scales {
    pub(crate) fn of(tests: &[Test]) -> Self {
        let every = || tests.iter().flat_map(|t| &t.inputs);
        let v = quantile(every().map(|i| i.v_m_s.abs()).collect(), 0.99).max(1e-9);
        let x = quantile(every().map(|i| i.x_m.abs()).collect(), 0.99).max(1e-9);
        let n = every().count().max(1) as f64;
        let rms = |f: &dyn Fn(&Inputs) -> f64| (every().map(|i| f(i).powi(2)).sum::<f64>() / n).sqrt();
        let tau = (rms(&|i| i.x_m) / rms(&|i| i.v_m_s).max(1e-12)).clamp(1e-4, 1e3);
        let dts: Vec<f64> = tests
            .iter()
            .flat_map(|t| t.inputs.windows(2).map(|w| w[1].t_s - w[0].t_s))
            .filter(|d| *d > 0.0)
            .collect();
        let dt = if dts.is_empty() { 1e-3 } else { quantile(dts, 0.5) };
        Self { v, x, tau, dt }
    }
}

/// The candidate force terms, written at the data's scales. The named effects' own forms (a linear spring,
/// a mass, a current-proportional damping) are not repeated here: the vocabulary covers them.
pub(crate) fn library(s: Scales) -> Vec<LibraryTerm> {
    let t = |feature: String, coef_unit: &str, family: &'static str| LibraryTerm {
        feature,
        coef_unit: coef_unit.to_string(),
        family,
    };
    let (v, x) = (s.v, s.x);
    let mut l: Vec<LibraryTerm> = [
        ("v*abs(v)", "N s^2/m^2", "quadratic (turbulent orifice) damping"),
        ("v^3", "N s^3/m^3", "cubic (hardening) damping"),
        (
            "sign(v)*sqrt(abs(v))",
            "N s^0.5/m^0.5",
            "shear-thinning (square-root) damping",
        ),
        (
            "abs(v)",
            "N s/m",
            "direction-independent velocity force (asymmetric orifice or valve)",
        ),
        (
            "v^2",
            "N s^2/m^2",
            "even quadratic velocity force (asymmetric orifice or valve)",
        ),
        ("x*abs(x)", "N/m^2", "progressive spring"),
        ("x^3", "N/m^3", "hardening spring (gas spring, bump stop)"),
        (
            "x^2",
            "N/m^2",
            "even position force (gas spring's compression asymmetry)",
        ),
        ("i*v*abs(v)", "N s^2/(m^2 A)", "field-dependent quadratic damping"),
        (
            "i*x",
            "N/(m A)",
            "field-dependent stiffness (pre-yield elasticity)",
        ),
    ]
    .into_iter()
    .map(|(f, unit, family)| t(f.into(), unit, family))
    .collect();
    l.push(t(
        format!("sign(x)*max(abs(x)-{},0)", num(0.6 * x)),
        "N/m",
        "end stop / dead-zone spring (backlash)",
    ));
    l.push(t(
        format!("tanh(x/{})", num(0.3 * x)),
        "N",
        "saturating centring force (detent)",
    ));
    // A spring that stiffens steeply toward one end of the stroke (a gas spring's compression, a bump stop),
    // without a pole: a term used beyond the measured travel stays finite.
    for k in [0.2, 0.4] {
        for sign in ["", "-"] {
            l.push(t(
                format!("exp({sign}x/{})", num(k * x)),
                "N",
                "spring stiffening toward one end of the stroke (gas spring, bump stop)",
            ));
        }
    }
    for k in [0.03, 0.15, 0.5] {
        l.push(t(
            format!("tanh(v/{})", num(k * v)),
            "N",
            "smooth friction (seal friction, smooth pre-yield transition)",
        ));
        l.push(t(
            format!("abs(i)*tanh(v/{})", num(k * v)),
            "N/A",
            "smooth pre-yield transition of the field's yield force",
        ));
    }
    for k in [0.1, 0.3, 1.0, 3.0] {
        let tau = num((k * s.tau).max(2.0 * s.dt));
        l.push(t(
            format!("abs(i)*lp(tanh(v/{}),{tau})", num(0.15 * v)),
            "N/A",
            "lagged field yield (the field's yield force builds up after a reversal)",
        ));
        l.push(t(
            format!("lp(v,{tau})"),
            "N s/m",
            "frequency-dependent (viscoelastic, Maxwell) damping",
        ));
        l.push(t(
            format!("lp(tanh(v/{}),{tau})", num(0.15 * v)),
            "N",
            "lagged friction (a yield force that builds up with a time constant)",
        ));
    }
    l.push(t(
        format!("x-lp(x,{})", num(s.tau.max(2.0 * s.dt))),
        "N/m",
        "frequency-dependent stiffness (viscoelastic, Maxwell spring)",
    ));
    // Memory of the last reversal: a force that changes over a travel `s0` after each reversal (bristles
    // deflecting before the seal slides, free play crossed before the piston moves), at travels of a
    // fraction of the stroke.
    for k in [0.003, 0.01, 0.03] {
        let s0 = num(k * x);
        l.push(t(
            format!("sign(v)*exp(-s/{s0})"),
            "N",
            "pre-sliding friction after a reversal (LuGre, Dahl bristles)",
        ));
        l.push(t(
            format!("abs(i)*sign(v)*exp(-s/{s0})"),
            "N/A",
            "field yield force missing over a travel after a reversal (free play, backlash, fluid compliance)",
        ));
    }
    // Friction that falls from a static to a kinetic level as the speed rises.
    for k in [0.02, 0.06, 0.2] {
        let vs = num(k * v);
        l.push(t(
            format!("sign(v)*exp(-(v/{vs})^2)"),
            "N",
            "Stribeck friction (static above kinetic, falling with speed)",
        ));
        l.push(t(
            format!("abs(i)*sign(v)*exp(-(v/{vs})^2)"),
            "N/A",
            "Stribeck effect of the field's yield force (static above dynamic yield)",
        ));
    }
    // Friction that depends on where the piston is (a seal rubbing harder toward the stroke's ends).
    for (f, unit, unit_i) in [("x^2", "N/m^2", "N/(m^2 A)"), ("abs(x)", "N/m", "N/(m A)")] {
        l.push(t(
            format!("sign(v)*{f}"),
            unit,
            "position-dependent friction (seal tighter toward the stroke's ends)",
        ));
        l.push(t(
            format!("abs(i)*sign(v)*{f}"),
            unit_i,
            "position-dependent yield force (field or gap varying along the stroke)",
        ));
    }
    // A field slower than the model's lags: the force the yield lacks while the field still builds up after
    // a command change, through a further lag of the current or a decay since the change.
    for k in [0.03, 0.1, 0.3] {
        let tau = num((k * s.tau).max(2.0 * s.dt));
        l.push(t(
            format!("sign(v)*(lp(i,{tau})-i)"),
            "N/A",
            "slow field build-up (a further lag of the field: eddy currents, the iron's reluctance)",
        ));
    }
    for k in [0.03, 0.1] {
        let tau = num((k * s.tau).max(2.0 * s.dt));
        l.push(t(
            format!("i*sign(v)*exp(-tc/{tau})"),
            "N/A",
            "slow field build-up after a command step",
        ));
    }
    l
}

/// Wavelengths scanned for a force periodic in position, as fractions of the stroke scale `Scales::x`
/// (longer is a smooth function of position, which the library's powers cover).
const RIPPLE_SHORTEST: f64 = 1.0 / 300.0;
const RIPPLE_LONGEST: f64 = 1.0 / 3.0;
/// Steps of the scan's log grid, then of its refinement around the best wavelength.
const RIPPLE_GRID: usize = 240;
const RIPPLE_REFINE: usize = 40;
/// Most samples the wavelength scan reads (every k-th beyond).
const RIPPLE_SAMPLES: usize = 20_000;

/// The pair `sin(x/L)`, `cos(x/L)` of a force periodic in position (cogging, a detent's ripple) whose
/// wavelength `2πL` best explains `target` (weights `w`): the peak of the residual's periodogram against
/// displacement on a log grid of wavelengths, refined around it.
fn ripple_terms(s: Scales, tests: &[Test], target: &[f64], w: &[f64]) -> Vec<LibraryTerm> {
    let xs: Vec<f64> = tests
        .iter()
        .flat_map(|t| t.inputs.iter().map(|i| i.x_m))
        .collect();
    let stride = xs.len().div_ceil(RIPPLE_SAMPLES).max(1);
    let pts: Vec<(f64, f64)> = (0..xs.len())
        .step_by(stride)
        .filter(|&k| w[k] != 0.0)
        .map(|k| (xs[k], target[k]))
        .collect();
    if pts.len() < 100 {
        return Vec::new();
    }
    // The share of the residual's energy a sine and cosine pair of wavenumber `q` (rad/m) explains.
    let power = |q: f64| -> f64 {
        let (mut ss, mut cc, mut sc, mut rs, mut rc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(x, r) in &pts {
            let (sn, cs) = (q * x).sin_cos();
            ss += sn * sn;
            cc += cs * cs;
            sc += sn * cs;
            rs += r * sn;
            rc += r * cs;
        }
        // Least squares on the pair: [ss sc; sc cc] β = [rs; rc], explained energy β·[rs; rc].
        let det = ss * cc - sc * sc;
        if det <= 1e-12 * (ss * cc).max(f64::MIN_POSITIVE) {
            return 0.0;
        }
        (cc * rs * rs - 2.0 * sc * rs * rc + ss * rc * rc) / det
    };
    let (lo, hi) = (RIPPLE_SHORTEST * s.x, RIPPLE_LONGEST * s.x);
    let grid = |lo: f64, hi: f64, n: usize| -> Vec<f64> {
        (0..n)
            .map(|k| lo * (hi / lo).powf(k as f64 / (n - 1) as f64))
            .collect()
    };
    let best = |lams: Vec<f64>| -> (f64, f64) {
        lams.into_par_iter()
            .map(|lam| (power(std::f64::consts::TAU / lam), lam))
            .reduce(|| (f64::NEG_INFINITY, lo), |a, b| if b.0 > a.0 { b } else { a })
    };
    let (_, lam) = best(grid(lo, hi, RIPPLE_GRID));
    let step = (hi / lo).powf(1.0 / (RIPPLE_GRID - 1) as f64);
    let (_, lam) = best(grid(lam / step, lam * step, RIPPLE_REFINE));
    // Four digits: a wavelength's error grows into a phase error over the stroke.
    let l = plain(lam / std::f64::consts::TAU, 4.0);
    let family = ripple_family("sin(x/").unwrap_or_default();
    ["sin", "cos"]
        .map(|f| LibraryTerm {
            feature: format!("{f}(x/{l})"),
            coef_unit: "N".into(),
            family,
        })
        .into()
}

/// The lagged current (the model's own excitation state) at every sample of every test.
pub(crate) fn lagged_current(model: &Model, p: &[f64], tests: &[Test]) -> Vec<Vec<f64>> {
    tests.iter().map(|t| current_over(model, p, &t.inputs)).collect()
}

/// The lagged current over each test's drive ([`Test::drive_inputs`]): what a term of the model is fed
/// when its force is predicted through the acquisition chain.
pub(crate) fn driven_current(model: &Model, p: &[f64], tests: &[Test]) -> Vec<Vec<f64>> {
    tests
        .iter()
        .map(|t| current_over(model, p, t.drive_inputs(t.len())))
        .collect()
}

fn current_over(model: &Model, p: &[f64], inputs: &[Inputs]) -> Vec<f64> {
    let mut out = vec![0.0; inputs.len()];
    let mut states = Vec::new();
    model.simulate_recording(p, inputs, &mut out, &mut states);
    let ns = model.n_states();
    inputs
        .iter()
        .enumerate()
        .map(|(k, inp)| model.eval(p, &states[k * ns..(k + 1) * ns], inp).current_a)
        .collect()
}

/// A library term's force as the file would show it, at every sample of every test (concatenated test
/// after test): the term over the test's drive with the [`driven_current`] `current`, through the test's
/// acquisition chain ([`Test::observed`]), as the model's own force is compared. A term judged on the
/// logged signals instead would not be the force a fit of the term makes on filtered data.
fn column(term: &str, tests: &[Test], current: &[Vec<f64>]) -> Option<Vec<f64>> {
    let f = Formula::parse(term, &[]).ok()?;
    let mut out = Vec::new();
    for (t, i) in tests.iter().zip(current) {
        out.extend(t.observed(f.series(t.drive_inputs(t.len()), i)));
    }
    out.iter().all(|v| v.is_finite()).then_some(out)
}

/// Smallest share of the residual's energy a term must explain to be kept by the forward regression.
const MIN_ERR: f64 = 0.02;
/// Most terms a discovered effect has.
const MAX_TERMS: usize = 3;

/// The current model's directions of change: at every sample of every test (concatenated), the change of
/// the force the fit sees (through each test's drive and acquisition chain, [`evaluate`]) with each
/// parameter, by a forward difference from `pred`, the prediction at `p` (backward at an upper bound). The
/// term search scores a candidate only on what these cannot make: refitted beside the term, the model takes
/// the rest.
pub(crate) fn model_directions(model: &Model, p: &[f64], tests: &[Test], pred: &[Vec<f64>]) -> Vec<Vec<f64>> {
    model
        .param_specs()
        .iter()
        .enumerate()
        .filter_map(|(k, s)| {
            let span = Some(s.upper - s.lower).filter(|d| d.is_finite()).unwrap_or(1.0);
            let h = 1e-5 * p[k].abs().max(1e-3 * span).max(1e-9);
            let h = if p[k] + h > s.upper { -h } else { h };
            let mut q = p.to_vec();
            q[k] += h;
            let moved = evaluate(model, &q, tests);
            let d: Vec<f64> = moved
                .iter()
                .flatten()
                .zip(pred.iter().flatten())
                .map(|(b, a)| (b - a) / h)
                .collect();
            d.iter().all(|v| v.is_finite()).then_some(d)
        })
        .collect()
}

/// The term a forward regression (FROLS) finds in the residual `f − pred` of the current model:
/// a data-defined effect named `name` with a coefficient per kept library term (initial guesses their
/// least-squares values beside the model's `directions`), or `None` when no term explains [`MIN_ERR`] of
/// it. Each candidate is orthogonalised against the model's directions of change first
/// ([`model_directions`]), as a regression with terms already in the model starts: a term is judged by
/// what it adds to the model, not by what it shares with it. `current` is the [`driven_current`]: the terms
/// are taken through each test's acquisition chain, as the model's force is.
pub(crate) fn propose_term(
    name: &str,
    tests: &[Test],
    pred: &[Vec<f64>],
    current: &[Vec<f64>],
    directions: Vec<Vec<f64>>,
    lib: &[LibraryTerm],
) -> Option<FormulaEffect> {
    // The force the term must add: measured − predicted, on the samples that count.
    let mut target = Vec::new();
    let mut w = Vec::new();
    for (t, p) in tests.iter().zip(pred) {
        let dw = direction_weights(t);
        for k in 0..t.len() {
            let r = t.f_n[k] - p[k];
            let ok = dw[k] != 0.0 && r.is_finite();
            target.push(if ok { r } else { 0.0 });
            w.push(if ok { 1.0 } else { 0.0 });
        }
    }
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let rr = dot(&target, &target);
    if rr <= 0.0 {
        return None;
    }
    // The library and the pair periodic in position at the wavelength this residual shows.
    let lib: Vec<LibraryTerm> = lib
        .iter()
        .cloned()
        .chain(ripple_terms(Scales::of(tests), tests, &target, &w))
        .collect();
    // A library term's column over the samples that count; `None` where it is not finite everywhere.
    let weighted = |j: usize| -> Option<Vec<f64>> {
        let c = column(&lib[j].feature, tests, current)?;
        Some(c.iter().zip(&w).map(|(a, b)| a * b).collect())
    };
    // A column orthogonalised against the chosen terms, and the share of the residual's energy it explains
    // (`None` when the chosen terms already span it: it adds nothing).
    let orthogonal = |c: &[f64], basis: &[Vec<f64>]| -> Option<(f64, Vec<f64>)> {
        let mut q = c.to_vec();
        for b in basis {
            let k = dot(&q, b) / dot(b, b);
            q.iter_mut().zip(b).for_each(|(q, b)| *q -= k * b);
        }
        let qq = dot(&q, &q);
        if qq <= 1e-10 * dot(c, c) || qq <= 0.0 {
            return None;
        }
        Some((dot(&q, &target).powi(2) / (qq * rr), q))
    };
    // The model's own directions open the basis (weighted and orthogonalised in place, so that no second
    // copy of them is held); those the others already span add nothing.
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for mut c in directions {
        c.iter_mut().zip(&w).for_each(|(c, w)| *c *= w);
        if let Some((_, q)) = orthogonal(&c, &basis) {
            basis.push(q);
        }
    }
    let n_model = basis.len();
    // The columns are computed afresh in each round (in parallel, each dropped once scored) rather than
    // held all at once: a library of ~50 terms would hold ~50 values per sample through the search, the
    // largest buffer of a diagnosis. Only the chosen terms' columns are kept.
    let first: Vec<Option<Option<f64>>> = (0..lib.len())
        .into_par_iter()
        .map(|j| weighted(j).map(|c| orthogonal(&c, &basis).map(|(err, _)| err)))
        .collect();
    // The library terms whose columns are finite; a candidate's index `ci` is its place in this list.
    let valid: Vec<usize> = (0..lib.len()).filter(|&j| first[j].is_some()).collect();
    let mut errs: Vec<Option<f64>> = first.into_iter().flatten().collect();
    let mut chosen: Vec<usize> = Vec::new();
    let mut raw: Vec<Vec<f64>> = Vec::new();
    while chosen.len() < MAX_TERMS {
        if !chosen.is_empty() {
            errs = (0..valid.len())
                .into_par_iter()
                .map(|ci| {
                    if chosen.contains(&ci) {
                        return None;
                    }
                    let c = weighted(valid[ci])?;
                    orthogonal(&c, &basis).map(|(err, _)| err)
                })
                .collect();
        }
        // The first candidate with the largest share, in library order.
        let best = errs
            .iter()
            .enumerate()
            .filter_map(|(ci, err)| err.filter(|_| !chosen.contains(&ci)).map(|err| (err, ci)))
            .reduce(|a, b| if b.0 > a.0 { b } else { a });
        match best {
            Some((err, ci)) if err >= MIN_ERR => {
                let Some(c) = weighted(valid[ci]) else { break };
                let Some((_, q)) = orthogonal(&c, &basis) else {
                    break;
                };
                chosen.push(ci);
                basis.push(q);
                raw.push(c);
            }
            _ => break,
        }
    }
    // The model's part of the basis spans its directions: the chosen terms' coefficients are fitted beside it.
    basis.truncate(n_model);
    if chosen.is_empty() {
        return None;
    }
    // Least-squares coefficients of the chosen (not orthogonalised) columns, fitted beside the model's
    // directions (the model's share of a term is the model's to take when refitted). A term chosen early can
    // end with a negligible share once the later terms are fitted beside it (they explain what it
    // explained): such a term is dropped and the rest refitted, so the effect keeps only terms that carry
    // force.
    let solve = |raw: &[Vec<f64>]| -> Option<DVector<f64>> {
        let cols: Vec<&Vec<f64>> = basis.iter().chain(raw).collect();
        let (n, m) = (cols.len(), raw.len());
        let mut ata = DMatrix::<f64>::zeros(n, n);
        let mut atb = DVector::<f64>::zeros(n);
        for a in 0..n {
            atb[a] = dot(cols[a], &target);
            for b in 0..n {
                ata[(a, b)] = dot(cols[a], cols[b]);
            }
        }
        let all = ata.lu().solve(&atb)?;
        Some(all.rows(n - m, m).into_owned())
    };
    let share =
        |raw: &[Vec<f64>], coef: &DVector<f64>, a: usize| coef[a].powi(2) * dot(&raw[a], &raw[a]) / rr;
    let mut coef = solve(&raw)?;
    while chosen.len() > 1 {
        let (weakest, s) = (0..chosen.len())
            .map(|a| (a, share(&raw, &coef, a)))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        if s >= MIN_ERR {
            break;
        }
        chosen.remove(weakest);
        raw.remove(weakest);
        coef = solve(&raw)?;
    }
    // Strongest term first: it names the family the effect resembles.
    let mut order: Vec<usize> = (0..chosen.len()).collect();
    order.sort_by(|&a, &b| share(&raw, &coef, b).total_cmp(&share(&raw, &coef, a)));
    drop(raw);
    let (chosen, coef): (Vec<usize>, Vec<f64>) = order.iter().map(|&a| (chosen[a], coef[a])).unzip();
    let mut params = Vec::new();
    let mut formula = Vec::new();
    let mut families = Vec::new();
    for (a, &ci) in chosen.iter().enumerate() {
        let term = &lib[valid[ci]];
        let c = coef[a];
        if !c.is_finite() {
            return None;
        }
        let pname = format!("{name}_c{}", a + 1);
        let bound = (1e3 * c.abs()).max(f64::MIN_POSITIVE);
        formula.push(format!("{pname} * {}", term.feature));
        families.push(term.family);
        params.push(FormulaParam {
            name: pname,
            unit: term.coef_unit.clone(),
            lower: -bound,
            upper: bound,
            guess: c,
            doc: format!("coefficient of {} ({})", term.feature, term.family),
        });
    }
    FormulaEffect::new(
        name,
        "force term found by the diagnosis's open search (FROLS over the candidate library)",
        families[0],
        &formula.join(" + "),
        params,
    )
    .ok()
}

/// The formula of a discovered effect with its fitted values and their units, e.g.
/// `310 N s^2/m^2 * v*abs(v)`.
pub fn readable(effect: &FormulaEffect, values: &[f64]) -> String {
    let mut text = effect.formula().to_string();
    for (p, v) in effect.declared_params().iter().zip(values) {
        text = text.replace(&p.name, &format!("{} {}", sig4(*v), p.unit));
    }
    text
}

/// The discovered effects as one effect named `name` (its parameters `NAME_c1`, `NAME_c2`, …, starting at
/// the values the effects carry), or `None` when there are none.
pub fn merged(name: &str, effects: &[FormulaEffect]) -> Option<FormulaEffect> {
    let mut parts = Vec::new();
    let mut params = Vec::new();
    for e in effects {
        for (p, feature) in e.declared_params().iter().zip(features_of(e)) {
            let mut p = p.clone();
            p.name = format!("{name}_c{}", params.len() + 1);
            parts.push(format!("{} * {feature}", p.name));
            params.push(p);
        }
    }
    if parts.is_empty() {
        return None;
    }
    let resembles: Vec<&str> = effects.iter().map(FormulaEffect::resembles).collect();
    FormulaEffect::new(
        name,
        "force term found by mrfeel diagnose's open search",
        &resembles.join("; "),
        &parts.join(" + "),
        params,
    )
    .ok()
}

/// The family of the term of `effect` that carries the most force with the coefficients `values` (its
/// share `c² Σ term²` over `tests`, with the [`driven_current`] `current`), or `None` when none of its terms
/// is in the library. Read from the final fit, not from the search's least-squares proposal: once the
/// model's own parameters are refitted beside the terms, the force can move from one term to another.
pub(crate) fn strongest_family(
    effect: &FormulaEffect,
    values: &[f64],
    tests: &[Test],
    current: &[Vec<f64>],
) -> Option<&'static str> {
    let lib = library(Scales::of(tests));
    features_of(effect)
        .iter()
        .zip(values)
        .filter_map(|(f, c)| {
            let family = lib
                .iter()
                .find(|t| &t.feature == f)
                .map(|t| t.family)
                .or_else(|| ripple_family(f))?;
            let col = column(f, tests, current)?;
            Some((family, c * c * col.iter().map(|x| x * x).sum::<f64>()))
        })
        .filter(|(_, share)| share.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .map(|(family, _)| family)
}

/// The family of a term periodic in position (`ripple_terms`), whose wavelength the residual chose.
fn ripple_family(feature: &str) -> Option<&'static str> {
    (feature.starts_with("sin(x/") || feature.starts_with("cos(x/"))
        .then_some("force periodic in position (cogging, a screw's lead, detent ripple)")
}

/// The library terms of a discovered effect (its formula is `c1 * term1 + c2 * term2 …`).
pub(crate) fn features_of(effect: &FormulaEffect) -> Vec<String> {
    effect
        .formula()
        .split(" + ")
        .zip(effect.declared_params())
        .map(|(part, p)| {
            part.strip_prefix(&format!("{} * ", p.name))
                .unwrap_or(part)
                .to_string()
        })
        .collect()
}

fn sig4(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let e = v.abs().log10().floor();
    if (-3.0..5.0).contains(&e) {
        let d = (3.0 - e).max(0.0) as usize;
        format!("{v:.d$}")
    } else {
        format!("{v:.3e}")
    }
}

/// What the final model's held-out residual is: structure a regressor predicts, or noise (`unexplained` in
/// the JSON when structure).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Verdict {
    /// Held-out NRMSE of the final model.
    pub heldout_nrmse: f64,
    /// Noise floor as an NRMSE.
    pub floor_nrmse: f64,
    /// Share of the held-out residual's mean square the regressor predicts out of sample (pooled over folds).
    pub predictable_share: f64,
    /// Where the held-out residual lives (regions, as for the base model).
    #[serde(rename = "where")]
    pub where_: Vec<super::residual::Region>,
    /// Signals whose features alone predict part of it (at least a fifth of the predictable share),
    /// strongest first, with their shares (names only in the JSON).
    #[serde(serialize_with = "names_only")]
    pub correlates_with: Vec<(String, f64)>,
    /// Structure is left (the residual is not noise).
    #[serde(skip)]
    pub structure: bool,
    /// The regressor had enough samples for its columns (ten a column) for its share to be read.
    #[serde(skip)]
    pub enough_samples: bool,
}

/// The names of `(name, share)` pairs, as a list.
fn names_only<S: serde::Serializer>(pairs: &[(String, f64)], s: S) -> Result<S::Ok, S::Error> {
    s.collect_seq(pairs.iter().map(|(name, _)| name))
}

impl Verdict {
    /// The regressor predicts the residual: its share is at least 5 % on enough samples. (Structure can be
    /// left without it: a held-out error far above the noise floor.)
    pub fn predicted(&self) -> bool {
        self.enough_samples && self.predictable_share >= MIN_PREDICTABLE_SHARE
    }
}

/// Smallest share of the held-out residual's mean square that must be predictable out of sample, in every
/// fold, for it to be called structure: below it, what a regressor with ~150 inputs finds in noise.
pub(crate) const MIN_PREDICTABLE_SHARE: f64 = 0.05;

/// Held-out error, as a multiple of the noise floor, beyond which what is left is structure whatever a
/// regressor predicts of it (a residual the signals cannot represent is still not noise).
pub(crate) const MAX_NOISE_RATIO: f64 = 1.3;

/// Most samples the verdict's regressor uses (every k-th beyond): a regular subsample measures its shares.
const VERDICT_SAMPLES: usize = 20_000;

/// Folds the verdict's regressor is cross-validated over.
const VERDICT_BLOCKS: usize = 4;

/// The verdict on the held-out residual `f − oof` of the final model (see the module documentation).
pub(crate) fn verdict(
    tests: &[Test],
    folds: &[Fold],
    oof: &[Vec<f64>],
    current: &[Vec<f64>],
    heldout_nrmse: f64,
    floor_nrmse: f64,
    at_floor: bool,
) -> Verdict {
    let s = Scales::of(tests);
    // The diagnosis's held-out residual (samples held out nowhere left out). The regressor is judged on
    // interleaved stretches of every test, each the motion's characteristic time long, dealt to the folds in
    // turn: whether the residual is predictable where the signals take values seen in training.
    let chunk = ((s.tau / s.dt).round() as usize).max(1);
    let mut fold_of: Vec<Vec<usize>> = tests.iter().map(|t| vec![usize::MAX; t.len()]).collect();
    for fold in folds {
        for sp in &fold.test {
            let of = fold_of[sp.test][sp.start..sp.end].iter_mut().zip(sp.start..);
            of.for_each(|(f, k)| *f = (k / chunk) % VERDICT_BLOCKS);
        }
    }
    let total: usize = tests.iter().map(Test::len).sum();
    let stride = total.div_ceil(VERDICT_SAMPLES).max(1);
    let shift = ((0.05 * s.tau / s.dt).round() as usize).clamp(1, 50);
    // Raw signals per sample: x, v, a, i, t, and copies shifted by ±shift samples.
    struct Row {
        fold: usize,
        r: f64,
        sig: [f64; 11],
        lp: [f64; 5],
    }
    /// The regressor's columns (functions of one sample's signals), and their indices by signal.
    type RowFeature = Box<dyn Fn(&Row) -> f64>;
    #[derive(Default)]
    struct Columns {
        groups: Vec<(String, Vec<usize>)>,
        feats: Vec<RowFeature>,
    }
    impl Columns {
        fn add(&mut self, g: &str, f: impl Fn(&Row) -> f64 + 'static) {
            let c = self.feats.len();
            self.feats.push(Box::new(f));
            match self.groups.iter_mut().find(|x| x.0 == g) {
                Some(x) => x.1.push(c),
                None => self.groups.push((g.to_string(), vec![c])),
            }
        }
    }
    let mut rows: Vec<Row> = Vec::new();
    // Low-pass v and x, and the direction function through lags of three time constants (a yield force
    // that builds up).
    let tau = num(s.tau.max(2.0 * s.dt));
    let low_pass: Vec<Option<Formula>> = [format!("lp(v,{tau})"), format!("lp(x,{tau})")]
        .into_iter()
        .chain([0.1, 0.3, 1.0].iter().map(|k| {
            let tau = num((k * s.tau).max(2.0 * s.dt));
            format!("lp(tanh(v/{}),{tau})", num(0.15 * s.v))
        }))
        .map(|f| Formula::parse(&f, &[]).ok())
        .collect();
    let mut k_all = 0usize;
    for (j, t) in tests.iter().enumerate() {
        let dw = direction_weights(t);
        let lp: Vec<Option<Vec<f64>>> = low_pass
            .iter()
            .map(|f| f.as_ref().map(|f| f.series(&t.inputs, &current[j])))
            .collect();
        let n = t.len();
        for k in 0..n {
            k_all += 1;
            if !(k_all - 1).is_multiple_of(stride) || fold_of[j][k] == usize::MAX || dw[k] == 0.0 {
                continue;
            }
            let r = t.f_n[k] - oof[j][k];
            if !r.is_finite() {
                continue;
            }
            let inp = &t.inputs[k];
            let back = &t.inputs[k.saturating_sub(shift)];
            let ahead = &t.inputs[(k + shift).min(n - 1)];
            rows.push(Row {
                fold: fold_of[j][k],
                r,
                sig: [
                    inp.x_m,
                    inp.v_m_s,
                    inp.a_m_s2,
                    current[j][k],
                    inp.t_s,
                    back.v_m_s,
                    ahead.v_m_s,
                    back.x_m,
                    ahead.x_m,
                    inp.current_cmd_a,
                    inp.current_cmd_a.abs() - current[j][k].abs(),
                ],
                lp: std::array::from_fn(|q| lp[q].as_ref().map_or(0.0, |l| l[k])),
            });
        }
    }
    let mut cols = Columns::default();
    let names = ["x", "v", "a", "i", "t"];
    let (vs, xs) = (s.v, s.x);
    // Smooth functions of each signal.
    for (k, g) in names.iter().enumerate() {
        cols.add(g, move |r| r.sig[k]);
        cols.add(g, move |r| r.sig[k].abs());
        cols.add(g, move |r| r.sig[k] * r.sig[k].abs());
        cols.add(g, move |r| r.sig[k].powi(3));
    }
    for sc in [0.03, 0.15, 0.5] {
        cols.add("v", move |r| (r.sig[1] / (sc * vs)).tanh());
        cols.add("v", move |r| r.sig[3].abs() * (r.sig[1] / (sc * vs)).tanh());
    }
    cols.add("x", move |r| (r.sig[0] / (0.3 * xs)).tanh());
    cols.add("i", |r| r.sig[3] * r.sig[1]);
    cols.add("i", |r| r.sig[3] * r.sig[0]);
    // The command and its lead over the lagged current (the lags' error at a current step).
    cols.add("i (command)", |r| r.sig[9]);
    cols.add("i (command)", |r| r.sig[10]);
    cols.add("i (command)", |r| r.sig[10] * r.sig[1].signum());
    cols.add("i (command)", |r| r.sig[10].abs());
    // Time-shifted copies and low-pass states: the force lagging or leading the motion.
    cols.add("v (shifted)", |r| r.sig[5]);
    cols.add("v (shifted)", |r| r.sig[6]);
    cols.add("x (shifted)", |r| r.sig[7]);
    cols.add("x (shifted)", |r| r.sig[8]);
    cols.add("v (low-pass)", |r| r.lp[0]);
    cols.add("x (low-pass)", |r| r.lp[1]);
    for q in 2..5 {
        cols.add("v (low-pass)", move |r| r.lp[q]);
        cols.add("v (low-pass)", move |r| r.sig[3].abs() * r.lp[q]);
    }
    // Piecewise-constant bins of each signal and of pairs of them.
    const B1: usize = 10;
    const B2: usize = 5;
    let edges = |k: usize, nb: usize| -> Vec<f64> {
        let all: Vec<f64> = rows.iter().map(|r| r.sig[k]).collect();
        if all.is_empty() {
            return Vec::new();
        }
        (1..nb)
            .map(|b| quantile(all.clone(), b as f64 / nb as f64))
            .collect()
    };
    let bin = |e: &[f64], v: f64| e.iter().filter(|&&x| v > x).count();
    for (k, g) in names.iter().enumerate() {
        let e = edges(k, B1);
        for b in 0..B1 {
            let e = e.clone();
            cols.add(g, move |r| f64::from(u8::from(bin(&e, r.sig[k]) == b)));
        }
    }
    for (k1, k2) in [(1usize, 0usize), (1, 3), (1, 2), (0, 4)] {
        let (e1, e2) = (edges(k1, B2), edges(k2, B2));
        let g = format!("{}×{}", names[k1], names[k2]);
        for b1 in 0..B2 {
            for b2 in 0..B2 {
                let (e1, e2) = (e1.clone(), e2.clone());
                cols.add(&g, move |r| {
                    f64::from(u8::from(bin(&e1, r.sig[k1]) == b1 && bin(&e2, r.sig[k2]) == b2))
                });
            }
        }
    }
    let Columns { groups, feats } = cols;
    let p = feats.len();
    let nf = VERDICT_BLOCKS;
    // Column scales (RMS), so one ridge penalty suits every column.
    let mut scale = vec![0.0; p];
    let mut x = vec![0.0; p];
    for r in &rows {
        for (c, f) in feats.iter().enumerate() {
            let v = f(r);
            scale[c] += v * v;
        }
    }
    let n = rows.len().max(1) as f64;
    scale.iter_mut().for_each(|s| *s = (*s / n).sqrt());
    // Gram matrix and right-hand side of each fold's held-out samples (the training ones: total − own).
    let mut gram = vec![DMatrix::<f64>::zeros(p + 1, p + 1); nf];
    let mut rhs = vec![DVector::<f64>::zeros(p + 1); nf];
    let mut rr = vec![0.0; nf];
    let mut count = vec![0usize; nf];
    // Most columns are bins, zero at most samples: only the non-zero ones are summed (adding a zero
    // product leaves a sum as it is, so the sums are the same numbers).
    let mut nz: Vec<usize> = Vec::with_capacity(p);
    for r in &rows {
        for (c, f) in feats.iter().enumerate() {
            x[c] = if scale[c] > 0.0 { f(r) / scale[c] } else { 0.0 };
        }
        nz.clear();
        nz.extend((0..p).filter(|&c| x[c] != 0.0));
        let fi = r.fold.min(nf - 1);
        let g = gram[fi].as_mut_slice();
        let ld = p + 1;
        for (ia, &a) in nz.iter().enumerate() {
            let xa = x[a];
            for &b in &nz[ia..] {
                g[a + b * ld] += xa * x[b];
            }
            g[a + p * ld] += xa;
            rhs[fi][a] += xa * r.r;
        }
        g[p + p * ld] += 1.0;
        rhs[fi][p] += r.r;
        rr[fi] += r.r * r.r;
        count[fi] += 1;
    }
    for g in &mut gram {
        for a in 0..=p {
            for b in 0..a {
                g[(a, b)] = g[(b, a)];
            }
        }
    }
    // Held-out sum of squared prediction errors of a ridge on the columns `cols` (+ intercept), per fold.
    let sse_with = |cols: &[usize]| -> Vec<f64> {
        let mut idx: Vec<usize> = cols.to_vec();
        idx.push(p);
        let m = idx.len();
        (0..nf)
            .map(|f| {
                let ntrain: usize = (0..nf).filter(|&o| o != f).map(|o| count[o]).sum();
                let lambda = 1e-2 * ntrain.max(1) as f64;
                let mut a = DMatrix::<f64>::zeros(m, m);
                let mut b = DVector::<f64>::zeros(m);
                for o in (0..nf).filter(|&o| o != f) {
                    for (ia, &ca) in idx.iter().enumerate() {
                        b[ia] += rhs[o][ca];
                        for (ib, &cb) in idx.iter().enumerate() {
                            a[(ia, ib)] += gram[o][(ca, cb)];
                        }
                    }
                }
                for d in 0..m - 1 {
                    a[(d, d)] += lambda;
                }
                let Some(beta) = a.cholesky().map(|c| c.solve(&b)) else {
                    return rr[f];
                };
                // Σ (r − x·β)² on the held-out fold = rr − 2 β·(Xᵀr) + βᵀ (XᵀX) β.
                let mut bt = 0.0;
                let mut quad = 0.0;
                for (ia, &ca) in idx.iter().enumerate() {
                    bt += beta[ia] * rhs[f][ca];
                    for (ib, &cb) in idx.iter().enumerate() {
                        quad += beta[ia] * gram[f][(ca, cb)] * beta[ib];
                    }
                }
                (rr[f] - 2.0 * bt + quad).max(0.0)
            })
            .collect()
    };
    let share = |sse: &[f64]| 1.0 - sse.iter().sum::<f64>() / rr.iter().sum::<f64>().max(f64::MIN_POSITIVE);
    let all_cols: Vec<usize> = (0..p).collect();
    let sse = sse_with(&all_cols);
    let predictable_share = share(&sse);
    let mut correlates_with: Vec<(String, f64)> = groups
        .iter()
        .map(|(name, cols)| (name.clone(), share(&sse_with(cols))))
        .filter(|(_, sh)| *sh >= 0.2 * predictable_share && *sh > 0.01)
        .collect();
    correlates_with.sort_by(|a, b| b.1.total_cmp(&a.1));
    let mut v = Verdict {
        heldout_nrmse,
        floor_nrmse,
        predictable_share,
        correlates_with,
        structure: false,
        enough_samples: rows.len() > 10 * p,
        where_: Vec::new(),
    };
    v.structure = !at_floor && (v.predicted() || heldout_nrmse > MAX_NOISE_RATIO * floor_nrmse);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every library term parses as an effect formula, so a kept term can always be saved and loaded.
    #[test]
    fn every_library_term_is_a_valid_formula() {
        let s = Scales {
            v: 0.08,
            x: 0.01,
            tau: 0.12,
            dt: 1e-3,
        };
        for t in library(s) {
            Formula::parse(&t.feature, &[]).unwrap_or_else(|e| panic!("{}: {e}", t.feature));
        }
    }

    /// A residual made of two library terms (a force even in velocity and a spring odd in displacement,
    /// under current steps) is found as those two terms with their exact coefficients, and no third term
    /// joins them.
    #[test]
    fn a_residual_of_two_library_terms_is_found_as_them() {
        let (tests, current) = three_sine_groups();
        let lib = library(Scales::of(&tests));
        let truth = [("v^2".to_string(), 1000.0), ("x^3".to_string(), 2e6)];
        let mut tests = tests;
        for (j, t) in tests.iter_mut().enumerate() {
            let cur = std::slice::from_ref(&current[j]);
            let one = std::slice::from_ref(t);
            let mut f = vec![0.0; t.len()];
            for (term, c) in &truth {
                let col = column(term, one, cur).expect("finite");
                f.iter_mut().zip(col).for_each(|(f, x)| *f += c * x);
            }
            t.f_n = f;
        }
        let oof: Vec<Vec<f64>> = tests.iter().map(|t| vec![0.0; t.len()]).collect();
        let e = propose_term("term1", &tests, &oof, &current, Vec::new(), &lib).expect("a term");
        let features = features_of(&e);
        let mut want: Vec<&str> = truth.iter().map(|t| t.0.as_str()).collect();
        let mut got: Vec<&str> = features.iter().map(String::as_str).collect();
        want.sort_unstable();
        got.sort_unstable();
        assert_eq!(got, want, "{}", e.formula());
        for (p, f) in e.declared_params().iter().zip(&features) {
            let c = truth
                .iter()
                .find(|t| &t.0 == f)
                .map(|t| t.1)
                .expect("a true term");
            assert!((p.guess - c).abs() <= 1e-6 * c, "{f}: {} against {c}", p.guess);
        }
    }

    /// A model with viscous damping and friction, fitted, leaves of a shear-thinning force only the part
    /// its own terms cannot take. Read beside the model's directions, that residual is found as the
    /// shear-thinning term with the force's whole coefficient (the model gives back what it took when
    /// refitted); read alone, the term gets a coefficient far from it.
    #[test]
    fn a_term_the_model_partly_absorbed_is_found_with_its_whole_force() {
        let (mut tests, current) = three_sine_groups();
        let lib = library(Scales::of(&tests));
        let (term, c) = ("sign(v)*sqrt(abs(v))", 40.0);
        let col = |f: &str| column(f, &tests, &current).expect("finite");
        let (s, dirs) = (col(term), vec![col("v"), col("sign(v)")]);
        // The least-squares residual of `c s` on the model's directions.
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let g = DMatrix::from_fn(2, 2, |a, b| dot(&dirs[a], &dirs[b]));
        let rhs = DVector::from_fn(2, |a, _| c * dot(&dirs[a], &s));
        let k = g.lu().solve(&rhs).expect("independent directions");
        let mut at = 0;
        for t in &mut tests {
            t.f_n = (at..at + t.len())
                .map(|n| c * s[n] - k[0] * dirs[0][n] - k[1] * dirs[1][n])
                .collect();
            at += t.len();
        }
        let zero: Vec<Vec<f64>> = tests.iter().map(|t| vec![0.0; t.len()]).collect();
        let with = propose_term("term1", &tests, &zero, &current, dirs.clone(), &lib).expect("a term");
        assert_eq!(features_of(&with), [term], "{}", with.formula());
        let guess = with.declared_params()[0].guess;
        assert!((guess - c).abs() <= 1e-6 * c, "{guess} against {c}");
        let alone = propose_term("term1", &tests, &zero, &current, Vec::new(), &lib).expect("a term");
        let p = alone.declared_params();
        let at_term = features_of(&alone).iter().position(|f| f == term);
        assert!(
            at_term.is_none_or(|i| (p[i].guess - c).abs() > 0.2 * c),
            "{}",
            alone.formula()
        );
    }

    /// Three sine groups of falling amplitude and rising frequency under current steps, with zero force,
    /// and their commanded current.
    fn three_sine_groups() -> (Vec<Test>, Vec<Vec<f64>>) {
        let tests: Vec<Test> = (0..3)
            .map(|j| {
                let (a, f) = (0.02 / (1.0 + j as f64), 1.0 + j as f64);
                let mut inputs = crate::device::effects::testkit::sine(a, f, 0.0, 1e-3, 3.999);
                for (k, i) in inputs.iter_mut().enumerate() {
                    i.current_cmd_a = 2.0 * ((k / 700 + j) % 4) as f64;
                }
                let f_n = vec![0.0; inputs.len()];
                Test::synthetic(&format!("g{j}.csv"), &format!("g{j}"), inputs, f_n)
            })
            .collect();
        let current: Vec<Vec<f64>> = tests
            .iter()
            .map(|t| t.inputs.iter().map(|i| i.current_cmd_a).collect())
            .collect();
        (tests, current)
    }

    /// A force periodic in position, beside a larger smooth one and noise, is found at its wavelength (to
    /// a fraction of a percent, off the scan's grid) by the periodogram of the residual against x.
    #[test]
    fn a_ripple_in_position_is_found_at_its_wavelength() {
        let lam = 0.0037;
        let inputs = crate::device::effects::testkit::sine(0.02, 1.3, 0.0, 1e-3, 5.999);
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(12345);
        let target: Vec<f64> = inputs
            .iter()
            .map(|i| {
                let u = rng.random::<f64>() - 0.5;
                0.8 * (std::f64::consts::TAU * i.x_m / lam + 0.4).sin() + 3.0 * i.v_m_s.signum() + u
            })
            .collect();
        let t = Test::synthetic("r.csv", "r", inputs, target.clone());
        let tests = [t];
        let terms = ripple_terms(Scales::of(&tests), &tests, &target, &vec![1.0; target.len()]);
        assert_eq!(terms.len(), 2);
        let l: f64 = terms[0]
            .feature
            .trim_start_matches("sin(x/")
            .trim_end_matches(')')
            .parse()
            .expect("a number");
        let found = std::f64::consts::TAU * l;
        assert!(
            (found / lam - 1.0).abs() < 0.003,
            "wavelength {found} against {lam}"
        );
    }

    #[test]
    fn numbers_are_written_to_two_digits_without_exponents() {
        assert_eq!(num(6.000000000000001e-5), "0.000060");
        assert_eq!(num(0.1234), "0.12");
        assert_eq!(num(37.6), "38");
        assert_eq!(num(1234.0), "1234");
    }

    #[test]
    fn readable_formulas_carry_values_and_units() {
        let e = FormulaEffect::new(
            "term1",
            "",
            "",
            "term1_c1 * v*abs(v)",
            vec![FormulaParam {
                name: "term1_c1".into(),
                unit: "N s^2/m^2".into(),
                lower: -1e9,
                upper: 1e9,
                guess: 1.0,
                doc: String::new(),
            }],
        )
        .expect("builds");
        assert_eq!(readable(&e, &[310.4]), "310.4 N s^2/m^2 * v*abs(v)");
    }
}
