//! Model discovery on measured data (`docs/spec/model-discovery.md`): fit a composed damper model to one or
//! many tests, validate a saved model on other tests, map where the residual lives, and name the missing
//! effect by the held-out error each registered effect removes.
//!
//! Everything here works through [`crate::device::Model`], the [`crate::device::Effect`] trait and a
//! [`crate::device::Registry`]: no effect is named in this module, so an effect a user registers is fitted
//! and diagnosed exactly like the built-in ones.

pub mod acquisition;
pub(crate) mod clipping;
pub mod diagnose;
pub mod discover;
pub mod fit;
pub(crate) mod load;
pub mod plots;
pub mod report;
#[cfg(feature = "rerun")]
pub mod rerun_log;
pub mod residual;
pub mod simulate;
pub mod timing;
pub mod validate;

use std::path::PathBuf;

use crate::device::{DeviceError, Inputs};
use crate::input::InputError;
use crate::measurement::Measurement;

pub use diagnose::{diagnose, DiagnoseOptions, Diagnosis};
pub use fit::{fit, FitOptions, FitResult};
pub(crate) use load::{acquisition_note, tests_predicting};
pub use load::{
    data_stats, default_current_limit_a, inputs_and_velocity_noise, inputs_of, load_tests, tests_from,
    tests_with, AcquisitionChoice,
};
pub use validate::{evaluate, Figures};

/// Errors of fitting, validation and diagnosis.
#[derive(Debug, thiserror::Error)]
pub enum IdentError {
    /// A bad measurement file.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A bad model spec or parameter file.
    #[error(transparent)]
    Device(#[from] DeviceError),
    /// No measurement file was given.
    #[error("no measurement files given")]
    NoData,
    /// Stopped on request ([`crate::interrupt`]).
    #[error("interrupted")]
    Interrupted,
    /// Anything else, in words.
    #[error("{0}")]
    Other(String),
}

/// `Err(Interrupted)` when a stop was asked for ([`crate::interrupt`]): long searches check between
/// stages, so a stop does not wait for the rest of the search to run on stopped fits.
pub(crate) fn stop_if_asked() -> Result<(), IdentError> {
    (!crate::interrupt::requested())
        .then_some(())
        .ok_or(IdentError::Interrupted)
}

/// One test prepared for the models: the inputs at every sample and the measured force.
#[derive(Debug, Clone)]
pub struct Test {
    /// The measurement file.
    pub path: PathBuf,
    /// File name, for tables and plots.
    pub name: String,
    /// Cross-validation group: tests of one group are held out together (see `load::group_of`).
    pub group: String,
    /// The model's inputs at every sample.
    pub inputs: Vec<Inputs>,
    /// Measured force at every sample, N.
    pub f_n: Vec<f64>,
    /// Whether the velocity was logged (else derived from the displacement).
    pub velocity_measured: bool,
    /// Noise standard deviation, at each sample, of a velocity derived here from the displacement (through
    /// the differentiator used at that sample, see [`inputs_of`]), m/s; `None`: estimated from the data.
    pub velocity_noise_m_s: Option<Vec<f64>>,
    /// When the file went through a moving average before it was logged: the motion before it, which drives
    /// the model, and the window the model's force goes through ([`acquisition`]). `None`: as logged.
    pub drive: Option<acquisition::Drive>,
}

impl Test {
    /// The test of one file, its acquisition filter detected from the file alone.
    pub fn from_measurement(m: &Measurement) -> Self {
        Self::with_filter(m, load::filter_of(&[m]))
    }

    /// The test of one file whose acquisition filter was detected beforehand (with the other tests of its
    /// protocol: [`load_tests`]).
    pub fn with_filter(m: &Measurement, filter: Option<acquisition::MovingAverage>) -> Self {
        let name = m
            .path
            .file_name()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let (inputs, velocity_noise_m_s) = load::inputs_and_velocity_noise(m);
        Self {
            path: m.path.clone(),
            group: load::group_of(m),
            name,
            inputs,
            f_n: m.f_n.clone(),
            velocity_measured: m.velocity_measured,
            velocity_noise_m_s,
            drive: filter.and_then(|f| load::drive_of(m, f)),
        }
    }

    /// The inputs that drive the model to predict the first `n` samples: the test's own, or with a
    /// filtered acquisition the motion before the filter from `window − 1` samples before the record.
    pub fn drive_inputs(&self, n: usize) -> &[Inputs] {
        match &self.drive {
            Some(d) => &d.inputs[..n + d.window() - 1],
            None => &self.inputs[..n],
        }
    }

    /// The force the file would show, from the model's force over [`Test::drive_inputs`]: itself, or its
    /// moving average over the acquisition's window (the crate's `Test::observer` fed all of it at once).
    pub fn observed(&self, model_force: Vec<f64>) -> Vec<f64> {
        let Some(mut mean) = self.observer() else {
            return model_force;
        };
        let mut out = Vec::with_capacity(model_force.len());
        mean.feed(&model_force, &mut out);
        out
    }

    /// The acquisition's moving average, to be fed the model's force piece by piece, or none where the
    /// file's force is the model's itself.
    pub(crate) fn observer(&self) -> Option<crate::signal::RollingMean> {
        let window = self.drive.as_ref().map_or(1, |d| d.window());
        (window > 1).then(|| crate::signal::RollingMean::new(window))
    }

    /// The model's prediction of the first `n` samples of the file's force.
    pub fn predict(&self, model: &crate::device::Model, params: &[f64], n: usize) -> Vec<f64> {
        self.observed(model.simulate(params, self.drive_inputs(n)))
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.f_n.len()
    }

    /// Whether the test has no samples.
    pub fn is_empty(&self) -> bool {
        self.f_n.is_empty()
    }

    /// A synthetic test with a measured velocity, file `name` of group `group`.
    #[cfg(test)]
    pub(crate) fn synthetic(name: &str, group: &str, inputs: Vec<Inputs>, f_n: Vec<f64>) -> Self {
        Self {
            path: name.into(),
            name: name.into(),
            group: group.into(),
            inputs,
            f_n,
            velocity_measured: true,
            velocity_noise_m_s: None,
            drive: None,
        }
    }
}

/// `n` samples of seeded white Gaussian noise of standard deviation `sd`, for tests.
#[cfg(test)]
pub(crate) fn noise(n: usize, sd: f64, seed: u64) -> Vec<f64> {
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let d = Normal::new(0.0, sd).unwrap();
    (0..n).map(|_| d.sample(&mut rng)).collect()
}
