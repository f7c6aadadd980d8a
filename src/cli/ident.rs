//! `mrfeel fit`, `mrfeel validate`, `mrfeel diagnose` (`docs/spec/model-discovery.md`). JSON (with
//! `--json`) or a table on stdout, nothing else; progress and notes on stderr.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};

use anyhow::Context;

use mrfeel::device::formula::{register_file, resolve_spec, FormulaEffect};
use mrfeel::device::{DeviceConfig, ParamsFile, Registry};
use mrfeel::ident::diagnose::DiagnoseOptions;
use mrfeel::ident::fit::Weighting;
use mrfeel::ident::report::{diagnose_table, DiagnoseJson, FitJson};
use mrfeel::ident::timing::{CommandTiming, TimingChoice, TimingDecision};
use mrfeel::ident::{AcquisitionChoice, Test};
use mrfeel::measurement::Measurement;
use mrfeel::prelude;

/// `--acquisition`, shared by `fit`, `validate` and `diagnose`.
#[derive(clap::Args, Debug, Clone)]
pub struct AcquisitionArg {
    /// The acquisition chain the files went through: `auto` (a moving average found in the data, by the comb
    /// of zeros it leaves in the spectra of a protocol's tests; where a protocol's tests are too short to
    /// show one, the window that the other protocols' windows predict as a share of the drive period, or
    /// the share `fit --save` stored in PARAMS.json, if their spectra confirm it; none where none shows),
    /// `as-logged` (compare
    /// the files as they are), or a window N in samples (every file went through a causal moving average of
    /// N samples: the model is driven by the motion before it and its force averaged likewise).
    #[arg(long, default_value = "auto")]
    pub acquisition: AcquisitionChoice,
}

/// `--effects`, shared by `fit`, `validate` and `diagnose`.
#[derive(clap::Args, Debug, Clone)]
pub struct EffectsArg {
    /// Data-defined effect files (TOML, as `diagnose --save-effect` writes them: a name, a formula over
    /// x, v, a, i, t and parameters with units and bounds) to register beside the built-in effects, so
    /// `--model bingham+NAME` and saved parameters of such a model load. A model spec may also name the file
    /// itself: `--model bingham+drag.toml`. Repeat for several.
    #[arg(long = "effects", value_name = "FILE.toml")]
    pub effects: Vec<PathBuf>,
}

impl EffectsArg {
    /// The built-in effects plus these files', and `spec` with any effect file it names replaced by the
    /// effect's name.
    fn registry(&self, spec: &str) -> anyhow::Result<(Registry, String)> {
        let mut registry = Registry::builtin();
        for f in &self.effects {
            register_file(&mut registry, f)?;
        }
        let spec = resolve_spec(spec, &mut registry, None)?;
        Ok((registry, spec))
    }
}

/// `--weighting`, shared by `fit` and `diagnose`.
#[derive(clap::Args, Debug, Clone)]
pub struct WeightingArg {
    /// How the tests share the loss of a joint fit: `tests` (each test counts once, whatever its length
    /// and logging rate: a measured damper's tests each have their own force scale, an error every
    /// sample of the test shares) or `samples` (every sample counts once, the plain sum of squares). The
    /// reported figures are over samples either way.
    #[arg(long, default_value = "tests", value_parser = super::named(&Weighting::ALL, Weighting::as_str))]
    pub weighting: Weighting,
}

