//! Fuzzing of every input format's one loader, on stable Rust within the test command: each shipped file
//! of a format is mutated byte-wise by proptest (bytes flipped, inserted, deleted, lines doubled, tokens a
//! parser finds hard put in: `nan`, `1e400`, quotes, brackets, NUL, escape codes, bare carriage returns),
//! written to a file and loaded. No load panics or takes more than a few seconds, and every refusal names
//! the file and a line in it.
//!
//! 48 cases per format in the test command; `-- --ignored` runs 2000 per format. `MRFEEL_FUZZ_CASES` and
//! `MRFEEL_FUZZ_SEED` (default fixed) set the count and vary the search.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestCaseError, TestRng, TestRunner};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Longest a load of a file of a few kilobytes may take (debug build, a busy machine).
const HANG: Duration = Duration::from_secs(10);

/// Tokens that parsers of numbers, strings, tables and lines find hard.
const TOKENS: [&str; 24] = [
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e400",
    "1e-400",
    "-0",
    "5e-324",
    "1e308",
    "99999999999999999999",
    "\"",
    "'",
    "[",
    "]]",
    "=",
    "\n",
    "\r",
    "\0",
    "\u{1b}[2J",
    "\u{feff}",
    ",",
    "<",
    "/>",
    "é",
];

/// One edit of a file's bytes, at a fraction of its length.
#[derive(Debug, Clone)]
enum Edit {
    Flip(f64, u8),
    Insert(f64, Vec<u8>),
    Token(f64, usize),
    Delete(f64, usize),
    DoubleLine(f64),
}

fn edit() -> impl Strategy<Value = Edit> {
    prop_oneof![
        (0.0..1.0f64, any::<u8>()).prop_map(|(at, b)| Edit::Flip(at, b)),
        (0.0..1.0f64, proptest::collection::vec(any::<u8>(), 1..8)).prop_map(|(at, b)| Edit::Insert(at, b)),
        (0.0..1.0f64, 0..TOKENS.len()).prop_map(|(at, k)| Edit::Token(at, k)),
        (0.0..1.0f64, 1..40usize).prop_map(|(at, n)| Edit::Delete(at, n)),
        (0.0..1.0f64).prop_map(Edit::DoubleLine),
    ]
}

fn apply(bytes: &[u8], edits: &[Edit]) -> Vec<u8> {
    let mut b = bytes.to_vec();
    for e in edits {
        let at = |f: f64, len: usize| ((f * len as f64) as usize).min(len);
        match e {
            Edit::Flip(f, x) => {
                if !b.is_empty() {
                    let k = at(*f, b.len() - 1);
                    b[k] ^= x | 1;
                }
            }
            Edit::Insert(f, x) => {
                let k = at(*f, b.len());
                b.splice(k..k, x.iter().copied());
            }
            Edit::Token(f, t) => {
                let k = at(*f, b.len());
                b.splice(k..k, TOKENS[*t].bytes());
            }
            Edit::Delete(f, n) => {
                let k = at(*f, b.len());
                let end = (k + n).min(b.len());
                b.drain(k..end);
            }
            Edit::DoubleLine(f) => {
                let k = at(*f, b.len());
                let start = b[..k].iter().rposition(|&c| c == b'\n').map_or(0, |p| p + 1);
                let end = b[k..]
                    .iter()
                    .position(|&c| c == b'\n')
                    .map_or(b.len(), |p| k + p + 1);
                let line = b[start..end].to_vec();
                b.splice(end..end, line);
            }
        }
    }
    b
}

/// Whether `msg` names the file `name` and a line of it: `name:LINE`, or `name: line LINE` (as the
/// text reader places a byte that is not UTF-8).
fn names_file_and_line(msg: &str, name: &str) -> bool {
    msg.match_indices(&format!("{name}:")).any(|(k, m)| {
        let rest = msg[k + m.len()..]
            .strip_prefix(" line ")
            .unwrap_or(&msg[k + m.len()..]);
        rest.chars().next().is_some_and(|c| c.is_ascii_digit())
    })
}

