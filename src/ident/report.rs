//! The contract's JSON outputs (`docs/spec/model-discovery.md`) and the human-readable tables.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde::Serialize;

use super::diagnose::{BaseTried, Candidate, Diagnosis, Discovered, StepResult};
use super::discover::Verdict;
use super::fit::FitResult;
use super::residual::{direction_weights, where_regions, Region};
use super::validate::{figures, Figures};
use super::Test;
use crate::device::Model;

/// One parameter in `fit --json`.
#[derive(Debug, Clone, Serialize)]
pub struct ParamJson {
    /// Fitted (or given) value, in `unit`.
    pub value: f64,
    /// Standard error from the fit's Jacobian; `null` where the data does not determine it.
    pub std_err: Option<f64>,
    /// Unit of the value.
    pub unit: String,
    /// Why the parameter was held (not fitted); omitted when empty.
    #[serde(skip_serializing_if = "String::is_empty")]
    pub note: String,
}

/// The figures of one measurement file.
#[derive(Debug, Clone, Serialize)]
pub struct FileJson {
    /// The file's path as given.
    pub path: String,
    /// RMS force error over RMS measured force.
    pub nrmse: f64,
    /// RMS force error, N.
    pub rmse_n: f64,
}

/// `fit --json` and `validate --json`.
#[derive(Debug, Clone, Serialize)]
pub struct FitJson {
    /// Model spec, `bingham+effect+…`.
    pub model: String,
    /// Samples scored.
    pub samples: usize,
    /// RMS force error over RMS measured force, all files.
    pub nrmse: f64,
    /// RMS force error, N, all files.
    pub rmse_n: f64,
    /// Every parameter by name.
    pub params: BTreeMap<String, ParamJson>,
    /// The figures per file.
    pub files: Vec<FileJson>,
    /// The figures over the samples whose velocity sign is known (farther from zero than 4 standard
    /// deviations of its noise): the samples fits minimise and held-out scores count. Where a noisy
    /// velocity crosses zero the direction of the yield force is a coin toss for every model, and those few
    /// samples can dominate `nrmse`.
    pub direction_known: Subset,
    /// Where in the motion the error concentrates; omitted when empty.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub r#where: Vec<Region>,
}

/// Error figures over a subset of the samples.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Subset {
    /// Samples in the subset.
    pub samples: usize,
    /// RMS force error over RMS measured force in the subset.
    pub nrmse: f64,
    /// RMS force error in the subset, N.
    pub rmse_n: f64,
}

impl FitJson {
    /// The contract's figures of `model` with `params` on `tests`, whose predictions are `pred`.
    pub fn new(
        model: &Model,
        params: &[f64],
        fit: Option<&FitResult>,
        tests: &[Test],
        pred: &[Vec<f64>],
    ) -> Self {
        let (per, total) = figures(pred, tests);
        let mut known = Figures::default();
        for (p, t) in pred.iter().zip(tests) {
            known.add(&Figures::of_weighted(p, &t.f_n, &direction_weights(t)));
        }
        let params = model
            .param_specs()
            .iter()
            .enumerate()
            .map(|(k, s)| {
                (
                    s.name.to_string(),
                    ParamJson {
                        value: params[k],
                        std_err: fit.and_then(|f| f.std_err[k]),
                        unit: s.unit.to_string(),
                        note: fit.map(|f| f.notes[k].clone()).unwrap_or_default(),
                    },
                )
            })
            .collect();
        Self {
            model: model.name(),
            samples: total.samples,
            nrmse: total.nrmse(),
            rmse_n: total.rmse_n(),
            params,
            files: tests
                .iter()
                .zip(&per)
                .map(|(t, f)| FileJson {
                    path: t.path.display().to_string(),
                    nrmse: f.nrmse(),
                    rmse_n: f.rmse_n(),
                })
                .collect(),
            direction_known: Subset {
                samples: known.samples,
                nrmse: known.nrmse(),
                rmse_n: known.rmse_n(),
            },
            r#where: where_regions(tests, pred),
        }
    }

