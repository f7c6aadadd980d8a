//! Discovery beyond the vocabulary, on data that neither mrfeel's effect code nor this crate made:
//! `python/independent_truth.py` writes the paper's device with a physical effect no named effect covers
//! (turbulent `v|v|` drag, an adiabatic gas spring, a yield force that builds up after each reversal, a
//! force ripple periodic in position, LuGre friction, a field lag that grows with current, a shear-thinning
//! fluid), on
//! sines, triangles, multisines and current steps, at 500 Hz to 3 kHz, with and without a velocity channel.
//!
//! For each, `diagnose` must either end within 1.3× of the true model's held-out error (the load cell's
//! noise: the truth's residual is that noise alone) or say that structure is left (`unexplained`); with
//! nothing hidden it must add nothing, discover nothing and call the residual noise. The default cases keep
//! the test time modest; `cargo test --release --no-default-features --test integration discovery:: --
//! --ignored` runs the whole matrix (264 diagnoses) in the release build, without the Rerun SDK.

use crate::common;

use std::path::Path;
use std::process::Command;

use mrfeel::device::formula::FormulaEffect;
use mrfeel::device::{Model, ModelSpec, Registry};
use mrfeel::ident::diagnose::cross_validate;
use mrfeel::ident::{diagnose, load_tests, DiagnoseOptions, Diagnosis, Test};

/// The load cell's noise of the generator at the paper's scale, N (its `NOISE0`).
const NOISE_N: f64 = 0.15;

/// Write `effects` with `python/independent_truth.py` (three sine groups at 0, 7 and 14 A, two cycles each
/// unless `env` says otherwise) into a temporary folder and load its files.
fn generate(effects: &str, env: &[(&str, &str)], seed: u64) -> (tempfile::TempDir, Vec<Test>) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("data");
    let mut cmd = Command::new(common::venv_python());
    cmd.arg(root.join("python/independent_truth.py"))
        .arg(effects)
        .arg(&out)
        .arg(seed.to_string())
        .env("CURRENTS", "0,7,14")
        .env("CYCLES", "2");
    for (k, v) in env {
        cmd.env(k, v);
    }
    let o = cmd.output().expect("running python/independent_truth.py");
    assert!(
        o.status.success(),
        "independent_truth.py {effects}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let tests = load_tests(&[out]).expect("generated files load");
    (dir, tests)
}

fn run(tests: &[Test]) -> Diagnosis {
    diagnose(
        tests,
        &ModelSpec::parse("bingham").expect("spec"),
        &Registry::builtin(),
        &DiagnoseOptions {
            open_search: true,
            ..Default::default()
        },
    )
    .expect("diagnose")
}

/// The true model's held-out NRMSE: its residual is the force noise `noise_n` alone, so `noise / F_rms`
/// over the samples.
fn truth_nrmse(tests: &[Test], noise_n: f64) -> f64 {
    let (ss, n) = tests
        .iter()
        .flat_map(|t| &t.f_n)
        .fold((0.0, 0usize), |(s, n), f| (s + f * f, n + 1));
    noise_n / (ss / n as f64).sqrt()
}

/// `diagnose` ends within 1.3× of the truth's held-out error, or reports `unexplained`.
fn near_truth_or_said(effects: &str, env: &[(&str, &str)], seed: u64) -> (Diagnosis, String) {
    let (_dir, tests) = generate(effects, env, seed);
    let d = run(&tests);
    let truth = truth_nrmse(&tests, NOISE_N);
    let report = mrfeel::ident::report::diagnose_table(&d);
    assert!(
        d.final_heldout_nrmse <= 1.3 * truth || d.unexplained().is_some(),
        "{effects} {env:?}: ended at held-out NRMSE {:.4}, {:.2}x the truth's {truth:.4}, and did not say \
         structure is left:\n{report}",
        d.final_heldout_nrmse,
        d.final_heldout_nrmse / truth
    );
    (d, report)
}

