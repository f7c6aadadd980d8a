//! The repository and the binary stand alone: a clone of the repository with nothing beside it runs the
//! main job, and a copy of the binary runs from any folder, with the models it ships built in.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// `bin` run in `dir` with no variable that could lead it to the source tree or a data folder.
fn run_in(bin: &Path, dir: &Path, args: &[&str]) -> Output {
    Command::new(bin)
        .args(args)
        .current_dir(dir)
        .env_remove("CARGO_MANIFEST_DIR")
        .env_remove("MRFEEL_DATA")
        .env_remove("MRFEEL_PYTHON")
        .output()
        .expect("the mrfeel binary runs")
}

/// Largest |force| of a measurement CSV's rows whose current column is `current_a`.
fn peak_force_at(csv: &Path, current_a: f64) -> f64 {
    let mut r = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .from_path(csv)
        .unwrap();
    let h = r.headers().unwrap().clone();
    let col = |n: &str| {
        h.iter()
            .position(|c| c == n)
            .unwrap_or_else(|| panic!("no {n} in {h:?}"))
    };
    let (f, i) = (col("f_n"), col("i_a"));
    r.records()
        .map(|row| row.unwrap())
        .filter(|row| (row[i].parse::<f64>().unwrap() - current_a).abs() < 0.05)
        .map(|row| row[f].parse::<f64>().unwrap().abs())
        .fold(0.0, f64::max)
}

/// A clone of the repository's committed tree into an empty folder (no data folder or anything else beside
/// it) runs the main job's quickest steps with the built binary: the paper's MTS test and feel loop, and a
/// fit of the real damper tests it carries.
#[test]
fn a_bare_clone_runs_the_main_job() {
    let tmp = tempfile::tempdir().unwrap();
    let clone = tmp.path().join("mrfeel");
    let git = Command::new("git")
        .args(["clone", "--quiet", "--no-hardlinks"])
        .arg(root())
        .arg(&clone)
        .output()
        .expect("git runs");
    assert!(git.status.success(), "{}", text(&git));
    let bin = env!("CARGO_BIN_EXE_mrfeel");
    let job = Command::new("bash")
        .arg(clone.join("scripts/main-job.sh"))
        .arg("out")
        .env("MRFEEL_BIN", bin)
        .env("MRFEEL_STEPS", "1 2")
        .output()
        .unwrap();
    assert!(job.status.success(), "{}", text(&job));
    let out = clone.join("out");
    for f in ["mts/paper-mts.csv", "paper-feel-loop.csv", "paper-feel-loop.rrd"] {
        assert!(out.join(f).is_file(), "{f} missing:\n{}", text(&job));
    }
    // The paper's Section 4 forces: about 10, 25 and 70 N at 2.2, 5 and 14 A (within 15 %: the sine's
    // viscous share and the load cell's noise ride on the yield force).
    for (i, paper) in [(2.2, 10.0), (5.0, 25.0), (14.0, 70.0)] {
        let f = peak_force_at(&out.join("mts/paper-mts.csv"), i);
        assert!(
            (f - paper).abs() < 0.15 * paper,
            "{i} A: {f} N against the paper's {paper} N"
        );
    }
    // The real damper's tests are in the clone: Bingham fitted on them explains most of the force.
    let fit = run_in(
        Path::new(bin),
        &clone,
        &["fit", "data/utfsm-mr-damper", "--model", "bingham", "--json"],
    );
    assert!(fit.status.success(), "{}", text(&fit));
    let v: serde_json::Value = serde_json::from_slice(&fit.stdout).unwrap();
    let files = v["files"].as_array().map(Vec::len).unwrap_or(0);
    assert_eq!(files, 15, "{v}");
    let nrmse = v["nrmse"].as_f64().unwrap();
    assert!(nrmse > 0.0 && nrmse < 0.25, "NRMSE {nrmse}");
}