#[derive(clap::Args, Debug, Clone)]
pub struct FitArgs {
    /// Measurement CSV files or directories of them (fitted jointly, each from its own start).
    #[arg(required = true)]
    pub data: Vec<PathBuf>,
    /// Model spec: `bingham` plus effects joined by `+`.
    #[arg(long, default_value = "bingham")]
    pub model: String,
    /// Write the model name and fitted parameters here (JSON, read by `validate --params`).
    #[arg(long)]
    pub save: Option<PathBuf>,
    #[command(flatten)]
    pub output: super::OutputArgs,
    /// Driver saturation of the current command, A (default: 14 A, the paper's driver, or the largest
    /// command in the data if higher).
    #[arg(long)]
    pub current_limit_a: Option<f64>,
    /// Also measure the held-out error: refit with each test group left out in turn (stderr).
    #[arg(long)]
    pub heldout: bool,
    #[command(flatten)]
    pub effects: EffectsArg,
    #[command(flatten)]
    pub acquisition: AcquisitionArg,
    #[command(flatten)]
    pub weighting: WeightingArg,
    /// When each logged current command takes effect: `after-sample` (a DAQ that reads the sensors, then
    /// writes the command), `at-sample` (already in force at the sample it is logged with), or `auto`: where
    /// some test's command changes, the model is fitted both ways and the smaller error kept.
    #[arg(long, default_value = "auto", value_parser = super::named(&TimingChoice::ALL, TimingChoice::as_str))]
    pub command_timing: TimingChoice,
}

#[derive(clap::Args, Debug, Clone)]
pub struct ValidateArgs {
    /// Measurement CSV files or directories of them.
    #[arg(required = true)]
    pub data: Vec<PathBuf>,
    /// Parameters written by `mrfeel fit --save` (or a device `.toml`); run unchanged, no refit.
    #[arg(long)]
    pub params: PathBuf,
    #[command(flatten)]
    pub output: super::OutputArgs,
    /// Write each test as read with the model's force beside the measured one (column `f_model_n`, the
    /// force as scored: through the acquisition filter where one was found): this file for one test, a
    /// directory of files named as the tests for several.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub effects: EffectsArg,
    #[command(flatten)]
    pub acquisition: AcquisitionArg,
}

#[derive(clap::Args, Debug, Clone)]
pub struct SimulateArgs {
    /// Parameters written by `mrfeel fit --save`, or a device file (`models/*.toml`).
    #[arg(long)]
    pub params: PathBuf,
    /// Motion and current in the measurement format: `t_s`, `x_m`, `i_a`, optionally `v_m_s` (derived from
    /// `x_m` as the fit derives it where absent); a measured `f_n`, if any, is kept as `f_measured_n`.
    #[arg(long)]
    pub input: PathBuf,
    /// Output CSV in the measurement format, `f_n` the model's force.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug, Clone)]
#[command(
    mut_arg("json", |a| a.help("Print the contract's JSON on stdout instead of a report")),
    mut_arg("plot", |a| a.help("Write PNG + SVG plots into this directory (where the model fails, the error falling)")),
    mut_arg("rerun", |a| a.help("Write a Rerun recording (.rrd) of measured vs model force, starting and final model")),
)]
pub struct DiagnoseArgs {
    /// Measurement CSV files or directories of them.
    #[arg(required = true)]
    pub data: Vec<PathBuf>,
    /// The model to start from (none: `bingham`, or the `spencer` base where it ends significantly better
    /// held out).
    #[arg(long)]
    pub model: Option<String>,
    #[command(flatten)]
    pub output: super::OutputArgs,
    /// Driver saturation of the current command, A (default: 14 A, the paper's driver, or the largest
    /// command in the data if higher).
    #[arg(long)]
    pub current_limit_a: Option<f64>,
    /// Write the final model fitted on every test here (PARAMS.json as `fit --save` writes it, without
    /// standard errors), for `validate --params`, `simulate --params` and a scenario's `[controller] model`.
    /// A final model with terms found beyond the vocabulary is not written: save them with `--save-effect`
    /// and fit the model that names that file.
    #[arg(long, value_name = "PARAMS.json")]
    pub save: Option<PathBuf>,
    /// Write the terms the open search found as one data-defined effect (TOML) named after the file, for
    /// `--effects FILE` (or `--model bingham+FILE`) in `fit`, `validate`, `diagnose` and device files.
    #[arg(long, value_name = "FILE.toml")]
    pub save_effect: Option<PathBuf>,
    /// Search the named effects only (no open search for terms outside the vocabulary).
    #[arg(long)]
    pub named_only: bool,
    #[command(flatten)]
    pub effects: EffectsArg,
    #[command(flatten)]
    pub acquisition: AcquisitionArg,
    #[command(flatten)]
    pub weighting: WeightingArg,
    /// When each logged current command takes effect: `after-sample` (a DAQ that reads the sensors, then
    /// writes the command), `at-sample` (already in force at the sample it is logged with), or `auto`: where
    /// some test's command changes, the starting model is fitted both ways and the smaller error kept.
    #[arg(long, default_value = "auto", value_parser = super::named(&TimingChoice::ALL, TimingChoice::as_str))]
    pub command_timing: TimingChoice,
}