/// As [`near_truth_or_said`], and the error fell well below the base model's whatever it ends with.
fn found_or_said(effects: &str, env: &[(&str, &str)], seed: u64) -> Diagnosis {
    let (d, report) = near_truth_or_said(effects, env, seed);
    assert!(
        d.final_heldout_nrmse < 0.8 * d.base_heldout_nrmse,
        "{effects}: {report}"
    );
    d
}

/// With nothing hidden: no named effect, no term, and the residual called noise.
fn nothing_found(env: &[(&str, &str)], seed: u64) {
    let (_dir, tests) = generate("none", env, seed);
    nothing_found_in(&tests, env);
}

/// [`nothing_found`] on tests already generated with `env`.
fn nothing_found_in(tests: &[Test], env: &[(&str, &str)]) {
    let d = run(tests);
    let report = mrfeel::ident::report::diagnose_table(&d);
    assert!(d.missing.is_empty(), "{env:?}: named {:?}\n{report}", d.missing);
    assert!(
        d.discovered.is_empty(),
        "{env:?}: discovered {:?}\n{report}",
        d.discovered.iter().map(|t| &t.formula).collect::<Vec<_>>()
    );
    assert!(
        d.unexplained().is_none(),
        "{env:?}: called the noise structure (predictable share {:.3})\n{report}",
        d.verdict.predictable_share
    );
}

/// Effects of the vocabulary, alone and in pairs, are named exactly with the open search on, nothing is
/// discovered beside them, and the diagnosis ends at the noise. A term of several library features can take
/// the parts of hysteresis and a spring at once and beat each alone in one step; were it let in there, the
/// diagnosis would miss hysteresis and end far above the noise.
#[test]
fn named_effects_are_named_exactly_with_the_open_search_on() {
    let mut seed = 7;
    for effects in [
        "hysteresis,stiffness",
        "hysteresis,asymmetry",
        "current_viscosity,stiffness",
        "hysteresis",
        "stiffness",
        "asymmetry",
        "current_viscosity",
        "magnetic_saturation",
        "inertia",
        "thermal_drift",
    ] {
        seed += 1;
        let (_dir, tests) = generate(effects, &[], seed);
        let d = run(&tests);
        let report = mrfeel::ident::report::diagnose_table(&d);
        let mut named = d.missing.clone();
        named.sort();
        let mut hidden: Vec<&str> = effects.split(',').collect();
        hidden.sort();
        assert_eq!(named, hidden, "{effects}:\n{report}");
        assert!(
            d.discovered.is_empty(),
            "{effects}: a term beside named effects\n{report}"
        );
        assert!(
            d.final_heldout_nrmse < 1.2 * d.noise_floor_nrmse && d.unexplained().is_none(),
            "{effects}: ended at {:.2}x the noise floor\n{report}",
            d.final_heldout_nrmse / d.noise_floor_nrmse
        );
    }
}

/// Turbulent drag `CD v|v|` on sines at 1 kHz: a term of the quadratic-damping family is found and the error
/// ends near the truth's; saved as an effect file and fitted alone, it keeps its held-out gain.
#[test]
fn velocity_squared_drag_is_found_as_quadratic_damping() {
    let (dir, tests) = generate("drag", &[], 1);
    let d = run(&tests);
    let report = mrfeel::ident::report::diagnose_table(&d);
    let truth = truth_nrmse(&tests, NOISE_N);
    assert!(
        d.final_heldout_nrmse <= 1.3 * truth,
        "held-out {:.4} vs truth {truth:.4}\n{report}",
        d.final_heldout_nrmse
    );
    assert_eq!(d.discovered.len(), 1, "{report}");
    let t = &d.discovered[0];
    assert!(
        t.features.iter().any(|f| f.contains("v*abs(v)")),
        "{:?}\n{report}",
        t.features
    );
    // The family is read from the final fit, where the `v|v|` term carries the force.
    assert!(t.resembles.starts_with("quadratic"), "{}\n{report}", t.resembles);
    assert!(d.unexplained().is_none(), "{report}");
    // The saved effect, loaded back and refitted alone from bingham on the same folds, keeps the gain.
    let path = dir.path().join("drag.toml");
    let merged = mrfeel::ident::discover::merged("drag", std::slice::from_ref(&t.effect)).expect("one term");
    std::fs::write(&path, merged.to_toml()).expect("write");
    let loaded = FormulaEffect::load(&path).expect("loads");
    let mut reg = Registry::builtin();
    reg.register(loaded);
    let model = Model::from_spec("bingham+drag", &reg, 14.0).expect("model");
    let opts = DiagnoseOptions::default();
    let (folds, _) = opts.folds(&tests);
    let bar = indicatif::ProgressBar::hidden();
    let cv = cross_validate(&model, &tests, &folds, None, &opts.cv_fit(), &bar);
    assert!(
        cv.heldout_nrmse() <= 1.05 * t.heldout_nrmse,
        "refitted alone {:.4} vs discovered {:.4}",
        cv.heldout_nrmse(),
        t.heldout_nrmse
    );
}

