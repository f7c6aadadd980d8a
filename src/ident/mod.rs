//! Model discovery on measured data (`shared/spec/model-discovery.md`): fit a composed damper model to one or
//! many tests, validate a saved model on other tests, map where the residual lives, and name the missing
//! effect by the held-out error each registered effect removes.
//!
//! Everything here works through [`crate::device::Model`], the [`crate::device::Effect`] trait and a
//! [`crate::device::Registry`]: no effect is named in this module, so an effect a user registers is fitted
//! and diagnosed exactly like the built-in ones.

pub mod cli;
pub mod diagnose;
pub mod fit;
pub mod plots;
pub mod report;
pub mod rerun_log;
pub mod residual;
pub mod validate;

use std::path::{Path, PathBuf};

use crate::device::params::TestSignals;
use crate::device::{DataStats, DeviceError, Inputs};
use crate::measurement::{smooth_derivative, Measurement, MeasurementError};

pub use diagnose::{diagnose, DiagnoseOptions, Diagnosis};
pub use fit::{fit, FitOptions, FitResult};
pub use validate::{evaluate, Figures};

/// Errors of fitting, validation and diagnosis.
#[derive(Debug, thiserror::Error)]
pub enum IdentError {
    #[error(transparent)]
    Measurement(#[from] MeasurementError),
    #[error(transparent)]
    Device(#[from] DeviceError),
    #[error("no measurement files given")]
    NoData,
    #[error("{0}")]
    Other(String),
}

/// One test prepared for the models: the inputs at every sample and the measured force.
#[derive(Debug, Clone)]
pub struct Test {
    pub path: PathBuf,
    /// File name, for tables and plots.
    pub name: String,
    /// Cross-validation group: tests of one group are held out together (see [`group_of`]).
    pub group: String,
    pub inputs: Vec<Inputs>,
    pub f_n: Vec<f64>,
    pub velocity_measured: bool,
}

impl Test {
    pub fn from_measurement(m: &Measurement) -> Self {
        let name = m
            .path
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        Self {
            path: m.path.clone(),
            group: group_of(m),
            name,
            inputs: inputs_of(m),
            f_n: m.f_n.clone(),
            velocity_measured: m.velocity_measured,
        }
    }

    pub fn len(&self) -> usize {
        self.f_n.len()
    }

    pub fn is_empty(&self) -> bool {
        self.f_n.is_empty()
    }
}

/// Model inputs of a measurement ([`Measurement::inputs`]), with the acceleration, when the file has none,
/// derived along the quieter of two routes: differentiating the measured velocity, or differentiating the
/// displacement twice. A velocity transducer is often far noisier than the displacement sensor (and a
/// derivative multiplies noise by ~0.5/dt), so the acceleration from a noisy velocity can be mostly noise,
/// which hides the `inertia` effect (errors in the variables attenuate its fit). The noise of each raw
/// signal is estimated from the data ([`residual::white_noise_std`]) and carried through the
/// differentiator's own noise gain; the route with the smaller result is used.
pub fn inputs_of(m: &Measurement) -> Vec<Inputs> {
    let mut inputs = m.inputs();
    if m.a_m_s2.is_some() || !m.velocity_measured || m.len() < 16 {
        return inputs;
    }
    let (g1, g2) = derivative_noise_gains();
    let dt = crate::measurement::median_interval(&m.t_s);
    let sd_from_v = g1 * residual::white_noise_std(&m.v_m_s) / dt;
    let sd_from_x = g2 * residual::white_noise_std(&m.x_m) / (dt * dt);
    if sd_from_x < sd_from_v {
        let v_x = smooth_derivative(&m.t_s, &m.x_m);
        for (i, a) in inputs.iter_mut().zip(smooth_derivative(&m.t_s, &v_x)) {
            i.a_m_s2 = a;
        }
    }
    inputs
}

/// White-noise gains of the smoothing differentiator applied once and twice on a unit-spaced grid (the
/// RMS of its impulse response): multiply by σ/dt and σ/dt² respectively.
fn derivative_noise_gains() -> (f64, f64) {
    let n = 41;
    let t: Vec<f64> = (0..n).map(|k| k as f64).collect();
    let mut imp = vec![0.0; n];
    imp[n / 2] = 1.0;
    let d1 = smooth_derivative(&t, &imp);
    let d2 = smooth_derivative(&t, &d1);
    let norm = |d: &[f64]| d.iter().map(|v| v * v).sum::<f64>().sqrt();
    (norm(&d1), norm(&d2))
}

/// The cross-validation group of a test: the `group` metadata key when present, else the file stem up to
/// its last `_` (`10mm1Hz_0p50A.csv` → `10mm1Hz`: the tests of one protocol at several currents), else the
/// stem itself. [`diagnose`] falls back to one group per file when this gives a single group.
pub fn group_of(m: &Measurement) -> String {
    if let Some(g) = m.meta.get("group") {
        return g.trim().to_string();
    }
    let stem = m
        .path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    match stem.rsplit_once('_') {
        Some((head, _)) if !head.is_empty() => head.to_string(),
        _ => stem,
    }
}

/// Read files and directories of CSV files into tests.
pub fn load_tests(paths: &[PathBuf]) -> Result<Vec<Test>, IdentError> {
    if paths.is_empty() {
        return Err(IdentError::NoData);
    }
    let ms = crate::measurement::read_all(paths)?;
    Ok(ms.iter().map(Test::from_measurement).collect())
}

/// Statistics the elements derive their initial guesses from.
pub fn data_stats(tests: &[Test]) -> DataStats {
    let cols: Vec<[Vec<f64>; 5]> = tests
        .iter()
        .map(|t| {
            [
                t.inputs.iter().map(|i| i.t_s).collect(),
                t.inputs.iter().map(|i| i.x_m).collect(),
                t.inputs.iter().map(|i| i.v_m_s).collect(),
                t.inputs.iter().map(|i| i.a_m_s2).collect(),
                t.inputs.iter().map(|i| i.current_cmd_a).collect(),
            ]
        })
        .collect();
    let sig: Vec<TestSignals<'_>> = cols
        .iter()
        .zip(tests)
        .map(|(c, t)| TestSignals {
            t_s: &c[0],
            x_m: &c[1],
            v_m_s: &c[2],
            a_m_s2: &c[3],
            i_a: &c[4],
            f_n: &t.f_n,
        })
        .collect();
    DataStats::from_tests(&sig)
}

/// Driver saturation to build models with when the user gives none: the paper's 14 A, or the largest
/// command in the data when that is higher (a command the rig applied was not saturated by our model).
pub fn default_current_limit_a(tests: &[Test]) -> f64 {
    let imax = tests
        .iter()
        .flat_map(|t| t.inputs.iter())
        .fold(0.0f64, |m, i| m.max(i.current_cmd_a.abs()));
    imax.max(crate::device::PAPER_CURRENT_LIMIT_A)
}

/// Root-mean-square of a slice (0 for an empty slice).
pub fn rms(x: &[f64]) -> f64 {
    if x.is_empty() {
        return 0.0;
    }
    (x.iter().map(|v| v * v).sum::<f64>() / x.len() as f64).sqrt()
}

/// Display name of a path for reports: as given.
pub fn display_path(p: &Path) -> String {
    p.display().to_string()
}
