//! Predict, not only score: the force of a saved model on a person's own motion and current (`mrfeel
//! simulate`), and the model's force beside the measured one (`mrfeel validate --out`).
//!
//! The force is [`crate::prelude::predict`]'s: the model's own law, on the motion read as the fit reads it
//! ([`super::inputs_of`]: a velocity derived from the displacement where the file has none, the
//! acceleration likewise), the current commands taking effect as the saved model's `command_timing` says.

use crate::device::DeviceConfig;
use crate::measurement::{Measurement, TextColumn};

/// The column the measured force is kept in when `simulate` writes the model's force as `f_n`.
pub const MEASURED_COLUMN: &str = "f_measured_n";
/// The column `validate --out` writes the model's force in, beside the measured `f_n`.
pub const MODEL_COLUMN: &str = "f_model_n";

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
    values.iter().for_each(|v| c.push(&v.to_string()));
    Ok(c)
}

fn file_name(p: &std::path::Path) -> String {
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| p.display().to_string())
}
