//! Named, unit-carrying model parameters.

use serde::{Deserialize, Serialize};

/// Declaration of one fitted parameter: its name (unique in a model, unit in the name), unit, physical
/// bounds and meaning. Bounds are hard limits the fitter respects; they are physical (a damping coefficient
/// is not negative), not tuned to a data set.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    /// Name, unique in a model, with its unit as suffix (`fc_gain_n_per_a`).
    pub name: &'static str,
    /// Unit (`N/A`).
    pub unit: &'static str,
    /// Lower physical bound, in `unit`.
    pub lower: f64,
    /// Upper physical bound, in `unit`.
    pub upper: f64,
    /// What the parameter is, one line.
    pub doc: &'static str,
    /// The value a parameter file that leaves this parameter out describes: set for a parameter added to an
    /// effect later, whose value here gives the effect as it was before (files saved then stay readable and
    /// mean what they meant). `None`: the parameter must be in every file.
    pub absent: Option<f64>,
}

impl ParamSpec {
    /// A parameter every file must give.
    pub const fn new(
        name: &'static str,
        unit: &'static str,
        lower: f64,
        upper: f64,
        doc: &'static str,
    ) -> Self {
        Self {
            name,
            unit,
            lower,
            upper,
            doc,
            absent: None,
        }
    }

    /// A parameter every file must give, from 0 up without bound (a gain, a damping, a stiffness).
    pub const fn non_negative(name: &'static str, unit: &'static str, doc: &'static str) -> Self {
        Self::new(name, unit, 0.0, f64::INFINITY, doc)
    }

    /// The value that a parameter file without this parameter means (see [`ParamSpec::absent`]).
    pub const fn absent_means(mut self, v: f64) -> Self {
        self.absent = Some(v);
        self
    }

    /// Clamp a value into the bounds.
    pub fn clamp(&self, v: f64) -> f64 {
        v.max(self.lower).min(self.upper)
    }
}

/// One parameter value with its optional standard error, as written to `PARAMS.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamValue {
    /// The value, in `unit`.
    pub value: f64,
    /// Standard error from the fit's Jacobian; `None` when the data does not determine the parameter.
    pub std_err: Option<f64>,
    /// Unit, as written (checked against the declaration where given).
    #[serde(default)]
    pub unit: String,
}

/// Summary statistics of measured or simulated data from which every element derives its initial
/// guesses (never typed in per data set). Computed by `ident` from the samples a fit is given.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DataStats {
    /// RMS of the measured force, N.
    pub f_rms_n: f64,
    /// Largest |force|, N.
    pub f_max_n: f64,
    /// Largest |velocity|, m/s.
    pub v_max_m_s: f64,
    /// RMS velocity, m/s.
    pub v_rms_m_s: f64,
    /// Largest |displacement| from mid-stroke, m.
    pub x_max_m: f64,
    /// Largest |acceleration| (measured or derived), m/s².
    pub a_max_m_s2: f64,
    /// Largest current command, A.
    pub i_max_a: f64,
    /// Mean current command, A.
    pub i_mean_a: f64,
    /// Median sample interval, s.
    pub dt_s: f64,
    /// The longest test's duration, s.
    pub duration_s: f64,
    /// Linear least-squares Bingham estimate `F ≈ (fc0 + k i) sgn v + c v` on the data (a starting point): `fc0`, N.
    pub fc0_n: f64,
    /// The estimate's `k`, N/A.
    pub fc_gain_n_per_a: f64,
    /// The estimate's `c`, N·s/m.
    pub c0_n_s_per_m: f64,
}

/// Signals of one test, borrowed, for [`DataStats::from_tests`].
#[derive(Debug, Clone, Copy)]
pub(crate) struct TestSignals<'a> {
    pub t_s: &'a [f64],
    pub x_m: &'a [f64],
    pub v_m_s: &'a [f64],
    pub a_m_s2: &'a [f64],
    pub i_a: &'a [f64],
    pub f_n: &'a [f64],
}

