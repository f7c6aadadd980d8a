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
    /// Samples counted.
    pub samples: usize,
    /// Sum of squared residuals, N².
    pub sse: f64,
    /// Sum of squared measured force, N².
    pub f_ss: f64,
}

impl Figures {
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

    /// Add the samples of `o`.
    pub fn add(&mut self, o: &Figures) {
        self.samples += o.samples;
        self.sse += o.sse;
        self.f_ss += o.f_ss;
    }

    /// The figures of all of `figs`, added in order.
    pub fn total(figs: &[Figures]) -> Figures {
        let mut t = Figures::default();
        figs.iter().for_each(|f| t.add(f));
        t
    }

    /// RMS force error, N.
    pub fn rmse_n(&self) -> f64 {
        (self.sse / self.samples.max(1) as f64).sqrt()
    }

    /// RMS force error over RMS measured force.
    pub fn nrmse(&self) -> f64 {
        (self.sse / self.f_ss.max(f64::MIN_POSITIVE)).sqrt()
    }

    /// Mean squared force error, N².
    pub fn mse(&self) -> f64 {
        self.sse / self.samples.max(1) as f64
    }
}

/// Per-test figures and their total, over the samples where the force channel is not stuck at a rail
/// (`ident::clipping`).
pub fn figures(pred: &[Vec<f64>], tests: &[Test]) -> (Vec<Figures>, Figures) {
    let per: Vec<Figures> = pred
        .iter()
        .zip(tests)
        .map(|(p, t)| Figures::of_weighted(p, &t.f_n, &super::clipping::unclipped(&t.f_n)))
        .collect();
    let tot = Figures::total(&per);
    (per, tot)
}

/// Refuse a model's results whose numbers are not finite (a parameter, its standard error, an error figure)
/// before anything is saved or printed, naming the samples that drove them: those whose residual is not a
/// number or is largest, with what was measured there. `what` names the command's results.
pub fn check_finite(
    what: &str,
    numbers: &[(String, f64)],
    tests: &[Test],
    pred: &[Vec<f64>],
) -> Result<(), String> {
    let Some((name, v)) = numbers.iter().find(|(_, v)| !v.is_finite()) else {
        return Ok(());
    };
    // Every sample by how much it weighs in the error: not a number first, then by |residual|.
    let mut samples: Vec<(f64, usize, usize)> = Vec::new();
    for (j, (t, p)) in tests.iter().zip(pred).enumerate() {
        for (k, (m, y)) in p.iter().zip(&t.f_n).enumerate() {
            let r = (m - y).abs();
            samples.push((if r.is_finite() { r } else { f64::INFINITY }, j, k));
        }
    }
    samples.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)).then(a.2.cmp(&b.2)));
    let named: Vec<String> = samples
        .iter()
        .take(3)
        .map(|&(_, j, k)| {
            let t = &tests[j];
            let i = t.inputs[k];
            format!(
                "`{}` at t = {} s (sample {}: x {} m, v {} m/s, current {} A, measured {} N, model {} N)",
                t.path.display(),
                i.t_s,
                k + 1,
                crate::input::text::short_number(i.x_m),
                crate::input::text::short_number(i.v_m_s),
                crate::input::text::short_number(i.current_cmd_a),
                crate::input::text::short_number(t.f_n[k]),
                crate::input::text::short_number(pred[j][k])
            )
        })
        .collect();
    Err(format!(
        "{what}: `{name}` is {v}, not a number that can be reported or saved (nothing was written); the \
         samples that drive it: {}",
        named.join("; ")
    ))
}

#[cfg(test)]
mod trust_tests {
    use super::*;
    use crate::device::Inputs;

    /// A result that is not a number is refused, and the sample that drove it is named first by its file
    /// and time; finite results pass.
    #[test]
    fn results_that_are_not_numbers_name_the_sample_that_drove_them() {
        let inputs: Vec<Inputs> = (0..20)
            .map(|k| Inputs {
                t_s: k as f64 * 0.01,
                x_m: 0.0,
                v_m_s: 0.1,
                a_m_s2: 0.0,
                current_cmd_a: if k == 7 { 1e300 } else { 1.0 },
            })
            .collect();
        let t = Test::synthetic("probe.csv", "g", inputs, vec![10.0; 20]);
        let mut pred = vec![vec![10.5; 20]];
        pred[0][7] = f64::INFINITY;
        let (_, total) = figures(&pred, std::slice::from_ref(&t));
        let e = check_finite(
            "fit",
            &[("rmse_n".into(), total.rmse_n())],
            std::slice::from_ref(&t),
            &pred,
        )
        .unwrap_err();
        assert!(e.starts_with("fit: `rmse_n` is inf"), "{e}");
        assert!(
            e.contains("samples that drive it: `probe.csv` at t = 0.07 s (sample 8"),
            "{e}"
        );
        pred[0][7] = 10.5;
        let (_, total) = figures(&pred, std::slice::from_ref(&t));
        assert_eq!(
            check_finite("fit", &[("rmse_n".into(), total.rmse_n())], &[t], &pred),
            Ok(())
        );
    }
}