/// A shear-thinning fluid (Herschel–Bulkley: the viscous force grows as |v|^0.7, not v), on triangles at
/// 500 Hz: the model's viscous term takes part of it, and the search, judging each term by what it adds
/// beside the model's own terms, finds a shear-thinning term and ends at the noise.
#[test]
fn shear_thinning_on_triangles_is_found_as_a_shear_thinning_term() {
    let env = [("HB_N", "0.7"), ("WAVE", "triangle"), ("FS", "500")];
    let (d, truth, report) = found_as("shear_thin", &env, 12, "shear-thinning");
    assert!(d.final_heldout_nrmse <= 1.1 * truth, "{report}");
    assert!(d.unexplained().is_none(), "{report}");
}

/// An adiabatic gas spring on sines (its force grows as (L / (L − x))^1.4, steeply toward one end): the
/// search finds a spring stiffening toward one end, and the held-out error falls to under a twelfth of
/// Bingham's (a polynomial in x, extrapolated to the largest stroke held out, stays above a seventh).
#[test]
fn a_gas_spring_is_found_as_a_spring_stiffening_toward_one_end() {
    let (d, _, report) = found_as("gas_spring", &[], 11, "spring stiffening toward one end");
    assert!(d.final_heldout_nrmse < d.base_heldout_nrmse / 12.0, "{report}");
}

/// Diagnose `effects` and check that a discovered term resembles `family`; the diagnosis, the truth's
/// held-out NRMSE and the report.
fn found_as(effects: &str, env: &[(&str, &str)], seed: u64, family: &str) -> (Diagnosis, f64, String) {
    let (_dir, tests) = generate(effects, env, seed);
    let d = run(&tests);
    let report = mrfeel::ident::report::diagnose_table(&d);
    let found = d.discovered.iter().any(|t| t.resembles.starts_with(family));
    assert!(found, "{effects}: no term resembles {family}\n{report}");
    (d, truth_nrmse(&tests, NOISE_N), report)
}

#[test]
fn gas_spring_on_triangles_at_2_khz_is_found_or_reported() {
    found_or_said("gas_spring", &[("WAVE", "triangle"), ("FS", "2000")], 2);
}

/// Slow in the debug build (over a minute): run with `--ignored`.
#[test]
#[ignore]
fn yield_lag_on_multisines_at_500_hz_without_velocity_is_found_or_reported() {
    found_or_said(
        "yield_lag",
        &[("WAVE", "multisine"), ("FS", "500"), ("NOVEL", "1")],
        3,
    );
}

