//! Bad input on the command line: an output that cannot be written, or a list that names a thing twice, is
//! an error that names the option (or file:line: field) and the culprit, with a non-zero exit, before
//! anything is run: nothing printed on stdout, no file written.

use crate::common;
use common::{mrfeel, s};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A small real test (448 samples) from the damper data beside the repository.
fn small_test() -> String {
    s(&root().join("data/utfsm-mr-damper/2mm5Hz_0p50A.csv"))
}

fn scenario(name: &str) -> String {
    s(&root().join("scenarios").join(name))
}

/// A temporary folder with a regular file `afile` in it, so that `afile/x` cannot be written (the tests
/// may run as root, who may write anywhere a directory exists or can be made).
fn setup() -> (tempfile::TempDir, PathBuf) {
    let d = tempfile::tempdir().expect("temp dir");
    let afile = d.path().join("afile");
    std::fs::write(&afile, "").unwrap();
    (d, afile)
}

/// The run failed cleanly before producing anything: non-zero exit, no panic, nothing on stdout, and the
/// error names every one of `needles`. Returns stderr.
fn refused(o: &Output, needles: &[&str]) -> String {
    let out = String::from_utf8_lossy(&o.stdout);
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(!o.status.success(), "exit 0; stderr: {err}");
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        out.is_empty(),
        "stdout not empty on an error: {out}\nstderr: {err}"
    );
    for n in needles {
        assert!(err.contains(n), "the error does not name `{n}`: {err}");
    }
    err
}

/// A short `mts` run (one cycle at 2 Hz) writing its CSV to `out`, then `more`.
fn mts_args(out: &str, more: &[&str]) -> Vec<String> {
    [
        "mts",
        "--current",
        "2",
        "--cycles",
        "1",
        "--frequency-hz",
        "2",
        "--out",
        out,
    ]
    .iter()
    .chain(more)
    .map(|a| a.to_string())
    .collect()
}

/// The files a folder holds (names), sorted.
fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

// ------------------------------------------------------------------ outputs checked before any work

#[test]
fn ident_commands_with_an_unwritable_plot_or_recording_print_nothing_and_write_nothing() {
    let (d, afile) = setup();
    let data = small_test();
    let plot = s(&afile.join("p"));
    let rrd = s(&afile.join("x.rrd"));
    let params = s(&root().join("models/paper-device.toml"));
    let cases: Vec<(Vec<&str>, &str, &str)> = vec![
        (vec!["fit", &data, "--json", "--plot", &plot], "--plot", &plot),
        (vec!["fit", &data, "--json", "--rerun", &rrd], "--rerun", &rrd),
        (vec!["fit", &data, "--plot", &plot], "--plot", &plot),
        (
            vec!["validate", &data, "--params", &params, "--json", "--plot", &plot],
            "--plot",
            &plot,
        ),
        (
            vec!["validate", &data, "--params", &params, "--rerun", &rrd],
            "--rerun",
            &rrd,
        ),
        (
            vec!["diagnose", &data, "--json", "--plot", &plot],
            "--plot",
            &plot,
        ),
        (vec!["diagnose", &data, "--rerun", &rrd], "--rerun", &rrd),
    ];
    for (args, option, path) in cases {
        let o = mrfeel(&args);
        let err = refused(&o, &[option, path, "not a directory"]);
        assert!(err.contains("nothing was run"), "{args:?}: {err}");
        // Refused before loading or fitting: no notes about the data on stderr.
        assert!(
            !err.contains("fitting") && !err.contains("acquisition"),
            "{args:?}: {err}"
        );
    }
    assert_eq!(listing(d.path()), vec!["afile"], "nothing written");
}

#[test]
fn fit_save_is_not_written_when_the_plot_cannot_be() {
    let (d, afile) = setup();
    let save = d.path().join("ok.json");
    let plot = s(&afile.join("x"));
    let o = mrfeel(&["fit", &small_test(), "--save", &s(&save), "--plot", &plot]);
    refused(&o, &["--plot", &plot]);
    assert!(!save.exists(), "--save written by a run that failed");
    // And the other way round: a save path in a missing directory stops the run before the plots.
    let save = d.path().join("no-such-dir").join("p.json");
    let plot_dir = d.path().join("plots");
    let o = mrfeel(&["fit", &small_test(), "--save", &s(&save), "--plot", &s(&plot_dir)]);
    refused(&o, &["--save", &s(&save), "does not exist"]);
    assert!(!plot_dir.exists(), "plots written by a run that failed");
}

#[test]
fn mts_writes_no_csv_when_the_plot_or_device_file_cannot_be_written() {
    let (d, afile) = setup();
    let out = d.path().join("o.csv");
    let out_s = s(&out);
    for (option, path) in [
        ("--plot", s(&afile.join("p"))),
        ("--save-device", s(&afile.join("d.json"))),
    ] {
        let o = mrfeel(&mts_args(&out_s, &[option, &path]));
        refused(&o, &[option, &path]);
        assert!(
            !out.exists(),
            "{option}: the CSV was written by a run that failed"
        );
    }
    // An --out that is a directory.
    let dir_s = s(d.path());
    let o = mrfeel(&mts_args(&dir_s, &[]));
    refused(&o, &["--out", &dir_s, "is a directory"]);
    assert_eq!(listing(d.path()), vec!["afile"], "nothing written");
}