/// The tests of the files, their acquisition chain taken as `choice` says, telling the person on stderr
/// what was done about it.
fn load_and_tell(
    paths: &[std::path::PathBuf],
    choice: AcquisitionChoice,
    share: Option<f64>,
) -> anyhow::Result<prelude::Data> {
    let data = prelude::load(paths, choice, share)?;
    tell(&data);
    Ok(data)
}

/// What reading the data noticed (clipped channels, acquisition filters, …), on stderr.
fn tell(data: &prelude::Data) {
    for line in &data.notes {
        mrfeel::noteln!("{line}");
    }
}

/// How the tests share the loss, said wherever there are several.
fn weighting_note(tests: &[Test], weighting: Weighting) -> Option<String> {
    let lens = || tests.iter().map(Test::len);
    let (lo, hi) = (lens().min()?, lens().max()?);
    if tests.len() < 2 {
        return None;
    }
    Some(match weighting {
        Weighting::Tests => {
            format!("each test counts once in the loss, from {lo} to {hi} samples (--weighting tests)")
        }
        Weighting::Samples => format!(
            "every sample counts once in the loss, the longest test {:.1}× the shortest (--weighting samples)",
            hi as f64 / lo as f64
        ),
    })
}

pub fn run_fit(a: &FitArgs) -> anyhow::Result<()> {
    if let Some(path) = &a.save {
        ParamsFile::check_path("--save", path).map_err(anyhow::Error::msg)?;
    }
    let (registry, spec) = a.effects.registry(&a.model)?;
    let data = load_and_tell(&a.data, a.acquisition.acquisition, None)?;
    let setup = prelude::FitSetup {
        model: spec,
        current_limit_a: a.current_limit_a,
        weighting: a.weighting.weighting,
        command_timing: a.command_timing,
    };
    let model = prelude::fit_model_in(&data.tests, &setup, &registry)?;
    let tests = &data.tests;
    let n: usize = tests.iter().map(Test::len).sum();
    let opts = setup.options();
    mrfeel::noteln!(
        "fitting {} ({} parameters) to {} tests, {n} samples{}",
        model.name(),
        model.n_params(),
        tests.len(),
        weighting_note(tests, opts.weighting).map_or(String::new(), |w| format!("; {w}"))
    );
    let t0 = std::time::Instant::now();
    let fitted = prelude::fit(model, data, &setup);
    let (fr, timing) = (&fitted.result, &fitted.timing);
    note_timing(timing);
    mrfeel::noteln!(
        "fitted in {:.2} s ({}{} simulations of the data: {} evaluations and {} Jacobian columns; {} more \
         columns assembled on kept states; {})",
        t0.elapsed().as_secs_f64(),
        if timing.fits.is_some() {
            "both readings of the current commands; the kept one: "
        } else {
            ""
        },
        fr.evaluations + fr.jacobian_columns.0,
        fr.evaluations,
        fr.jacobian_columns.0,
        fr.jacobian_columns.1,
        fr.termination
    );
    let pred = fitted.predictions();
    let (_, total) = mrfeel::ident::validate::figures(&pred, &fitted.tests);
    let mut numbers: Vec<(String, f64)> = Vec::new();
    for ((spec, p), se) in fitted.model.param_specs().iter().zip(&fr.params).zip(&fr.std_err) {
        numbers.push((spec.name.to_string(), *p));
        numbers.extend(se.map(|se| (format!("std_err of {}", spec.name), se)));
    }
    numbers.extend([("rmse_n".into(), total.rmse_n()), ("nrmse".into(), total.nrmse())]);
    mrfeel::ident::validate::check_finite("fit", &numbers, &fitted.tests, &pred)
        .map_err(anyhow::Error::msg)?;
    let out = fitted.report(&pred);
    if let Some(path) = &a.save {
        fitted
            .params_file()
            .write(path)
            .with_context(|| format!("writing {}", path.display()))?;
        mrfeel::noteln!("saved {}", path.display());
    }
    let (model, tests) = (&fitted.model, &fitted.tests);
    if a.heldout {
        // The diagnosis's folds; each fold fitted as `fit` fits (tolerance, standard errors).
        let (folds, how) = DiagnoseOptions::default().folds(tests);
        let bar = indicatif::ProgressBar::hidden();
        let cv = mrfeel::ident::diagnose::cross_validate(model, tests, &folds, None, &opts, &bar);
        mrfeel::noteln!(
            "held-out NRMSE {:.4} (RMSE {:.3} N), {how}",
            cv.heldout_nrmse(),
            cv.total.rmse_n()
        );
        for (f, fig) in folds.iter().zip(&cv.per_fold) {
            mrfeel::noteln!("  {:<32} held-out NRMSE {:.4}", f.label, fig.nrmse());
        }
    }
    outputs(&out, "fit", &a.output, tests, &pred)
}