/// A scenario that names `../models/…` files, copied into a folder where they are not, with a copy of the
/// binary and no source tree in reach, runs on the built-in files of those names and gives the very bytes
/// of the same scenario naming the repository's files; `--data-dir` takes precedence over the built-in
/// files; a file that is nowhere is an error at the scenario's line that says how to fix it.
#[test]
fn a_copied_binary_runs_a_copied_scenario_anywhere() {
    let tmp = tempfile::tempdir().unwrap();
    let bin = tmp.path().join("bin/mrfeel");
    std::fs::create_dir_all(bin.parent().unwrap()).unwrap();
    std::fs::copy(env!("CARGO_BIN_EXE_mrfeel"), &bin).unwrap();
    let work = tmp.path().join("work");
    std::fs::create_dir_all(&work).unwrap();
    let original = std::fs::read_to_string(root().join("scenarios/paper-feel-loop.toml")).unwrap();
    let short = original.replace("duration_s = 12.0", "duration_s = 1.0");
    assert_ne!(short, original);
    std::fs::write(work.join("copied.toml"), &short).unwrap();
    // The same scenario naming the repository's files by absolute paths.
    let models = root().join("models");
    let absolute = short.replace("../models", models.to_str().unwrap());
    std::fs::write(work.join("absolute.toml"), &absolute).unwrap();

    let copied = run_in(&bin, &work, &["run", "copied.toml", "--out", "copied.csv"]);
    assert!(copied.status.success(), "{}", text(&copied));
    assert!(
        text(&copied).contains("using the built-in <built-in>/models/stick-rig.urdf"),
        "{}",
        text(&copied)
    );
    let absolute = run_in(&bin, &work, &["run", "absolute.toml", "--out", "absolute.csv"]);
    assert!(absolute.status.success(), "{}", text(&absolute));
    let read = |f: &str| std::fs::read(work.join(f)).unwrap();
    assert!(read("copied.csv").len() > 1000);
    assert_eq!(
        read("copied.csv"),
        read("absolute.csv"),
        "built-in files differ from the repository's"
    );

    // A data folder's device (twice the yield force per ampere) is taken before the built-in one.
    let data = tmp.path().join("data");
    std::fs::create_dir_all(data.join("models")).unwrap();
    let device = std::fs::read_to_string(models.join("paper-device.toml")).unwrap();
    let gain_line = device
        .lines()
        .find(|l| l.starts_with("fc_gain_n_per_a"))
        .expect("the device has a yield-force gain");
    let gain: f64 = gain_line
        .split('=')
        .nth(1)
        .unwrap()
        .split('#')
        .next()
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    let stronger = device.replace(gain_line, &format!("fc_gain_n_per_a = {}", 2.0 * gain));
    std::fs::write(data.join("models/paper-device.toml"), stronger).unwrap();
    let from_data = run_in(
        &bin,
        &work,
        &[
            "--data-dir",
            data.to_str().unwrap(),
            "run",
            "copied.toml",
            "--out",
            "data.csv",
        ],
    );
    assert!(from_data.status.success(), "{}", text(&from_data));
    assert_ne!(
        read("data.csv"),
        read("copied.csv"),
        "--data-dir's device was not used"
    );

    // A device no folder has: refused at its line, naming the key and how to fix it.
    std::fs::write(
        work.join("missing.toml"),
        short.replace("../models/paper-device.toml", "../models/my-device.toml"),
    )
    .unwrap();
    let line = short
        .lines()
        .position(|l| l.contains("paper-device.toml"))
        .unwrap()
        + 1;
    let missing = run_in(&bin, &work, &["run", "missing.toml", "--out", "m.csv"]);
    let msg = text(&missing);
    assert_eq!(missing.status.code(), Some(1), "{msg}");
    for needle in [
        format!("missing.toml:{line}: field `device.file`"),
        "my-device.toml".into(),
        "--data-dir".into(),
        "paper-device.toml".into(),
    ] {
        assert!(msg.contains(&needle), "{needle} not in: {msg}");
    }
    assert!(!work.join("m.csv").exists());
}

/// `scenarios/paper-fine-corrections.toml` ships in the binary: copied into a folder with a copy of the
/// binary and no source tree in reach it runs on the built-in models, and the built-in copy
/// (`<built-in>/scenarios/paper-fine-corrections.toml`) runs from the same folder to the same bytes, as
/// does its bare file name from an empty folder (saying that it uses the built-in file).
#[test]
fn the_fine_corrections_scenario_runs_anywhere_and_is_built_in() {
    let tmp = tempfile::tempdir().unwrap();
    let bin = tmp.path().join("mrfeel");
    std::fs::copy(env!("CARGO_BIN_EXE_mrfeel"), &bin).unwrap();
    let original = std::fs::read_to_string(root().join("scenarios/paper-fine-corrections.toml")).unwrap();
    std::fs::write(tmp.path().join("paper-fine-corrections.toml"), &original).unwrap();
    let copied = run_in(
        &bin,
        tmp.path(),
        &["run", "paper-fine-corrections.toml", "--out", "copied.csv"],
    );
    assert!(copied.status.success(), "{}", text(&copied));
    let built_in = run_in(
        &bin,
        tmp.path(),
        &[
            "run",
            "<built-in>/scenarios/paper-fine-corrections.toml",
            "--out",
            "built-in.csv",
        ],
    );
    assert!(built_in.status.success(), "{}", text(&built_in));
    let read = |f: &str| std::fs::read(tmp.path().join(f)).unwrap();
    // 10 s at 1 kHz.
    let rows = read("copied.csv").split(|&b| b == b'\n').count();
    assert!(rows > 10_000, "{rows} lines");
    assert_eq!(read("copied.csv"), read("built-in.csv"));
    let empty = tmp.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let bare = run_in(
        &bin,
        &empty,
        &["run", "paper-fine-corrections.toml", "--out", "../bare.csv"],
    );
    assert!(bare.status.success(), "{}", text(&bare));
    assert!(
        text(&bare).contains("using the built-in <built-in>/scenarios/paper-fine-corrections.toml"),
        "{}",
        text(&bare)
    );
    assert_eq!(read("bare.csv"), read("built-in.csv"));
}

