//! What the held-out examples share: their command line (`[DIR] [--weighting tests|samples]`), the tests, and
//! the diagnosis's folds and fold fits, so that each judges a model as `diagnose` judges a candidate.

use mrfeel::device::{Model, Registry};
use mrfeel::ident::diagnose::{cross_validate, CvResult, DiagnoseOptions, Fold};
use mrfeel::ident::fit::{FitOptions, Weighting};
use mrfeel::ident::{default_current_limit_a, load_tests, Test};

pub struct Heldout {
    pub tests: Vec<Test>,
    pub folds: Vec<Fold>,
    /// The diagnosis's cross-validation fits, with the weighting asked for.
    pub opts: FitOptions,
}

impl Heldout {
    /// The tests of `DIR` (default `data/utfsm-mr-damper`) and the diagnosis's folds, fitted with
    /// the `--weighting` given (default: each test once); prints how the folds were made.
    pub fn from_args() -> anyhow::Result<Self> {
        let (weighting, args) =
            Weighting::from_args(std::env::args().skip(1).collect()).map_err(anyhow::Error::msg)?;
        let dir = args
            .first()
            .cloned()
            .unwrap_or_else(|| "data/utfsm-mr-damper".into());
        let tests = load_tests(&[dir.into()])?;
        let diagnosis = DiagnoseOptions {
            fit: FitOptions {
                weighting,
                ..FitOptions::default()
            },
            ..DiagnoseOptions::default()
        };
        let (folds, how) = diagnosis.folds(&tests);
        println!("{how}");
        Ok(Self {
            tests,
            folds,
            opts: diagnosis.cv_fit(),
        })
    }

    /// The model `spec` of `registry`, cross-validated over the folds.
    pub fn cross_validate(&self, spec: &str, registry: &Registry) -> anyhow::Result<(Model, CvResult)> {
        let model = Model::from_spec(spec, registry, default_current_limit_a(&self.tests))?;
        let cv = cross_validate(
            &model,
            &self.tests,
            &self.folds,
            None,
            &self.opts,
            &indicatif::ProgressBar::hidden(),
        );
        Ok((model, cv))
    }
}
