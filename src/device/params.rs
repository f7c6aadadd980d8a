//! Named, unit-carrying model parameters.

use serde::{Deserialize, Serialize};

/// Declaration of one fitted parameter: its name (unique in a model, unit in the name), unit, physical
/// bounds and meaning. Bounds are hard limits the fitter respects; they are physical (a damping coefficient
/// is not negative), not tuned to a data set.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamSpec {
    pub name: &'static str,
    pub unit: &'static str,
    pub lower: f64,
    pub upper: f64,
    pub doc: &'static str,
}

impl ParamSpec {
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
        }
    }

    /// Clamp a value into the bounds.
    pub fn clamp(&self, v: f64) -> f64 {
        v.max(self.lower).min(self.upper)
    }
}

/// One parameter value with its optional standard error, as written to `PARAMS.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ParamValue {
    pub value: f64,
    /// Standard error from the fit's Jacobian; `None` when the data does not determine the parameter.
    #[serde(default)]
    pub std_err: Option<f64>,
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
    /// Largest and mean current command, A.
    pub i_max_a: f64,
    pub i_mean_a: f64,
    /// Median sample interval, s, and the longest test's duration, s.
    pub dt_s: f64,
    pub duration_s: f64,
    /// Linear least-squares Bingham estimate `F ≈ (fc0 + k i) sgn v + c v` on the data (a starting point).
    pub fc0_n: f64,
    pub fc_gain_n_per_a: f64,
    pub c0_n_s_per_m: f64,
}
