//! The library's front door: load measurements, fit a model, validate it, predict with it, diagnose what it
//! lacks and run a scenario, each as one call. The command line (`fit`, `validate`, `diagnose`, `run`) and
//! the Python bindings both call these, so a result is the same, to the bit, whichever way it was asked
//! for; they differ only in how they show it.
#![warn(missing_docs)]

use std::path::{Path, PathBuf};

use anyhow::Context;

pub use crate::device::{DeviceConfig, Model, ModelSpec, ParamsFile, Registry};
pub use crate::ident::diagnose::{DiagnoseOptions, Diagnosis};
pub use crate::ident::fit::{FitOptions, FitResult, Weighting};
pub use crate::ident::report::{DiagnoseJson, FitJson};
pub use crate::ident::timing::{TimingChoice, TimingDecision};
pub use crate::ident::validate::Figures;
pub use crate::ident::{AcquisitionChoice, IdentError, Test};
pub use crate::input::InputError;
pub use crate::measurement::Measurement;
pub use crate::scenario::{Origin, Override, Scenario};
pub use crate::sim::Results;

use crate::ident::fit::all_spans;
use crate::ident::timing::{decide, retimed};
use crate::ident::validate::evaluate;

/// Measurements prepared for the models, and what was found about their acquisition chain.
#[derive(Debug, Clone)]
pub struct Data {
    /// The tests, ready for the models.
    pub tests: Vec<Test>,
    /// The share of the drive period that the acquisition filter spanned, where one was found (saved in
    /// PARAMS.json: `acquisition_window_periods`).
    pub window_periods: Option<f64>,
    /// What was done about the acquisition chain, one line each (the command line prints them on stderr).
    pub notes: Vec<String>,
}

/// Read measurement files and directories of them (`*.csv`, sorted by name).
pub fn read(paths: &[PathBuf]) -> Result<Vec<Measurement>, IdentError> {
    if paths.is_empty() {
        return Err(IdentError::NoData);
    }
    Ok(crate::measurement::read_all(paths)?)
}

/// Read the files and prepare them ([`prepare`]); a file read twice (named twice, or named and found in a
/// named directory) is refused.
pub fn load(paths: &[PathBuf], acquisition: AcquisitionChoice, share: Option<f64>) -> anyhow::Result<Data> {
    Ok(load_keeping(paths, acquisition, share)?.1)
}

/// [`load`], keeping the measurements as read (for writing them out again beside a model's force).
pub fn load_keeping(
    paths: &[PathBuf],
    acquisition: AcquisitionChoice,
    share: Option<f64>,
) -> anyhow::Result<(Vec<Measurement>, Data)> {
    let ms = read(paths)?;
    let data = prepare_unchecked(&ms, acquisition, share)?;
    no_file_twice(&data.tests)?;
    no_test_twice(&data.tests)?;
    Ok((ms, data))
}

/// Tests of measurements read together, their acquisition chain taken as `acquisition` says (under `auto`,
/// where a protocol's tests do not show a filter themselves, `share` of the drive period is checked: the
/// one a saved model found). A measurement without force, or two with every sample equal, are refused.
pub fn prepare(
    ms: &[Measurement],
    acquisition: AcquisitionChoice,
    share: Option<f64>,
) -> anyhow::Result<Data> {
    let data = prepare_unchecked(ms, acquisition, share)?;
    no_test_twice(&data.tests)?;
    Ok(data)
}

fn prepare_unchecked(
    ms: &[Measurement],
    acquisition: AcquisitionChoice,
    share: Option<f64>,
) -> anyhow::Result<Data> {
    if ms.is_empty() {
        return Err(IdentError::NoData.into());
    }
    crate::ident::load::refuse_zero_force(ms)?;
    let (tests, window_periods) = match acquisition {
        AcquisitionChoice::Auto => crate::ident::tests_predicting(ms, share),
        _ => (crate::ident::tests_with(ms, acquisition)?, None),
    };
    let mut notes = crate::ident::clipping::notes(&tests);
    notes.extend(match acquisition {
        AcquisitionChoice::Auto => crate::ident::acquisition_note(&tests),
        AcquisitionChoice::AsLogged => {
            vec!["acquisition: the files are compared as they are (--acquisition as-logged)".into()]
        }
        AcquisitionChoice::MovingAverage(n) => vec![format!(
            "acquisition: every file was logged through a moving average of {n} samples (--acquisition {n}); \
             the model is driven by the motion before it and its force goes through the same average"
        )],
    });
    Ok(Data {
        tests,
        window_periods,
        notes,
    })
}

