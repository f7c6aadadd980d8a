//! The modified Bouc–Wen model of Spencer et al. (1997) as a base of its own: records of a known Spencer
//! device, driven by broadband displacement with a switched current, are fitted by `mrfeel fit --model
//! spencer`, and the fit predicts a second record of another protocol, as the device does.
//!
//! The second device (issue 34, item 6): `python/independent_truth.py broadband` writes a Bouc–Wen damper
//! of another make (the 1997 form at another force scale and stroke, written from the paper's equations,
//! not the crate's), band-limited random displacement, a switched then continuously varying command,
//! 3 kHz, two records of different seeds. `diagnose` without `--model` chooses its base by held-out error;
//! the model it ends with, fitted on record 1, must predict record 2 as well as Spencer's model fitted on
//! record 1 alone.

use crate::common;
use common::{mrfeel, ok, s};

use std::path::{Path, PathBuf};
use std::process::Command;

use mrfeel::device::spencer::{PARAMS, SPENCER_1997};
use mrfeel::measurement::Measurement;
use mrfeel::prelude::{self, AcquisitionChoice, DeviceConfig, Registry};

/// The 1997 paper's device as a parameter file (its command in volts read as amperes).
fn truth_file(dir: &Path) -> PathBuf {
    let params: serde_json::Map<String, serde_json::Value> = PARAMS
        .iter()
        .zip(SPENCER_1997)
        .map(|(p, v)| (p.name.to_string(), serde_json::json!({ "value": v })))
        .collect();
    let path = dir.join("truth.json");
    std::fs::write(
        &path,
        serde_json::to_string_pretty(&serde_json::json!({"model": "spencer", "params": params})).unwrap(),
    )
    .unwrap();
    path
}

/// An `mts` record of the device: 2 kHz, 5 N of load-cell noise (under 1 % of its force), the current
/// switched between `currents`.
/// `drive`: protocol, amplitude (m), frequency (Hz), currents (A), seed.
fn record(dir: &Path, name: &str, truth: &Path, drive: [&str; 5]) -> PathBuf {
    let [protocol, amp, f_hz, currents, seed] = drive;
    let out = dir.join(name);
    ok(&mrfeel(&[
        "mts",
        "--device",
        &s(truth),
        "--protocol",
        protocol,
        "--amplitude-m",
        amp,
        "--frequency-hz",
        f_hz,
        "--current",
        currents,
        "--cycles",
        "2",
        "--sample-rate-hz",
        "2000",
        "--physics-hz",
        "20000",
        "--force-noise-n",
        "5",
        "--load-cell-range-n",
        "5000",
        "--seed",
        seed,
        "--out",
        &s(&out),
    ]));
    out
}

fn json_of(o: &std::process::Output) -> serde_json::Value {
    ok(o);
    serde_json::from_slice(&o.stdout).expect("JSON on stdout")
}

/// Fitted on a multisine record with the current switched 0.2 → 1.2 → 0.6 A, the Spencer model predicts
/// a sine record of another amplitude, frequency and currents within twice the noise floor's NRMSE, and
/// better than the Bingham model fitted to the same record (which has no pre-yield roll-off).
#[test]
#[ignore = "minutes in the debug build (14 parameters, a stiff model); run in release with --ignored"]
fn spencer_fitted_on_broadband_switched_data_predicts_another_record() {
    let d = tempfile::tempdir().unwrap();
    let truth = truth_file(d.path());
    let train = record(
        d.path(),
        "train.csv",
        &truth,
        ["multisine", "0.01", "1", "0.2,1.2,0.6", "1"],
    );
    let other = record(
        d.path(),
        "other.csv",
        &truth,
        ["sine", "0.012", "2.5", "0.9,0.1", "2"],
    );
    let fitted = d.path().join("fit.json");
    let fit = json_of(&mrfeel(&[
        "fit",
        &s(&train),
        "--model",
        "spencer",
        "--json",
        "--save",
        &s(&fitted),
    ]));
    assert_eq!(fit["model"], "spencer");
    let held = json_of(&mrfeel(&[
        "validate",
        &s(&other),
        "--params",
        &s(&fitted),
        "--json",
    ]));
    let f = Measurement::read(&other).unwrap().f_n;
    let rms = (f.iter().map(|f| f * f).sum::<f64>() / f.len() as f64).sqrt();
    let floor = 5.0 / rms;
    let nrmse = held["nrmse"].as_f64().unwrap();
    // The bingham model on the same record, for comparison.
    let bfile = d.path().join("bingham.json");
    ok(&mrfeel(&["fit", &s(&train), "--save", &s(&bfile)]));
    let bheld = json_of(&mrfeel(&[
        "validate",
        &s(&other),
        "--params",
        &s(&bfile),
        "--json",
    ]));
    let bn = bheld["nrmse"].as_f64().unwrap();
    eprintln!("spencer held-out NRMSE {nrmse}, bingham {bn}, floor {floor}");
    assert!(
        nrmse < 2.0 * floor,
        "spencer held-out NRMSE {nrmse}, floor {floor}"
    );
    assert!(nrmse < 0.5 * bn, "spencer {nrmse}, bingham {bn}");
}

