//! A Rerun recording of measured vs model force for interactive inspection: per test, the measured and
//! model force and the residual as time series (timeline `t`, each test from its own start), and the
//! force–velocity cloud as points.

use std::path::Path;

use rerun::{Points2D, RecordingStream, RecordingStreamBuilder, Scalars, TimeColumn};

use super::{IdentError, Test};

fn rr<E: std::fmt::Display>(e: E) -> IdentError {
    IdentError::Other(format!("rerun: {e}"))
}

/// Entity-path-safe name.
fn ent(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Write `path` (`.rrd`) with one or more models' predictions (`(label, prediction per test)`), whole or not
/// at all ([`crate::outputs::write_whole`]).
pub fn record(path: &Path, tests: &[Test], models: &[(&str, &[Vec<f64>])]) -> Result<(), IdentError> {
    record_with_notes(path, tests, models, None)
}

/// [`record`], with a text (the diagnosis's verdict on what is left) logged at `diagnosis/verdict`.
pub fn record_with_notes(
    path: &Path,
    tests: &[Test],
    models: &[(&str, &[Vec<f64>])],
    notes: Option<&str>,
) -> Result<(), IdentError> {
    crate::outputs::write_whole(
        path,
        |tmp| record_into(tmp, tests, models, notes),
        |e| IdentError::Other(format!("--rerun {}: {e}", path.display())),
    )
}

fn record_into(
    path: &Path,
    tests: &[Test],
    models: &[(&str, &[Vec<f64>])],
    notes: Option<&str>,
) -> Result<(), IdentError> {
    let rec = RecordingStreamBuilder::new("mrfeel").save(path).map_err(rr)?;
    if let Some(text) = notes {
        rec.log_static("diagnosis/verdict", &rerun::TextDocument::new(text))
            .map_err(rr)?;
    }
    for (j, t) in tests.iter().enumerate() {
        let base = format!("tests/{}", ent(&t.name));
        series(&rec, format!("{base}/force/measured"), t, t.f_n.iter().copied())?;
        series(
            &rec,
            format!("{base}/current_a"),
            t,
            t.inputs.iter().map(|i| i.current_cmd_a),
        )?;
        cloud(&rec, format!("{base}/force_velocity/measured"), t, &t.f_n)?;
        for (label, pred) in models {
            let (p, l) = (&pred[j], ent(label));
            series(&rec, format!("{base}/force/{l}"), t, p.iter().copied())?;
            series(
                &rec,
                format!("{base}/residual/{l}"),
                t,
                p.iter().zip(&t.f_n).map(|(m, f)| m - f),
            )?;
            cloud(&rec, format!("{base}/force_velocity/{l}"), t, p)?;
        }
    }
    rec.flush_blocking().map_err(rr)?;
    Ok(())
}

/// A time series over the test's samples (timeline `t`).
fn series(
    rec: &RecordingStream,
    path: String,
    t: &Test,
    values: impl Iterator<Item = f64>,
) -> Result<(), IdentError> {
    let times = TimeColumn::new_duration_secs("t", t.inputs.iter().map(|i| i.t_s));
    let scalars = Scalars::new(values).columns_of_unit_batches().map_err(rr)?;
    rec.send_columns(path, [times], scalars).map_err(rr)
}

/// The force–velocity cloud of a force over the test's samples.
fn cloud(rec: &RecordingStream, path: String, t: &Test, force: &[f64]) -> Result<(), IdentError> {
    let fv: Vec<(f32, f32)> = t
        .inputs
        .iter()
        .zip(force)
        .map(|(i, f)| (i.v_m_s as f32, *f as f32))
        .collect();
    rec.log_static(path, &Points2D::new(fv).with_radii([0.5f32]))
        .map_err(rr)
}
