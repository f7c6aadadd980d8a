//! Naming the missing effect (`docs/explanation/diagnosis.md`): every registered effect not in the model is
//! added in turn, fitted, and judged by the error it removes on data its fit never saw (folds of test
//! groups, or time blocks of one test); the best significant one is kept and the search repeats; a final
//! backward pass drops any kept effect the others make redundant.
//!
//! Significance: a candidate lowers the held-out error in every fold and removes at least
//! [`DiagnoseOptions::min_gain`] of it and [`DiagnoseOptions::min_excess_removed`] of its part above the
//! noise floor (`super::residual::noise_floor_n`); the search ends within [`DiagnoseOptions::floor_ratio`]
//! of that floor. When no effect alone passes, the (at most two) that pass all but a fold are tried beside
//! every other effect: a pair counts when it is significant and also removes as much of the error each of
//! its effects alone leaves; the backward pass removes a pair only as a whole.

use std::collections::{BTreeMap, HashMap};
use std::sync::Mutex;

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;

use super::discover::{
    driven_current, lagged_current, library, model_directions, propose_term, readable, verdict, Scales,
    Verdict,
};
use super::fit::{fit, span_stats, FitOptions, Span};
use super::residual::{direction_weights, noise_floor_n, where_regions, Region, Signatures};
use super::validate::{evaluate, Figures};
use super::{IdentError, Test};
use crate::device::formula::FormulaEffect;
use crate::device::{Base, Effect, Model, ModelSpec, Registry};
use crate::signal::quantile;

/// Settings of a diagnosis.
#[derive(Debug, Clone)]
pub struct DiagnoseOptions {
    /// Driver saturation for every model, A.
    pub current_limit_a: f64,
    /// Smallest fraction of the held-out mean-square error an effect must remove.
    pub min_gain: f64,
    /// Smallest fraction of the held-out mean-square error above the noise floor an effect must remove. A
    /// tenth: where the model's form of an effect differs from the device's (Dahl against Bouc–Wen
    /// hysteresis), that difference is most of what is left, and a true second effect removes little of it.
    pub min_excess_removed: f64,
    /// Stop adding once held-out RMSE ≤ this × the noise floor (1.05; below it the significance rules alone
    /// keep a right model from being "improved").
    pub floor_ratio: f64,
    /// Time blocks for a single test.
    pub blocks: usize,
    /// Most folds over groups of tests.
    pub max_folds: usize,
    /// Options of the fits on all data (base and final model).
    pub fit: FitOptions,
    /// Convergence tolerance of the cross-validation fits: a held-out judgment at the
    /// [`DiagnoseOptions::min_gain`] level does not need a reported fit's, and each candidate costs a fit per fold.
    pub cv_tol: f64,
    /// Show a progress bar on stderr (hidden when stderr is not a terminal).
    pub progress: bool,
    /// Search the library of candidate force terms beside the named effects ([`super::discover`]);
    /// `mrfeel diagnose` turns it on unless `--named-only`.
    pub open_search: bool,
}

impl DiagnoseOptions {
    /// The folds the diagnosis judges held-out errors on ([`make_folds`]) and how they were made.
    pub fn folds(&self, tests: &[Test]) -> (Vec<Fold>, String) {
        make_folds(tests, self.blocks, self.max_folds)
    }

    /// The options of the diagnosis's cross-validation fits: no standard errors, tolerance `cv_tol`.
    pub fn cv_fit(&self) -> FitOptions {
        FitOptions {
            tol: self.cv_tol,
            std_errors: false,
            ..self.fit.clone()
        }
    }
}

impl Default for DiagnoseOptions {
    fn default() -> Self {
        Self {
            current_limit_a: crate::device::PAPER_CURRENT_LIMIT_A,
            min_gain: 0.05,
            min_excess_removed: 0.1,
            floor_ratio: 1.05,
            blocks: 4,
            max_folds: 5,
            fit: FitOptions::default(),
            cv_tol: 1e-5,
            progress: false,
            open_search: false,
        }
    }
}

/// One cross-validation fold: the samples fitted and the samples scored.
#[derive(Debug, Clone)]
pub struct Fold {
    /// The samples fitted.
    pub train: Vec<Span>,
    /// The samples held out and scored.
    pub test: Vec<Span>,
    /// What is held out, for tables (a test group or a part of each test).
    pub label: String,
}

/// The folds for these tests and a sentence saying how they were made.
pub fn make_folds(tests: &[Test], blocks: usize, max_folds: usize) -> (Vec<Fold>, String) {
    if tests.len() == 1 {
        let (folds, k) = time_block_folds(tests, blocks);
        return (
            folds,
            format!("blocked cross-validation over {k} contiguous time blocks of the one test"),
        );
    }
    // Groups in order of first appearance.
    let mut groups: Vec<String> = Vec::new();
    let mut key: Vec<usize> = Vec::with_capacity(tests.len());
    for t in tests {
        let g = groups.iter().position(|g| *g == t.group).unwrap_or_else(|| {
            groups.push(t.group.clone());
            groups.len() - 1
        });
        key.push(g);
    }
    let mut kind = "group";
    // Names that group nothing: group by motion where that groups some tests (a held-out fold is then a motion
    // the fit never saw, at every current), else one group per test.
    if groups.len() < 2 || groups.len() == tests.len() {
        let sig: Vec<(f64, f64)> = tests.iter().map(motion_signature).collect();
        let motion = motion_groups(&sig);
        let n_motion = motion.iter().max().map_or(0, |m| m + 1);
        if n_motion >= 2 && n_motion < tests.len() {
            groups = (0..n_motion)
                .map(|g| {
                    let j = motion.iter().position(|&m| m == g).unwrap_or(0);
                    format!("±{:.2} mm, {:.3} m/s", sig[j].0 * 1e3, sig[j].1)
                })
                .collect();
            key = motion;
            kind = "motion group";
        } else {
            groups = tests.iter().map(|t| t.name.clone()).collect();
            key = (0..tests.len()).collect();
            kind = "test";
        }
    }
    let ng = groups.len();
    if ng == 2 {
        // Two groups: a fold fitted on one has seen one motion only, where effects that differ elsewhere (a
        // spring and a mass on one sine) cannot be told apart. Hold out a time block of every test instead.
        let (folds, k) = time_block_folds(tests, blocks);
        return (
            folds,
            format!(
                "blocked cross-validation over {k} contiguous time blocks of every test (only two {kind}s: {})",
                groups.join("; ")
            ),
        );
    }
    let k = ng.min(max_folds.max(2));
    let whole = super::fit::all_spans(tests);
    let folds = (0..k)
        .map(|f| {
            let (test, train): (Vec<Span>, Vec<Span>) = whole.iter().partition(|s| key[s.test] % k == f);
            let label = if ng == k {
                format!("{kind} {}", groups[f])
            } else {
                format!("fold {}/{k}", f + 1)
            };
            Fold { train, test, label }
        })
        .collect();
    let how = if ng == k && kind != "test" {
        format!("leave one {kind} out over {k} {kind}s ({})", groups.join("; "))
    } else if ng == k {
        format!("leave one test out over {k} tests")
    } else {
        format!("{k}-fold over {ng} {kind}s")
    };
    (folds, how)
}

/// Folds that each hold out one of `blocks` contiguous time blocks of every test (block `b` of each test in
/// fold `b`) and fit the rest; the number of folds made is returned beside them.
fn time_block_folds(tests: &[Test], blocks: usize) -> (Vec<Fold>, usize) {
    let shortest = tests.iter().map(Test::len).min().unwrap_or(0);
    let k = blocks.clamp(2, shortest.max(2));
    let span = |j: usize, b: usize| {
        let n = tests[j].len();
        Span {
            test: j,
            start: b * n / k,
            end: (b + 1) * n / k,
        }
    };
    let folds = (0..k)
        .map(|b| Fold {
            train: (0..tests.len())
                .flat_map(|j| (0..k).filter(move |&c| c != b).map(move |c| (j, c)))
                .map(|(j, c)| span(j, c))
                .collect(),
            test: (0..tests.len()).map(|j| span(j, b)).collect(),
            label: format!("block {}/{k}", b + 1),
        })
        .collect();
    (folds, k)
}