/// On triangle waves current-dependent damping is significant first against `v|v|` drag, and the term found
/// after it explains little of the rest (the named-first diagnosis ended at 6.7× the truth's error, calling
/// the rest unexplained): the second path, where the term competes at every step, finds the drag itself and
/// ends at the truth's error.
#[test]
fn drag_on_triangles_is_found_where_a_named_effect_is_significant_first() {
    let (_dir, tests) = generate("drag", &[("FS", "1000"), ("WAVE", "triangle")], 109);
    let d = run(&tests);
    let truth = truth_nrmse(&tests, NOISE_N);
    let report = mrfeel::ident::report::diagnose_table(&d);
    assert!(d.final_heldout_nrmse <= 1.3 * truth, "{report}");
    assert!(d.unexplained().is_none(), "{report}");
    assert_eq!(d.discovered.len(), 1, "{report}");
    assert!(d.discovered[0].formula.contains("v*abs(v)"), "{report}");
}

#[test]
fn drag_under_current_steps_at_3_khz_is_found_or_reported() {
    found_or_said("drag", &[("STEPS", "1"), ("FS", "3000")], 4);
}

/// A force ripple periodic in position (a detent, a screw's lead), finer than the verdict's bins and in no
/// named effect: the open search reads its wavelength from the residual's periodogram against x, and the
/// error ends at the truth's with a term of the periodic family and nothing said to be left.
#[test]
fn a_ripple_in_position_is_found_as_a_periodic_term() {
    let (_dir, tests) = generate("ripple", &[], 8);
    let d = run(&tests);
    let report = mrfeel::ident::report::diagnose_table(&d);
    let truth = truth_nrmse(&tests, NOISE_N);
    assert!(
        d.final_heldout_nrmse <= 1.3 * truth,
        "held-out {:.4} vs truth {truth:.4} (base {:.4})\n{report}",
        d.final_heldout_nrmse,
        d.base_heldout_nrmse
    );
    assert!(
        d.discovered
            .iter()
            .any(|t| t.resembles.contains("periodic in position")),
        "{report}"
    );
    assert!(d.missing.is_empty(), "{report}");
    assert!(d.unexplained().is_none(), "{report}");
}

/// LuGre friction on multisines at 500 Hz without a velocity channel, whose bristle state is a memory of
/// the motion: whatever the search finds, the tool ends near the truth or says structure is left, and when
/// the signals predict little of what is left it says so.
#[test]
fn effects_no_signal_predicts_are_still_reported() {
    let (d, report) = near_truth_or_said(
        "lugre",
        &[("WAVE", "multisine"), ("FS", "500"), ("NOVEL", "1")],
        9,
    );
    if d.unexplained().is_some() && d.verdict.predictable_share < 0.05 {
        assert!(report.contains("do not carry"), "lugre: {report}");
    }
}

/// A field that lags more at high current (a coil whose inductance grows with current), under current
/// steps: the residual lives in the fifth of a second after each step.
#[test]
fn a_field_lag_growing_with_current_is_found_or_reported() {
    near_truth_or_said("slow_field", &[("STEPS", "1")], 10);
}

/// Triangle waves whose corners are rounded over 5 % of the period carry a comb of zeros in their
/// displacement's spectrum with no filter anywhere. On one draw of the load cell's noise (seed 341: one of
/// 46 seeds tried) that comb passed for a 149-sample moving average in the slowest group, and the diagnosis,
/// driving the model with the motion "before" the filter, ended at 48 times the noise floor calling the rest
/// unexplained. A filter found in the spectra is taken only where the model follows the force better with
/// it undone: here none is, and nothing is found.
#[test]
fn a_smooth_drive_is_not_taken_for_a_filtered_acquisition() {
    let env = [("FS", "1000"), ("WAVE", "triangle")];
    let (_dir, tests) = generate("none", &env, 341);
    let filtered: Vec<&str> = tests
        .iter()
        .filter(|t| t.drive.is_some())
        .map(|t| t.name.as_str())
        .collect();
    assert!(filtered.is_empty(), "read through a filter: {filtered:?}");
    nothing_found_in(&tests, &env);
}

#[test]
fn nothing_hidden_on_sines_at_1_khz_finds_nothing() {
    nothing_found(&[], 5);
}

/// Slow in the debug build (over a minute): run with `--ignored`.
#[test]
#[ignore]
fn nothing_hidden_under_heavy_noise_on_triangles_at_3_khz_finds_nothing() {
    nothing_found(&[("WAVE", "triangle"), ("FS", "3000"), ("NOISE", "1.5")], 6);
}

