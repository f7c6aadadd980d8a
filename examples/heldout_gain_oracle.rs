//! How much of the real damper's held-out error is each test's own force scale?
//!
//! The held-out predictions of `diagnose`'s folds (leave one amplitude/frequency group out), then the same
//! predictions with each held-out test scaled by its own best gain, by its best gain and offset, and by a
//! gain that drifts linearly over the test: an oracle that uses the held-out forces, which no model could. If even the oracle misses a goal, no model
//! whose only failing is a test-to-test scale (the device's state drifting between tests) could meet it.
//! Samples count as in the fit and the diagnosis (velocity sign known).
//!
//!
//! Beside the oracle, what a law of the current could do that no effect of the vocabulary has: a gain for each
//! current level, learned on each fold's training tests (their predictions by the fold's own fit) and put on
//! the held-out tests at that level. That is no oracle: if the scale were a function of the current, it would
//! carry over to the group left out.
//!
//! `cargo run --release --example heldout_gain_oracle [DIR] [--weighting samples]` (default
//! `data/utfsm-mr-damper`, each test counted once in the fits)

use mrfeel::device::{Model, Registry};
use std::collections::BTreeMap;

use mrfeel::ident::diagnose::{CvResult, Fold};
use mrfeel::ident::residual::direction_weights;
use mrfeel::ident::Test;

mod heldout;
use heldout::Heldout;

fn main() -> anyhow::Result<()> {
    let heldout = Heldout::from_args()?;
    let (tests, folds) = (&heldout.tests, &heldout.folds);
    let registry = Registry::builtin();
    for spec in [
        "bingham",
        "bingham+hysteresis",
        "bingham+hysteresis+current_viscosity",
    ] {
        let (model, cv) = heldout.cross_validate(spec, &registry)?;
        let by_level = level_gains_learned_in_training(&model, tests, folds, &cv);
        // Sums of squares: as predicted, scaled by each test's gain, and by gain and offset; of the force.
        let (mut raw, mut scaled, mut affine, mut drifting, mut force) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let mut levelled = 0.0;
        let mut gains = Vec::new();
        for (ti, (t, pred)) in tests.iter().zip(&cv.oof).enumerate() {
            let w = direction_weights(t);
            let (mut fm, mut mm, mut f1, mut m1, mut n) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for ((f, m), w) in t.f_n.iter().zip(pred).zip(&w) {
                (fm, mm, f1, m1, n) = (fm + w * f * m, mm + w * m * m, f1 + w * f, m1 + w * m, n + w);
            }
            let g = fm / mm;
            let det = mm * n - m1 * m1;
            let (a, b) = ((fm * n - m1 * f1) / det, (mm * f1 - m1 * fm) / det);
            gains.push(format!("{} {g:.3}", t.name.trim_end_matches(".csv")));
            // Gain `c + d τ`, τ the time through the test from 0 to 1: least squares on `m` and `m τ`.
            let (t0, t1) = (t.inputs[0].t_s, t.inputs[t.len() - 1].t_s);
            let tau: Vec<f64> = t.inputs.iter().map(|i| (i.t_s - t0) / (t1 - t0)).collect();
            let (mut s11, mut s12, mut s22, mut b1, mut b2) = (0.0, 0.0, 0.0, 0.0, 0.0);
            for (((f, m), w), u) in t.f_n.iter().zip(pred).zip(&w).zip(&tau) {
                let mu = m * u;
                (s11, s12, s22) = (s11 + w * m * m, s12 + w * m * mu, s22 + w * mu * mu);
                (b1, b2) = (b1 + w * f * m, b2 + w * f * mu);
            }
            let dd = s11 * s22 - s12 * s12;
            let (c, d) = ((b1 * s22 - s12 * b2) / dd, (s11 * b2 - s12 * b1) / dd);
            for (((f, m), w), u) in t.f_n.iter().zip(pred).zip(&w).zip(&tau) {
                drifting += w * (f - (c + d * u) * m).powi(2);
            }
            for (((f, m), w), l) in t.f_n.iter().zip(pred).zip(&w).zip(&by_level[ti]) {
                levelled += w * (f - l * m).powi(2);
            }
            for ((f, m), w) in t.f_n.iter().zip(pred).zip(&w) {
                raw += w * (f - m).powi(2);
                scaled += w * (f - g * m).powi(2);
                affine += w * (f - a * m - b).powi(2);
                force += w * f * f;
            }
        }
        println!(
            "{spec}: held-out NRMSE {:.4}; each held-out test scaled by its own gain {:.4}; by gain and offset \
             {:.4}; by a gain drifting linearly over the test {:.4}; (no oracle) by a gain per current level \
             learned on the training tests {:.4}",
            (raw / force).sqrt(),
            (scaled / force).sqrt(),
            (affine / force).sqrt(),
            (drifting / force).sqrt(),
            (levelled / force).sqrt()
        );
        println!("  gains: {}", gains.join(", "));
    }
    Ok(())
}

/// The current level of a test at constant current, in hundredths of an ampere.
fn level_of(t: &Test) -> i64 {
    (t.inputs[t.len() / 2].current_cmd_a * 100.0).round() as i64
}

/// For every sample of every test, the gain of its current level learned on the training tests of the fold
/// that holds it out: least squares of the measured force on the fold's own prediction, over the training
/// samples at that level (1 where no training test has the level).
fn level_gains_learned_in_training(
    model: &Model,
    tests: &[Test],
    folds: &[Fold],
    cv: &CvResult,
) -> Vec<Vec<f64>> {
    let mut out: Vec<Vec<f64>> = tests.iter().map(|t| vec![1.0; t.len()]).collect();
    for (fold, params) in folds.iter().zip(&cv.fold_params) {
        let mut sums: BTreeMap<i64, (f64, f64)> = BTreeMap::new();
        for s in &fold.train {
            let t = &tests[s.test];
            let pred = t.predict(model, params, s.end);
            let w = direction_weights(t);
            let e = sums.entry(level_of(t)).or_default();
            for k in s.start..s.end {
                e.0 += w[k] * t.f_n[k] * pred[k];
                e.1 += w[k] * pred[k] * pred[k];
            }
        }
        for s in &fold.test {
            if let Some((fm, mm)) = sums.get(&level_of(&tests[s.test])) {
                out[s.test][s.start..s.end].fill(fm / mm);
            }
        }
    }
    out
}