    /// The table printed without `--json`.
    pub fn table(&self, title: &str) -> String {
        let mut s = String::new();
        let _ = writeln!(
            s,
            "{title} {}: {} samples, NRMSE {:.4}, RMSE {} N",
            self.model,
            self.samples,
            self.nrmse,
            force(self.rmse_n)
        );
        let k = &self.direction_known;
        if k.samples < self.samples {
            let _ = writeln!(
                s,
                "  where the velocity's sign is known ({} samples, as fits and held-out scores count): \
                 NRMSE {:.4}, RMSE {} N",
                k.samples,
                k.nrmse,
                force(k.rmse_n)
            );
        }
        let _ = writeln!(s, "\n{:<28} {:>14} {:>12}  unit", "parameter", "value", "std err");
        for (name, p) in &self.params {
            let se = p.std_err.map_or_else(|| "—".into(), force);
            let value = crate::input::text::significant(p.value, 6);
            let _ = writeln!(s, "{name:<28} {value:>14} {se:>12}  {}", p.unit);
            if !p.note.is_empty() {
                let _ = writeln!(s, "{:<28} ({})", "", p.note);
            }
        }
        let _ = writeln!(s, "\n{:<40} {:>8} {:>10}", "file", "NRMSE", "RMSE N");
        for f in &self.files {
            let _ = writeln!(
                s,
                "{:<40} {:>8.4} {:>10}",
                short(&f.path, 40),
                f.nrmse,
                force(f.rmse_n)
            );
        }
        region_rows(&mut s, "where the error is", &self.r#where);
        s
    }
}

/// The regions under a heading, one row each; nothing without regions.
fn region_rows(s: &mut String, heading: &str, regions: &[Region]) {
    if !regions.is_empty() {
        let _ = writeln!(s, "\n{heading}:");
    }
    for r in regions {
        let _ = writeln!(
            s,
            "  {:<44} {:>5.1} % of the squared error, RMSE {} N",
            r.region,
            100.0 * r.share_of_error,
            force(r.rmse_n)
        );
    }
}

fn short(p: &str, n: usize) -> String {
    let c = p.chars().count();
    if c <= n {
        p.to_string()
    } else {
        format!("…{}", p.chars().skip(c - n + 1).collect::<String>())
    }
}

/// `base`: the starting model's figures.
#[derive(Debug, Clone, Serialize)]
pub struct BaseJson {
    /// RMS force error over RMS measured force, fitted on all data.
    pub nrmse: f64,
    /// RMS force error, N, fitted on all data.
    pub rmse_n: f64,
    /// Held-out NRMSE (each fold scored by a fit without it).
    pub heldout_nrmse: f64,
}

/// `final`: the model the diagnosis ends with.
#[derive(Debug, Clone, Serialize)]
pub struct FinalJson {
    /// Model spec.
    pub model: String,
    /// Its held-out NRMSE.
    pub heldout_nrmse: f64,
}

/// `diagnose --json`: the contract's keys, then a few extra ones (`steps`, `cross_validation`,
/// `noise_floor_nrmse`, `pruned`).
#[derive(Debug, Clone, Serialize)]
pub struct DiagnoseJson {
    /// The starting model's spec.
    pub base_model: String,
    /// Samples scored.
    pub samples: usize,
    /// The starting model's figures.
    pub base: BaseJson,
    /// Where in the motion the starting model's error concentrates.
    pub r#where: Vec<Region>,
    /// Effects tried on the starting model, best first.
    pub candidates: Vec<Candidate>,
    /// Effects the diagnosis adds, in the order added (empty: the residual is noise).
    pub missing: Vec<String>,
    /// The final model.
    #[serde(rename = "final")]
    pub final_: FinalJson,
    /// Every step of the search.
    pub steps: Vec<StepResult>,
    /// How the data was split for held-out errors.
    pub cross_validation: String,
    /// Held-out NRMSE the measurement noise alone would give.
    pub noise_floor_nrmse: f64,
    /// Effects removed at the end because dropping them did not raise the held-out error.
    pub pruned: Vec<String>,
    /// Terms outside the vocabulary the diagnosis added, in the order added.
    pub discovered: Vec<Discovered>,
    /// Present only when the final model's held-out residual is structure, not noise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub unexplained: Option<Verdict>,
    /// The bases tried, with their held-out figures; `chosen` marks the one the diagnosis carried on from.
    pub bases_tried: Vec<BaseTried>,
}

impl DiagnoseJson {
    /// The contract's view of a diagnosis.
    pub fn new(d: &Diagnosis) -> Self {
        Self {
            base_model: d.base_model.clone(),
            samples: d.samples,
            base: BaseJson {
                nrmse: d.base_fit_nrmse,
                rmse_n: d.base_fit_rmse_n,
                heldout_nrmse: d.base_heldout_nrmse,
            },
            r#where: d.where_.clone(),
            candidates: d.candidates.clone(),
            missing: d.missing.clone(),
            final_: FinalJson {
                model: d.final_model.clone(),
                heldout_nrmse: d.final_heldout_nrmse,
            },
            steps: d.steps.clone(),
            cross_validation: d.cv_scheme.clone(),
            noise_floor_nrmse: d.noise_floor_nrmse,
            pruned: d.pruned.clone(),
            discovered: d.discovered.clone(),
            unexplained: d.unexplained().cloned(),
            bases_tried: d.bases.clone(),
        }
    }
}

/// One row per candidate, then the evidence for the best.
fn candidate_rows(s: &mut String, cands: &[Candidate]) {
    for c in cands {
        let _ = writeln!(
            s,
            "  {:<22} {:>10.4} {:>10.1}% {:>3}/{:<3} {:>12}",
            c.effect,
            c.heldout_nrmse,
            100.0 * c.improvement,
            c.folds_better,
            c.folds,
            if c.significant { "yes" } else { "no" }
        );
    }
    if let Some(c) = cands.first() {
        let _ = writeln!(s, "  best, {}: {}", c.effect, c.evidence);
    }
}

/// The noise floor for the text report: four decimals, or, where that would print 0.0000 (a force filtered
/// before it was logged by a filter the data do not show: its third differences hold almost no white
/// noise), the figure and what it means for the diagnosis.
fn floor_words(nrmse: f64) -> String {
    if nrmse >= 5e-5 {
        format!("{nrmse:.4}")
    } else {
        format!(
            "{nrmse:.1e} (almost no white noise in the force: filtered before it was logged? The stop at the \
             noise floor does not apply; the held-out gains alone decide)"
        )
    }
}

/// The diagnosis for a person: where the base model fails, each step's candidates, the error falling.
pub fn diagnose_table(d: &Diagnosis) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{} on {} samples: NRMSE {:.4} fitted on all (over the samples the fit counts, without those whose velocity sign \
         is unknown), held-out NRMSE {:.4} ({}); noise floor NRMSE {}",
        d.base_model,
        d.samples,
        d.base_fit_nrmse,
        d.base_heldout_nrmse,
        d.cv_scheme,
        floor_words(d.noise_floor_nrmse)
    );
    if d.bases.len() > 1 {
        let tried: Vec<String> = d
            .bases
            .iter()
            .map(|b| format!("{}: {}", b.model, b.note))
            .collect();
        let _ = writeln!(
            s,
            "base {} chosen by held-out error; {}",
            d.base_model,
            tried.join("; ")
        );
    }
    region_rows(&mut s, &format!("where {} fails", d.base_model), &d.where_);
    for st in d.steps.iter().filter(|st| !st.candidates.is_empty()) {
        let _ = writeln!(
            s,
            "\neffects added to {} (held-out NRMSE {:.4}):",
            st.model, st.heldout_nrmse
        );
        let _ = writeln!(
            s,
            "  {:<22} {:>10} {:>11} {:>7} {:>12}",
            "effect", "held-out", "improvement", "folds", "significant"
        );
        candidate_rows(&mut s, &st.candidates);
        if let Some(t) = &st.term {
            let _ = writeln!(
                s,
                "  open search, {}: held-out NRMSE {:.4} ({:.1} %), lower in {}/{} folds, significant: {}",
                t.effect,
                t.heldout_nrmse,
                100.0 * t.improvement,
                t.folds_better,
                t.folds,
                if t.significant { "yes" } else { "no" }
            );
        }
        if !st.pairs.is_empty() {
            let _ = writeln!(
                s,
                "  no effect alone is significant; effects that remove enough error overall, with each other beside them:"
            );
            candidate_rows(&mut s, &st.pairs);
        }
    }
    let _ = writeln!(s, "\nthe error falling:");
    let _ = writeln!(s, "  {:<48} {:>10}", "model", "held-out NRMSE");
    for st in &d.steps {
        let bar = "█".repeat(
            (40.0 * st.heldout_nrmse / d.base_heldout_nrmse.max(1e-300))
                .round()
                .clamp(0.0, 60.0) as usize,
        );
        let _ = writeln!(s, "  {:<48} {:>10.4}  {bar}", st.model, st.heldout_nrmse);
    }
    if !d.pruned.is_empty() {
        let _ = writeln!(s, "  (removed again as redundant: {})", d.pruned.join(", "));
    }
    if d.steps.len() > 1 && d.steps.last().is_some_and(|st| st.candidates.is_empty()) {
        let _ = writeln!(
            s,
            "  (at the noise floor after the last step: no further effect was tried, none could be significant)"
        );
    }
    let _ = writeln!(
        s,
        "\nmissing: {}\nfinal: {} (held-out NRMSE {:.4}, fitted on all {:.4})",
        if d.missing.is_empty() && !d.verdict.structure {
            "none (the residual is explained)".to_string()
        } else if d.missing.is_empty() {
            "no named effect (see below)".to_string()
        } else {
            d.missing.join(", ")
        },
        d.final_model,
        d.final_heldout_nrmse,
        d.final_fit_nrmse
    );
    for t in &d.discovered {
        let _ = writeln!(
            s,
            "found beyond the vocabulary: {} = {} (resembles {}); held-out NRMSE {:.4}, {:.1} % below the model \
             before it",
            t.name,
            t.formula,
            t.resembles,
            t.heldout_nrmse,
            100.0 * t.improvement
        );
    }
    s.push_str(&verdict_words(d));
    s
}