/// A test's motion: the 99th percentiles of |x| and |v| (m, m/s), robust to a few spikes of noise.
fn motion_signature(t: &Test) -> (f64, f64) {
    if t.inputs.is_empty() {
        return (0.0, 0.0);
    }
    (
        quantile(t.inputs.iter().map(|i| i.x_m.abs()).collect(), 0.99),
        quantile(t.inputs.iter().map(|i| i.v_m_s.abs()).collect(), 0.99),
    )
}

/// Tests with the same motion signature (amplitude and speed within 5 %), labelled 0, 1, … in order of first
/// appearance.
fn motion_groups(sig: &[(f64, f64)]) -> Vec<usize> {
    let close = |a: f64, b: f64| (a - b).abs() <= 0.05 * a.abs().max(b.abs());
    let mut label = vec![usize::MAX; sig.len()];
    let mut next = 0;
    for j in 0..sig.len() {
        if label[j] != usize::MAX {
            continue;
        }
        label[j] = next;
        for i in j + 1..sig.len() {
            if label[i] == usize::MAX && close(sig[i].0, sig[j].0) && close(sig[i].1, sig[j].1) {
                label[i] = next;
            }
        }
        next += 1;
    }
    label
}

/// Held-out performance of one model spec.
#[derive(Debug, Clone)]
pub struct CvResult {
    /// The model judged.
    pub spec: ModelSpec,
    /// Held-out figures of each fold.
    pub per_fold: Vec<Figures>,
    /// Held-out figures over all folds.
    pub total: Figures,
    /// Fitted parameters of each fold's model (for warm starts).
    pub fold_params: Vec<Vec<f64>>,
    /// Each fold's fitted loss on its training samples ([`crate::ident::fit::FitResult::loss`]), N².
    pub fold_train_loss: Vec<f64>,
    /// Out-of-fold prediction at every sample (each scored by one fold); empty where shed (until chosen).
    pub oof: Vec<Vec<f64>>,
    /// The signatures of the held-out residual, kept when `oof` was shed.
    pub(crate) sig: Option<Signatures>,
}

impl CvResult {
    /// Held-out NRMSE over all folds.
    pub fn heldout_nrmse(&self) -> f64 {
        self.total.nrmse()
    }

    /// The same model fitted again (`other`): in each fold the fit with the lower *training* error, lower by
    /// more than `margin` (N²). `None` when no fold of `other` fits better.
    fn better_fits(&self, other: &CvResult, folds: &[Fold], margin: f64) -> Option<CvResult> {
        let better: Vec<usize> = (0..folds.len())
            .filter(|&f| other.fold_train_loss[f] < self.fold_train_loss[f] * (1.0 - 1e-9) - margin)
            .collect();
        if better.is_empty() {
            return None;
        }
        let mut out = self.clone();
        out.sig = None;
        for f in better {
            out.per_fold[f] = other.per_fold[f];
            out.fold_params[f] = other.fold_params[f].clone();
            out.fold_train_loss[f] = other.fold_train_loss[f];
            for s in &folds[f].test {
                out.oof[s.test][s.start..s.end].copy_from_slice(&other.oof[s.test][s.start..s.end]);
            }
        }
        out.total = Figures::total(&out.per_fold);
        Some(out)
    }

    /// Drop the per-sample held-out predictions, keeping their signatures (at most one candidate of a step
    /// needs them again: [`CvResult::restore_oof`]).
    fn shed_oof(&mut self, tests: &[Test]) {
        if !self.oof.is_empty() {
            self.sig = Some(Signatures::of(tests, &self.oof));
            self.oof = Vec::new();
        }
    }

    /// A copy without the held-out predictions (for the path the backward pass may return to).
    fn shed(&self, tests: &[Test]) -> CvResult {
        let mut out = self.clone();
        out.shed_oof(tests);
        out
    }

    /// The held-out predictions again where they were shed, simulated as [`cross_validate`] did.
    fn restore_oof(mut self, model: &Model, tests: &[Test], folds: &[Fold]) -> CvResult {
        if self.oof.is_empty() {
            let preds: Vec<Vec<(Span, Vec<f64>)>> = folds
                .par_iter()
                .zip(&self.fold_params)
                .map(|(fold, p)| {
                    fold.test
                        .iter()
                        .map(|s| (*s, heldout_prediction(model, p, tests, s)))
                        .collect()
                })
                .collect();
            self.oof = out_of_fold(tests, preds.into_iter().flatten());
            self.sig = None;
        }
        self
    }

    fn signatures(&self, tests: &[Test]) -> Signatures {
        self.sig.unwrap_or_else(|| Signatures::of(tests, &self.oof))
    }
}

/// Every sample of `tests` at NaN but those `preds` gives, each over its held-out span.
fn out_of_fold(tests: &[Test], preds: impl IntoIterator<Item = (Span, Vec<f64>)>) -> Vec<Vec<f64>> {
    let mut oof: Vec<Vec<f64>> = tests.iter().map(|t| vec![f64::NAN; t.len()]).collect();
    for (s, p) in preds {
        oof[s.test][s.start..s.end].copy_from_slice(&p);
    }
    oof
}

fn heldout_prediction(model: &Model, p: &[f64], tests: &[Test], s: &Span) -> Vec<f64> {
    let sim = tests[s.test].predict(model, p, s.end);
    sim[s.start..s.end].to_vec()
}

/// Starting values for `model` from a fitted `parent` (matching parameter names), the rest data-derived.
fn start_from(
    model: &Model,
    parent: Option<(&Model, &[f64])>,
    tests: &[Test],
    spans: &[Span],
) -> Option<Vec<f64>> {
    let (pm, pp) = parent?;
    let mut p = model.initial_guess(&span_stats(tests, spans));
    for (k, s) in model.param_specs().iter().enumerate() {
        if let Some(j) = pm.param_index(s.name) {
            p[k] = pp[j];
        }
    }
    Some(p)
}

/// Smallest fraction of the parent's training error a candidate's first stage must remove in a fold for the
/// second stage (every parameter) to run there.
const STAGE_TWO_MIN_GAIN: f64 = 0.01;

/// A fold's fitted parameters, training loss, held-out figures and held-out predictions.
type FoldOutcome = (Vec<f64>, f64, Figures, Vec<(Span, Vec<f64>)>);