/// The reading of the current commands, on stderr, where it matters: where a command changes inside a test,
/// or where at-sample was asked for.
fn note_timing(timing: &TimingDecision) {
    if timing.fits.is_some() || timing.timing == CommandTiming::AtSample {
        mrfeel::noteln!("{}", timing.note());
    }
}

fn outputs(
    out: &FitJson,
    title: &str,
    output: &super::OutputArgs,
    tests: &[Test],
    pred: &[Vec<f64>],
) -> anyhow::Result<()> {
    // The files first, stdout last: a run that fails to write prints no result.
    if let Some(dir) = &output.plot {
        let files = mrfeel::ident::plots::plot_model(dir, tests, pred, &out.model, "")?;
        mrfeel::noteln!("wrote {} plot files into {}", files.len(), dir.display());
    }
    #[cfg(not(feature = "rerun"))]
    let _ = &output.rerun; // refused before the command runs (main.rs)
    #[cfg(feature = "rerun")]
    if let Some(path) = &output.rerun {
        mrfeel::ident::rerun_log::record(path, tests, &[(&out.model, pred)])?;
        mrfeel::noteln!("wrote Rerun recording {}", path.display());
    }
    if output.json {
        mrfeel::outln!("{}", serde_json::to_string_pretty(out)?)?;
    } else {
        mrfeel::out!("{}", out.table(title))?;
    }
    Ok(())
}

pub fn run_validate(a: &ValidateArgs) -> anyhow::Result<()> {
    let (registry, _) = a.effects.registry("bingham")?;
    let cfg = DeviceConfig::load(&a.params, &registry)?;
    let (ms, data) =
        prelude::load_keeping(&a.data, a.acquisition.acquisition, cfg.acquisition_window_periods)?;
    tell(&data);
    prelude::require(&data.tests, cfg.model.n_params())?;
    note_timing(&TimingDecision {
        timing: cfg.command_timing,
        fits: None,
    });
    let (tests, pred, out) = prelude::validate(&cfg, data)?;
    let (_, total) = mrfeel::ident::validate::figures(&pred, &tests);
    mrfeel::ident::validate::check_finite(
        "validate",
        &[("rmse_n".into(), total.rmse_n()), ("nrmse".into(), total.nrmse())],
        &tests,
        &pred,
    )
    .map_err(anyhow::Error::msg)?;
    if let Some(path) = &a.out {
        write_beside(path, &ms, &pred)?;
    }
    outputs(&out, "validate", &a.output, &tests, &pred)
}