/// The verdict on what is left, in words.
pub fn verdict_words(d: &Diagnosis) -> String {
    let v = &d.verdict;
    let mut s = String::new();
    if v.structure && v.predicted() {
        let _ = writeln!(
            s,
            "\nUNEXPLAINED: what {} leaves is structure, not noise. A regressor on the measured signals predicts \
             {:.0} % of its held-out residual out of sample (held-out NRMSE {:.4} against a noise floor of {}); \
             no named effect and no term of the open search's library explains it.",
            d.final_model,
            100.0 * v.predictable_share,
            v.heldout_nrmse,
            floor_words(v.floor_nrmse)
        );
    } else if v.structure {
        let _ = writeln!(
            s,
            "\nUNEXPLAINED: what {} leaves is structure, not noise: its held-out NRMSE {:.4} is {:.1}× the noise \
             floor of {}, yet a regressor on the measured signals predicts only {:.1} % of it out of sample. \
             The missing effect depends on something those signals do not carry in a form the regressor can use \
             (a memory of the motion, a fine periodic shape, the force path itself); no named effect and no term \
             of the open search's library explains it.",
            d.final_model,
            v.heldout_nrmse,
            v.heldout_nrmse / v.floor_nrmse,
            floor_words(v.floor_nrmse),
            100.0 * v.predictable_share,
        );
    }
    if v.structure {
        if !v.correlates_with.is_empty() {
            let list: Vec<String> = v
                .correlates_with
                .iter()
                .map(|(n, sh)| format!("{n} ({:.0} %)", 100.0 * sh))
                .collect();
            let _ = writeln!(s, "  it follows: {}", list.join(", "));
        }
        for r in v.where_.iter().take(3) {
            let _ = writeln!(
                s,
                "  it lives at {:<40} {:>5.1} % of the squared error, RMSE {:.3} N",
                r.region,
                100.0 * r.share_of_error,
                r.rmse_n
            );
        }
    } else {
        let _ = writeln!(
            s,
            "\nwhat is left is noise: a regressor on the measured signals predicts {:.1} % of the held-out \
             residual out of sample (held-out NRMSE {:.4}, noise floor {})",
            100.0 * v.predictable_share,
            v.heldout_nrmse,
            floor_words(v.floor_nrmse)
        );
    }
    s
}

/// A force for people: three significant digits (`82.7`, `0.479`).
fn force(f_n: f64) -> String {
    crate::input::text::significant(f_n, 3)
}

#[cfg(test)]
mod tests {
    use super::floor_words;

    #[test]
    fn a_noise_floor_that_would_print_as_zero_is_shown_and_explained() {
        assert_eq!(floor_words(0.0032), "0.0032");
        let tiny = floor_words(2.04e-5);
        assert!(tiny.starts_with("2.0e-5 ("), "{tiny}");
        assert!(tiny.contains("filtered"), "{tiny}");
        assert!(!floor_words(0.0).starts_with("0.0000"));
    }
}