/// Refuse a file read twice (named twice, or named and also inside a named directory): its test would count
/// twice in every fit and figure.
fn no_file_twice(tests: &[Test]) -> anyhow::Result<()> {
    let mut seen: Vec<(crate::outputs::FileId, &Path)> = Vec::with_capacity(tests.len());
    for t in tests {
        // One file however it is reached: symlinks, `..`, hard links.
        let key = crate::outputs::file_id(&t.path);
        if let Some((_, first)) = seen.iter().find(|(k, _)| *k == key) {
            let also = if *first == t.path.as_path() {
                String::new()
            } else {
                format!(" (also as `{}`)", first.display())
            };
            anyhow::bail!(
                "DATA: `{}`{also} is read twice: named twice, or named and also found in a named directory; \
                 its test would count twice: name every file once (nothing was run)",
                t.path.display()
            );
        }
        seen.push((key, &t.path));
    }
    Ok(())
}

/// Refuse one test under two names (a copy: every sample the same): it would count twice.
fn no_test_twice(tests: &[Test]) -> anyhow::Result<()> {
    for (k, t) in tests.iter().enumerate() {
        // Equal forces first: a cheap test that almost always fails for two different measurements.
        if let Some(first) = tests[..k].iter().find(|u| u.f_n == t.f_n && u.inputs == t.inputs) {
            anyhow::bail!(
                "DATA: `{}` holds the same samples as `{}` (every time, motion, current and force equal): one \
                 test under two names would count twice: give it once (nothing was run)",
                t.path.display(),
                first.path.display()
            );
        }
    }
    Ok(())
}

/// What a fit is asked to do (`mrfeel fit`'s options).
#[derive(Debug, Clone, Default)]
pub struct FitSetup {
    /// Model spec: `bingham` plus effects joined by `+` (empty: `bingham`).
    pub model: String,
    /// Driver saturation of the current command, A (`None`: 14 A, or the largest command in the data).
    pub current_limit_a: Option<f64>,
    /// How the tests share the loss.
    pub weighting: Weighting,
    /// When the logged current commands took effect (or decide from the data).
    pub command_timing: TimingChoice,
}

impl FitSetup {
    /// The fit's options: the defaults with this weighting.
    pub fn options(&self) -> FitOptions {
        FitOptions {
            weighting: self.weighting,
            ..FitOptions::default()
        }
    }
}

/// The driver saturation for `tests`: the one given (a positive number of amperes) or the default.
pub fn current_limit(given: Option<f64>, tests: &[Test]) -> anyhow::Result<f64> {
    match given {
        Some(l) if !(l.is_finite() && l > 0.0) => {
            anyhow::bail!("--current-limit-a {l}: must be a positive number of amperes")
        }
        Some(l) => Ok(l),
        None => Ok(crate::ident::default_current_limit_a(tests)),
    }
}

/// The model `spec` with the builtin effects.
pub fn model(spec: &str, current_limit_a: f64) -> anyhow::Result<Model> {
    model_in(spec, &Registry::builtin(), current_limit_a)
}

/// The model `spec` with the effects of `registry` (the built-ins plus data-defined effects).
fn model_in(spec: &str, registry: &Registry, current_limit_a: f64) -> anyhow::Result<Model> {
    let spec = ModelSpec::parse(if spec.trim().is_empty() { "bingham" } else { spec })?;
    Ok(Model::new(&spec, registry, current_limit_a)?)
}

/// Every test must have enough samples for a fit of `n` parameters.
pub fn require(tests: &[Test], n: usize) -> anyhow::Result<()> {
    for t in tests {
        if t.len() < 2 * n {
            let what = format!("a fit or validation of a model of {n} parameters");
            return Err(crate::measurement::too_few_samples(&t.path, t.len(), 2 * n, &what).into());
        }
    }
    Ok(())
}

/// The model a fit of `tests` starts from (`setup.model` at the driver saturation for them), checked to
/// have few enough parameters for every test.
pub fn fit_model(tests: &[Test], setup: &FitSetup) -> anyhow::Result<Model> {
    fit_model_in(tests, setup, &Registry::builtin())
}

/// [`fit_model`] with the effects of `registry`.
pub fn fit_model_in(tests: &[Test], setup: &FitSetup, registry: &Registry) -> anyhow::Result<Model> {
    let limit = current_limit(setup.current_limit_a, tests)?;
    let model = model_in(&setup.model, registry, limit)?;
    require(tests, model.n_params())?;
    Ok(model)
}

