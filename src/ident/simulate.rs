//! Predict, not only score: the force of a saved model on a person's own motion and current (`mrfeel
//! simulate`), and the model's force beside the measured one (`mrfeel validate --out`).
//!
//! The force law is the model's ([`crate::device::Model::simulate`]); the motion is read as the fit reads
//! it ([`super::inputs_of`]: a velocity derived from the displacement where the file has none, the
//! acceleration derived likewise), and the current commands take effect as the saved model's
//! `command_timing` says.

use crate::device::DeviceConfig;
use crate::measurement::{Measurement, TextColumn};

use super::timing::retimed;
use super::Test;

/// The column the measured force is kept in when `simulate` writes the model's force as `f_n`.
pub const MEASURED_COLUMN: &str = "f_measured_n";
/// The column `validate --out` writes the model's force in, beside the measured `f_n`.
pub const MODEL_COLUMN: &str = "f_model_n";

/// The force of the device `cfg` at every sample of the motion and current of `m`, integrated from the
/// record's start (the lags settled at its first command).
pub fn predicted_force(cfg: &DeviceConfig, m: &Measurement) -> Vec<f64> {
    let test = Test::with_filter(m, None);
    let tests = retimed(vec![test], cfg.command_timing);
    cfg.model.simulate(&cfg.params, &tests[0].inputs)
}

/// `m` with `f_n` replaced by `force`: the measurement format, as a rig logging the model would write it.
/// A measured force, if `m` has one, is kept beside it as [`MEASURED_COLUMN`]; the other columns and the
/// metadata are kept, with `source` and `model` saying what made the force.
pub fn prediction(m: &Measurement, force: Vec<f64>, cfg: &DeviceConfig) -> Result<Measurement, String> {
    let mut out = m.clone();
    if !m.f_n.is_empty() {
        out.extra
            .insert(MEASURED_COLUMN.to_string(), numbers(&m.f_n, m, MEASURED_COLUMN)?);
    }
    out.f_n = force;
    out.meta.insert(
        "source".into(),
        format!(
            "mrfeel {} simulate: the model's force on the motion and current of {}",
            env!("CARGO_PKG_VERSION"),
            file_name(&m.path)
        ),
    );
    out.meta.insert("model".into(), cfg.model.name());
    out.meta.insert("params".into(), file_name(&cfg.path));
    Ok(out)
}

/// `m` as read, with the model's force `force` beside its measured `f_n` as [`MODEL_COLUMN`].
pub fn beside(m: &Measurement, force: &[f64]) -> Result<Measurement, String> {
    let mut out = m.clone();
    out.extra
        .insert(MODEL_COLUMN.to_string(), numbers(force, m, MODEL_COLUMN)?);
    Ok(out)
}

/// A numeric column as an extra column of `m` (shortest exact form, so it reads back to the same numbers);
/// an error where `m` already has a column of that name.
fn numbers(values: &[f64], m: &Measurement, name: &str) -> Result<TextColumn, String> {
    if m.extra.contains_key(name) {
        return Err(format!(
            "{}: already has a column `{name}`, where the output would write the {}; rename it (nothing was \
             written)",
            m.path.display(),
            if name == MODEL_COLUMN {
                "model's force"
            } else {
                "measured force"
            }
        ));
    }
    let mut c = TextColumn::default();
    for v in values {
        c.push(&v.to_string());
    }
    Ok(c)
}

fn file_name(p: &std::path::Path) -> String {
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}