pub fn run_diagnose(a: &DiagnoseArgs) -> anyhow::Result<()> {
    if let Some(path) = &a.save_effect {
        effect_name_of(path)?;
    }
    if let Some(path) = &a.save {
        ParamsFile::check_path("--save", path).map_err(anyhow::Error::msg)?;
    }
    let (registry, spec) = a.effects.registry(a.model.as_deref().unwrap_or("bingham"))?;
    let data = load_and_tell(&a.data, a.acquisition.acquisition, None)?;
    let setup = prelude::DiagnoseSetup {
        // Empty: no base named, the diagnosis chooses one by held-out error.
        model: if a.model.is_some() { spec } else { String::new() },
        current_limit_a: a.current_limit_a,
        weighting: a.weighting.weighting,
        command_timing: a.command_timing,
        progress: std::io::stderr().is_terminal(),
    };
    if let Some(w) = weighting_note(&data.tests, setup.weighting) {
        mrfeel::noteln!("diagnose: in every fit {w}");
    }
    let t0 = std::time::Instant::now();
    let prelude::Diagnosed {
        tests,
        diagnosis: d,
        timing,
        final_model,
    } = prelude::diagnose_in(data, &setup, &registry, !a.named_only)?;
    note_timing(&timing);
    let mut numbers = vec![
        ("base fit nrmse".to_string(), d.base_fit_nrmse),
        ("base held-out nrmse".into(), d.base_heldout_nrmse),
        ("final fit nrmse".into(), d.final_fit_nrmse),
        ("final held-out nrmse".into(), d.final_heldout_nrmse),
    ];
    numbers.extend(
        d.final_params
            .iter()
            .enumerate()
            .map(|(k, v)| (format!("final parameter {}", k + 1), *v)),
    );
    mrfeel::ident::validate::check_finite("diagnose", &numbers, &tests, &d.final_pred)
        .map_err(anyhow::Error::msg)?;
    mrfeel::noteln!("diagnosed in {:.1} s", t0.elapsed().as_secs_f64());
    if let Some(path) = &a.save {
        if !d.discovered.is_empty() {
            let named: Vec<&str> = d
                .final_model
                .split('+')
                .filter(|part| !d.discovered.iter().any(|t| t.name == *part))
                .collect();
            anyhow::bail!(
                "--save {}: the final model {} has terms found beyond the vocabulary, which a PARAMS.json \
                 cannot carry; write them with `--save-effect NAME.toml`, then `mrfeel fit DATA --model \
                 {}+NAME.toml --save {}`",
                path.display(),
                d.final_model,
                named.join("+"),
                path.display()
            );
        }
        final_model
            .write(path)
            .with_context(|| format!("writing {}", path.display()))?;
        mrfeel::noteln!("saved the final model {} in {}", d.final_model, path.display());
    }
    // The files first, stdout last: a run that fails to write prints no result.
    if let Some(dir) = &a.output.plot {
        let files = mrfeel::ident::plots::plot_diagnosis(dir, &tests, &d)?;
        mrfeel::noteln!("wrote {} plot files into {}", files.len(), dir.display());
    }
    #[cfg(feature = "rerun")]
    if let Some(path) = &a.output.rerun {
        let mut models: Vec<(&str, &[Vec<f64>])> = vec![(&d.base_model, &d.base_pred)];
        if d.final_model != d.base_model {
            models.push((&d.final_model, &d.final_pred));
        }
        // The final model's held-out prediction: its residual is what the verdict judged.
        let heldout = format!("{} held out", d.final_model);
        models.push((&heldout, &d.final_oof));
        let words = mrfeel::ident::report::verdict_words(&d);
        mrfeel::ident::rerun_log::record_with_notes(path, &tests, &models, Some(words.trim()))?;
        mrfeel::noteln!("wrote Rerun recording {}", path.display());
    }
    if let Some(path) = &a.save_effect {
        let name = effect_name_of(path)?;
        let found: Vec<FormulaEffect> = d.discovered.iter().map(|t| t.effect.clone()).collect();
        let Some(effect) = mrfeel::ident::discover::merged(&name, &found) else {
            anyhow::bail!(
                "--save-effect {}: the diagnosis added no term beyond the vocabulary, so there is no effect to \
                 write",
                path.display()
            );
        };
        std::fs::write(path, effect.to_toml()).with_context(|| format!("writing {}", path.display()))?;
        mrfeel::noteln!(
            "saved the discovered effect `{name}` = {} in {} (use: --effects {} --model {}+{name})",
            effect.formula(),
            path.display(),
            path.display(),
            d.base_model
        );
    }
    if a.output.json {
        mrfeel::outln!("{}", serde_json::to_string_pretty(&DiagnoseJson::new(&d))?)?;
    } else {
        mrfeel::out!("{}", diagnose_table(&d))?;
    }
    Ok(())
}

