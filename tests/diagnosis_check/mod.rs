//! The verdict on a diagnosis of data with known hidden effects, shared by the synthetic-data tests
//! (`tests/ident.rs`, mrfeel's own effects hidden) and `tests/independent_truth.rs` (effects written again).

use mrfeel::device::{ModelSpec, Registry};
use mrfeel::ident::{diagnose, DiagnoseOptions, Diagnosis, Test};

/// Diagnose `tests` from `bingham` (driver limit `limit_a`). Ok when it names exactly the `hidden` effects
/// and, if there are any, the held-out error at least halves or reaches 1.2× the noise floor (with none, the
/// final model is the base and its held-out error within 1.2× the noise floor); else what went wrong and the
/// diagnosis report.
pub fn verdict(tests: &[Test], hidden: &[&str], limit_a: f64) -> Result<Diagnosis, String> {
    let registry = Registry::builtin();
    let d = diagnose(
        tests,
        &ModelSpec::parse("bingham").expect("spec"),
        &registry,
        &DiagnoseOptions {
            current_limit_a: limit_a,
            ..Default::default()
        },
    )
    .map_err(|e| format!("diagnose failed: {e}"))?;
    let report = mrfeel::ident::report::diagnose_table(&d);
    let mut found = d.missing.clone();
    found.sort();
    let mut want: Vec<String> = hidden.iter().map(|s| s.to_string()).collect();
    want.sort();
    if found != want {
        return Err(format!("hidden {hidden:?}, found {found:?}:\n{report}"));
    }
    let ok = if hidden.is_empty() {
        d.final_model == d.base_model && d.final_heldout_nrmse <= 1.2 * d.noise_floor_nrmse
    } else {
        d.final_heldout_nrmse <= 0.5 * d.base_heldout_nrmse
            || d.final_heldout_nrmse <= 1.2 * d.noise_floor_nrmse
    };
    if !ok {
        return Err(format!("held-out error did not fall enough:\n{report}"));
    }
    Ok(d)
}
