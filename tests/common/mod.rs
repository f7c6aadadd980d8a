//! Helpers shared by the integration tests (each test file includes this module).

// Each test file uses a part of these helpers.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

/// The repository's Python (made by the test command with rerun-sdk and jsbsim); panics with how to make
/// it when it is missing.
pub fn venv_python() -> PathBuf {
    let py = Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv/bin/python");
    assert!(
        py.exists(),
        "{} is missing: run the test command `./scripts/test-all.sh`, which creates the Python environment \
         first, or `scripts/python-env.sh` before `cargo test`",
        py.display()
    );
    py
}

/// Read a Rerun recording back with the Rerun SDK of the same version (`tests/rerun_readback.py`) and check
/// it against the run's CSV: whether the check passed, and what the script printed.
pub fn rerun_readback(rrd: &Path, csv: &Path) -> (bool, String) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let out = std::process::Command::new(venv_python())
        .arg(root.join("tests/rerun_readback.py"))
        .arg(rrd)
        .arg(csv)
        .output()
        .unwrap_or_else(|e| panic!("running tests/rerun_readback.py: {e}"));
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

/// Write a run's CSV and its Rerun recording (as `mrfeel run --out --rerun` does) into a temporary folder
/// and read the recording back against the CSV ([`rerun_readback`]).
#[cfg(feature = "rerun")]
pub fn record_and_read_back(res: &mrfeel::sim::Results) -> (bool, String) {
    let dir = tempfile::tempdir().unwrap();
    let (csv, rrd) = (dir.path().join("run.csv"), dir.path().join("run.rrd"));
    res.write_csv(std::fs::File::create(&csv).unwrap()).unwrap();
    {
        let rec = mrfeel::viz::rerun_rig::to_file(&rrd).unwrap();
        mrfeel::sim::log_rerun(&rec, res).unwrap();
    }
    rerun_readback(&rrd, &csv)
}

/// Run the `mrfeel` binary with `args` to the end; its exit status, stdout and stderr.
pub fn mrfeel<S: AsRef<std::ffi::OsStr>>(args: &[S]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args(args)
        .output()
        .expect("the mrfeel binary runs")
}

/// A path as a command-line argument (the tests' paths are UTF-8).
pub fn s(p: &Path) -> String {
    p.to_str().expect("utf-8 path").to_string()
}

/// The stderr of a run that must have succeeded; its stderr in the panic message when it did not.
pub fn ok(o: &std::process::Output) -> String {
    let err = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{err}");
    err
}