/// Cross-validate one model over the folds (parallel over folds, results in fold order).
pub fn cross_validate(
    model: &Model,
    tests: &[Test],
    folds: &[Fold],
    parent: Option<(&Model, &CvResult)>,
    opts: &FitOptions,
    bar: &ProgressBar,
) -> CvResult {
    let weights: Vec<Vec<f64>> = tests.par_iter().map(direction_weights).collect();
    // With a fold for every thread the folds are the parallel work (see [`FitOptions::parallel`]). The same
    // numbers either way.
    let opts = &FitOptions {
        parallel: opts.parallel && folds.len() < rayon::current_num_threads(),
        ..opts.clone()
    };
    // The parent's parameters that the first stage holds: all but its linear gains.
    let inherited: Vec<usize> = match parent {
        Some((pm, _)) => model
            .param_specs()
            .iter()
            .enumerate()
            .filter(|(k, s)| pm.param_index(s.name).is_some() && !model.linear_gains().contains(k))
            .map(|(k, _)| k)
            .collect(),
        None => Vec::new(),
    };
    let staged = !inherited.is_empty() && inherited.len() + model.linear_gains().len() < model.n_params();
    let out: Vec<FoldOutcome> = folds
        .par_iter()
        .enumerate()
        .map(|(fi, fold)| {
            let start = start_from(
                model,
                parent.map(|(m, cv)| (m, cv.fold_params[fi].as_slice())),
                tests,
                &fold.train,
            );
            let fit_from = |start: Option<Vec<f64>>, hold: Vec<usize>| {
                let opts = FitOptions {
                    start,
                    hold,
                    std_errors: false,
                    ..opts.clone()
                };
                fit(model, tests, &fold.train, &opts)
            };
            // Staged: first the new effect's parameters with the base's linear gains (the rest held at the
            // parent's fit of this fold), then all from there: fewer simulations, the same verdicts.
            let fr = match start {
                Some(p0) if staged => {
                    let first = fit_from(Some(p0), inherited.clone());
                    // An effect that removes less than `STAGE_TWO_MIN_GAIN` of the parent's training error with
                    // its own parameters free is not in these data: no whole-model fit for it.
                    let parent_loss = parent.map(|(_, cv)| cv.fold_train_loss[fi]);
                    if parent_loss.is_some_and(|pl| first.loss > (1.0 - STAGE_TWO_MIN_GAIN) * pl) {
                        first
                    } else {
                        fit_from(Some(first.params), opts.hold.clone())
                    }
                }
                other => fit_from(other, opts.hold.clone()),
            };
            let mut fig = Figures::default();
            let mut preds = Vec::new();
            for s in &fold.test {
                let p = heldout_prediction(model, &fr.params, tests, s);
                let w = &weights[s.test][s.start..s.end];
                fig.add(&Figures::of_weighted(&p, &tests[s.test].f_n[s.start..s.end], w));
                preds.push((*s, p));
            }
            bar.inc(1);
            (fr.params, fr.loss, fig, preds)
        })
        .collect();
    let (mut per_fold, mut fold_params, mut fold_train_loss, mut preds) = (vec![], vec![], vec![], vec![]);
    for (p, loss, fig, pr) in out {
        per_fold.push(fig);
        fold_params.push(p);
        fold_train_loss.push(loss);
        preds.extend(pr);
    }
    CvResult {
        spec: model.spec().clone(),
        total: Figures::total(&per_fold),
        per_fold,
        fold_params,
        fold_train_loss,
        oof: out_of_fold(tests, preds),
        sig: None,
    }
}

/// One candidate effect judged against the model it would extend (an entry of `candidates` in the JSON).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Candidate {
    /// Effect name (`a+b` for a pair, the formula for an open-search term).
    pub effect: String,
    /// Held-out NRMSE of the model with the effect.
    pub heldout_nrmse: f64,
    /// 1 − held-out NRMSE / the held-out NRMSE of the model it extends.
    pub improvement: f64,
    /// Whether the improvement passed the significance test over the folds.
    pub significant: bool,
    /// The signature in the residual that suggested the effect, in words.
    pub evidence: String,
    /// Folds in which it lowered the held-out error, of all folds.
    #[serde(skip)]
    pub folds_better: usize,
    /// Folds judged.
    #[serde(skip)]
    pub folds: usize,
}

/// One step of the search: the model and its held-out error (an entry of `steps` in the JSON).
#[derive(Debug, Clone, serde::Serialize)]
pub struct StepResult {
    /// Model spec at this step.
    pub model: String,
    /// The effect this step added, if any.
    #[serde(skip)]
    pub added: Option<String>,
    /// Held-out NRMSE of the model.
    pub heldout_nrmse: f64,
    /// Candidates tried at this step (best first).
    #[serde(skip)]
    pub candidates: Vec<Candidate>,
    /// Pairs of effects tried at this step because no effect alone was significant (best first; `effect` is
    /// `a+b`).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub pairs: Vec<Candidate>,
    /// The term the open search proposed at this step, judged like the named effects (`effect` is its
    /// formula).
    #[serde(skip)]
    pub term: Option<Candidate>,
}

/// A force term outside the vocabulary that the diagnosis added (an entry of `discovered` in the JSON).
#[derive(Debug, Clone, serde::Serialize)]
pub struct Discovered {
    /// The term's name, as `--save-effect` writes it.
    pub name: String,
    /// The formula with the final fit's values and their units.
    pub formula: String,
    /// The library terms it is made of.
    pub features: Vec<String>,
    /// Held-out NRMSE of the model it completed.
    pub heldout_nrmse: f64,
    /// Share of the previous model's held-out NRMSE it removed.
    pub improvement: f64,
    /// The physical family its strongest term most resembles.
    pub resembles: String,
    /// The effect, its guesses set to the final fit's values (what `--save-effect` writes).
    #[serde(skip)]
    pub effect: FormulaEffect,
}

/// Everything a diagnosis found.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    /// The starting model's spec.
    pub base_model: String,
    /// Samples scored.
    pub samples: usize,
    /// Base model fitted on all data: NRMSE.
    pub base_fit_nrmse: f64,
    /// Base model fitted on all data: RMS force error, N.
    pub base_fit_rmse_n: f64,
    /// Base model's held-out NRMSE.
    pub base_heldout_nrmse: f64,
    /// Base model's parameters fitted on all data.
    pub base_params: Vec<f64>,
    /// Base-model prediction (fitted on all data) at every sample.
    pub base_pred: Vec<Vec<f64>>,
    /// Where in the motion the base model's error concentrates.
    pub where_: Vec<Region>,
    /// Candidates against the base model, best first.
    pub candidates: Vec<Candidate>,
    /// Effects the diagnosis adds, in the order added (empty: the residual is noise).
    pub missing: Vec<String>,
    /// Effects the backward pass removed again (made redundant by effects added later).
    pub pruned: Vec<String>,
    /// The final model's spec.
    pub final_model: String,
    /// The final model's held-out NRMSE.
    pub final_heldout_nrmse: f64,
    /// Final model fitted on all data.
    pub final_params: Vec<f64>,
    /// Final-model prediction (fitted on all data) at every sample, N.
    pub final_pred: Vec<Vec<f64>>,
    /// Final model fitted on all data: NRMSE.
    pub final_fit_nrmse: f64,
    /// Every step of the search.
    pub steps: Vec<StepResult>,
    /// How the data was split for held-out errors.
    pub cv_scheme: String,
    /// Held-out NRMSE the measurement noise alone would give.
    pub noise_floor_nrmse: f64,
    /// The final model's held-out prediction at every sample (each sample from the fold that held it out).
    pub final_oof: Vec<Vec<f64>>,
    /// Terms outside the vocabulary the diagnosis added, in the order added.
    pub discovered: Vec<Discovered>,
    /// What the final model's held-out residual is: structure or noise.
    pub verdict: Verdict,
    /// The registry the final model was built from (the given one plus the discovered terms).
    pub registry: Registry,
    /// The bases the diagnosis tried, the one it carried on from marked (one entry when the base was
    /// given: [`diagnose`]; each base with [`diagnose_choosing_base`]).
    pub bases: Vec<BaseTried>,
}

/// A base model the diagnosis tried, with its held-out figures (an entry of `bases_tried` in the JSON).
#[derive(Debug, Clone, serde::Serialize)]
pub struct BaseTried {
    /// The base's spec (`bingham`, `spencer`).
    pub model: String,
    /// Held-out NRMSE of the base alone (`None`: not fitted; `note` says why).
    pub heldout_nrmse: Option<f64>,
    /// The model a diagnosis from this base ended with, when one ran.
    pub final_model: Option<String>,
    /// Its held-out NRMSE.
    pub final_heldout_nrmse: Option<f64>,
    /// Whether the diagnosis carries on from this base.
    pub chosen: bool,
    /// Why it was or was not chosen, in words.
    pub note: String,
}

impl BaseTried {
    fn new(
        spec: &ModelSpec,
        heldout: Option<f64>,
        ended: Option<&Diagnosis>,
        chosen: bool,
        note: String,
    ) -> Self {
        Self {
            model: spec.to_string(),
            heldout_nrmse: heldout,
            final_model: ended.map(|d| d.final_model.clone()),
            final_heldout_nrmse: ended.map(|d| d.final_heldout_nrmse),
            chosen,
            note,
        }
    }

