//! Run a model with given parameters on tests, unchanged (no refit), and measure its error.

use rayon::prelude::*;

use super::Test;
use crate::device::Model;

/// Model force at every sample of every test, each test integrated from its own start (parallel, in order).
pub fn evaluate(model: &Model, params: &[f64], tests: &[Test]) -> Vec<Vec<f64>> {
    tests
        .par_iter()
        .map(|t| t.predict(model, params, t.len()))
        .collect()
}

/// Error figures of one test or of all of them (measurement-format.md: `rmse_n` of model − measured,
/// `nrmse = rmse_n / rms(f_n)` over the same samples).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Figures {
    pub samples: usize,
    /// Sum of squared residuals, N².
    pub sse: f64,
    /// Sum of squared measured force, N².
    pub f_ss: f64,
}

impl Figures {
    pub fn of(model_n: &[f64], measured_n: &[f64]) -> Self {
        let mut f = Figures {
            samples: model_n.len(),
            ..Default::default()
        };
        for (m, y) in model_n.iter().zip(measured_n) {
            let r = m - y;
            f.sse += if r.is_finite() { r * r } else { f64::INFINITY };
            f.f_ss += y * y;
        }
        f
    }

    /// Figures over the samples with a non-zero weight only (see
    /// [`super::residual::direction_weights`]).
    pub fn of_weighted(model_n: &[f64], measured_n: &[f64], weights: &[f64]) -> Self {
        let mut f = Figures::default();
        for ((m, y), w) in model_n.iter().zip(measured_n).zip(weights) {
            if *w == 0.0 {
                continue;
            }
            let r = m - y;
            f.samples += 1;
            f.sse += if r.is_finite() { r * r } else { f64::INFINITY };
            f.f_ss += y * y;
        }
        f
    }

    pub fn add(&mut self, o: &Figures) {
        self.samples += o.samples;
        self.sse += o.sse;
        self.f_ss += o.f_ss;
    }

    pub fn rmse_n(&self) -> f64 {
        (self.sse / self.samples.max(1) as f64).sqrt()
    }

    pub fn nrmse(&self) -> f64 {
        (self.sse / self.f_ss.max(f64::MIN_POSITIVE)).sqrt()
    }

    pub fn mse(&self) -> f64 {
        self.sse / self.samples.max(1) as f64
    }
}

/// Per-test figures and their total, over the samples where the force channel is not stuck at a rail
/// ([`super::clipping`]).
pub fn figures(pred: &[Vec<f64>], tests: &[Test]) -> (Vec<Figures>, Figures) {
    let per: Vec<Figures> = pred
        .iter()
        .zip(tests)
        .map(|(p, t)| Figures::of_weighted(p, &t.f_n, &super::clipping::unclipped(&t.f_n)))
        .collect();
    let mut tot = Figures::default();
    for f in &per {
        tot.add(f);
    }
    (per, tot)
}