/// `spencer+hysteresis` is refused (the base has its own Bouc–Wen state) with the reason, and an
/// unknown base names the ones there are.
#[test]
fn spencer_with_a_second_hysteresis_and_an_unknown_base_are_refused() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/utfsm-mr-damper/2mm5Hz_0p50A.csv");
    let o = mrfeel(&["fit", &s(&data), "--model", "spencer+hysteresis"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("hysteresis") && err.contains("Bouc"), "{err}");
    let o = mrfeel(&["fit", &s(&data), "--model", "bouc+stiffness"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("`bouc`") && err.contains("spencer"), "{err}");
}

/// Write `records` broadband records of the second device (`DUR` seconds each at 3 kHz, seeds `seed`,
/// `seed + 1`, …) with `python/independent_truth.py broadband` into `dir`; their paths.
pub(crate) fn broadband(
    dir: &Path,
    dur_s: f64,
    records: usize,
    seed: u64,
    env: &[(&str, &str)],
) -> Vec<PathBuf> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = dir.join("broadband");
    let mut cmd = Command::new(common::venv_python());
    cmd.arg(root.join("python/independent_truth.py"))
        .arg("broadband")
        .arg(&out)
        .arg(seed.to_string())
        .env("DUR", dur_s.to_string())
        .env("RECORDS", records.to_string());
    for (k, v) in env {
        cmd.env(k, v);
    }
    let o = cmd.output().expect("running python/independent_truth.py");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (1..=records)
        .map(|r| out.join(format!("record{r}.csv")))
        .collect()
}

fn data(path: &Path) -> prelude::Data {
    prelude::load(&[path.to_path_buf()], AcquisitionChoice::Auto, None).expect("record loads")
}

/// What a diagnosis of record 1 ended with: its JSON, and the NRMSE of its final model on record 2 through
/// `validate`'s path (the saved model run unchanged). `model`: `""` lets the diagnosis choose its base.
pub(crate) fn diagnosed_on_record_2(model: &str, rec1: &Path, rec2: &Path) -> (serde_json::Value, f64) {
    let setup = prelude::DiagnoseSetup {
        model: model.into(),
        ..Default::default()
    };
    let d = prelude::diagnose_in(data(rec1), &setup, &Registry::builtin(), true).expect("diagnose");
    let json = serde_json::to_value(prelude::DiagnoseJson::new(&d.diagnosis)).expect("json");
    let text = serde_json::to_string(&d.final_model).expect("params");
    // The diagnosis's registry: a term it discovered is part of its final model.
    let cfg =
        DeviceConfig::from_json(&text, Path::new("final.json"), &d.diagnosis.registry).expect("saved model");
    let (_, _, v) = prelude::validate(&cfg, data(rec2)).expect("validate");
    (json, v.nrmse)
}

/// Spencer's model fitted on record 1 (`mrfeel fit --model spencer`'s path), its NRMSE on record 2.
pub(crate) fn spencer_on_record_2(rec1: &Path, rec2: &Path) -> f64 {
    let setup = prelude::FitSetup {
        model: "spencer".into(),
        ..Default::default()
    };
    let d1 = data(rec1);
    let model = prelude::fit_model(&d1.tests, &setup).expect("model");
    let fitted = prelude::fit(model, d1, &setup);
    let cfg = prelude::saved_model(&fitted.params_file(), Path::new("spencer.json")).expect("saved model");
    prelude::validate(&cfg, data(rec2)).expect("validate").2.nrmse
}