#[test]
fn mts_creates_a_plot_directory_that_does_not_exist_yet() {
    // The check refuses what cannot be written, not what is merely new.
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("o.csv");
    let plot = d.path().join("new").join("plots");
    let o = mrfeel(&mts_args(&s(&out), &["--plot", &s(&plot)]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.is_file());
    assert!(
        plot.join("mts.png").is_file() && plot.join("mts.svg").is_file(),
        "{:?}",
        listing(&plot)
    );
    assert!(
        !String::from_utf8_lossy(&o.stdout).is_empty(),
        "the summary is printed"
    );
}

#[test]
fn run_daq_sweep_and_compare_refuse_unwritable_outputs_before_running() {
    let (d, afile) = setup();
    let out = d.path().join("ok.csv");
    let rrd = s(&afile.join("x.rrd"));
    let plot = s(&afile.join("p"));
    let o = mrfeel(&[
        "run",
        &scenario("paper-feel-loop.toml"),
        "--out",
        &s(&out),
        "--rerun",
        &rrd,
    ]);
    refused(&o, &["--rerun", &rrd]);
    assert!(!out.exists(), "run: --out written by a run that failed");
    let o = mrfeel(&[
        "daq-sweep",
        &scenario("response-time.toml"),
        "--rates",
        "100",
        "--plot",
        &plot,
    ]);
    refused(&o, &["--plot", &plot]);
    let compare = scenario("compare-feel.toml");
    for (option, path) in [("--plot", &plot), ("--rerun", &rrd)] {
        let o = mrfeel(&[
            "compare",
            &compare,
            "--feel",
            "centring_spring",
            "--json",
            option,
            path,
        ]);
        let err = refused(&o, &[option, path]);
        // One error, said once (Rerun's error text used to come three times over).
        assert_eq!(err.matches(path.as_str()).count(), 1, "{err}");
        assert_eq!(err.lines().count(), 1, "{err}");
    }
    assert_eq!(listing(d.path()), vec!["afile"], "nothing written");
}

#[test]
fn two_options_naming_one_path_are_refused() {
    let d = tempfile::tempdir().unwrap();
    let p = d.path().join("same");
    let dotted = format!("{}/./same", d.path().display());
    let o = mrfeel(&["fit", &small_test(), "--plot", &s(&p), "--rerun", &dotted]);
    refused(&o, &["--plot", "--rerun", "same"]);
    assert!(listing(d.path()).is_empty(), "nothing written");
}

#[test]
#[cfg(unix)]
fn one_file_spelled_two_ways_or_linked_is_one_output() {
    let d = tempfile::tempdir().unwrap();
    std::fs::create_dir(d.path().join("sub")).unwrap();
    let saved = d.path().join("same.json");
    // `sub/../same.json`, an absolute spelling, a symlink and a hard link to an existing file.
    let up = s(&d.path().join("sub/../same.json"));
    let o = mrfeel(&["fit", &small_test(), "--save", &s(&saved), "--rerun", &up]);
    refused(&o, &["--save", "--rerun", "name the same file"]);
    assert!(listing(d.path()) == vec!["sub"], "nothing written");
    std::fs::write(&saved, "{}").unwrap();
    let link = d.path().join("link.json");
    std::os::unix::fs::symlink(&saved, &link).unwrap();
    let hard = d.path().join("hard.json");
    std::fs::hard_link(&saved, &hard).unwrap();
    for other in [&link, &hard] {
        let o = mrfeel(&["fit", &small_test(), "--save", &s(&saved), "--rerun", &s(other)]);
        refused(&o, &["name the same file"]);
        assert_eq!(
            std::fs::read_to_string(&saved).unwrap(),
            "{}",
            "the file was changed"
        );
    }
}

#[test]
fn an_output_that_is_one_of_the_inputs_is_refused_and_the_input_kept() {
    let d = tempfile::tempdir().unwrap();
    let data = d.path().join("test.csv");
    std::fs::copy(small_test(), &data).unwrap();
    let before = std::fs::read(&data).unwrap();
    let data_s = s(&data);
    let o = mrfeel(&["fit", &data_s, "--rerun", &data_s]);
    refused(&o, &["--rerun", "input measurement"]);
    // Reached through the directory the data were named by.
    let o = mrfeel(&["fit", &s(d.path()), "--save", &data_s]);
    refused(&o, &["--save", "input measurement"]);
    let params = d.path().join("p.json");
    let o = mrfeel(&["fit", &data_s, "--save", &s(&params)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = mrfeel(&[
        "validate",
        &data_s,
        "--params",
        &s(&params),
        "--rerun",
        &s(&params),
    ]);
    refused(&o, &["--rerun", "input params file"]);
    let o = mrfeel(&mts_args(&s(&params), &["--device", &s(&params)]));
    refused(&o, &["--out", "input device file"]);
    assert_eq!(
        std::fs::read(&data).unwrap(),
        before,
        "the measurement was changed"
    );
    assert!(
        std::fs::read_to_string(&params).unwrap().contains("\"model\""),
        "the params file was changed"
    );
    let tree = scenario_tree();
    let scenario_copy = tree.path().join("scenarios/paper-feel-loop.toml");
    let text = std::fs::read(&scenario_copy).unwrap();
    let o = mrfeel(&["run", &s(&scenario_copy), "--out", &s(&scenario_copy)]);
    refused(&o, &["--out", "input scenario"]);
    assert_eq!(
        std::fs::read(&scenario_copy).unwrap(),
        text,
        "the scenario was changed"
    );
}

/// A copy of the repository's `scenarios/` and `models/` in a temporary folder (the scenarios name the
/// models as `../models/…`), so that a run that wrongly writes over an input destroys only the copy.
fn scenario_tree() -> tempfile::TempDir {
    let d = tempfile::tempdir().unwrap();
    for sub in ["scenarios", "models"] {
        std::fs::create_dir(d.path().join(sub)).unwrap();
        for e in std::fs::read_dir(root().join(sub)).unwrap() {
            let p = e.unwrap().path();
            if p.is_file() {
                std::fs::copy(&p, d.path().join(sub).join(p.file_name().unwrap())).unwrap();
            }
        }
    }
    d
}

#[test]
#[cfg(unix)]
fn run_and_compare_refuse_an_output_that_is_a_file_the_scenario_names() {
    let d = scenario_tree();
    let models = d.path().join("models");
    let scn = d.path().join("scenarios/paper-feel-loop.toml");
    // A spring feel unit, so that the run also reads the feel-spring file.
    let springs_scn = d.path().join("scenarios/springs.toml");
    std::fs::write(
        &springs_scn,
        std::fs::read_to_string(&scn).unwrap()
            + "\n[feel_system]\nkind = \"centring_spring\"\nsprings = \"../models/feel-springs.toml\"\n\
               damping_n_s_per_m = 100.0\n",
    )
    .unwrap();
    let device = models.join("paper-device.toml");
    let link = d.path().join("device-link.toml");
    std::os::unix::fs::symlink(&device, &link).unwrap();
    let before: Vec<(PathBuf, Vec<u8>)> = std::fs::read_dir(&models)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| (p.clone(), std::fs::read(&p).unwrap()))
        .collect();
    let run_cases = [
        (&scn, "--out", device.clone(), "input device file"),
        (&scn, "--rerun", models.join("stick-rig.urdf"), "input URDF"),
        (&scn, "--out", models.join("pilot-hand.toml"), "input pilot model"),
        (&scn, "--out", link.clone(), "input device file"),
        (
            &springs_scn,
            "--rerun",
            models.join("feel-springs.toml"),
            "input feel-spring file",
        ),
    ];
    for (scenario, option, path, what) in run_cases {
        let o = mrfeel(&["run", &s(scenario), option, &s(&path)]);
        refused(&o, &[option, &s(&path), what, "nothing was run"]);
    }
    let o = mrfeel(&["daq-sweep", &s(&scn), "--rates", "100", "--plot", &s(&device)]);
    refused(&o, &["--plot", "input device file"]);
    let compare = d.path().join("scenarios/compare-feel.toml");
    let compare_cases = [
        (
            "--rerun",
            models.join("feel-springs.toml"),
            "input feel-spring file",
        ),
        ("--rerun", scn.clone(), "input base scenario"),
        ("--rerun", link.clone(), "input device file"),
        ("--plot", models.join("stick-rig.urdf"), "input URDF"),
    ];
    for (option, path, what) in compare_cases {
        let o = mrfeel(&[
            "compare",
            &s(&compare),
            "--feel",
            "centring_spring",
            option,
            &s(&path),
        ]);
        refused(&o, &[option, &s(&path), what, "nothing was run"]);
    }
    for (p, bytes) in before {
        assert!(std::fs::read(&p).unwrap() == bytes, "{} was changed", p.display());
    }
}

// ------------------------------------------------------------------ a thing named twice

#[test]
fn a_measurement_file_given_twice_is_refused_by_fit_validate_and_diagnose() {
    let d = tempfile::tempdir().unwrap();
    let data = d.path().join("data");
    std::fs::create_dir(&data).unwrap();
    let file = data.join("a.csv");
    std::fs::copy(small_test(), &file).unwrap();
    let params = s(&root().join("models/paper-device.toml"));
    let (f, dir) = (s(&file), s(&data));
    let dotted = format!("{}/./a.csv", data.display());
    for files in [
        vec![f.as_str(), f.as_str()],
        vec![dir.as_str(), f.as_str()],
        vec![f.as_str(), &dotted],
    ] {
        for cmd in ["fit", "validate", "diagnose"] {
            let mut args = vec![cmd];
            args.extend(&files);
            args.push("--json");
            if cmd == "validate" {
                args.extend(["--params", params.as_str()]);
            }
            let o = mrfeel(&args);
            refused(&o, &["DATA", "a.csv", "read twice"]);
        }
    }
    // Named once, the same file fits.
    let o = mrfeel(&["fit", &f, "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).expect("JSON on stdout");
    assert_eq!(v["samples"], 448, "{v}");
}

#[test]
fn mts_refuses_an_effect_or_a_parameter_named_twice() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("o.csv");
    let o_s = s(&out);
    let o = mrfeel(&mts_args(&o_s, &["--effects", "hysteresis,hysteresis"]));
    refused(&o, &["--effects", "`hysteresis` named twice"]);
    let o = mrfeel(&mts_args(&o_s, &["--set", "te_s=0.01", "--set", "te_s=0.02"]));
    refused(&o, &["--set te_s", "twice", "0.01", "0.02"]);
    // An effect the device already has would be added to nothing.
    let saved = s(&d.path().join("truth.json"));
    let o = mrfeel(&mts_args(
        &o_s,
        &["--effects", "hysteresis", "--save-device", &saved],
    ));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    std::fs::remove_file(&out).unwrap();
    let o = mrfeel(&mts_args(&o_s, &["--device", &saved, "--effects", "hysteresis"]));
    refused(&o, &["--effects", "already has `hysteresis`", "truth.json"]);
    assert!(!out.exists(), "nothing written");
}

#[test]
fn compare_refuses_a_feel_system_named_twice_or_none() {
    let compare = scenario("compare-feel.toml");
    let o = mrfeel(&["compare", &compare, "--feel", "mr,mr"]);
    refused(&o, &["--feel mr,mr", "`mr` named twice"]);
    let o = mrfeel(&["compare", &compare, "--feel", "mr,,q_feel"]);
    refused(&o, &["--feel", "empty name"]);

    // The scenario's `systems`, with the repository's paths made absolute so that the copy loads.
    let text = std::fs::read_to_string(&compare).unwrap();
    let text = text
        .replace(
            "\"paper-feel-loop.toml\"",
            &format!("{:?}", scenario("paper-feel-loop.toml")),
        )
        .replace(
            "\"../models/feel-springs.toml\"",
            &format!("{:?}", s(&root().join("models/feel-springs.toml"))),
        );
    let (line, original) = text
        .lines()
        .enumerate()
        .find(|(_, l)| l.starts_with("systems = "))
        .map(|(k, l)| (k + 1, l.to_string()))
        .expect("a `systems` line");
    let d = tempfile::tempdir().unwrap();
    for (systems, needle) in [
        (
            r#"systems = ["centring_spring", "q_feel", "q_feel"]"#,
            "`q_feel` named twice",
        ),
        ("systems = []", "no feel system listed"),
    ] {
        let path = d.path().join("c.toml");
        std::fs::write(&path, text.replace(&original, systems)).unwrap();
        let o = mrfeel(&["compare", &s(&path), "--feel", "centring_spring"]);
        refused(
            &o,
            &[&format!("{}:{line}: field `systems`", path.display()), needle],
        );
    }
    // The copy itself, unchanged but for its paths, loads and runs.
    let path = d.path().join("c.toml");
    std::fs::write(&path, text.replace(&original, r#"systems = ["centring_spring"]"#)).unwrap();
    let o = mrfeel(&["compare", &s(&path)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("| centring_spring |"));
}

#[test]
fn daq_sweep_refuses_a_rate_given_twice() {
    let o = mrfeel(&[
        "daq-sweep",
        &scenario("response-time.toml"),
        "--rates",
        "100,200,100",
    ]);
    refused(&o, &["--rates 100,200,100", "100 Hz given twice"]);
}

// ------------------------------------------------------------------ options and files named where they were given

#[test]
fn mts_sensor_options_out_of_range_name_the_option_and_write_nothing() {
    let d = tempfile::tempdir().unwrap();
    let out = s(&d.path().join("o.csv"));
    for (option, value, field) in [
        ("--force-noise-n", "-1", "load_cell.noise_rms"),
        ("--position-noise-m", "-1e-6", "displacement.noise_rms"),
        ("--velocity-noise-m-s", "NaN", "velocity.noise_rms"),
        ("--load-cell-range-n", "0", "load_cell.range"),
        ("--adc-bits", "64", "adc_bits"),
    ] {
        let arg = format!("{option}={value}");
        let o = mrfeel(&["mts", "--current", "2", "--out", &out, &arg]);
        refused(&o, &[option, field]);
        assert!(listing(d.path()).is_empty(), "{option}: a file was written");
    }
}

/// A negative number after an option, with a space (`--amplitude-m -0.01`), is that option's value, refused
/// by the check that names it (exit 1), not an unknown flag `-0` (clap's usage error, exit 2).
#[test]
fn a_negative_number_after_an_option_is_its_value_refused_by_name() {
    let d = tempfile::tempdir().unwrap();
    let out = s(&d.path().join("o.csv"));
    for (option, value, field) in [
        ("--amplitude-m", "-0.01", "amplitude_m"),
        ("--force-noise-n", "-1", "load_cell.noise_rms"),
        ("--current", "-3", "current"),
    ] {
        let current = if option == "--current" { value } else { "2" };
        let mut args = vec!["mts", "--current", current, "--out", &out];
        if option != "--current" {
            args.extend([option, value]);
        }
        let o = mrfeel(&args);
        refused(&o, &[field, value]);
        assert_eq!(o.status.code(), Some(1), "{option} {value}");
        assert!(listing(d.path()).is_empty(), "{option}: a file was written");
    }
}

#[test]
fn validate_refuses_a_test_too_short_to_judge_a_model_by() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(small_test()).unwrap();
    // The header and three samples: fewer than twice the paper device's parameters.
    let short: String = text
        .lines()
        .take_while(|l| l.starts_with('#'))
        .chain(text.lines().filter(|l| !l.starts_with('#')).take(4))
        .map(|l| format!("{l}\n"))
        .collect();
    let path = d.path().join("short.csv");
    std::fs::write(&path, short).unwrap();
    let params = s(&root().join("models/paper-device.toml"));
    let o = mrfeel(&["validate", &s(&path), "--params", &params, "--json"]);
    refused(&o, &["short.csv", "3 samples"]);
}

#[test]
fn compare_names_the_scenario_line_of_a_missing_springs_file_and_a_readable_fault_bound() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(scenario("compare-feel.toml")).unwrap();
    // Relative paths in the scenario resolve from its folder: point them back at the repository.
    let models = s(&root().join("models"));
    let scenarios = s(&root().join("scenarios"));
    let fixed = text
        .replace("\"../models/", &format!("\"{models}/"))
        .replace("base = \"", &format!("base = \"{scenarios}/"));
    let missing = d.path().join("missing-springs.toml");
    std::fs::write(
        &missing,
        fixed.replace("feel-springs.toml", "no-such-springs.toml"),
    )
    .unwrap();
    let line = fixed.lines().position(|l| l.starts_with("file = ")).unwrap() + 1;
    let e = refused(
        &mrfeel(&["compare", &s(&missing)]),
        &["missing-springs.toml", "springs.file", "no-such-springs.toml"],
    );
    assert!(e.contains(&format!(":{line}:")), "line {line} not named: {e}");

    let early = d.path().join("early-end.toml");
    std::fs::write(&early, fixed.replace("end_s = 10.0", "end_s = 1.0")).unwrap();
    let e = refused(
        &mrfeel(&["compare", &s(&early)]),
        &["fault_test.end_s", "within the task"],
    );
    assert!(!e.contains("179769"), "the bound is printed as f64::MAX: {e}");
    // A window past the task's end would say the faults act where the run never goes.
    let late = d.path().join("late-end.toml");
    std::fs::write(&late, fixed.replace("end_s = 10.0", "end_s = 1000.0")).unwrap();
    refused(&mrfeel(&["compare", &s(&late)]), &["fault_test.end_s", "1000"]);
}

#[test]
#[cfg(unix)]
fn a_reader_that_closes_the_pipe_ends_the_run_quietly() {
    use std::os::unix::process::ExitStatusExt;
    // `mrfeel fit … --json | head -c0`: the reader is gone long before the fit prints (it loads and fits
    // first). The run must end by SIGPIPE, as Unix tools do, not panic in `println!`.
    let mut child = Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args(["fit", &small_test(), "--json"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(o.status.signal(), Some(libc_sigpipe()), "{:?}: {err}", o.status);
}

/// SIGPIPE's number on Linux and the BSDs.
fn libc_sigpipe() -> i32 {
    13
}

#[test]
#[cfg(unix)]
fn a_hard_link_to_a_measurement_given_is_the_same_test() {
    let d = tempfile::tempdir().unwrap();
    let a = d.path().join("a.csv");
    std::fs::copy(small_test(), &a).unwrap();
    let b = d.path().join("b.csv");
    std::fs::hard_link(&a, &b).unwrap();
    refused(&mrfeel(&["fit", &s(&a), &s(&b)]), &["read twice", "b.csv"]);
}

/// A copy of a measurement under another name is the same test: every sample equal. Read as two tests it
/// would count twice in the fit; it is refused, naming both files. One force sample changed, they are two.
#[test]
fn a_copy_of_a_measurement_under_another_name_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let a = d.path().join("a.csv");
    std::fs::copy(small_test(), &a).unwrap();
    let b = d.path().join("b.csv");
    std::fs::copy(small_test(), &b).unwrap();
    for cmd in ["fit", "diagnose"] {
        refused(
            &mrfeel(&[cmd, &s(&a), &s(&b)]),
            &["b.csv", "a.csv", "same samples"],
        );
    }
    refused(
        &mrfeel(&["fit", &s(d.path())]),
        &["b.csv", "a.csv", "same samples"],
    );
    let text = std::fs::read_to_string(&b).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let header = lines.iter().position(|l| l.starts_with("t_s")).unwrap();
    let fi = lines[header].split(',').position(|c| c == "f_n").unwrap();
    let last = lines.len() - 1;
    let mut fields: Vec<String> = lines[last].split(',').map(String::from).collect();
    let f: f64 = fields[fi].parse().unwrap();
    fields[fi] = format!("{}", f + 1.0);
    lines[last] = fields.join(",");
    std::fs::write(&b, lines.join("\n") + "\n").unwrap();
    let o = mrfeel(&["fit", &s(&a), &s(&b), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
#[cfg(target_os = "linux")]
fn a_full_stdout_is_an_error_not_a_panic() {
    for args in [
        vec!["fit".to_string(), small_test(), "--json".into()],
        vec!["run".into(), scenario("paper-feel-loop.toml"), "--json".into()],
    ] {
        let full = std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
            .args(&args)
            .stdout(full)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {err}");
        assert!(
            !err.contains("panicked") && err.contains("writing to stdout"),
            "{args:?}: {err}"
        );
    }
}

/// stderr only carries notes (what was written, the timing, the error): a run whose stderr cannot be
/// written still does its work and exits as it would have, and a refused run still exits 1, not with a
/// panic's 101.
#[test]
#[cfg(target_os = "linux")]
fn a_full_stderr_loses_the_notes_not_the_run() {
    let d = tempfile::tempdir().unwrap();
    let saved = d.path().join("p.json");
    let full = || std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap();
    let ok = std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args(["fit", &small_test(), "--json", "--save", &s(&saved)])
        .stderr(full())
        .output()
        .unwrap();
    assert_eq!(ok.status.code(), Some(0));
    let json: serde_json::Value = serde_json::from_slice(&ok.stdout).expect("the fit's JSON on stdout");
    assert!(json["nrmse"].as_f64().is_some_and(|e| e.is_finite()), "{json}");
    assert!(
        std::fs::metadata(&saved).is_ok_and(|m| m.len() > 0),
        "--save written"
    );
    let refused = std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args(["fit", "no-such-file.csv"])
        .stderr(full())
        .output()
        .unwrap();
    assert_eq!(refused.status.code(), Some(1));
}

/// A plot directory that cannot take the plots is refused before anything is written: a symbolic link to
/// nothing (was "File exists" from the directory's creation), and a directory holding a directory named
/// like a plot file (was an error after `--save` had been written).
#[test]
#[cfg(unix)]
fn a_plot_directory_that_cannot_take_plots_is_refused_before_the_run() {
    let d = tempfile::tempdir().unwrap();
    let saved = d.path().join("p.json");
    let dangling = d.path().join("plots-link");
    std::os::unix::fs::symlink(d.path().join("nowhere"), &dangling).unwrap();
    let err = refused(
        &mrfeel(&[
            "fit",
            &small_test(),
            "--save",
            &s(&saved),
            "--plot",
            &s(&dangling),
        ]),
        &[
            "--plot",
            "plots-link",
            "symbolic link",
            "nowhere",
            "does not exist",
        ],
    );
    assert!(!err.contains("File exists"), "{err}");
    assert!(!saved.exists(), "--save written before the refusal");

    let plots = d.path().join("plots");
    std::fs::create_dir_all(plots.join("force_time.svg")).unwrap();
    refused(
        &mrfeel(&["fit", &small_test(), "--save", &s(&saved), "--plot", &s(&plots)]),
        &["--plot", "force_time.svg", "a directory"],
    );
    assert!(!saved.exists(), "--save written before the refusal");
}

/// `argv` run under a file-size limit of 8 KiB, with `SIGXFSZ` ignored so that a write past the limit fails
/// with an error (`EFBIG`) as on a full disk, instead of killing the process.
#[cfg(target_os = "linux")]
fn under_a_file_size_limit(argv: &[String]) -> Output {
    Command::new("sh")
        .arg("-c")
        .arg("trap '' XFSZ; ulimit -f 16; exec \"$0\" \"$@\"")
        .arg(env!("CARGO_BIN_EXE_mrfeel"))
        .args(argv)
        .output()
        .expect("sh runs")
}

/// A write that fails half way (here past a file-size limit, as on a full disk) leaves the file that was
/// there whole and no partial file beside it, and the run fails naming the file: `mts --out`, `run --out`
/// and `fit --save` wrote in place, so the old file was gone and 8 KiB of a CSV was left in its stead.
#[test]
#[cfg(target_os = "linux")]
fn a_write_that_fails_half_way_keeps_the_old_file_whole() {
    let d = tempfile::tempdir().unwrap();
    let keep = d.path().join("keep.csv");
    let old = "the results of an earlier run\n";
    let cases: [Vec<String>; 2] = [
        ["mts", "--current", "1,2,3", "--cycles", "4", "--out", &s(&keep)]
            .map(String::from)
            .to_vec(),
        ["run", &scenario("paper-feel-loop.toml"), "--out", &s(&keep)]
            .map(String::from)
            .to_vec(),
    ];
    for argv in cases {
        std::fs::write(&keep, old).unwrap();
        let o = under_a_file_size_limit(&argv);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{argv:?}: {err}");
        assert!(
            !err.contains("panicked") && err.contains("keep.csv"),
            "{argv:?}: {err}"
        );
        assert_eq!(
            std::fs::read_to_string(&keep).unwrap(),
            old,
            "{argv:?}: the old file was changed"
        );
        assert_eq!(
            listing(d.path()),
            ["keep.csv"],
            "{argv:?}: a partial file was left"
        );
    }
    // Unlimited, the same runs replace the file whole.
    let o = mrfeel(&["mts", "--current", "1,2,3", "--cycles", "4", "--out", &s(&keep)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let csv = std::fs::read_to_string(&keep).unwrap();
    assert!(csv.len() > 16 * 512 && !csv.contains(old), "{} bytes", csv.len());
    assert_eq!(listing(d.path()), ["keep.csv"]);
}

/// `mts` options that give no usable record are refused before anything runs, naming the setting: a physics
/// rate below the sample rate (was raised to it without a word), a sample rate below the motion's Nyquist
/// rate (was a header-only CSV that `fit` refuses), a protocol of more samples than any test (a frequency of
/// 1e-9 Hz ran until the memory was full), a current beyond what a measurement file may hold (was a CSV
/// whose forces made the fit's figures `null`).
#[test]
fn mts_refuses_settings_that_give_no_usable_record() {
    let d = tempfile::tempdir().unwrap();
    let out = s(&d.path().join("m.csv"));
    let cases: [(&[&str], &[&str]); 6] = [
        (
            &["--physics-hz", "500"],
            &["physics_hz", "500 Hz is below the sample rate 1000 Hz"],
        ),
        (
            &["--frequency-hz", "200", "--sample-rate-hz", "100"],
            &[
                "sample_rate_hz",
                "100 Hz cannot record a motion of 200 Hz",
                "400 Hz",
            ],
        ),
        (&["--frequency-hz", "1e-9"], &["cycles", "samples", "1e7"]),
        (&["--cycles", "1e-6"], &["cycles", "give 0 samples"]),
        (&["--current", "2,1e300"], &["current", "1e300 A", "1e150"]),
        (
            &["--physics-hz", "1e7", "--frequency-hz", "0.001", "--cycles", "1"],
            &["physics_hz", "10000000000 integration steps", "1e9"],
        ),
    ];
    for (more, needles) in cases {
        let mut argv = vec!["mts", "--current", "2", "--out", &out];
        argv.extend_from_slice(more);
        // A later `--current` replaces the first.
        let o = mrfeel(&argv);
        refused(&o, needles);
        assert!(!Path::new(&out).exists(), "{more:?}: a file was written");
    }
}

/// A measured value beyond ±1e150 is refused at its line and column (the fit's squares overflowed and
/// it reported `null` figures with exit 0 and saved them); a test whose force is zero in every sample is
/// refused, naming the file and column (its NRMSE, relative to the rms force, read 6.9e149 in `fit`).
#[test]
fn a_force_no_instrument_reads_or_none_at_all_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(small_test()).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let header = lines.iter().position(|l| l.starts_with("t_s,")).unwrap();
    let with_force = |k: usize, f: &str| -> String {
        let mut out: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        for (j, l) in out.iter_mut().enumerate().skip(header + 1) {
            if k == usize::MAX || j == k {
                let mut fields: Vec<&str> = l.split(',').collect();
                *fields.last_mut().unwrap() = f;
                *l = fields.join(",");
            }
        }
        out.join("\n") + "\n"
    };
    let huge = d.path().join("huge.csv");
    std::fs::write(&huge, with_force(header + 10, "1e300")).unwrap();
    let zero = d.path().join("zero.csv");
    std::fs::write(&zero, with_force(usize::MAX, "0.0")).unwrap();
    let saved = d.path().join("p.json");
    let line = format!("huge.csv:{}", header + 11);
    refused(
        &mrfeel(&["fit", &s(&huge), "--save", &s(&saved)]),
        &[&line, "f_n", "1e300", "beyond ±1e150"],
    );
    for cmd in ["fit", "diagnose"] {
        refused(
            &mrfeel(&[cmd, &s(&zero)]),
            &["zero.csv", "`f_n` is zero in every one"],
        );
    }
    assert!(!saved.exists());
}

/// The files a command writes into its plot directory are outputs like any other: an input or another
/// output in it with a plot file's name, or a plot file there that links to an input, is refused before
/// the run (a measurement named `force_time.png`, a recording named like a plot, `mts --out mp/mts.svg
/// --plot mp` and a plot linked to the measurement were all overwritten, with exit 0).
#[test]
#[cfg(unix)]
fn nothing_read_or_written_may_sit_in_a_plot_directory_under_a_plot_name() {
    let d = tempfile::tempdir().unwrap();
    let pd = d.path().join("pd");
    std::fs::create_dir(&pd).unwrap();
    let as_png = pd.join("force_time.png");
    std::fs::copy(small_test(), &as_png).unwrap();
    let before = std::fs::read(&as_png).unwrap();
    refused(
        &mrfeel(&["fit", &s(&as_png), "--plot", &s(&pd)]),
        &["--plot", "the input measurement", "force_time.png"],
    );
    refused(
        &mrfeel(&[
            "fit",
            &small_test(),
            "--plot",
            &s(&pd),
            "--rerun",
            &s(&pd.join("x.png")),
        ]),
        &["--plot", "--rerun", "x.png"],
    );
    let mp = d.path().join("mp");
    refused(
        &mrfeel(&mts_args(&s(&mp.join("mts.svg")), &["--plot", &s(&mp)])),
        &["--plot", "--out", "mts.svg"],
    );
    let ld = d.path().join("ld");
    std::fs::create_dir(&ld).unwrap();
    let data = d.path().join("m.csv");
    std::fs::copy(small_test(), &data).unwrap();
    std::os::unix::fs::symlink(&data, ld.join("force_time.svg")).unwrap();
    refused(
        &mrfeel(&["fit", &s(&data), "--plot", &s(&ld)]),
        &["--plot", "force_time.svg", "m.csv"],
    );
    assert_eq!(std::fs::read(&as_png).unwrap(), before);
    assert_eq!(
        std::fs::read(&data).unwrap(),
        std::fs::read(small_test()).unwrap()
    );
    assert!(!mp.exists());
}

/// An output that is a stream, not a file (a named pipe here, `/dev/null` alike), is written to, not
/// replaced by a regular file: the reader gets the CSV and the pipe stays a pipe.
#[test]
#[cfg(target_os = "linux")]
fn an_output_that_is_a_pipe_is_written_not_replaced() {
    use std::os::unix::fs::FileTypeExt;
    let d = tempfile::tempdir().unwrap();
    let fifo = d.path().join("pipe.csv");
    let made = Command::new("mkfifo").arg(&fifo).status().expect("mkfifo runs");
    assert!(made.success());
    let reader = {
        let fifo = fifo.clone();
        std::thread::spawn(move || std::fs::read_to_string(fifo).unwrap())
    };
    let o = mrfeel(&mts_args(&s(&fifo), &[]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let got = reader.join().unwrap();
    assert!(
        got.contains("t_s,") && got.lines().count() > 100,
        "{} bytes",
        got.len()
    );
    assert!(std::fs::symlink_metadata(&fifo).unwrap().file_type().is_fifo());
}

/// `mrfeel` with `args` and `stdin` written to its standard input from a thread (errors writing are the
/// reader having stopped, as it should on a refused input).
#[cfg(unix)]
fn mrfeel_fed(args: &[&str], stdin: impl FnOnce(&mut dyn std::io::Write) + Send + 'static) -> Output {
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("mrfeel starts");
    let mut input = child.stdin.take().unwrap();
    let writer = std::thread::spawn(move || stdin(&mut input));
    let out = child.wait_with_output().expect("mrfeel ends");
    writer.join().unwrap();
    out
}

/// An input that is a device (`/dev/zero`) or a stream that never ends used to be read until the memory
/// ran out (10 GB in 6 s). A device is refused by name, a stream past the most any input of its kind can
/// be (64 MiB for a scenario) too, before anything is written.
#[test]
#[cfg(unix)]
fn an_input_that_is_a_device_or_an_endless_stream_is_refused_not_read_until_memory_runs_out() {
    let d = tempfile::tempdir().unwrap();
    let out = s(&d.path().join("o.csv"));
    for argv in [
        vec!["run", "/dev/zero", "--out", &out],
        vec!["daq-sweep", "/dev/zero"],
        vec!["compare", "/dev/zero"],
        vec!["fit", "/dev/zero"],
        vec!["validate", &small_test(), "--params", "/dev/zero"],
        vec!["mts", "--current", "1", "--out", &out, "--device", "/dev/zero"],
    ] {
        refused(&mrfeel(&argv), &["/dev/zero", "not a file but a device"]);
    }
    let endless = mrfeel_fed(&["run", "/dev/stdin", "--out", &out], |w| {
        let block = "# a comment\n".repeat(1 << 16);
        while w.write_all(block.as_bytes()).is_ok() {}
    });
    refused(&endless, &["/dev/stdin", "longer than 64 MiB"]);
    // A file says its length and is refused without being read (a sparse file: no disk used).
    let long = d.path().join("long.toml");
    std::fs::File::create(&long).unwrap().set_len(65 << 20).unwrap();
    refused(
        &mrfeel(&["run", &s(&long), "--out", &out]),
        &["long.toml", "longer than 64 MiB"],
    );
    assert!(!d.path().join("o.csv").exists());
}

/// A scenario given as a pipe (`cat s.toml | mrfeel run /dev/stdin`) is read once. It was read twice,
/// once to list the files no output may overwrite and once to run, and the second read found the pipe
/// empty: "missing field `name`" (or, from a named pipe, a wait for ever). Read once, it runs as the same
/// scenario from a file does, to the bit.
#[test]
#[cfg(unix)]
fn a_scenario_from_a_pipe_is_read_once_and_runs_as_from_its_file() {
    let d = tempfile::tempdir().unwrap();
    let text = paper_feel_loop_absolute().replace("duration_s = 12.0", "duration_s = 2.0");
    assert!(
        text.contains("duration_s = 2.0"),
        "the scenario's duration line moved"
    );
    let file = d.path().join("s.toml");
    std::fs::write(&file, &text).unwrap();
    let from_file = mrfeel(&["run", &s(&file), "--json"]);
    assert!(
        from_file.status.success(),
        "{}",
        String::from_utf8_lossy(&from_file.stderr)
    );
    let piped = mrfeel_fed(&["run", "/dev/stdin", "--json"], move |w| {
        let _ = w.write_all(text.as_bytes());
    });
    assert!(
        piped.status.success(),
        "{}",
        String::from_utf8_lossy(&piped.stderr)
    );
    assert_eq!(
        String::from_utf8_lossy(&piped.stdout),
        String::from_utf8_lossy(&from_file.stdout)
    );
}

/// TOML files: a value of the wrong type is named by its key (the parser's message names none), and a file
/// whose lines end in a bare carriage return, which TOML does not allow, says so (the message was empty).
#[test]
fn a_toml_value_of_the_wrong_type_is_named_and_bare_cr_line_endings_are_explained() {
    let d = tempfile::tempdir().unwrap();
    let text = paper_feel_loop_absolute();
    let typed = d.path().join("typed.toml");
    std::fs::write(&typed, text.replace("duration_s = 12.0", "duration_s = \"12\"")).unwrap();
    let line = text.lines().position(|l| l.starts_with("duration_s")).unwrap() + 1;
    refused(
        &mrfeel(&["run", &s(&typed)]),
        &[
            &format!("typed.toml:{line}: field `duration_s`: "),
            "expected f64",
        ],
    );
    let cr = d.path().join("cr.toml");
    std::fs::write(&cr, text.replace('\n', "\r")).unwrap();
    for argv in [vec!["run", &s(&cr)], vec!["compare", &s(&cr)]] {
        refused(
            &mrfeel(&argv),
            &["cr.toml:1: ", "bare carriage return", "LF or CRLF"],
        );
    }
    // The same file with CRLF endings is read as with LF.
    let crlf = d.path().join("crlf.toml");
    std::fs::write(
        &crlf,
        text.replace('\n', "\r\n")
            .replace("duration_s = 12.0", "duration_s = \"12\""),
    )
    .unwrap();
    refused(
        &mrfeel(&["run", &s(&crlf)]),
        &[&format!("crlf.toml:{line}: field `duration_s`: ")],
    );
}

/// A parameter file is JSON by its extension in any case (`P.JSON`), or read from a pipe by its text: both
/// were read as TOML and refused with "invalid key" at line 1. All three give the same figures.
#[test]
#[cfg(unix)]
fn a_params_file_from_a_pipe_or_named_in_capitals_is_read_as_json() {
    let d = tempfile::tempdir().unwrap();
    let params = d.path().join("p.json");
    let o = mrfeel(&["fit", &small_test(), "--save", &s(&params)]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let validate = |p: &str| mrfeel(&["validate", &small_test(), "--params", p, "--json"]);
    let named = validate(&s(&params));
    assert!(
        named.status.success(),
        "{}",
        String::from_utf8_lossy(&named.stderr)
    );
    let capitals = d.path().join("P.JSON");
    std::fs::copy(&params, &capitals).unwrap();
    let caps = validate(&s(&capitals));
    assert!(caps.status.success(), "{}", String::from_utf8_lossy(&caps.stderr));
    assert_eq!(caps.stdout, named.stdout);
    let text = std::fs::read(&params).unwrap();
    let piped = mrfeel_fed(
        &["validate", &small_test(), "--params", "/dev/stdin", "--json"],
        move |w| {
            let _ = w.write_all(&text);
        },
    );
    assert!(
        piped.status.success(),
        "{}",
        String::from_utf8_lossy(&piped.stderr)
    );
    assert_eq!(piped.stdout, named.stdout);
}

/// A comparison replaces its base scenario's faults with its own: a `[[fault]]` in the base was dropped
/// without a word (the results byte-identical to a base without it). It is now said, naming both files.
#[test]
fn compare_says_that_the_base_scenarios_faults_are_not_used() {
    let tree = scenario_tree();
    let base = tree.path().join("scenarios/paper-feel-loop.toml");
    let mut text = std::fs::read_to_string(&base).unwrap();
    text.push_str("\n[[fault]]\nkind = \"coil_open\"\nstart_s = 2.0\nend_s = 3.0\n");
    std::fs::write(&base, text).unwrap();
    let cmp = tree.path().join("scenarios/compare-feel.toml");
    let o = mrfeel(&["compare", &s(&cmp), "--feel", "mr", "--json"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("1 [[fault]] table(s)")
            && err.contains("paper-feel-loop.toml")
            && err.contains("not used"),
        "{err}"
    );
}

/// `daq-sweep` names the scenario's line when the scenario is no step test (`feel.law`) and when a rate is
/// beyond its physics rate (`rig.physics_hz`); both named no file or line, and the rate was reported
/// before the law that makes every rate moot.
#[test]
fn daq_sweep_errors_name_the_scenario_line() {
    let pfl = scenario("paper-feel-loop.toml");
    let text = std::fs::read_to_string(&pfl).unwrap();
    let law = text.lines().position(|l| l.starts_with("law = ")).unwrap() + 1;
    refused(
        &mrfeel(&["daq-sweep", &pfl, "--rates", "100000"]),
        &[&format!("paper-feel-loop.toml:{law}: `feel.law`"), "force-steps"],
    );
    let rt = scenario("response-time.toml");
    let text = std::fs::read_to_string(&rt).unwrap();
    let hz = text.lines().position(|l| l.starts_with("physics_hz")).unwrap() + 1;
    refused(
        &mrfeel(&["daq-sweep", &rt, "--rates", "100000"]),
        &[
            "--rates",
            "100000 Hz",
            &format!("response-time.toml:{hz}: `rig.physics_hz`"),
        ],
    );
}

/// A range message of a quantity without a unit ends at its bracket (it ended in a space).
#[test]
fn a_unitless_range_message_has_no_trailing_space() {
    let d = tempfile::tempdir().unwrap();
    let text = paper_feel_loop_absolute().replace("gain = 1.005", "gain = 9.0");
    let p = d.path().join("g.toml");
    std::fs::write(&p, text).unwrap();
    let e = refused(&mrfeel(&["run", &s(&p)]), &["`load_cell.gain`", "[0.5, 2]"]);
    assert!(e.trim_end_matches('\n').ends_with("[0.5, 2]"), "{e:?}");
}

/// The paper's feel-loop scenario with its model paths absolute, so that it runs from anywhere (a
/// temporary folder, a pipe).
fn paper_feel_loop_absolute() -> String {
    let models = s(&root().join("models"));
    std::fs::read_to_string(scenario("paper-feel-loop.toml"))
        .unwrap()
        .replace("\"../models/", &format!("\"{models}/"))
}

/// `[rig]` written as dotted keys at the top level (`rig.physics_hz = 1000.0`, valid TOML) was refused
/// with "expected a borrowed string"; it now runs as the table form does, to the bit, and an error in it
/// names the dotted key's line.
#[test]
fn a_rig_written_with_dotted_keys_runs_as_its_table() {
    let d = tempfile::tempdir().unwrap();
    let text = paper_feel_loop_absolute().replace("duration_s = 12.0", "duration_s = 2.0");
    let mut rig = Vec::new();
    let mut rest = Vec::new();
    let mut in_rig = false;
    for l in text.lines() {
        let t = l.trim();
        if t.starts_with('[') {
            in_rig = t == "[rig]";
            if in_rig {
                continue;
            }
        }
        if in_rig {
            if t.contains('=') && !t.starts_with('#') {
                rig.push(format!("rig.{t}"));
            }
        } else {
            rest.push(l.to_string());
        }
    }
    assert_eq!(rig.len(), 2, "the [rig] table changed: {rig:?}");
    let at = rest.iter().position(|l| l.starts_with("seed")).unwrap() + 1;
    rest.splice(at..at, rig);
    let dotted = rest.join("\n") + "\n";
    let (table_file, dotted_file) = (d.path().join("table.toml"), d.path().join("dotted.toml"));
    std::fs::write(&table_file, &text).unwrap();
    std::fs::write(&dotted_file, &dotted).unwrap();
    let run = |p: &Path| {
        let o = mrfeel(&["run", &s(p), "--json"]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        o.stdout
    };
    assert_eq!(run(&dotted_file), run(&table_file));
    let slow = d.path().join("slow.toml");
    let bad = dotted.replace("rig.physics_hz = 1000.0", "rig.physics_hz = 5.0");
    std::fs::write(&slow, &bad).unwrap();
    let line = bad.lines().position(|l| l.starts_with("rig.physics_hz")).unwrap() + 1;
    refused(
        &mrfeel(&["run", &s(&slow)]),
        &[
            &format!("slow.toml:{line}: field `rig.physics_hz`"),
            "[100, 100000]",
        ],
    );
}

/// `--spawn` streams to a viewer and writes no file, so a recording file asked for beside it is refused by
/// the argument parser (exit 2, both options named): nothing printed, no file written.
#[test]
fn run_refuses_a_recording_file_beside_a_spawned_viewer() {
    let d = tempfile::tempdir().expect("temp dir");
    let rrd = d.path().join("run.rrd");
    let o = mrfeel(&[
        "run",
        &scenario("paper-feel-loop.toml"),
        "--spawn",
        "--rerun",
        &s(&rrd),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("--spawn") && err.contains("--rerun"), "{err}");
    assert!(o.stdout.is_empty() && !rrd.exists(), "{err}");
}
