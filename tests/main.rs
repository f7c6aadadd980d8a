//! mrfeel's integration tests, one module per file beside this one, built as one test binary so that the
//! crate and its dependencies are linked once and all tests share one pool of threads.
//!
//! One file's tests: `cargo test --locked --test integration MODULE::` (e.g. `flight::`); one test:
//! `cargo test --locked --test integration flight::NAME -- --exact --nocapture`.

mod common;
mod diagnosis_check;

mod acquisition;
mod active_stick;
mod aero;
mod bad_input_cli;
mod bad_input_device;
mod bad_input_files;
mod controller_model;
mod custom_effect;
mod discovery;
mod docs;
mod f16;
mod feel;
mod flight;
mod flight_tracking;
mod foundation;
mod fuzz_parsers;
mod ident;
mod independent_truth;
mod install;
mod memory;
mod properties;
mod rig;
mod sim;
mod simulate;
mod spencer;
mod sweep;
mod trust;

/// Every test file beside this one is one of its modules: a file added without its `mod` line would
/// silently never run, since the package declares this binary alone (`autotests = false`).
#[test]
fn every_test_file_is_a_module_of_this_binary() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests");
    let main = std::fs::read_to_string(dir.join("main.rs")).unwrap();
    let mut missing = Vec::new();
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let Some(stem) = path.file_stem().and_then(|s| s.to_str()) else {
            continue;
        };
        let is_module = path.extension().is_some_and(|e| e == "rs") || path.join("mod.rs").exists();
        if is_module && stem != "main" && !main.lines().any(|l| l == format!("mod {stem};")) {
            missing.push(stem.to_string());
        }
    }
    assert!(
        missing.is_empty(),
        "test files not declared in tests/main.rs: {missing:?}"
    );
}