/// An aircraft named in a copied scenario is flown from the built-in model, from any folder.
#[test]
fn a_copied_flight_scenario_flies_the_built_in_aircraft() {
    let tmp = tempfile::tempdir().unwrap();
    let bin: PathBuf = tmp.path().join("mrfeel");
    std::fs::copy(env!("CARGO_BIN_EXE_mrfeel"), &bin).unwrap();
    let original = std::fs::read_to_string(root().join("scenarios/c172p-pitch-tracking.toml")).unwrap();
    let at = original.lines().find(|l| l.starts_with("duration_s")).unwrap();
    std::fs::write(
        tmp.path().join("fly.toml"),
        original.replace(at, "duration_s = 2.0"),
    )
    .unwrap();
    let o = run_in(
        &bin,
        tmp.path(),
        &["run", "fly.toml", "--out", "fly.csv", "--json"],
    );
    assert!(o.status.success(), "{}", text(&o));
    let csv = std::fs::read_to_string(tmp.path().join("fly.csv")).unwrap();
    let header = csv.lines().find(|l| !l.starts_with('#')).unwrap();
    assert!(header.contains("nz_g"), "{header}");
}

/// The binary holds no path to the repository's model, data or Python files: what it ships is built in.
#[test]
fn the_binary_names_no_file_of_the_source_tree() {
    let bytes = std::fs::read(env!("CARGO_BIN_EXE_mrfeel")).unwrap();
    for dir in ["models", "scenarios", "python", ".venv", "data"] {
        let p = root().join(dir);
        let needle = p.to_str().unwrap().as_bytes();
        assert!(
            !bytes.windows(needle.len()).any(|w| w == needle),
            "the binary contains {}",
            p.display()
        );
    }
}

/// `run --plot DIR` draws the run, and shades the windows where a fault was active (named `fault` in the
/// legend) only when the scenario has one.
#[test]
fn run_plot_draws_the_run_with_its_fault_windows() {
    let tmp = tempfile::tempdir().unwrap();
    let original = std::fs::read_to_string(root().join("scenarios/paper-feel-loop.toml")).unwrap();
    let short = original
        .replace("duration_s = 12.0", "duration_s = 1.0")
        .replace("../models", root().join("models").to_str().unwrap());
    let faulty = format!("{short}\n[[fault]]\nkind = \"coil_open\"\nstart_s = 0.3\nend_s = 0.6\n");
    std::fs::write(tmp.path().join("clean.toml"), &short).unwrap();
    std::fs::write(tmp.path().join("faulty.toml"), &faulty).unwrap();
    let bin = Path::new(env!("CARGO_BIN_EXE_mrfeel"));
    for (scn, dir, fault) in [("clean.toml", "clean", false), ("faulty.toml", "faulty", true)] {
        let o = run_in(bin, tmp.path(), &["run", scn, "--plot", dir]);
        assert!(o.status.success(), "{}", text(&o));
        let png = std::fs::read(tmp.path().join(dir).join("run.png")).unwrap();
        assert!(
            png.starts_with(b"\x89PNG") && png.len() > 10_000,
            "{dir}: {} bytes",
            png.len()
        );
        let svg = std::fs::read_to_string(tmp.path().join(dir).join("run.svg")).unwrap();
        for label in [
            "desired",
            "load cell",
            "damper",
            "command",
            "stick angle",
            "pilot",
        ] {
            assert!(svg.contains(label), "{dir}: no `{label}` in the plot");
        }
        // The SVG writer puts a text element's content on a line of its own.
        let legend = svg.lines().any(|l| l.trim() == "fault");
        assert_eq!(legend, fault, "{dir}: fault legend");
    }
}