/// A fitted model and what it was fitted on.
#[derive(Debug)]
pub struct Fitted {
    /// The model fitted.
    pub model: Model,
    /// Its parameters, standard errors and figures.
    pub result: FitResult,
    /// The command timing decided for the data.
    pub timing: TimingDecision,
    /// The tests as the model reads them (their current commands retimed as decided).
    pub tests: Vec<Test>,
    /// [`Data::window_periods`] of the data fitted.
    pub window_periods: Option<f64>,
    /// How the tests shared the loss.
    pub weighting: Weighting,
}

/// Fit `model` ([`fit_model`]) to the tests of `data` jointly, each from its own start, as `mrfeel fit`.
pub fn fit(model: Model, data: Data, setup: &FitSetup) -> Fitted {
    let opts = setup.options();
    let (tests, timing) = decide(&model, data.tests, setup.command_timing, &opts);
    let result = match timing.kept_fit() {
        Some(fr) => fr.clone(),
        None => crate::ident::fit(&model, &tests, &all_spans(&tests), &opts),
    };
    Fitted {
        model,
        result,
        timing,
        tests,
        window_periods: data.window_periods,
        weighting: setup.weighting,
    }
}

impl Fitted {
    /// PARAMS.json of the fit (`mrfeel fit --save`).
    pub fn params_file(&self) -> ParamsFile {
        let mut file = ParamsFile::new(&self.model, &self.result.params, Some(&self.result.std_err));
        file.command_timing = Some(self.timing.timing.as_str().to_string());
        file.weighting = Some(self.weighting.as_str().to_string());
        file.acquisition_window_periods = self.window_periods;
        file
    }

    /// The model's force at every sample of every test it was fitted on.
    pub fn predictions(&self) -> Vec<Vec<f64>> {
        evaluate(&self.model, &self.result.params, &self.tests)
    }

    /// `fit --json` for the predictions `pred` ([`Fitted::predictions`]).
    pub fn report(&self, pred: &[Vec<f64>]) -> FitJson {
        FitJson::new(
            &self.model,
            &self.result.params,
            Some(&self.result),
            &self.tests,
            pred,
        )
    }
}

/// A saved model (PARAMS.json or a device `.toml`) run unchanged on tests: the tests as it reads them
/// (its saved command timing), its force on each, and `validate --json`.
pub fn validate(cfg: &DeviceConfig, data: Data) -> anyhow::Result<(Vec<Test>, Vec<Vec<f64>>, FitJson)> {
    require(&data.tests, cfg.model.n_params())?;
    let tests = retimed(data.tests, cfg.command_timing);
    let pred = evaluate(&cfg.model, &cfg.params, &tests);
    let mut out = FitJson::new(&cfg.model, &cfg.params, None, &tests, &pred);
    // Standard errors as the PARAMS.json saved them.
    for (name, p) in out.params.iter_mut() {
        p.std_err = cfg.model.param_index(name).and_then(|k| cfg.std_errs[k]);
    }
    Ok((tests, pred, out))
}

/// A saved model's force on the motion and current commands of `m` (its force column is not used), as
/// `validate` drives it: from the first sample, the commands read as the model was fitted, the motion as
/// logged (no acquisition filter is undone).
pub fn predict(cfg: &DeviceConfig, m: &Measurement) -> Vec<f64> {
    let test = Test::with_filter(m, None);
    let test = retimed(vec![test], cfg.command_timing).remove(0);
    test.predict(&cfg.model, &cfg.params, test.inputs.len())
}

/// What a diagnosis is asked to do (`mrfeel diagnose`'s options).
#[derive(Debug, Clone, Default)]
pub struct DiagnoseSetup {
    /// The model to start from (empty: the base chosen by held-out error,
    /// [`crate::ident::diagnose::diagnose_choosing_base`]).
    pub model: String,
    /// Driver saturation of the current command, A (`None`: the default for the data).
    pub current_limit_a: Option<f64>,
    /// How the tests share the loss.
    pub weighting: Weighting,
    /// When the logged current commands took effect (or decide from the data).
    pub command_timing: TimingChoice,
    /// Draw progress bars on stderr.
    pub progress: bool,
}

/// A diagnosis and what it was made on.
#[derive(Debug, Clone)]
pub struct Diagnosed {
    /// The tests as read (command timing decided on the starting model).
    pub tests: Vec<Test>,
    /// The effects found, step by step.
    pub diagnosis: Diagnosis,
    /// The command timing decided on the starting model.
    pub timing: TimingDecision,
    /// The final model fitted on every test, as PARAMS.json (no standard errors: the diagnosis's fits skip
    /// them).
    pub final_model: ParamsFile,
}

