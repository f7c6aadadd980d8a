//! The feel controller runs on a model of its own (issue 31): the plant the rig simulates and the model the
//! controller believes are apart, and the controller's feedforward follows only the latter.

mod common;

use std::path::{Path, PathBuf};

use mrfeel::device::{DeviceConfig, Registry};
use mrfeel::scenario::Scenario;
use mrfeel::sim::{self, Devices, Results, RunOptions};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn paper_device() -> DeviceConfig {
    DeviceConfig::load(&root().join("models/paper-device.toml"), &Registry::builtin()).unwrap()
}

fn paper_scenario() -> Scenario {
    Scenario::load(&root().join("scenarios/paper-feel-loop.toml")).unwrap()
}

fn run(scn: &Scenario, plant: &DeviceConfig, controller: &DeviceConfig) -> Results {
    let devices = Devices {
        plant: plant.clone(),
        controller: controller.clone(),
        controller_is_plant: false,
    };
    let rig = sim::build_rig(scn, plant).unwrap();
    sim::run(scn, &devices, rig, RunOptions::default(), |_| {}).unwrap()
}

/// The controller reads only its own model: told the yield force per ampere is 1.6× the plant's, it
/// commands too little current and the load cell falls short of the feel, which it does not when told
/// the truth.
#[test]
fn a_wrong_controller_model_raises_the_force_error() {
    let scn = paper_scenario();
    let plant = paper_device();
    let right = run(&scn, &plant, &plant).summary();
    let figures = |s: &mrfeel::sim::Summary| {
        (
            s.tracking_rmse_n.expect("the feel resists the sweep"),
            s.tracking_nrmse.expect("the feel resists the sweep"),
        )
    };
    let mut wrong = plant.clone();
    let k = wrong.model.param_index("fc_gain_n_per_a").unwrap();
    wrong.params[k] *= 1.6;
    let wrong = run(&scn, &plant, &wrong).summary();
    let (right, wrong) = (figures(&right), figures(&wrong));
    eprintln!(
        "right {:.2} N ({:.1} %), wrong gain {:.2} N ({:.1} %)",
        right.0,
        100.0 * right.1,
        wrong.0,
        100.0 * wrong.1
    );
    assert!(
        wrong.0 > 1.3 * right.0,
        "wrong {:.2} N, right {:.2} N",
        wrong.0,
        right.0
    );
}

/// Without `[controller] model` the controller believes the plant's file, and the summary says so; with
/// the plant's own file named as the model, the run is the same to the bit.
#[test]
fn without_a_controller_model_the_plants_file_is_used_and_the_summary_says_so() {
    let scn = paper_scenario();
    let devices = Devices::load(&scn).unwrap();
    assert!(devices.controller_is_plant);
    let rig = sim::build_rig(&scn, &devices.plant).unwrap();
    let own = sim::run(&scn, &devices, rig, RunOptions::default(), |_| {}).unwrap();
    let s = own.summary();
    assert!(
        s.controller_model.contains("paper-device.toml") && s.controller_model.contains("the plant's file"),
        "{}",
        s.controller_model
    );
    let named = run(&scn, &devices.plant, &paper_device());
    let same = own
        .rows
        .iter()
        .zip(&named.rows)
        .all(|(a, b)| a.current_a.to_bits() == b.current_a.to_bits());
    assert!(same && own.rows.len() == named.rows.len());
}

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// A scenario whose `[controller] model` names a file the device code refuses is refused at load, naming
/// the scenario's line and key and the model file's line and field: an effect it does not know, or a file
/// of another kind (a scenario).
#[test]
fn a_controller_model_with_an_unknown_effect_or_of_the_wrong_kind_is_refused_with_file_line_field() {
    let dir = tempfile::tempdir().unwrap();
    let scn_text = std::fs::read_to_string(root().join("scenarios/paper-feel-loop.toml"))
        .unwrap()
        .replace("../models/", &format!("{}/models/", root().display()));
    let device_text = std::fs::read_to_string(root().join("models/paper-device.toml")).unwrap();
    let bad_effect = write(
        dir.path(),
        "ctl.toml",
        &device_text.replacen("model = \"bingham\"", "model = \"bingham+backlash\"", 1),
    );
    assert!(std::fs::read_to_string(&bad_effect)
        .unwrap()
        .contains("bingham+backlash"));
    let wrong_kind = write(dir.path(), "ctl-scenario.toml", &scn_text);
    for (model, file_line_field) in [
        (
            &bad_effect,
            format!(
                "ctl.toml:{}: field `model`",
                device_text.lines().position(|l| l.starts_with("model")).unwrap() + 1
            ),
        ),
        (&wrong_kind, "ctl-scenario.toml:".to_string()),
    ] {
        let text = scn_text.replacen(
            "[controller]\n",
            &format!("[controller]\nmodel = \"{}\"\n", model.display()),
            1,
        );
        let scn_path = write(dir.path(), "scn.toml", &text);
        let line = text.lines().position(|l| l.starts_with("model = ")).unwrap() + 1;
        let out = common::mrfeel(&[std::ffi::OsStr::new("run"), scn_path.as_os_str()]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{err}");
        assert!(
            err.contains(&format!("scn.toml:{line}: `controller.model`")) && err.contains(&file_line_field),
            "{err}"
        );
    }
}