impl DataStats {
    /// Statistics over several tests, including a linear least-squares Bingham estimate
    /// `F ≈ (fc0 + k |i|) sgn v + c v` (non-negative coefficients), the starting point of every fit.
    ///
    /// Signals of unequal length are read up to the shortest kinematic signal; the force statistics
    /// (`f_rms_n`, `f_max_n`, the Bingham estimate) use only the samples that have a force, so a test
    /// without force yet (e.g. synthetic inputs before the truth model runs) gives kinematic statistics and
    /// no panic.
    pub(crate) fn from_tests(tests: &[TestSignals<'_>]) -> Self {
        let mut s = DataStats::default();
        let (mut n, mut f2, mut v2, mut isum) = (0usize, 0.0, 0.0, 0.0);
        let mut dts = Vec::new();
        // Normal equations of the 3-parameter linear Bingham fit.
        let mut ata = [[0.0f64; 3]; 3];
        let mut atb = [0.0f64; 3];
        let mut nf = 0usize;
        for t in tests {
            let len = t
                .t_s
                .len()
                .min(t.x_m.len())
                .min(t.v_m_s.len())
                .min(t.a_m_s2.len())
                .min(t.i_a.len());
            for k in 0..len {
                let (v, i) = (t.v_m_s[k], t.i_a[k].abs());
                n += 1;
                v2 += v * v;
                isum += i;
                s.v_max_m_s = s.v_max_m_s.max(v.abs());
                s.x_max_m = s.x_max_m.max(t.x_m[k].abs());
                s.a_max_m_s2 = s.a_max_m_s2.max(t.a_m_s2[k].abs());
                s.i_max_a = s.i_max_a.max(i);
                let Some(&f) = t.f_n.get(k) else {
                    continue;
                };
                nf += 1;
                f2 += f * f;
                s.f_max_n = s.f_max_n.max(f.abs());
                let sg = super::bingham::sgn(v);
                let row = [sg, sg * i, v];
                for a in 0..3 {
                    atb[a] += row[a] * f;
                    for b in 0..3 {
                        ata[a][b] += row[a] * row[b];
                    }
                }
            }
            dts.extend(t.t_s[..len].windows(2).map(|w| w[1] - w[0]));
            if let (Some(a), Some(b)) = (t.t_s[..len].first(), t.t_s[..len].last()) {
                s.duration_s = s.duration_s.max(b - a);
            }
        }
        if n == 0 {
            return s;
        }
        s.f_rms_n = (f2 / nf.max(1) as f64).sqrt();
        s.v_rms_m_s = (v2 / n as f64).sqrt();
        s.i_mean_a = isum / n as f64;
        dts.sort_by(f64::total_cmp);
        s.dt_s = dts.get(dts.len() / 2).copied().unwrap_or(1e-3);
        let coef = nonneg_lstsq3(ata, atb);
        s.fc0_n = coef[0];
        s.fc_gain_n_per_a = coef[1];
        s.c0_n_s_per_m = coef[2];
        s
    }
}

/// Least squares with non-negative coefficients for a 3-unknown problem given its normal equations:
/// solve every subset of active coefficients and keep the best feasible one (8 subsets).
fn nonneg_lstsq3(ata: [[f64; 3]; 3], atb: [f64; 3]) -> [f64; 3] {
    let mut best = ([0.0; 3], 0.0f64); // objective relative to zero: -(2 x·atb - x·ata·x)
    for mask in 1u8..8 {
        let idx: Vec<usize> = (0..3).filter(|k| mask & (1 << k) != 0).collect();
        let m = idx.len();
        let mut a = nalgebra::DMatrix::<f64>::zeros(m, m);
        let mut b = nalgebra::DVector::<f64>::zeros(m);
        for (r, &i) in idx.iter().enumerate() {
            b[r] = atb[i];
            for (c, &j) in idx.iter().enumerate() {
                a[(r, c)] = ata[i][j];
            }
        }
        let Some(sol) = a.clone().lu().solve(&b) else {
            continue;
        };
        if sol.iter().any(|v| !v.is_finite() || *v < 0.0) {
            continue;
        }
        let mut x = [0.0; 3];
        for (r, &i) in idx.iter().enumerate() {
            x[i] = sol[r];
        }
        // Reduction in sum of squares: 2 x·atb - x·ata·x
        let mut gain = 0.0;
        for i in 0..3 {
            gain += 2.0 * x[i] * atb[i];
            for j in 0..3 {
                gain -= x[i] * ata[i][j] * x[j];
            }
        }
        if gain > best.1 {
            best = (x, gain);
        }
    }
    best.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_of_a_test_without_force_are_kinematic_only_and_do_not_panic() {
        let t: Vec<f64> = (0..100).map(|k| k as f64 * 1e-3).collect();
        let x: Vec<f64> = t.iter().map(|t| 0.01 * (6.0 * t).sin()).collect();
        let v: Vec<f64> = t.iter().map(|t| 0.06 * (6.0 * t).cos()).collect();
        let a = vec![0.0; 100];
        let i = vec![2.0; 100];
        let f_short = vec![5.0; 40];
        for f in [&[][..], &f_short[..]] {
            let s = DataStats::from_tests(&[TestSignals {
                t_s: &t,
                x_m: &x,
                v_m_s: &v[..90], // shorter than t: read up to 90 samples
                a_m_s2: &a,
                i_a: &i,
                f_n: f,
            }]);
            assert!((s.v_max_m_s - 0.06).abs() < 1e-12);
            assert!((s.i_mean_a - 2.0).abs() < 1e-12);
            assert!((s.dt_s - 1e-3).abs() < 1e-12);
            let want_f = if f.is_empty() { 0.0 } else { 5.0 };
            assert!((s.f_rms_n - want_f).abs() < 1e-12, "{}", s.f_rms_n);
        }
    }
}
