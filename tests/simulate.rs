//! `mrfeel simulate` (the force of a saved model on a person's own motion and current) and `validate
//! --out` (the model's force beside the measured one), through the binary.

use crate::common;
use common::{mrfeel, ok, s};

use std::path::{Path, PathBuf};

use mrfeel::measurement::Measurement;

/// A noiseless record of the virtual MTS machine (no sensor noise, no ADC rounding) of the paper's device
/// with hidden `effects`: multisine displacement, the current switched between three levels; the device it
/// simulated saved beside it. Returns (record, device).
fn noiseless_record(dir: &Path, effects: &str, no_velocity: bool) -> (PathBuf, PathBuf) {
    let (rec, dev) = (dir.join("rec.csv"), dir.join("truth.json"));
    let mut args = vec![
        "mts".to_string(),
        "--current".into(),
        "2,9,5".into(),
        "--protocol".into(),
        "multisine".into(),
        "--amplitude-m".into(),
        "0.02".into(),
        "--frequency-hz".into(),
        "0.5".into(),
        "--cycles".into(),
        "1".into(),
        "--force-noise-n".into(),
        "0".into(),
        "--position-noise-m".into(),
        "0".into(),
        "--velocity-noise-m-s".into(),
        "0".into(),
        "--adc-bits".into(),
        "0".into(),
        "--effects".into(),
        effects.into(),
        "--save-device".into(),
        s(&dev),
        "--out".into(),
        s(&rec),
    ];
    if no_velocity {
        args.push("--no-velocity".into());
    }
    ok(&mrfeel(&args));
    (rec, dev)
}

fn simulate(params: &Path, input: &Path, out: &Path) -> std::process::Output {
    mrfeel(&[
        "simulate",
        "--params",
        &s(params),
        "--input",
        &s(input),
        "--out",
        &s(out),
    ])
}

/// rms(a − b) / rms(b).
fn nrmse(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let e: f64 = a.iter().zip(b).map(|(a, b)| (a - b) * (a - b)).sum();
    let f: f64 = b.iter().map(|b| b * b).sum();
    (e / f).sqrt()
}

/// `simulate` on the motion and current of a noiseless `mts` record, with the device `mts` saved,
/// gives the force `mts` recorded. The device has a spring and a saturating field (forces of the
/// inputs at the sample alone): equal to 10⁻⁶ of the rms force, where the only difference is the
/// displacement the fit's reader smooths. With hysteresis, whose state `mts` integrates on ten
/// substeps a sample and `simulate` on the samples, within 1 %.
#[test]
fn simulate_reproduces_the_noiseless_force_of_the_mts_record() {
    for (effects, tol) in [
        ("stiffness,magnetic_saturation", 1e-6),
        ("hysteresis,stiffness", 1e-2),
    ] {
        let d = tempfile::tempdir().unwrap();
        let (rec, dev) = noiseless_record(d.path(), effects, false);
        let out = d.path().join("force.csv");
        ok(&simulate(&dev, &rec, &out));
        let measured = Measurement::read(&rec).unwrap();
        let model = Measurement::read(&out).unwrap();
        assert_eq!(model.t_s, measured.t_s);
        assert_eq!(model.x_m, measured.x_m, "the motion is written as given");
        let e = nrmse(&model.f_n, &measured.f_n);
        assert!(e < tol, "{effects}: NRMSE {e} against mts's force");
        // The measured force is kept beside the model's.
        let kept: Vec<f64> = model.extra["f_measured_n"]
            .fields()
            .map(|f| f.parse().unwrap())
            .collect();
        assert_eq!(kept, measured.f_n);
    }
}

/// Without a velocity column, `simulate` derives the velocity from the displacement as the fit does:
/// on the noiseless record the force is still mts's within 0.5 % (the derivative's error near the
/// current switches and reversals).
#[test]
fn simulate_derives_the_velocity_when_the_file_has_none() {
    let d = tempfile::tempdir().unwrap();
    let (rec, dev) = noiseless_record(d.path(), "stiffness", true);
    // Motion and current only: no force column at all.
    let m = Measurement::read(&rec).unwrap();
    let motion = d.path().join("motion.csv");
    let mut text = String::from("t_s,x_m,i_a\n");
    for k in 0..m.len() {
        text.push_str(&format!("{},{},{}\n", m.t_s[k], m.x_m[k], m.i_a[k]));
    }
    std::fs::write(&motion, text).unwrap();
    let out = d.path().join("force.csv");
    ok(&simulate(&dev, &motion, &out));
    let model = Measurement::read(&out).unwrap();
    assert!(!model.extra.contains_key("f_measured_n"));
    let e = nrmse(&model.f_n, &m.f_n);
    assert!(e < 5e-3, "NRMSE {e}");
}