    /// The base a diagnosis started from, chosen, with where it ended.
    fn started(spec: &ModelSpec, d: &Diagnosis, note: &str) -> Self {
        Self::new(spec, Some(d.base_heldout_nrmse), Some(d), true, note.into())
    }
}

impl StepResult {
    /// A step at `model` judged by `cv`, its candidates still to be tried.
    fn new(model: String, added: Option<String>, cv: &CvResult) -> Self {
        Self {
            model,
            added,
            heldout_nrmse: cv.heldout_nrmse(),
            candidates: Vec::new(),
            pairs: Vec::new(),
            term: None,
        }
    }
}

impl Diagnosis {
    /// The verdict when structure is left (`unexplained` in the JSON), else `None`.
    pub fn unexplained(&self) -> Option<&Verdict> {
        self.verdict.structure.then_some(&self.verdict)
    }
}

/// Run the diagnosis of `base` on `tests` with the effects of `registry`.
pub fn diagnose(
    tests: &[Test],
    base: &ModelSpec,
    registry: &Registry,
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, IdentError> {
    let (mut d, _) = diagnose_path(tests, base, registry, opts, None)?;
    d.bases = vec![BaseTried::started(base, &d, "the base given")];
    Ok(d)
}

/// The diagnosis from the base that ends best, when the user named none: from `bingham` first (whose effects
/// name what is missing); each further base ([`Base::ALL`]) carries the diagnosis on only when, alone, it is
/// significantly better held out overall (not in every fold: rival whole models are ranked by their held-out
/// error) than the model the diagnosis so far ended with (not the first base: a Bouc–Wen base would hide
/// the `hysteresis` that `bingham+hysteresis` names), and is kept when the diagnosis from it ends lower. A
/// further base is not fitted when nothing is left for it to explain, or a test is too short for it.
pub fn diagnose_choosing_base(
    tests: &[Test],
    registry: &Registry,
    opts: &DiagnoseOptions,
) -> Result<Diagnosis, IdentError> {
    let specs: Vec<ModelSpec> = Base::ALL
        .iter()
        .map(|&base| ModelSpec {
            base,
            effects: Vec::new(),
        })
        .collect();
    let Some((first, rest)) = specs.split_first() else {
        return Err(IdentError::Other("no base model to start from".into()));
    };
    let (mut best, mut best_cv) = diagnose_path(tests, first, registry, opts, None)?;
    let mut bases = vec![BaseTried::started(first, &best, "the default base")];
    let (folds, _) = opts.folds(tests);
    let noise = noise_floor_n(tests);
    let bar = progress_bar(opts);
    for spec in rest {
        let model = Model::new(spec, registry, opts.current_limit_a)?;
        let shortest = tests.iter().map(Test::len).min().unwrap_or(0);
        let skip = if best_cv.total.rmse_n() <= opts.floor_ratio * noise {
            Some(format!(
                "not fitted: {} ends at the noise floor, nothing is left for another base to explain",
                best.final_model
            ))
        } else if best.unexplained().is_none() {
            Some(format!(
                "not fitted: no structure is left in {}'s held-out residual for another base to explain",
                best.final_model
            ))
        } else if shortest < 2 * model.n_params() {
            Some(format!(
                "not fitted: a test of {shortest} samples is too short for its {} parameters",
                model.n_params()
            ))
        } else {
            None
        };
        if let Some(note) = skip {
            bases.push(BaseTried::new(spec, None, None, false, note));
            continue;
        }
        bar.set_message(format!("trying the base {spec}"));
        let cv = cross_validate(&model, tests, &folds, None, &opts.cv_fit(), &bar);
        super::stop_if_asked()?;
        let better = enough_removed(&best_cv, &cv, noise * noise, opts);
        let alone = Some(cv.heldout_nrmse());
        let note = format!(
            "alone {}significantly better held out than {} ({:.4} against {:.4}, lower in {} of {} folds)",
            if better { "" } else { "not " },
            best.final_model,
            cv.heldout_nrmse(),
            best_cv.heldout_nrmse(),
            folds_better(&best_cv, &cv),
            folds.len()
        );
        if !better {
            bases.push(BaseTried::new(spec, alone, None, false, note));
            continue;
        }
        let (d, dcv) = diagnose_path(tests, spec, registry, opts, Some(cv))?;
        let lower = dcv.total.sse < best_cv.total.sse;
        if lower {
            bases.iter_mut().for_each(|b| b.chosen = false);
            bases.push(BaseTried::new(spec, alone, Some(&d), true, note));
            (best, best_cv) = (d, dcv);
        } else {
            let note = format!("{note}; its diagnosis ended no lower held out");
            bases.push(BaseTried::new(spec, alone, Some(&d), false, note));
        }
    }
    bar.finish_and_clear();
    best.bases = bases;
    Ok(best)
}

/// A progress spinner on stderr when `opts.progress`, else hidden.
fn progress_bar(opts: &DiagnoseOptions) -> ProgressBar {
    if opts.progress {
        let b = ProgressBar::with_draw_target(None, ProgressDrawTarget::stderr());
        b.set_style(
            ProgressStyle::with_template("{spinner} {msg} [{elapsed_precise}] {pos} fits")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        b
    } else {
        ProgressBar::hidden()
    }
}

/// The diagnosis from `base`: named effects first, the open search only where none is significant. Where
/// that path named an effect and still ends with structure left, a second path lets a term compete with the
/// named effects at every step (a named effect can be significant beside a cause it only partly mimics), and
/// it is kept when it ends significantly lower held out.
fn diagnose_path(
    tests: &[Test],
    base: &ModelSpec,
    registry: &Registry,
    opts: &DiagnoseOptions,
    first: Option<CvResult>,
) -> Result<(Diagnosis, CvResult), IdentError> {
    let cache = CvCache::default();
    let (d, cv) = diagnose_from(tests, base, registry, opts, first.clone(), false, &cache)?;
    let named = !d.missing.is_empty() || !d.pruned.is_empty();
    if !opts.open_search || !named || d.unexplained().is_none() {
        return Ok((d, cv));
    }
    let (d2, cv2) = diagnose_from(tests, base, registry, opts, first, true, &cache)?;
    let noise = noise_floor_n(tests);
    Ok(if enough_removed(&cv, &cv2, noise * noise, opts) {
        (d2, cv2)
    } else {
        (d, cv)
    })
}

/// One diagnosis path from `base` ([`diagnose`]), its `bases` left empty, and the final model's held-out
/// result; `first`: the base's cross-validation on `opts.folds(tests)` with `opts.cv_fit()`, when already
/// made. With `term_competes`, the open search runs at every step and its term is added instead of the
/// significant named effect when it is significant and lower held out.
fn diagnose_from(
    tests: &[Test],
    base: &ModelSpec,
    registry: &Registry,
    opts: &DiagnoseOptions,
    first: Option<CvResult>,
    term_competes: bool,
    cache: &CvCache,
) -> Result<(Diagnosis, CvResult), IdentError> {
    if tests.is_empty() {
        return Err(IdentError::NoData);
    }
    // The given effects, and the terms the open search adds as it finds them.
    let mut reg = registry.clone();
    let build = |spec: &ModelSpec, reg: &Registry| Model::new(spec, reg, opts.current_limit_a);
    let base_model = build(base, &reg)?;
    let (folds, cv_scheme) = opts.folds(tests);
    let all: Vec<Span> = super::fit::all_spans(tests);
    let samples: usize = tests.iter().map(Test::len).sum();
    let f_ss: f64 = tests.iter().flat_map(|t| &t.f_n).map(|f| f * f).sum();
    let f_rms = (f_ss / samples.max(1) as f64).sqrt();
    let noise = noise_floor_n(tests);
    let cv_fit = opts.cv_fit();
    // Candidates cross-validated side by side keep each fit to one thread (see [`FitOptions::parallel`]).
    let side_by_side = FitOptions {
        parallel: false,
        ..cv_fit.clone()
    };

    let bar = progress_bar(opts);

    bar.set_message(format!("fitting {base}"));
    let base_fit = fit(&base_model, tests, &all, &opts.fit);
    let base_pred = evaluate(&base_model, &base_fit.params, tests);
    let where_ = where_regions(tests, &base_pred);
    // The lagged current the library's and the verdict's features read: the base model's excitation state,
    // over the logged samples for the verdict and over each test's drive for the library's terms (the same
    // where no test went through a filter).
    let current = lagged_current(&base_model, &base_fit.params, tests);
    let driven = tests
        .iter()
        .any(|t| t.drive.is_some())
        .then(|| driven_current(&base_model, &base_fit.params, tests));
    let term_current = driven.as_ref().unwrap_or(&current);
    let lib = library(Scales::of(tests));
    let mut discovered: Vec<(FormulaEffect, f64, f64)> = Vec::new();

    let mut cur_model = base_model;
    let mut cur = first.unwrap_or_else(|| cross_validate(&cur_model, tests, &folds, None, &cv_fit, &bar));
    let mut steps = vec![StepResult::new(base.to_string(), None, &cur)];
    let mut missing: Vec<String> = Vec::new();
    // The effects added at each step (one, or a pair), in order.
    let mut added_groups: Vec<Vec<String>> = Vec::new();
    // Held-out results of the models on the path, by spec, for the backward pass.
    let mut path_cv: BTreeMap<String, CvResult> = BTreeMap::new();
    path_cv.insert(cur.spec.to_string(), cur.shed(tests));
    let search = Search {
        tests,
        folds: &folds,
        cv_fit: &cv_fit,
        opts,
        noise,
        bar: &bar,
    };

    loop {
        // At the noise floor no candidate can be significant (`judge`): stop, once the base's own candidates
        // are ranked (the contract's `candidates`).
        if steps.len() > 1 && search.at_floor(&cur) {
            break;
        }
        let names: Vec<&'static str> = registry
            .names()
            .into_iter()
            .filter(|n| !cur.spec.has(n) && registry.get(n).is_some_and(|e| cur.spec.base.admits(e.stage())))
            .collect();
        if names.is_empty() {
            break;
        }
        // The extensions `specs` of the current model cross-validated from its fits, best first.
        let extend = |specs: Vec<ModelSpec>, cur: &CvResult| -> Result<Vec<(Model, CvResult)>, IdentError> {
            let done: Vec<Result<(Model, CvResult), IdentError>> = specs
                .par_iter()
                .map(|spec| {
                    let m = build(spec, &reg)?;
                    let cv = cache.get_or(&m, cur, registry, || {
                        let parent = Some((&cur_model, cur));
                        let mut cv = cross_validate(&m, tests, &folds, parent, &side_by_side, &bar);
                        cv.shed_oof(tests);
                        cv
                    });
                    Ok((m, cv))
                })
                .collect();
            let mut done: Vec<(Model, CvResult)> = done.into_iter().collect::<Result<_, _>>()?;
            done.sort_by(|a, b| a.1.total.sse.total_cmp(&b.1.total.sse));
            Ok(done)
        };
        bar.set_message(format!("trying {} effects on {}", names.len(), cur.spec));
        let mut tried = extend(names.iter().map(|n| cur.spec.with(n)).collect(), &cur)?;
        super::stop_if_asked()?;
        if search.refit_from_candidates(&mut cur, &cur_model, &tried) {
            path_cv.insert(cur.spec.to_string(), cur.shed(tests));
        }
        let mut cands = search.candidates(&cur, &tried, registry);
        let mut pairs: Vec<(Model, CvResult)> = Vec::new();
        let mut pair_cands: Vec<Candidate> = Vec::new();
        if !cands.iter().any(|c| c.significant) {
            // No effect alone is significant. Effects whose signatures coincide on these tests (a spring and a
            // mass at one frequency per group) are separable only together: an effect that removes enough of
            // the error overall but fails a fold is tried again with each other effect beside it.
            let seeds: Vec<usize> = (0..tried.len())
                .filter(|&i| search.promising(&cur, &tried[i].1))
                .take(PAIR_SEEDS)
                .collect();
            // From the current model's fits, both effects from their initial guesses: the seed's own fit has
            // taken its partner's part, the very thing the pair undoes.
            let mut jobs: Vec<ModelSpec> = Vec::new();
            for &si in &seeds {
                let seed_spec = tried[si].0.spec();
                for n in &names {
                    let twice = seeds
                        .iter()
                        .take_while(|&&o| o != si)
                        .any(|&o| tried[o].0.spec().has(n));
                    if !seed_spec.has(n) && !twice {
                        jobs.push(seed_spec.with(n));
                    }
                }
            }
            if !jobs.is_empty() {
                bar.set_message(format!("trying {} pairs of effects on {}", jobs.len(), cur.spec));
                pairs = extend(jobs, &cur)?;
                if search.refit_from_candidates(&mut cur, &cur_model, &pairs) {
                    path_cv.insert(cur.spec.to_string(), cur.shed(tests));
                    cands = search.candidates(&cur, &tried, registry);
                }
                pair_cands = search.candidates(&cur, &pairs, registry);
                for (c, (m, cv)) in pair_cands.iter_mut().zip(&pairs) {
                    c.significant &= search.beats_each_member(&cur, m, cv, &tried);
                }
            }
        }
        let named_choice = if let Some(bi) = cands.iter().position(|c| c.significant) {
            Some(tried.swap_remove(bi))
        } else if let Some(pi) = pair_cands.iter().position(|c| c.significant) {
            // The single fits of both members are on the path, for the backward pass.
            for (m, cv) in &tried {
                path_cv.insert(m.name(), cv.shed(tests));
            }
            Some(pairs.swap_remove(pi))
        } else {
            None
        };
        // The open search, where no named effect (or pair) is significant (on the second path, at every step):
        // a library term judged on the same folds by the same rules. Named effects come first because a term
        // fitted freely can take the parts of two named effects at once and beat each alone in one step.
        let mut term: Option<(Model, CvResult, FormulaEffect)> = None;
        let mut term_cand: Option<Candidate> = None;
        if opts.open_search && (named_choice.is_none() || term_competes) && !search.at_floor(&cur) {
            super::stop_if_asked()?;
            let name = next_term_name(&reg);
            // The search reads the residual of the model fitted to all the data, at whose optimum the
            // residual holds nothing along the model's own directions, the ones each candidate is cleared of.
            let start = Some(fold_median(&cur.fold_params));
            let full = fit(
                &cur_model,
                tests,
                &all,
                &FitOptions {
                    start,
                    ..cv_fit.clone()
                },
            );
            let pred = evaluate(&cur_model, &full.params, tests);
            let directions = model_directions(&cur_model, &full.params, tests, &pred);
            if let Some(effect) = propose_term(&name, tests, &pred, term_current, directions, &lib) {
                bar.set_message(format!("trying the term {} on {}", effect.formula(), cur.spec));
                let mut with = reg.clone();
                with.register(effect.clone());
                let m = build(&cur.spec.with(&name), &with)?;
                let cv = cross_validate(&m, tests, &folds, Some((&cur_model, &cur)), &cv_fit, &bar);
                term_cand = Some(search.candidate(
                    &cur,
                    &cv,
                    format!("{name} = {}", effect.formula()),
                    format!(
                        "found by forward regression beside the model's own terms; resembles {}",
                        effect.resembles()
                    ),
                ));
                term = Some((m, cv, effect));
            }
        }
        // The term where it is significant and, beside a significant named effect (second path only),
        // lower held out; else the significant named effect (or pair).
        let term_significant = term_cand.as_ref().is_some_and(|tc| tc.significant);
        if let Some(last) = steps.last_mut() {
            last.heldout_nrmse = cur.heldout_nrmse();
            (last.candidates, last.pairs, last.term) = (cands, pair_cands, term_cand);
        }
        let (m, cv, term_added) = match (named_choice, term) {
            (named, Some((m, cv, effect)))
                if term_significant && named.as_ref().is_none_or(|(_, ncv)| cv.total.sse < ncv.total.sse) =>
            {
                reg.register(effect.clone());
                (m, cv, Some(effect))
            }
            (Some((m, cv)), _) => {
                let cv = cv.restore_oof(&m, tests, &folds);
                (m, cv, None)
            }
            _ => break,
        };
        // Its folds were fitted from the current model's fits, staged; a fit from the data-derived start may
        // end lower. Each fold keeps the fit with the lower training error.
        bar.set_message(format!("fitting {} afresh", m.spec()));
        let whole_fit = FitOptions {
            std_errors: false,
            ..opts.fit.clone()
        };
        let fresh = cross_validate(&m, tests, &folds, None, &whole_fit, &bar);
        let cv = cv
            .better_fits(&fresh, &folds, refit_margin(&m, noise))
            .unwrap_or(cv);
        let added: Vec<String> = added_effects(&m, &cur.spec).into_iter().cloned().collect();
        match term_added {
            Some(effect) => discovered.push((effect, cv.heldout_nrmse(), improvement(&cur, &cv))),
            None => missing.extend(added.iter().cloned()),
        }
        added_groups.push(added.clone());
        steps.push(StepResult::new(m.name(), Some(added.join("+")), &cv));
        path_cv.insert(m.name(), cv.shed(tests));
        cur_model = m;
        cur = cv;
    }

    // Backward pass: drop an added effect (or pair, as a whole) whose removal does not significantly raise the
    // held-out error.
    let mut pruned = Vec::new();
    while added_groups.len() >= 2 {
        super::stop_if_asked()?;
        bar.set_message(format!(
            "checking each of {} added effects is still needed",
            missing.len()
        ));
        let without: Vec<Result<(usize, Model, CvResult), IdentError>> = added_groups
            .par_iter()
            .enumerate()
            .map(|(gi, group)| {
                let spec = ModelSpec {
                    base: cur.spec.base,
                    effects: cur
                        .spec
                        .effects
                        .iter()
                        .filter(|x| !group.contains(x))
                        .cloned()
                        .collect(),
                };
                let m = build(&spec, &reg)?;
                let cv = match path_cv.get(&spec.to_string()) {
                    Some(cv) => cv.clone(),
                    None => cross_validate(&m, tests, &folds, Some((&cur_model, &cur)), &side_by_side, &bar),
                };
                Ok((gi, m, cv))
            })
            .collect();
        let without: Vec<(usize, Model, CvResult)> = without.into_iter().collect::<Result<_, _>>()?;
        // The removal that costs least; drop it unless the full model is significantly better.
        let Some((gi, m, cv)) = without
            .into_iter()
            .min_by(|a, b| a.2.total.sse.total_cmp(&b.2.total.sse))
        else {
            break;
        };
        let (needed, _) = search.judge(&cv, &cur);
        if needed {
            break;
        }
        let group = added_groups.remove(gi);
        missing.retain(|x| !group.contains(x));
        discovered.retain(|(e, _, _)| !group.iter().any(|g| g == e.name()));
        pruned.extend(group);
        steps.push(StepResult::new(m.name(), None, &cv));
        cur = cv.restore_oof(&m, tests, &folds);
        cur_model = m;
    }

    super::stop_if_asked()?;
    bar.set_message(format!("fitting {}", cur.spec));
    let final_fit = fit(
        &cur_model,
        tests,
        &all,
        &FitOptions {
            start: start_from(
                &cur_model,
                Some((&build(base, &reg)?, &base_fit.params)),
                tests,
                &all,
            ),
            ..opts.fit.clone()
        },
    );
    let final_pred = evaluate(&cur_model, &final_fit.params, tests);
    bar.set_message("judging what is left");
    let noise_floor_nrmse = noise / f_rms.max(f64::MIN_POSITIVE);
    let mut verdict = verdict(
        tests,
        &folds,
        &cur.oof,
        &current,
        cur.heldout_nrmse(),
        noise_floor_nrmse,
        search.at_floor(&cur),
    );
    verdict.where_ = where_regions(tests, &cur.oof);
    let discovered: Vec<Discovered> = discovered
        .into_iter()
        .map(|(effect, heldout_nrmse, improvement)| {
            let values: Vec<f64> = effect
                .params()
                .iter()
                .map(|s| {
                    cur_model
                        .param_index(s.name)
                        .map_or(f64::NAN, |k| final_fit.params[k])
                })
                .collect();
            let effect = match super::discover::strongest_family(&effect, &values, tests, term_current) {
                Some(family) => effect.with_resembles(family),
                None => effect,
            };
            Discovered {
                name: effect.name().to_string(),
                formula: readable(&effect, &values),
                features: super::discover::features_of(&effect),
                heldout_nrmse,
                improvement,
                resembles: effect.resembles().to_string(),
                effect: effect.with_values(&values),
            }
        })
        .collect();
    bar.finish_and_clear();
    let d = Diagnosis {
        base_model: base.to_string(),
        samples,
        base_fit_nrmse: base_fit.nrmse(),
        base_fit_rmse_n: base_fit.rmse_n(),
        // The base's held-out figure as it ended (a fold may have been refitted from a candidate's fit).
        base_heldout_nrmse: steps[0].heldout_nrmse,
        base_params: base_fit.params,
        base_pred,
        where_,
        candidates: steps[0].candidates.clone(),
        missing,
        pruned,
        final_model: cur.spec.to_string(),
        final_heldout_nrmse: cur.heldout_nrmse(),
        final_fit_nrmse: final_fit.nrmse(),
        final_params: final_fit.params,
        final_pred,
        steps,
        cv_scheme,
        noise_floor_nrmse,
        final_oof: cur.oof.clone(),
        discovered,
        verdict,
        registry: reg,
        bases: Vec::new(),
    };
    Ok((d, cur))
}

/// The parameters of the folds' fits, each the median over the folds (a model that stands for them all).
fn fold_median(fold_params: &[Vec<f64>]) -> Vec<f64> {
    let n = fold_params.first().map_or(0, Vec::len);
    (0..n)
        .map(|k| quantile(fold_params.iter().map(|p| p[k]).collect(), 0.5))
        .collect()
}

/// The next free name of a discovered term: `term1`, `term2`, …
fn next_term_name(reg: &Registry) -> String {
    (1..)
        .map(|k| format!("term{k}"))
        .find(|n| reg.get(n).is_none())
        .unwrap_or_default()
}

/// How many effects that remove enough error but fail a fold are each tried again beside every other effect.
const PAIR_SEEDS: usize = 2;

/// How much lower (N²) a second fit of `model` must end on a fold's training samples to replace the first:
/// `p σ²`, the expected fall of a least-squares loss when its `p` parameters are fitted to noise `σ`. Closer
/// fits are the same fit as far as the data can tell (a refit may move a parameter they leave free).
fn refit_margin(model: &Model, noise_n: f64) -> f64 {
    model.n_params() as f64 * noise_n * noise_n
}

/// The named candidates' cross-validations of one diagnosis, shared by the two paths of [`diagnose_path`]
/// (the second repeats the first up to where a term first wins), keyed by model and parent fits. Only models
/// of the given registry's effects: a term of the same name may be another formula on the other path.
#[derive(Default)]
struct CvCache(Mutex<HashMap<String, CvResult>>);

impl CvCache {
    /// The cross-validation of `model` from the current model's `parent` fits: kept, or `run` and kept.
    fn get_or(
        &self,
        model: &Model,
        parent: &CvResult,
        given: &Registry,
        run: impl FnOnce() -> CvResult,
    ) -> CvResult {
        let named = |spec: &ModelSpec| spec.effects.iter().all(|e| given.get(e).is_some());
        if !named(model.spec()) || !named(&parent.spec) {
            return run();
        }
        let bits: Vec<Vec<u64>> = parent
            .fold_params
            .iter()
            .map(|p| p.iter().map(|v| v.to_bits()).collect())
            .collect();
        let key = format!("{}|{}|{bits:?}", model.spec(), parent.spec);
        if let Some(cv) = self.0.lock().expect("cache lock").get(&key) {
            return cv.clone();
        }
        let cv = run();
        self.0.lock().expect("cache lock").insert(key, cv.clone());
        cv
    }
}

/// What every judgment of one diagnosis shares.
struct Search<'a> {
    tests: &'a [Test],
    folds: &'a [Fold],
    cv_fit: &'a FitOptions,
    opts: &'a DiagnoseOptions,
    /// Noise floor, N.
    noise: f64,
    bar: &'a ProgressBar,
}

impl Search<'_> {
    fn at_floor(&self, cv: &CvResult) -> bool {
        cv.total.rmse_n() <= self.opts.floor_ratio * self.noise
    }

    /// Is `cand` significantly better than `cur` on held-out data? Returns the verdict and the number of
    /// folds in which it was better.
    fn judge(&self, cur: &CvResult, cand: &CvResult) -> (bool, usize) {
        let better = folds_better(cur, cand);
        let ok = !self.at_floor(cur)
            && better == cur.per_fold.len()
            && enough_removed(cur, cand, self.noise * self.noise, self.opts);
        (ok, better)
    }

    /// Removes enough of `cur`'s held-out error overall, though perhaps not in every fold.
    fn promising(&self, cur: &CvResult, cand: &CvResult) -> bool {
        !self.at_floor(cur) && enough_removed(cur, cand, self.noise * self.noise, self.opts)
    }

    /// A candidate may beat the current model only because its fit left a local minimum the current model's
    /// fit of a fold is stuck in. So before the best significant candidate of `tried` (best first) is
    /// believed, the current model is refitted in each fold from it, keeping the fit with the lower training
    /// error, until the best is one it was already refitted from. Returns whether `cur` changed.
    fn refit_from_candidates(
        &self,
        cur: &mut CvResult,
        cur_model: &Model,
        tried: &[(Model, CvResult)],
    ) -> bool {
        let mut changed = false;
        let mut restarted_from: Vec<usize> = Vec::new();
        while let Some(bi) = (0..tried.len()).find(|&i| self.judge(cur, &tried[i].1).0) {
            if restarted_from.contains(&bi) {
                break;
            }
            restarted_from.push(bi);
            self.bar
                .set_message(format!("refitting {} from {}", cur.spec, tried[bi].0.spec()));
            let again = cross_validate(
                cur_model,
                self.tests,
                self.folds,
                Some((&tried[bi].0, &tried[bi].1)),
                self.cv_fit,
                self.bar,
            );
            if let Some(better) = cur.better_fits(&again, self.folds, refit_margin(cur_model, self.noise)) {
                *cur = better;
                changed = true;
            }
        }
        changed
    }

    /// Does the pair `(m, cv)` remove enough of the held-out error that each of its effects alone (in `tried`)
    /// leaves? (Not a pair of one effect that matters and one along for the ride.)
    fn beats_each_member(
        &self,
        cur: &CvResult,
        m: &Model,
        cv: &CvResult,
        tried: &[(Model, CvResult)],
    ) -> bool {
        added_effects(m, &cur.spec).into_iter().all(|e| {
            tried
                .iter()
                .find(|(sm, _)| sm.spec().effects.last() == Some(e))
                .is_some_and(|(_, single)| enough_removed(single, cv, self.noise * self.noise, self.opts))
        })
    }

    /// `tried` (extensions of `cur`, best first) judged against `cur`, with their evidence.
    fn candidates(&self, cur: &CvResult, tried: &[(Model, CvResult)], registry: &Registry) -> Vec<Candidate> {
        let cur_sig = cur.signatures(self.tests);
        tried
            .iter()
            .map(|(m, cv)| {
                let names: Vec<&str> = added_effects(m, &cur.spec).into_iter().map(String::as_str).collect();
                let sig = cv.signatures(self.tests);
                let signature = match names.as_slice() {
                    [one] => registry
                        .get(one)
                        .map(|e| e.residual_signature().to_string())
                        .unwrap_or_default(),
                    several => format!(
                        "{} together: their signatures coincide on these tests, so that neither alone, fitted \
                         on the training folds, predicts every held-out fold",
                        several.join(" and ")
                    ),
                };
                self.candidate(cur, cv, names.join("+"), evidence(&signature, &cur_sig, &sig))
            })
            .collect()
    }

    /// `cand` judged against `cur` as the candidate `effect`: its evidence `why`, then the change of the
    /// held-out error.
    fn candidate(&self, cur: &CvResult, cand: &CvResult, effect: String, why: String) -> Candidate {
        let (significant, folds_better) = self.judge(cur, cand);
        let folds = self.folds.len();
        Candidate {
            effect,
            heldout_nrmse: cand.heldout_nrmse(),
            improvement: improvement(cur, cand),
            significant,
            evidence: format!(
                "{why}; held-out RMSE {:.4} → {:.4} N, lower in {folds_better} of {folds} folds",
                cur.total.rmse_n(),
                cand.total.rmse_n(),
            ),
            folds_better,
            folds,
        }
    }
}