#[test]
fn nothing_hidden_on_multisines_at_500_hz_without_velocity_finds_nothing() {
    nothing_found(&[("WAVE", "multisine"), ("FS", "500"), ("NOVEL", "1")], 7);
}

/// The whole matrix: every out-of-vocabulary effect of `python/independent_truth.py` on every protocol, at
/// 500 Hz, 1 kHz and 3 kHz, with and without a velocity channel; nothing hidden at three noise levels.
#[test]
#[ignore]
fn discovery_matrix() {
    let mut failures = Vec::new();
    let mut seed = 100;
    for effect in [
        "drag",
        "gas_spring",
        "yield_lag",
        "stribeck",
        "backlash",
        "end_friction",
        "lugre",
        "ripple",
        "compress",
        "cavitation",
        "slow_field",
    ] {
        for wave in ["sine", "triangle", "multisine", "steps"] {
            for fs in ["500", "1000", "3000"] {
                for novel in ["0", "1"] {
                    seed += 1;
                    let mut env = vec![("FS", fs), ("NOVEL", novel)];
                    if wave == "steps" {
                        env.push(("STEPS", "1"));
                    } else {
                        env.push(("WAVE", wave));
                    }
                    let r = std::panic::catch_unwind(|| {
                        // The first three the library can capture: their error must also fall.
                        let d = if ["drag", "gas_spring", "yield_lag"].contains(&effect) {
                            found_or_said(effect, &env, seed)
                        } else {
                            near_truth_or_said(effect, &env, seed).0
                        };
                        (
                            d.final_heldout_nrmse,
                            d.unexplained().is_some(),
                            d.final_model.clone(),
                        )
                    });
                    match r {
                        Ok((h, u, m)) => eprintln!("{effect} {env:?}: {m} held-out {h:.4} unexplained {u}"),
                        Err(_) => failures.push(format!("{effect} {env:?}")),
                    }
                }
            }
        }
    }
    for noise in ["0.05", "0.15", "1.5"] {
        for fs in ["500", "3000"] {
            seed += 1;
            let env = [("NOISE", noise), ("FS", fs), ("WAVE", "mix")];
            if std::panic::catch_unwind(|| nothing_found(&env, seed)).is_err() {
                failures.push(format!("none {env:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "failed: {failures:#?}");
}

/// `fit` loads a hand-written effect file named in the spec (`bingham+FILE.toml`) through the same registry
/// as the built-ins: on drag data it fits the drag and the error falls well below `bingham`'s.
#[test]
fn fit_loads_an_effect_file_named_in_the_model_spec() {
    let (dir, tests) = generate("drag", &[], 8);
    let data = dir.path().join("data");
    let effect = dir.path().join("quad.toml");
    std::fs::write(
        &effect,
        "name = \"quad\"\nformula = \"quad_cd * v * abs(v)\"\n\n[params.quad_cd]\nunit = \"N s^2/m^2\"\n\
         lower = -1e5\nupper = 1e5\n",
    )
    .expect("write");
    let nrmse = |model: &str| -> (f64, serde_json::Value) {
        let o = Command::new(env!("CARGO_BIN_EXE_mrfeel"))
            .args(["fit", "--json", "--model", model])
            .arg(&data)
            .output()
            .expect("mrfeel fit");
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let j: serde_json::Value = serde_json::from_slice(&o.stdout).expect("json");
        (j["nrmse"].as_f64().expect("nrmse"), j)
    };
    let (plain, _) = nrmse("bingham");
    let (with, j) = nrmse(&format!("bingham+{}", effect.display()));
    assert_eq!(j["model"], "bingham+quad");
    // The generator's drag coefficient is 1000 N s²/m²: found to within 5 %.
    let cd = j["params"]["quad_cd"]["value"].as_f64().expect("quad_cd");
    assert!((cd - 1000.0).abs() < 50.0, "quad_cd = {cd}");
    // Over every sample, reversals included (where a noisy velocity's sign is unknown), so the fall is
    // smaller than held out; the coefficient above is the physical check.
    assert!(with < 0.95 * plain, "bingham {plain:.4}, with the file {with:.4}");
    // Where the velocity's sign is known (the samples the fit minimises), the fit is at the noise: the
    // figures over all samples and over those are both reported, and fit and held-out scores agree.
    let known = &j["direction_known"];
    let (n_known, n_all) = (
        known["samples"].as_u64().expect("samples"),
        j["samples"].as_u64().expect("all"),
    );
    assert!(
        n_known < n_all && n_known as f64 > 0.97 * n_all as f64,
        "{n_known} of {n_all}"
    );
    let truth = truth_nrmse(&tests, NOISE_N);
    let k = known["nrmse"].as_f64().expect("nrmse");
    assert!(
        k <= 1.3 * truth,
        "direction-known NRMSE {k:.4} vs the noise's {truth:.4}"
    );
}

/// An effect file with an unknown feature, a formula that does not parse or a parameter without bounds
/// stops the command with the file, the line and the field, before any data is read.
#[test]
fn bad_effect_files_stop_the_command_at_their_line() {
    let dir = tempfile::tempdir().expect("temp dir");
    let good =
        "name = \"e\"\nformula = \"e_c * v\"\n\n[params.e_c]\nunit = \"N s/m\"\nlower = 0\nupper = 1e4\n";
    for (text, want) in [
        (
            good.replace("e_c * v", "e_c * q"),
            ":2: field `formula`: unknown feature `q`",
        ),
        (
            good.replace("e_c * v", "e_c * (v"),
            ":2: field `formula`: formula does not parse",
        ),
        (good.replace("upper = 1e4\n", ""), ":4:"),
    ] {
        let path = dir.path().join("e.toml");
        std::fs::write(&path, &text).expect("write");
        let o = Command::new(env!("CARGO_BIN_EXE_mrfeel"))
            .args(["fit", "nothing.csv", "--effects"])
            .arg(&path)
            .args(["--model", "bingham+e"])
            .output()
            .expect("mrfeel fit");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{text}");
        assert!(err.contains("e.toml") && err.contains(want), "{text}\n{err}");
        if want == ":4:" {
            assert!(err.contains("upper"), "{err}");
        }
    }
}

/// `diagnose --save` writes the final model as `fit --save` would: run unchanged by `validate`, it scores the
/// data at the noise floor. A final model with a discovered term is refused, naming `--save-effect`, and
/// nothing is written.
#[test]
fn diagnose_saves_its_final_model_for_validate_and_refuses_one_with_a_term() {
    let (dir, _) = generate("hysteresis", &[], 31);
    let data = dir.path().join("data");
    let saved = dir.path().join("final.json");
    let o = common::mrfeel(&[
        "diagnose",
        &common::s(&data),
        "--json",
        "--save",
        &common::s(&saved),
    ]);
    common::ok(&o);
    let d: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let p: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&saved).unwrap()).unwrap();
    assert_eq!(p["model"], d["final"]["model"], "{p}");
    let floor = d["noise_floor_nrmse"].as_f64().unwrap();
    let v = common::mrfeel(&[
        "validate",
        &common::s(&data),
        "--json",
        "--params",
        &common::s(&saved),
    ]);
    common::ok(&v);
    let v: serde_json::Value = serde_json::from_slice(&v.stdout).unwrap();
    let nrmse = v["nrmse"].as_f64().unwrap();
    assert!(
        nrmse < 1.2 * floor,
        "validate of the saved model: NRMSE {nrmse}, noise floor {floor}"
    );

    let (dir, _) = generate("drag", &[], 1);
    let data = dir.path().join("data");
    let saved = dir.path().join("final.json");
    let o = common::mrfeel(&["diagnose", &common::s(&data), "--save", &common::s(&saved)]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--save-effect"), "{err}");
    assert!(!saved.exists(), "a refused --save writes nothing");
}