/// A loader of one format: loads the file at the path, its error as text.
type Loader = fn(&Path) -> Result<(), String>;

/// Fuzz one format with `cases` mutations: `file` (relative paths in it made absolute, so that the files it names are found)
/// mutated and loaded by `load` as `name` in a temporary folder. `whole_file` lists refusals of the file as
/// a whole that have no line to name (an empty file), as fragments of their message.
fn fuzz(cases: u32, file: &str, name: &str, load: Loader, whole_file: &[&str]) {
    let seed: u64 = std::env::var("MRFEEL_FUZZ_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(30);
    let path = root().join(file);
    let dir_of = path.parent().unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    // `"../models/x"` → the absolute path, so that the mutated copy elsewhere names the same files.
    let text = text.replace("\"../", &format!("\"{}/", dir_of.parent().unwrap().display()));
    let original = text.into_bytes();
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join(name);
    std::fs::write(&target, &original).unwrap();
    load(&target).unwrap_or_else(|e| panic!("the unmutated {file} does not load: {e}"));

    let mut seed_bytes = [0u8; 32];
    seed_bytes[..8].copy_from_slice(&seed.to_le_bytes());
    let config = Config {
        cases,
        failure_persistence: None,
        ..Config::default()
    };
    let mut runner = TestRunner::new_with_rng(config, TestRng::from_seed(RngAlgorithm::ChaCha, &seed_bytes));
    let result = runner.run(&proptest::collection::vec(edit(), 1..5), |edits| {
        let bytes = apply(&original, &edits);
        std::fs::write(&target, &bytes).unwrap();
        let t0 = Instant::now();
        let outcome = std::panic::catch_unwind(|| load(&target));
        let took = t0.elapsed();
        prop_assert!(took < HANG, "the load took {took:?}");
        match outcome {
            Err(_) => Err(TestCaseError::fail("the loader panicked")),
            Ok(Ok(())) => Ok(()),
            Ok(Err(msg)) => {
                let whole = whole_file.iter().any(|w| msg.contains(w)) && msg.contains(name);
                prop_assert!(
                    whole || names_file_and_line(&msg, name),
                    "the refusal does not name {name}:LINE: {msg}"
                );
                Ok(())
            }
        }
    });
    if let Err(e) = result {
        panic!("{file} ({cases} cases, MRFEEL_FUZZ_SEED={seed}): {e}");
    }
}

fn measurement_csv(cases: u32) {
    fuzz(
        cases,
        "data/utfsm-mr-damper/2mm5Hz_0p50A.csv",
        "m.csv",
        |p| {
            let m = mrfeel::measurement::Measurement::read(p).map_err(|e| e.to_string())?;
            // What every command asks of a test before it uses it.
            m.require_samples(8, "a fit").map_err(|e| e.to_string())
        },
        &["empty file", "samples, fewer than"],
    );
}

fn scenario_toml(cases: u32) {
    fuzz(
        cases,
        "scenarios/paper-feel-loop.toml",
        "s.toml",
        |p| {
            mrfeel::scenario::Scenario::load(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn flight_scenario_toml(cases: u32) {
    fuzz(
        cases,
        "scenarios/c172p-pitch-tracking.toml",
        "f.toml",
        |p| {
            mrfeel::scenario::Scenario::load(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn compare_toml(cases: u32) {
    fuzz(
        cases,
        "scenarios/compare-feel.toml",
        "c.toml",
        |p| {
            mrfeel::compare::CompareScenario::load(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn device_toml(cases: u32) {
    fuzz(
        cases,
        "models/paper-device.toml",
        "d.toml",
        |p| {
            mrfeel::device::DeviceConfig::load(p, &mrfeel::device::Registry::builtin())
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn params_json(cases: u32) {
    let d = tempfile::tempdir().unwrap();
    let params = d.path().join("params.json");
    let model = mrfeel::device::Model::from_spec(
        "bingham+hysteresis",
        &mrfeel::device::Registry::builtin(),
        mrfeel::device::PAPER_CURRENT_LIMIT_A,
    )
    .unwrap();
    let p: Vec<f64> = model
        .param_specs()
        .iter()
        .map(|s| 0.5 * (s.lower + s.upper.min(1e3)))
        .collect();
    mrfeel::device::ParamsFile::new(&model, &p, None)
        .write(&params)
        .unwrap();
    // An absolute path: `root().join` of it is itself.
    fuzz(
        cases,
        params.to_str().unwrap(),
        "p.json",
        |p| {
            mrfeel::device::DeviceConfig::load(p, &mrfeel::device::Registry::builtin())
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn effect_toml(cases: u32) {
    // The effect file of docs/spec/model-discovery.md: a formula with a low-pass state and two parameters.
    let d = tempfile::tempdir().unwrap();
    let effect = d.path().join("drag.toml");
    std::fs::write(
        &effect,
        "name = \"drag\"\ndescribe = \"turbulent orifice flow\"\nresembles = \"quadratic damping\"\n\
         formula = \"drag_c1 * v*abs(v) + drag_c2 * lp(v, 0.02)\"\n\n\
         [params.drag_c1]\nunit = \"N s^2/m^2\"\nlower = -1e6\nupper = 1e6\nguess = 310.0\n\
         doc = \"coefficient of v*abs(v)\"\n\n\
         [params.drag_c2]\nunit = \"N s/m\"\nlower = -1e4\nupper = 1e4\n",
    )
    .unwrap();
    fuzz(
        cases,
        effect.to_str().unwrap(),
        "e.toml",
        |p| {
            mrfeel::device::formula::FormulaEffect::load(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn pilot_hand_toml(cases: u32) {
    fuzz(
        cases,
        "models/pilot-hand.toml",
        "h.toml",
        |p| {
            mrfeel::scenario::load_hand(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn feel_springs_toml(cases: u32) {
    fuzz(
        cases,
        "models/feel-springs.toml",
        "sp.toml",
        |p| {
            mrfeel::control::feel::FeelSprings::load(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn aircraft_toml(cases: u32) {
    fuzz(
        cases,
        "models/aircraft/c172p.toml",
        "a.toml",
        |p| {
            mrfeel::aero::AircraftModel::load(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn jsbsim_reference_csv(cases: u32) {
    fuzz(
        cases,
        "scenarios/jsbsim/c172p_doublet.csv",
        "r.csv",
        |p| {
            mrfeel::input::reference::ReferenceRun::load(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

fn urdf(cases: u32) {
    fuzz(
        cases,
        "models/stick-rig.urdf",
        "r.urdf",
        |p| {
            mrfeel::input::urdf::UrdfModel::load(p)
                .map(drop)
                .map_err(|e| format!("{e:#}"))
        },
        &[],
    );
}

/// Every format's loader, each with `cases` mutations.
const FORMATS: [fn(u32); 12] = [
    measurement_csv,
    scenario_toml,
    flight_scenario_toml,
    compare_toml,
    device_toml,
    params_json,
    effect_toml,
    pilot_hand_toml,
    feel_springs_toml,
    aircraft_toml,
    jsbsim_reference_csv,
    urdf,
];

/// Cases of each format: `MRFEEL_FUZZ_CASES`, else `default`.
fn cases(default: u32) -> u32 {
    std::env::var("MRFEEL_FUZZ_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Every format, 48 mutations each (about 2 s in all in the test profile).
#[test]
fn every_format_refuses_mutated_files_at_a_line_without_panic_or_hang() {
    for f in FORMATS {
        f(cases(48));
    }
}

/// The larger seeded sweep: 2000 mutations of each format.
#[test]
#[ignore = "a larger sweep: cargo test --test integration fuzz_parsers:: -- --ignored"]
fn every_format_larger_sweep() {
    for f in FORMATS {
        f(cases(2000));
    }
}
