//! Results checked before they are saved, and outputs safe to write (docs/reference/invariants.md): input that parses
//! but would make meaningless results, a run that breaks a physical invariant, parallel writers to one
//! output, the leftovers of killed runs, and input echoed in errors.

use crate::common;
use common::mrfeel;

use std::path::{Path, PathBuf};
use std::process::Output;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn s(p: &Path) -> String {
    p.to_str().expect("utf-8 path").to_string()
}

/// The run failed cleanly: exit 1, no panic, nothing on stdout, the error naming every one of `needles`.
fn refused(o: &Output, needles: &[&str]) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        o.stdout.is_empty(),
        "stdout on an error: {}",
        String::from_utf8_lossy(&o.stdout)
    );
    for n in needles {
        assert!(err.contains(n), "the error does not name `{n}`: {err}");
    }
    err
}

/// The real 2 mm / 5 Hz test at 0.5 A with the field of `column` at data line `line` (1-based, after the
/// header) replaced by `value`, written into `dir`; the file's path and the file line of that sample.
fn corrupted(dir: &Path, column: &str, line: usize, value: &str) -> (PathBuf, usize) {
    let text = std::fs::read_to_string(root().join("data/utfsm-mr-damper/2mm5Hz_0p50A.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let header = lines.iter().position(|l| l.starts_with("t_s,")).unwrap();
    let c = lines[header].split(',').position(|h| h == column).unwrap();
    let at = header + line;
    let mut fields: Vec<String> = lines[at].split(',').map(str::to_string).collect();
    fields[c] = value.to_string();
    lines[at] = fields.join(",");
    let p = dir.join("2mm5Hz_0p50A.csv");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    (p, at + 1)
}

/// One current sample of 1e20 A, or one force sample of -1e149 N, in a real test: `fit` used to exit 0
/// (with `"nrmse": null`, or an RMS error of 4.7e147 N) and save what `validate` refuses. Each is refused
/// at its line and column as a spike, and nothing is saved.
#[test]
fn a_spike_in_a_measurement_is_refused_at_its_line_and_nothing_is_saved() {
    for (column, value) in [("i_a", "1e20"), ("f_n", "-1e149")] {
        let d = tempfile::tempdir().unwrap();
        let (csv, line) = corrupted(d.path(), column, 100, value);
        let params = d.path().join("params.json");
        let o = mrfeel(&["fit", &s(&csv), "--save", &s(&params), "--json"]);
        refused(
            &o,
            &[
                &format!("2mm5Hz_0p50A.csv:{line}: column `{column}`"),
                "looks like a spike",
            ],
        );
        assert!(!params.exists(), "a params file was saved");
    }
}

/// A scenario: the paper's feel loop with `edits` (`key = value` lines replaced inside their table, or
/// added), written beside the shipped one's files so that its relative paths resolve.
fn paper_loop_with(dir: &Path, edits: &[(&str, &str, &str)]) -> PathBuf {
    let text = std::fs::read_to_string(root().join("scenarios/paper-feel-loop.toml")).unwrap();
    let mut out = Vec::new();
    let mut table = String::new();
    for l in text.lines() {
        let t = l.trim();
        if t.starts_with('[') {
            table = t.trim_matches(|c| c == '[' || c == ']').to_string();
        }
        let replaced = edits
            .iter()
            .find(|(tb, key, _)| *tb == table && t.split_once('=').is_some_and(|(k, _)| k.trim() == *key));
        match replaced {
            Some((_, key, value)) => out.push(format!("{key} = {value}")),
            None => out.push(l.to_string()),
        }
    }
    let mut text = out.join("\n") + "\n";
    let abs = s(&root().join("models"));
    text = text.replace("\"../models", &format!("\"{abs}"));
    let p = dir.join("scenario.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// `feel.max_force_n = 5e-324`: no sample resists the motion, and the tracking error was printed as NaN.
/// Now every number printed is one; the tracking error is said to be unmeasurable.
#[test]
fn a_feel_too_small_to_track_prints_no_nan() {
    let d = tempfile::tempdir().unwrap();
    let scn = paper_loop_with(
        d.path(),
        &[("feel", "max_force_n", "5e-324"), ("", "duration_s", "2.0")],
    );
    let o = mrfeel(&["run", &s(&scn)]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!out.to_lowercase().contains("nan"), "{out}");
    assert!(out.contains("force tracking: none to measure"), "{out}");
    let o = mrfeel(&["run", &s(&scn), "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["tracking_nrmse"], serde_json::Value::Null);
    assert_eq!(v["resisting_samples"], 0);
}

/// A 100 Hz pilot command in the paper's loop left the energy balance 30.8 % open, with exit 0. The run is
/// an error that names the invariant, a time inside the run, and the pilot's frequency at its line.
#[test]
fn a_pilot_command_too_fast_for_the_hand_breaks_the_energy_balance_and_is_named() {
    let d = tempfile::tempdir().unwrap();
    let scn = paper_loop_with(
        d.path(),
        &[("pilot", "frequency_hz", "100.0"), ("", "duration_s", "2.0")],
    );
    let out = d.path().join("run.csv");
    let o = mrfeel(&["run", &s(&scn), "--out", &s(&out)]);
    let err = refused(
        &o,
        &["`pilot.frequency_hz`", "energy balance within 5 %", "at t = "],
    );
    let line = std::fs::read_to_string(&scn)
        .unwrap()
        .lines()
        .position(|l| l.starts_with("frequency_hz"))
        .unwrap()
        + 1;
    assert!(err.contains(&format!("scenario.toml:{line}:")), "{err}");
    assert!(!out.exists(), "results were written");
}

/// The paper's loop at `rig.physics_hz = 100000` drove the load cell to 334.9 N past its 250 N range with
/// exit 0. The run is an error that names the load cell's range and the physics rate.
#[test]
fn a_physics_rate_the_loop_does_not_converge_at_is_named_by_the_load_cell_range() {
    let d = tempfile::tempdir().unwrap();
    let scn = paper_loop_with(
        d.path(),
        &[("rig", "physics_hz", "100000.0"), ("", "duration_s", "1.5")],
    );
    let o = mrfeel(&["run", &s(&scn)]);
    refused(&o, &["`rig.physics_hz`", "load cell within its ±250 N range"]);
}

/// A short `mts` run writing `out`.
fn mts(out: &Path) -> Output {
    mrfeel(&[
        "mts",
        "--current",
        "2",
        "--cycles",
        "1",
        "--frequency-hz",
        "2",
        "--out",
        &s(out),
    ])
}

/// Eight runs writing one output at once, several times over: every run succeeds (a check of the output
/// made the file itself and failed some with "File exists"), the output is one whole file, and no
/// temporary file is left.
#[test]
fn parallel_runs_writing_one_output_all_succeed_and_leave_one_whole_file() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("same.csv");
    for _round in 0..3 {
        let _ = std::fs::remove_file(&out);
        let runs: Vec<Output> = std::thread::scope(|sc| {
            let hs: Vec<_> = (0..8).map(|_| sc.spawn(|| mts(&out))).collect();
            hs.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for o in &runs {
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        }
        mrfeel::measurement::Measurement::read(&out).expect("one whole measurement");
        let names: Vec<String> = std::fs::read_dir(d.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, ["same.csv"]);
    }
}

/// A run killed while writing leaves its temporary file; the next run writing into that directory removes
/// it. A temporary file a live run holds is kept.
#[test]
fn the_partial_file_of_a_killed_run_is_removed_by_the_next_run() {
    let d = tempfile::tempdir().unwrap();
    let stale = d.path().join(".same.mrfeel-partial-AbCdEfGhIj.csv");
    std::fs::write(&stale, "t_s,x_m,i_a,f_n\n0,0,0,").unwrap();
    let live = d.path().join(".other.mrfeel-partial-KlMnOpQrSt.csv");
    std::fs::write(&live, "t_s,x_m").unwrap();
    let held = std::fs::File::open(&live).unwrap();
    held.lock().unwrap();
    let o = mts(&d.path().join("same.csv"));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!stale.exists(), "the killed run's partial file is still there");
    assert!(live.exists(), "a live run's partial file was removed");
}

/// A 5 MB field holding a terminal escape code: the error quotes it bounded and escaped.
#[test]
fn errors_quote_input_bounded_and_with_control_characters_escaped() {
    let d = tempfile::tempdir().unwrap();
    let field = format!("\u{1b}[2J{}", "9".repeat(5 << 20));
    let (csv, line) = corrupted(d.path(), "f_n", 10, &format!("x{field}"));
    let o = mrfeel(&[
        "validate",
        &s(&csv),
        "--params",
        &s(&root().join("models/paper-device.toml")),
    ]);
    let err = refused(
        &o,
        &[&format!("2mm5Hz_0p50A.csv:{line}: column `f_n`"), "\\u{1b}[2J"],
    );
    assert!(err.len() < 4000, "an error of {} bytes", err.len());
    assert!(!err.contains('\u{1b}'), "a raw escape code in the error");
}

/// A `run` with nothing that needs its whole rows streams them to its CSV as they are made (memory bounded
/// whatever its length); the file is the same to the byte as that of a run that keeps its rows (`--plot`
/// needs them).
#[test]
fn a_streamed_run_writes_the_same_csv_as_a_kept_one() {
    let d = tempfile::tempdir().unwrap();
    let scn = paper_loop_with(d.path(), &[("", "duration_s", "1.0")]);
    let (streamed, kept) = (d.path().join("streamed.csv"), d.path().join("kept.csv"));
    let o = mrfeel(&["run", &s(&scn), "--out", &s(&streamed)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let plots = d.path().join("plots");
    let o = mrfeel(&["run", &s(&scn), "--out", &s(&kept), "--plot", &s(&plots)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (a, b) = (std::fs::read(&streamed).unwrap(), std::fs::read(&kept).unwrap());
    assert!(a.len() > 100_000, "{} bytes", a.len());
    assert!(a == b, "the streamed CSV differs from the kept one");
}