/// A params file with the yield force per ampere 10 % off gives a force measurably different from the
/// record's: an NRMSE between 3 % and 12 % (the yield force is most of this device's force; a wrong
/// file that left the force unchanged, or scaled all of it, would fall outside).
#[test]
fn a_wrong_params_file_gives_a_measurably_different_force() {
    let d = tempfile::tempdir().unwrap();
    let (rec, dev) = noiseless_record(d.path(), "stiffness", false);
    let text = std::fs::read_to_string(&dev).unwrap();
    let mut json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let gain = &mut json["params"]["fc_gain_n_per_a"]["value"];
    *gain = serde_json::json!(gain.as_f64().unwrap() * 1.1);
    let wrong = d.path().join("wrong.json");
    std::fs::write(&wrong, serde_json::to_string_pretty(&json).unwrap()).unwrap();
    let out = d.path().join("force.csv");
    ok(&simulate(&wrong, &rec, &out));
    let e = nrmse(
        &Measurement::read(&out).unwrap().f_n,
        &Measurement::read(&rec).unwrap().f_n,
    );
    assert!((0.03..0.12).contains(&e), "NRMSE {e}");
}

/// Bad input names the file, the line and the field, exits non-zero and writes nothing.
#[test]
fn bad_input_to_simulate_names_file_line_and_field() {
    let d = tempfile::tempdir().unwrap();
    let (_, dev) = noiseless_record(d.path(), "stiffness", false);
    let out = d.path().join("force.csv");
    let cases: Vec<(&str, String, Vec<&str>)> = vec![
        (
            "no_x.csv",
            "t_s,i_a\n0,1\n0.001,1\n".into(),
            vec!["no_x.csv:1", "`x_m`"],
        ),
        (
            "bad_i.csv",
            "t_s,x_m,i_a\n0,0,1\n0.001,0.0001,1\n0.002,0.0002,one\n".into(),
            vec!["bad_i.csv:4", "`i_a`", "one"],
        ),
        (
            "back.csv",
            "t_s,x_m,i_a\n0,0,1\n0.002,0.0001,1\n0.001,0.0002,1\n".into(),
            vec!["back.csv:4", "`t_s`"],
        ),
    ];
    for (name, text, needles) in cases {
        let input = d.path().join(name);
        std::fs::write(&input, text).unwrap();
        let o = simulate(&dev, &input, &out);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{err}");
        for n in needles {
            assert!(err.contains(n), "{name}: the error does not name `{n}`: {err}");
        }
        assert!(!out.exists(), "{name}: wrote {}", out.display());
    }
    // A params file with a parameter that is not a number: its line and field.
    let bad = d.path().join("bad.json");
    std::fs::write(
        &bad,
        "{\"model\": \"bingham\",\n \"params\": {\n  \"fc0_n\": {\"value\": \"x\"}\n}}",
    )
    .unwrap();
    let good_input = d.path().join("no_x.csv");
    std::fs::write(&good_input, "t_s,x_m,i_a\n0,0,1\n0.001,0.0001,1\n").unwrap();
    let o = simulate(&bad, &good_input, &out);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("bad.json:3") && err.contains("fc0_n"), "{err}");
    assert!(!out.exists());
}

/// `validate --out` writes the file as read with `f_model_n` beside `f_n`: the force `simulate` gives on
/// the same file, and the one `validate` scored (the NRMSE of the written columns is the reported one).
#[test]
fn validate_out_writes_the_scored_model_force_beside_the_measured_one() {
    let d = tempfile::tempdir().unwrap();
    let (rec, dev) = noiseless_record(d.path(), "stiffness", false);
    let beside = d.path().join("beside.csv");
    let o = mrfeel(&[
        "validate",
        &s(&rec),
        "--params",
        &s(&dev),
        "--json",
        "--acquisition",
        "as-logged",
        "--out",
        &s(&beside),
    ]);
    ok(&o);
    let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let b = Measurement::read(&beside).unwrap();
    let measured = Measurement::read(&rec).unwrap();
    assert_eq!(b.f_n, measured.f_n);
    let model: Vec<f64> = b.extra["f_model_n"]
        .fields()
        .map(|f| f.parse().unwrap())
        .collect();
    let reported = json["nrmse"].as_f64().unwrap();
    assert!(
        (nrmse(&model, &b.f_n) - reported).abs() <= 1e-12 * reported.max(1e-300),
        "{} vs {reported}",
        nrmse(&model, &b.f_n)
    );
    let out = d.path().join("force.csv");
    ok(&simulate(&dev, &rec, &out));
    assert_eq!(model, Measurement::read(&out).unwrap().f_n);
}