/// The effects of `m` that `cur` does not have (one for a candidate, two for a pair), in `m`'s order.
fn added_effects<'a>(m: &'a Model, cur: &ModelSpec) -> Vec<&'a String> {
    m.spec().effects.iter().filter(|e| !cur.has(e)).collect()
}

/// Does `cand` remove at least [`DiagnoseOptions::min_gain`] of `cur`'s held-out mean-square error and
/// [`DiagnoseOptions::min_excess_removed`] of its part above the noise floor?
fn enough_removed(cur: &CvResult, cand: &CvResult, noise_mse: f64, opts: &DiagnoseOptions) -> bool {
    let (m_cur, m_cand) = (cur.total.mse(), cand.total.mse());
    let gain = 1.0 - m_cand / m_cur.max(f64::MIN_POSITIVE);
    let excess = (m_cur - noise_mse).max(f64::MIN_POSITIVE);
    let removed = (m_cur - m_cand) / excess;
    gain >= opts.min_gain && removed >= opts.min_excess_removed
}

fn folds_better(cur: &CvResult, cand: &CvResult) -> usize {
    cur.per_fold
        .iter()
        .zip(&cand.per_fold)
        .filter(|(a, b)| b.sse < a.sse)
        .count()
}

/// 1 − `cand`'s held-out NRMSE over `cur`'s.
fn improvement(cur: &CvResult, cand: &CvResult) -> f64 {
    1.0 - cand.heldout_nrmse() / cur.heldout_nrmse().max(f64::MIN_POSITIVE)
}

