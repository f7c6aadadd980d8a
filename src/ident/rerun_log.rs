//! A Rerun recording of measured vs model force for interactive inspection: per test, the measured and
//! model force and the residual as time series (timeline `t`, each test from its own start), and the
//! force–velocity cloud as points.

use std::path::Path;

use rerun::{Points2D, RecordingStreamBuilder, Scalars, TimeColumn};

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
        let times = || TimeColumn::new_duration_secs("t", t.inputs.iter().map(|i| i.t_s));
        rec.send_columns(
            format!("{base}/force/measured"),
            [times()],
            Scalars::new(t.f_n.iter().copied())
                .columns_of_unit_batches()
                .map_err(rr)?,
        )
        .map_err(rr)?;
        rec.send_columns(
            format!("{base}/current_a"),
            [times()],
            Scalars::new(t.inputs.iter().map(|i| i.current_cmd_a))
                .columns_of_unit_batches()
                .map_err(rr)?,
        )
        .map_err(rr)?;
        let fv: Vec<(f32, f32)> = t
            .inputs
            .iter()
            .zip(&t.f_n)
            .map(|(i, f)| (i.v_m_s as f32, *f as f32))
            .collect();
        rec.log_static(
            format!("{base}/force_velocity/measured"),
            &Points2D::new(fv).with_radii([0.5f32]),
        )
        .map_err(rr)?;
        for (label, pred) in models {
            let p = &pred[j];
            let l = ent(label);
            rec.send_columns(
                format!("{base}/force/{l}"),
                [times()],
                Scalars::new(p.iter().copied())
                    .columns_of_unit_batches()
                    .map_err(rr)?,
            )
            .map_err(rr)?;
            rec.send_columns(
                format!("{base}/residual/{l}"),
                [times()],
                Scalars::new(p.iter().zip(&t.f_n).map(|(m, f)| m - f))
                    .columns_of_unit_batches()
                    .map_err(rr)?,
            )
            .map_err(rr)?;
            let fv: Vec<(f32, f32)> = t
                .inputs
                .iter()
                .zip(p)
                .map(|(i, f)| (i.v_m_s as f32, *f as f32))
                .collect();
            rec.log_static(
                format!("{base}/force_velocity/{l}"),
                &Points2D::new(fv).with_radii([0.5f32]),
            )
            .map_err(rr)?;
        }
    }
    rec.flush_blocking().map_err(rr)?;
    Ok(())
}