/// The generalisation check of a second device: on the broadband Bouc–Wen damper, `diagnose` (no base
/// named) fitted on record 1 predicts record 2 at most 5 % worse than Spencer's model fitted on record 1
/// (the truth's own form: at best a model can match it there, and 5 % leaves room for the diagnosis's fits
/// stopping at their tolerances; the measurement had diagnose 29 % worse, 0.45 against 0.35), and
/// says which bases it tried. `BROADBAND_DUR` sets the records' length in seconds (default 2); the
/// figures, with the diagnosis from `bingham` beside them, go to stderr.
#[test]
#[ignore = "minutes in the debug build (stiff 14-parameter Spencer fits); run in release with --ignored"]
fn on_a_broadband_bouc_wen_damper_diagnose_predicts_a_second_record_as_well_as_spencer() {
    let dur: f64 = std::env::var("BROADBAND_DUR")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(2.0);
    let dir = tempfile::tempdir().unwrap();
    let recs = broadband(dir.path(), dur, 2, 1, &[]);
    let (json, chosen) = diagnosed_on_record_2("", &recs[0], &recs[1]);
    let spencer = spencer_on_record_2(&recs[0], &recs[1]);
    let (bjson, from_bingham) = diagnosed_on_record_2("bingham", &recs[0], &recs[1]);
    eprintln!(
        "record 2 NRMSE, {dur} s records: chosen base {} → {} {chosen:.4}; from bingham → {} {from_bingham:.4}; \
         spencer alone {spencer:.4}\nbases tried: {:#}",
        json["base_model"], json["final"]["model"], bjson["final"]["model"], json["bases_tried"]
    );
    let bases = json["bases_tried"].as_array().expect("bases_tried");
    assert_eq!(bases.len(), 2, "{json:#}");
    assert!(
        chosen <= 1.05 * spencer,
        "record 2: diagnose's final model {} NRMSE {chosen:.4}, spencer alone {spencer:.4}",
        json["final"]["model"]
    );
}

/// The second device's records as `mrfeel` reads them (items 1 and 4 of the check): a broadband record with
/// a switched, then continuously varying command is one test (no sine period or current level assumed: no
/// acquisition filter is read into its random spectrum, and one test is cross-validated over time
/// blocks); a load cell of ±600 N on its ±1 kN force is found stuck at both rails, each named with the
/// count of samples the file logs there (runs shorter than the rule's 8 samples aside), and those samples
/// weigh nothing in the fit and in every score.
#[test]
fn a_broadband_record_with_a_saturated_load_cell_is_read_with_its_clip_named_and_left_out() {
    let dir = tempfile::tempdir().unwrap();
    let recs = broadband(dir.path(), 1.0, 1, 5, &[("CLIP", "600")]);
    let m = Measurement::read(&recs[0]).unwrap();
    let at = |rail: f64| m.f_n.iter().filter(|f| **f == rail).count();
    let (top, bottom) = (at(600.0), at(-600.0));
    assert!(top > 50 && bottom > 50, "the force must clip: {top}, {bottom}");
    let levels: std::collections::BTreeSet<u64> = m.i_a.iter().map(|i| i.to_bits()).collect();
    assert!(levels.len() > 100, "a varying command: {} levels", levels.len());
    let d = data(&recs[0]);
    assert_eq!(d.tests.len(), 1);
    assert!(
        d.tests[0].drive.is_none(),
        "no moving average in a random spectrum: {:?}",
        d.notes
    );
    assert!(
        !d.notes.iter().any(|n| n.starts_with("acquisition")),
        "{:?}",
        d.notes
    );
    for (rail, n) in [(600.0, top), (-600.0, bottom)] {
        let note = d
            .notes
            .iter()
            .find(|l| l.contains(&format!("stuck at {rail} N")))
            .unwrap_or_else(|| panic!("no note of the {rail} N rail: {:?}", d.notes));
        let named: usize = note
            .split(" over ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .and_then(|c| c.parse().ok())
            .expect("a sample count");
        assert!(
            named <= n && named + 16 >= n,
            "{note}: the file logs {n} samples at {rail} N"
        );
    }
    let w = mrfeel::ident::residual::direction_weights(&d.tests[0]);
    let left_out = m
        .f_n
        .iter()
        .zip(&w)
        .filter(|(f, w)| f.abs() == 600.0 && **w == 0.0)
        .count();
    assert!(
        left_out + 32 >= top + bottom,
        "{left_out} of {} clipped samples left out",
        top + bottom
    );
    let (folds, how) = mrfeel::ident::diagnose::make_folds(&d.tests, 4, 5);
    assert_eq!(folds.len(), 4, "{how}");
    assert!(how.starts_with("blocked cross-validation"), "{how}");
}