/// The evidence for a candidate in words: its residual signature, and the measured signatures of the
/// held-out residual it removes.
fn evidence(signature: &str, before: &Signatures, after: &Signatures) -> String {
    let mut changes: Vec<(f64, &str, f64, f64)> = before
        .named()
        .iter()
        .zip(after.named())
        .map(|((name, b), (_, a))| (b.abs() - a.abs(), *name, *b, a))
        .filter(|c| c.0 > 0.0)
        .collect();
    changes.sort_by(|a, b| b.0.total_cmp(&a.0));
    let mut s = String::new();
    if !signature.is_empty() {
        s.push_str(&format!("expected signature: {signature}. "));
    }
    let shown: Vec<String> = changes
        .iter()
        .take(2)
        .map(|(_, n, b, a)| format!("{n}: {b:.3} → {a:.3}"))
        .collect();
    if shown.is_empty() {
        s.push_str("removes none of the measured residual signatures");
    } else {
        s.push_str(&format!(
            "measured in the held-out residual, it removes {}",
            shown.join("; ")
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two cross-validations of one model over two folds of one 4-sample test (fold 0 scores samples 0–1,
    /// fold 1 samples 2–3): `(training sse, held-out sse, prediction)` per fold.
    fn cv_of(folds: [(f64, f64, f64); 2]) -> CvResult {
        let per_fold: Vec<Figures> = folds
            .iter()
            .map(|&(_, heldout, _)| Figures {
                samples: 2,
                sse: heldout,
                f_ss: 100.0,
            })
            .collect();
        CvResult {
            spec: ModelSpec::parse("bingham").expect("spec"),
            total: Figures::total(&per_fold),
            per_fold,
            fold_params: folds.iter().map(|&(t, _, _)| vec![t]).collect(),
            fold_train_loss: folds.iter().map(|&(t, _, _)| t).collect(),
            oof: vec![vec![folds[0].2, folds[0].2, folds[1].2, folds[1].2]],
            sig: None,
        }
    }

    #[test]
    fn a_refit_replaces_a_fold_only_where_it_fits_its_training_samples_better() {
        let span = |start, end| Span { test: 0, start, end };
        let folds: Vec<Fold> = [(span(2, 4), span(0, 2)), (span(0, 2), span(2, 4))]
            .into_iter()
            .map(|(train, test)| Fold {
                train: vec![train],
                test: vec![test],
                label: String::new(),
            })
            .collect();
        let cur = cv_of([(10.0, 5.0, 1.0), (10.0, 5.0, 2.0)]);
        // Fold 0 fits its training samples better but predicts worse; fold 1 fits worse but predicts better.
        let again = cv_of([(8.0, 7.0, 3.0), (12.0, 1.0, 4.0)]);
        let merged = cur.better_fits(&again, &folds, 0.0).expect("fold 0 fits better");
        // Chosen by the training error alone: the held-out samples play no part.
        assert_eq!(merged.fold_train_loss, vec![8.0, 10.0]);
        assert_eq!(merged.per_fold[0].sse, 7.0);
        assert_eq!(merged.per_fold[1].sse, 5.0);
        assert_eq!(merged.total.sse, 12.0);
        assert_eq!(merged.oof[0], vec![3.0, 3.0, 2.0, 2.0]);
        // No fold better: nothing to replace.
        assert!(cur.better_fits(&cur.clone(), &folds, 0.0).is_none());
    }

    /// A pair is significant only if it also removes enough of the error each of its effects leaves alone:
    /// an effect that merely tips the one fold its partner fails does not ride along.
    #[test]
    fn a_pair_counts_only_when_it_improves_on_each_of_its_effects_alone() {
        use crate::device::effects::testkit::model;
        let opts = DiagnoseOptions::default();
        let fit_opts = FitOptions::default();
        let bar = ProgressBar::hidden();
        let search = Search {
            tests: &[],
            folds: &[],
            cv_fit: &fit_opts,
            opts: &opts,
            noise: 0.0,
            bar: &bar,
        };
        let cur = cv_of([(0.0, 10.0, 0.0), (0.0, 10.0, 0.0)]);
        // The spring alone: a third of the error overall, but worse in the second fold. The mass alone: nothing.
        let spring = cv_of([(0.0, 3.0, 0.0), (0.0, 10.5, 0.0)]);
        let mass = cv_of([(0.0, 11.0, 0.0), (0.0, 11.0, 0.0)]);
        assert!(search.promising(&cur, &spring) && !search.judge(&cur, &spring).0);
        let tried = vec![
            (model("bingham+stiffness"), spring),
            (model("bingham+inertia"), mass),
        ];
        let pair = model("bingham+stiffness+inertia");
        // Both folds explained together: counts.
        let together = cv_of([(0.0, 1.0, 0.0), (0.0, 1.0, 0.0)]);
        assert!(search.judge(&cur, &together).0);
        assert!(search.beats_each_member(&cur, &pair, &together, &tried));
        // Better than the base in every fold, but only 4.4 % below the spring alone: the mass rides along.
        let along = cv_of([(0.0, 3.0, 0.0), (0.0, 9.9, 0.0)]);
        assert!(search.judge(&cur, &along).0);
        assert!(!search.beats_each_member(&cur, &pair, &along, &tried));
    }

    fn sine_test(name: &str, group: &str, amp_m: f64, f_hz: f64, i_a: f64) -> Test {
        let inputs = crate::device::effects::testkit::sine(amp_m, f_hz, i_a, 1e-3, 1.999);
        let f_n = vec![0.0; inputs.len()];
        Test::synthetic(name, group, inputs, f_n)
    }

    /// Files whose names group nothing (each its own group): three motions at two currents each are held
    /// out a motion at a time, both currents together; with names that group, the names decide.
    #[test]
    fn folds_follow_the_motion_when_the_names_group_nothing() {
        let motions = [(0.02, 1.0), (0.01, 2.5), (0.03, 0.4)];
        let mut tests = Vec::new();
        for (k, (a, f)) in motions.iter().enumerate() {
            for (c, i) in [0.0, 14.0].iter().enumerate() {
                let name = format!("run{}", 2 * k + c);
                tests.push(sine_test(&name, &name, *a, *f, *i));
            }
        }
        let (folds, how) = make_folds(&tests, 4, 5);
        assert_eq!(folds.len(), 3, "{how}");
        assert!(how.starts_with("leave one motion group out over 3"), "{how}");
        let held = |fold: &Fold| fold.test.iter().map(|s| s.test).collect::<Vec<usize>>();
        for (f, fold) in folds.iter().enumerate() {
            assert_eq!(held(fold), vec![2 * f, 2 * f + 1], "fold {f}: {how}");
        }
        // Names that group: by name, even across motions.
        for (j, t) in tests.iter_mut().enumerate() {
            t.group = format!("g{}", j % 3);
        }
        let (folds, how) = make_folds(&tests, 4, 5);
        assert_eq!(folds.len(), 3, "{how}");
        for (f, fold) in folds.iter().enumerate() {
            assert_eq!(held(fold), vec![f, f + 3], "fold {f}: {how}");
        }
        // Two groups: every fold holds out one time block of every test and is fitted on the other blocks of
        // both groups; every sample is held out exactly once.
        for (j, t) in tests.iter_mut().enumerate() {
            t.group = format!("g{}", j % 2);
        }
        let (folds, how) = make_folds(&tests, 4, 5);
        assert_eq!(folds.len(), 4, "{how}");
        assert!(how.starts_with("blocked cross-validation"), "{how}");
        for (j, t) in tests.iter().enumerate() {
            let mut held = vec![0usize; t.len()];
            for fold in &folds {
                for s in fold.test.iter().filter(|s| s.test == j) {
                    held[s.start..s.end].iter_mut().for_each(|h| *h += 1);
                    let trained = fold.train.iter().filter(|r| r.test == j);
                    assert!(trained.clone().all(|r| r.end <= s.start || r.start >= s.end));
                    assert_eq!(
                        trained.map(|r| r.end - r.start).sum::<usize>(),
                        t.len() - (s.end - s.start)
                    );
                }
            }
            assert!(held.iter().all(|&h| h == 1), "test {j}: {how}");
        }
        // Every test its own motion: one test per fold.
        let name = |j: usize| format!("r{j}");
        let distinct: Vec<Test> = (0..4)
            .map(|j| sine_test(&name(j), &name(j), 0.01 * (j + 1) as f64, 1.0, 7.0))
            .collect();
        let (folds, how) = make_folds(&distinct, 4, 5);
        assert_eq!(folds.len(), 4, "{how}");
        assert!(how.starts_with("leave one test out"), "{how}");
    }
}
