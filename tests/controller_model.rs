//! The feel controller runs on a model of its own (issue 31): the plant the rig simulates and the model the
//! controller believes are apart, and the controller's feedforward follows only the latter.

mod common;

use std::path::{Path, PathBuf};

use mrfeel::device::{DeviceConfig, Registry};
use mrfeel::scenario::Scenario;
use mrfeel::sim::loop_study::Renderable;
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
/// A plant with pre-yield hysteresis the nominal controller does not know: the paper's damper with the
/// hidden truth `mrfeel mts` draws by default (Dahl shape; the elastic pre-yield displacement 1 % of the
/// 1 in. test amplitude, the viscous pre-yield velocity 20 % of the test's peak speed).
fn hysteresis_plant(dir: &Path) -> DeviceConfig {
    let text = std::fs::read_to_string(root().join("models/paper-device.toml"))
        .unwrap()
        .replacen("model = \"bingham\"", "model = \"bingham+hysteresis\"", 1)
        .replacen(
            "[params]\n",
            "[params]\nhyst_x_yield_m = 2.54e-4\nhyst_v_yield_m_s = 0.016\n",
            1,
        );
    let path = write(dir, "hysteresis-plant.toml", &text);
    DeviceConfig::load(&path, &Registry::builtin()).unwrap()
}

/// On the hysteresis plant, where the plant can render the desired force (`Renderable`: between its force
/// at 0 A and 90 % of its force at 14 A at the sample's speed, on its steady pre-yield branch), the
/// controller that believes `bingham+hysteresis` (observer on the sensor samples, inverse on the state
/// predicted one lag ahead) tracks as well as the paper's loop does on a plant without hysteresis (the
/// loop's floor, within 10 %). The hidden effect's error lies outside that band: at the slow stroke ends the
/// pre-yield branch gives `Fy·v/v_y`, below the feel's force at any current, so over all resisting samples
/// the error is several times the band's whatever the controller believes.
#[test]
fn the_hysteresis_aware_controller_tracks_at_the_loops_floor_where_the_plant_can_render_the_force() {
    let dir = tempfile::tempdir().unwrap();
    let scn = paper_scenario();
    let limit = scn.controller.gains.out_max;
    let paper = paper_device();
    let floor = run(&scn, &paper, &paper);
    let (_, e_floor, _) = Renderable::new(&paper, limit).unwrap().error(&floor);
    let plant = hysteresis_plant(dir.path());
    let band = Renderable::new(&plant, limit).unwrap();
    let nominal = run(&scn, &plant, &paper);
    let aware = run(&scn, &plant, &plant);
    let (n0, e0, r0) = band.error(&nominal);
    let (n1, e1, r1) = band.error(&aware);
    let (s0, s1) = (nominal.summary(), aware.summary());
    let resists = "the feel resists the sweep";
    let (a0, a1) = (
        s0.tracking_rmse_n.expect(resists),
        s1.tracking_rmse_n.expect(resists),
    );
    let (q0, q1) = (
        s0.tracking_nrmse.expect(resists),
        s1.tracking_nrmse.expect(resists),
    );
    eprintln!(
        "where renderable: floor (bingham plant and controller) {e_floor:.2} N; hysteresis plant, bingham \
         controller {e0:.2} N ({:.1} %, {n0} samples), bingham+hysteresis controller {e1:.2} N ({:.1} %, {n1} \
         samples): {:+.1} %; all resisting samples: {:.2} N ({:.1} %) -> {:.2} N ({:.1} %)",
        100.0 * r0,
        100.0 * r1,
        100.0 * (e1 / e0 - 1.0),
        a0,
        100.0 * q0,
        a1,
        100.0 * q1
    );
    // The band is most of the resisting motion: the figure is not a corner of the run.
    assert!(
        n0 > s0.resisting_samples / 2 && n1 > s1.resisting_samples / 2,
        "{n0} {n1}"
    );
    assert!(
        e1 <= 1.1 * e_floor,
        "floor {e_floor:.2} N, bingham+hysteresis {e1:.2} N"
    );
    assert!(
        a0 > 3.0 * e0 && a1 > 3.0 * e1,
        "all {a0:.2} / {a1:.2} N, band {e0:.2} / {e1:.2} N"
    );
}