/// Diagnose the tests of `data` from `setup.model` as `mrfeel diagnose`.
pub fn diagnose(data: Data, setup: &DiagnoseSetup) -> anyhow::Result<Diagnosed> {
    diagnose_in(data, setup, &Registry::builtin(), false)
}

/// [`diagnose`] with the effects of `registry`, and with the open search for terms beyond the vocabulary
/// when `open_search` (`mrfeel diagnose` unless `--named-only`).
pub fn diagnose_in(
    data: Data,
    setup: &DiagnoseSetup,
    registry: &Registry,
    open_search: bool,
) -> anyhow::Result<Diagnosed> {
    let tests = data.tests;
    let limit = current_limit(setup.current_limit_a, &tests)?;
    let base = model_in(&setup.model, registry, limit)?;
    // The largest model the search can reach needs the most samples.
    let most = registry
        .names()
        .iter()
        .filter(|n| !base.spec().has(n))
        .filter_map(|n| registry.get(n))
        .map(|e| e.params().len())
        .sum::<usize>()
        + base.n_params();
    require(&tests, most)?;
    let opts = DiagnoseOptions {
        current_limit_a: limit,
        progress: setup.progress,
        fit: FitOptions {
            weighting: setup.weighting,
            ..FitOptions::default()
        },
        open_search,
        ..Default::default()
    };
    let quick = FitOptions {
        std_errors: false,
        ..opts.fit.clone()
    };
    let (tests, timing) = decide(&base, tests, setup.command_timing, &quick);
    let d = if setup.model.trim().is_empty() {
        crate::ident::diagnose::diagnose_choosing_base(&tests, registry, &opts)?
    } else {
        crate::ident::diagnose(&tests, base.spec(), registry, &opts)?
    };
    let final_spec = model_in(&d.final_model, &d.registry, limit)?;
    let mut final_model = ParamsFile::new(&final_spec, &d.final_params, None);
    final_model.command_timing = Some(timing.timing.as_str().to_string());
    final_model.weighting = Some(setup.weighting.as_str().to_string());
    final_model.acquisition_window_periods = data.window_periods;
    Ok(Diagnosed {
        tests,
        diagnosis: d,
        timing,
        final_model,
    })
}

/// The scenario at `path` with values replaced by dotted key (`feel.gradient_n_per_m` → 900), checked as the
/// file's own; `what` names where the overrides were given, for errors (`overrides["feel.x"]`).
pub fn load_scenario_with(
    path: &Path,
    overrides: &[(String, serde_json::Value)],
    what: &str,
) -> anyhow::Result<Scenario> {
    let overrides = overrides
        .iter()
        .map(|(key, v)| {
            let origin = Origin::Argument(format!("{what}[{key:?}]"));
            let value = toml::Value::try_from(v)
                .map_err(|e| anyhow::anyhow!("{origin}: `{key}`: not a scenario value: {e}"))?;
            Ok(Override::set(key, value, origin))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(Scenario::load_with(path, &overrides)?)
}

/// Run a loaded scenario (read from `path`) headless to its end, as `mrfeel run` without a recording.
pub fn run_scenario(scn: &Scenario, path: &Path) -> anyhow::Result<Results> {
    let devices = crate::sim::Devices::load(scn)?;
    let rig = crate::sim::build_rig(scn, &devices.plant)?;
    let opts = crate::sim::RunOptions { frames_hz: None };
    crate::sim::run(scn, &devices, rig, opts, |_| {})
        .with_context(|| format!("running scenario {}", path.display()))
}

/// `mrfeel run --json`'s summary of a run of `scn`: the run's figures, and with an aircraft its flight's
/// under `flight`.
pub fn run_summary(res: &Results, scn: &Scenario) -> serde_json::Result<serde_json::Value> {
    let mut v = serde_json::to_value(res.summary())?;
    if let (Some(m), Some(obj)) = (
        crate::sim::metrics::FlightMetrics::of(res, scn),
        v.as_object_mut(),
    ) {
        obj.insert("flight".into(), serde_json::to_value(m)?);
    }
    Ok(v)
}

/// The model a PARAMS.json describes, as `validate --params` reads it (`name` stands for its file in
/// messages).
pub fn saved_model(file: &ParamsFile, name: &Path) -> anyhow::Result<DeviceConfig> {
    let text = serde_json::to_string_pretty(file)?;
    Ok(DeviceConfig::from_json(&text, name, &Registry::builtin())?)
}