/// `validate --out`: each test as read with the model's force beside the measured one; `path` is the file
/// for one test, a directory (made if missing) of files named as the tests for several.
fn write_beside(path: &std::path::Path, ms: &[Measurement], pred: &[Vec<f64>]) -> anyhow::Result<()> {
    let files: Vec<(PathBuf, Measurement)> = ms
        .iter()
        .zip(pred)
        .map(|(m, p)| {
            let target = if ms.len() == 1 {
                path.to_path_buf()
            } else {
                path.join(m.path.file_name().unwrap_or_default())
            };
            Ok((
                target,
                mrfeel::ident::simulate::beside(m, p).map_err(anyhow::Error::msg)?,
            ))
        })
        .collect::<anyhow::Result<_>>()?;
    if ms.len() > 1 {
        std::fs::create_dir_all(path).with_context(|| format!("--out: creating {}", path.display()))?;
    }
    for (target, m) in &files {
        m.write(target)?;
    }
    mrfeel::noteln!(
        "wrote the model's force beside the measured one (column `{}`) into {}",
        mrfeel::ident::simulate::MODEL_COLUMN,
        path.display()
    );
    Ok(())
}

/// `mrfeel simulate`: the force of a saved model (or a device file) on the motion and current of a file.
pub fn run_simulate(a: &SimulateArgs) -> anyhow::Result<()> {
    let registry = Registry::builtin();
    let cfg = DeviceConfig::load(&a.params, &registry)?;
    let m = Measurement::read_motion(&a.input)?;
    let force = prelude::predict(&cfg, &m);
    if let Some(k) = force.iter().position(|f| !f.is_finite()) {
        anyhow::bail!(
            "{}:{}: the model of {} gives a force that is not a number at t = {} s: its parameters are outside \
             where it can be integrated (nothing was written)",
            a.input.display(),
            m.lines.get(k).copied().unwrap_or(0),
            a.params.display(),
            m.t_s[k]
        );
    }
    let out = mrfeel::ident::simulate::prediction(&m, force, &cfg).map_err(anyhow::Error::msg)?;
    out.write(&a.out)?;
    mrfeel::noteln!(
        "wrote the force of {} ({}) on the {} samples of {} into {}",
        cfg.model.name(),
        a.params.display(),
        m.len(),
        a.input.display(),
        a.out.display()
    );
    Ok(())
}

/// The effect name a `--save-effect` file gives: its stem, which must be a valid effect name.
fn effect_name_of(path: &Path) -> anyhow::Result<String> {
    let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or_default();
    let ok = stem.chars().next().is_some_and(|c| c.is_ascii_alphabetic())
        && stem.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
        && path.extension().is_some_and(|e| e == "toml");
    if !ok {
        anyhow::bail!(
            "--save-effect {}: the file is named NAME.toml, NAME being the effect's name in model specs \
             (letters, digits and `_`, starting with a letter)",
            path.display()
        );
    }
    Ok(stem.to_string())
}
