//! Model discovery end to end: fits recover known parameters, diagnosis names exactly the effects hidden in
//! synthetic data (each effect alone, none, pairs; several protocols, sample rates, measured or derived
//! velocity), a user's own effect is diagnosed like the built-in ones, and the CLI keeps its contract.

use crate::common;
use common::mrfeel;

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use mrfeel::device::{DataStats, Effect, EffectStage, Inputs, Model, ModelSpec, ParamSpec, Registry, Stage};
use mrfeel::ident::fit::{all_spans, fit, FitOptions};
use mrfeel::ident::{data_stats, diagnose, DiagnoseOptions, Test};
use mrfeel::measurement::{smooth_derivative, Measurement};

use crate::diagnosis_check;

/// The paper's device (models/paper-device.toml values, with some friction and damping so that every
/// base term is visible): fc0, fc_gain, c0, Te, Tm.
const PAPER_BASE: [f64; 5] = [2.0, 4.83, 60.0, 0.015, 0.008];
const LIMIT_A: f64 = 14.0;

#[derive(Clone, Copy, Debug)]
enum Protocol {
    Sine,
    Triangle,
    Multisine,
}

/// Displacement, velocity and acceleration of a protocol at time `t`; `k` varies amplitude/frequency.
fn motion(p: Protocol, k: usize, t: f64) -> (f64, f64, f64) {
    use std::f64::consts::PI;
    let s = 1.0 + 0.35 * k as f64;
    match p {
        Protocol::Sine => {
            let (a, w) = (0.02 / s.sqrt(), 2.0 * PI * 1.2 * s);
            (
                a * (w * t).sin(),
                a * w * (w * t).cos(),
                -a * w * w * (w * t).sin(),
            )
        }
        Protocol::Triangle => {
            // Constant-speed ramps with rounded turnarounds: x = a·asin(k sin wt)/asin(k), k = 0.97.
            let (a, w, k) = (0.02, 2.0 * PI * 1.0 * s, 0.97f64);
            let sn = (w * t).sin();
            let norm = k.asin();
            let x = a * (k * sn).asin() / norm;
            let v = a * k * w * (w * t).cos() / ((1.0 - k * k * sn * sn).sqrt() * norm);
            (x, v, 0.0)
        }
        Protocol::Multisine => {
            let comps = [(0.012, 0.8, 0.0), (0.006, 2.3, 1.0), (0.003, 4.1, 2.0)];
            let (mut x, mut v, mut ac) = (0.0, 0.0, 0.0);
            for (a, f, ph) in comps {
                let w = 2.0 * PI * f * s.sqrt();
                x += a * (w * t + ph).sin();
                v += a * w * (w * t + ph).cos();
                ac -= a * w * w * (w * t + ph).sin();
            }
            (x, v, ac)
        }
    }
}

struct Case {
    protocol: Protocol,
    rate_hz: f64,
    velocity_measured: bool,
    files: usize,
    seconds_per_file: f64,
    seed: u64,
    velocity_noise_m_s: f64,
}

/// Current schedule: levels of the paper's driver range held 0.25–0.5 s, seeded.
fn schedule(n: usize, dt: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let levels = [0.0, 3.5, 7.0, 10.5, 14.0];
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let hold = ((0.25 + 0.25 * rng.random::<f64>()) / dt) as usize;
        let l = levels[rng.random_range(0..levels.len())];
        out.extend(std::iter::repeat_n(l, hold.max(1)));
    }
    out.truncate(n);
    out
}

/// Noise of a velocity transducer, m/s (standard deviation): the virtual MTS machine's default
/// (`mrfeel mts --velocity-noise-m-s`).
const VELOCITY_NOISE_M_S: f64 = 2e-4;

/// Noise-free truth inputs and the inputs a rig would record (quantised displacement; velocity measured
/// with white noise of `c.velocity_noise_m_s`, or derived from the displacement).
fn make_inputs(c: &Case, file: usize, rng: &mut ChaCha8Rng) -> (Vec<Inputs>, Measurement) {
    let dt = 1.0 / c.rate_hz;
    let n = (c.seconds_per_file * c.rate_hz) as usize;
    let cur = schedule(n, dt, rng);
    let mut truth = Vec::with_capacity(n);
    for (k, &i) in cur.iter().enumerate() {
        let t = k as f64 * dt;
        let (x, v, a) = motion(c.protocol, file, t);
        truth.push(Inputs {
            t_s: t,
            x_m: x,
            v_m_s: v,
            a_m_s2: a,
            current_cmd_a: i,
        });
    }
    // Triangle acceleration from the velocity.
    if matches!(c.protocol, Protocol::Triangle) {
        let t: Vec<f64> = truth.iter().map(|i| i.t_s).collect();
        let v: Vec<f64> = truth.iter().map(|i| i.v_m_s).collect();
        for (i, a) in truth.iter_mut().zip(smooth_derivative(&t, &v)) {
            i.a_m_s2 = a;
        }
    }
    let vn = Normal::new(0.0, c.velocity_noise_m_s).expect("sigma");
    let m = Measurement {
        path: PathBuf::from(format!("case{}_file{file}_{}.csv", c.seed, file)),
        t_s: truth.iter().map(|i| i.t_s).collect(),
        x_m: truth.iter().map(|i| (i.x_m / 1e-6).round() * 1e-6).collect(),
        v_m_s: truth
            .iter()
            .map(|i| ((i.v_m_s + vn.sample(rng)) / 1e-6).round() * 1e-6)
            .collect(),
        velocity_measured: true,
        i_a: cur,
        f_n: vec![0.0; n],
        lines: (2..n + 2).collect(),
        ..Default::default()
    };
    let mut m = m;
    if !c.velocity_measured {
        m.v_m_s = smooth_derivative(&m.t_s, &m.x_m);
        m.velocity_measured = false;
    }
    (truth, m)
}

/// Synthetic tests of the paper's device with `hidden` effects at their typical strength, plus noise.
fn synth(c: &Case, hidden: &[&str], registry: &Registry, noise_n: f64) -> Vec<Test> {
    let mut rng = ChaCha8Rng::seed_from_u64(c.seed);
    let runs: Vec<(Vec<Inputs>, Measurement)> = (0..c.files).map(|f| make_inputs(c, f, &mut rng)).collect();
    let base = Model::from_spec("bingham", registry, LIMIT_A).expect("base");
    // Statistics of the base device on these protocols: the scale the effects' typical strengths follow.
    let base_tests: Vec<Test> = runs
        .iter()
        .map(|(tr, m)| {
            let mut m = m.clone();
            m.f_n = base.simulate(&PAPER_BASE, tr);
            Test::from_measurement(&m)
        })
        .collect();
    let stats = data_stats(&base_tests);
    let mut spec = ModelSpec::parse("bingham").expect("spec");
    for h in hidden {
        spec = spec.with(h);
    }
    let model = Model::new(&spec, registry, LIMIT_A).expect("model");
    let p = model.typical_params(&PAPER_BASE, &stats).expect("typical");
    let nd = Normal::new(0.0, noise_n).expect("sigma");
    runs.into_iter()
        .map(|(tr, mut m)| {
            let f = model.simulate(&p, &tr);
            // Load-cell noise and 0.01 N quantisation.
            m.f_n = f
                .iter()
                .map(|f| ((f + nd.sample(&mut rng)) / 0.01).round() * 0.01)
                .collect();
            Test::from_measurement(&m)
        })
        .collect()
}

fn check_diagnosis(c: Case, hidden: &[&str]) {
    if let Err(e) = diagnosis_verdict(&c, hidden) {
        panic!("{e}");
    }
}

/// Ok when `diagnose` names exactly the hidden effects and the held-out error falls enough; else the report.
fn diagnosis_verdict(c: &Case, hidden: &[&str]) -> Result<(), String> {
    let tests = synth(c, hidden, &Registry::builtin(), 0.4);
    diagnosis_check::verdict(&tests, hidden, LIMIT_A)
        .map(|_| ())
        .map_err(|e| format!("{} (seed {}): {e}", describe(c), c.seed))
}

/// The diagnosis cases of this file (protocol, rate, velocity measured, files, seconds, hidden effects).
#[allow(clippy::type_complexity)]
const CASES: [(Protocol, f64, bool, usize, f64, &[&str]); 10] = [
    (Protocol::Sine, 1000.0, true, 1, 8.0, &[]),
    (Protocol::Triangle, 1000.0, true, 3, 3.0, &["hysteresis"]),
    (Protocol::Multisine, 2000.0, false, 1, 5.0, &["asymmetry"]),
    (Protocol::Sine, 500.0, false, 3, 6.0, &["magnetic_saturation"]),
    (Protocol::Triangle, 1000.0, true, 1, 8.0, &["current_viscosity"]),
    (Protocol::Multisine, 1000.0, false, 1, 8.0, &["stiffness"]),
    (Protocol::Multisine, 2000.0, true, 3, 2.5, &["inertia"]),
    (Protocol::Sine, 1000.0, true, 1, 10.0, &["thermal_drift"]),
    (
        Protocol::Sine,
        1000.0,
        false,
        3,
        3.0,
        &["hysteresis", "stiffness"],
    ),
    (
        Protocol::Triangle,
        500.0,
        true,
        1,
        16.0,
        &["asymmetry", "magnetic_saturation"],
    ),
];

/// Every diagnosis case on other seeds, and with measured velocity ten times noisier (2 mm/s), so that nothing
/// is tuned to the committed seeds. Slow: `SWEEP_SEEDS=100..104 cargo test --release --test integration
/// ident::diagnosis_sweep -- --ignored --nocapture` (default seeds 100..102; `SWEEP_NOISE=2e-4,1e-3` velocity noises;
/// `SWEEP_ONLY=inertia` the cases whose hidden effects contain that word).
#[test]
#[ignore]
fn diagnosis_sweep_over_seeds_and_velocity_noise() {
    let range = std::env::var("SWEEP_SEEDS").unwrap_or_else(|_| "100..102".into());
    let (a, b) = range.split_once("..").expect("SWEEP_SEEDS=A..B");
    let seeds = a.parse::<u64>().expect("A")..b.parse::<u64>().expect("B");
    let noises: Vec<f64> = std::env::var("SWEEP_NOISE")
        .unwrap_or_else(|_| "2e-4,2e-3".into())
        .split(',')
        .map(|s| s.parse().expect("noise"))
        .collect();
    let mut failures = Vec::new();
    let mut runs = 0;
    for seed in seeds {
        for &noise in &noises {
            for (k, (p, rate, meas, files, secs, hidden)) in CASES.iter().enumerate() {
                // Velocity noise only matters when velocity is measured.
                if !meas && noise != noises[0] {
                    continue;
                }
                if let Ok(only) = std::env::var("SWEEP_ONLY") {
                    if !format!("{hidden:?}").contains(&only) {
                        continue;
                    }
                }
                let mut c = case(*p, *rate, *meas, *files, *secs, 1000 * seed + k as u64);
                c.velocity_noise_m_s = noise;
                runs += 1;
                let r = diagnosis_verdict(&c, hidden);
                eprintln!(
                    "seed {} noise {noise:e} {hidden:?}: {}",
                    c.seed,
                    if r.is_ok() { "ok" } else { "FAIL" }
                );
                if let Err(e) = r {
                    failures.push(e);
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {runs} diagnoses failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

fn describe(c: &Case) -> String {
    format!(
        "{:?}, {} Hz, velocity {}, {} file(s) of {} s",
        c.protocol,
        c.rate_hz,
        if c.velocity_measured {
            "measured"
        } else {
            "derived"
        },
        c.files,
        c.seconds_per_file
    )
}

fn case(
    protocol: Protocol,
    rate_hz: f64,
    velocity_measured: bool,
    files: usize,
    secs: f64,
    seed: u64,
) -> Case {
    Case {
        protocol,
        rate_hz,
        velocity_measured,
        files,
        seconds_per_file: secs,
        seed,
        velocity_noise_m_s: VELOCITY_NOISE_M_S,
    }
}

#[test]
fn diagnosis_adds_nothing_to_a_model_that_is_already_right() {
    check_diagnosis(case(Protocol::Sine, 1000.0, true, 1, 8.0, 1), &[]);
}

#[test]
fn diagnosis_finds_hidden_hysteresis() {
    check_diagnosis(case(Protocol::Triangle, 1000.0, true, 3, 3.0, 2), &["hysteresis"]);
}

#[test]
fn diagnosis_finds_hidden_asymmetry() {
    check_diagnosis(
        case(Protocol::Multisine, 2000.0, false, 1, 5.0, 3),
        &["asymmetry"],
    );
}

#[test]
fn diagnosis_finds_hidden_magnetic_saturation() {
    check_diagnosis(
        case(Protocol::Sine, 500.0, false, 3, 6.0, 4),
        &["magnetic_saturation"],
    );
}

#[test]
fn diagnosis_finds_hidden_current_viscosity() {
    check_diagnosis(
        case(Protocol::Triangle, 1000.0, true, 1, 8.0, 5),
        &["current_viscosity"],
    );
}

#[test]
fn diagnosis_finds_hidden_stiffness() {
    check_diagnosis(
        case(Protocol::Multisine, 1000.0, false, 1, 8.0, 6),
        &["stiffness"],
    );
}

#[test]
fn diagnosis_finds_hidden_inertia() {
    check_diagnosis(case(Protocol::Multisine, 2000.0, true, 3, 2.5, 7), &["inertia"]);
}

#[test]
fn diagnosis_finds_hidden_thermal_drift() {
    check_diagnosis(case(Protocol::Sine, 1000.0, true, 1, 10.0, 8), &["thermal_drift"]);
}

#[test]
fn diagnosis_finds_hidden_hysteresis_and_stiffness_together() {
    check_diagnosis(
        case(Protocol::Sine, 1000.0, false, 3, 3.0, 9),
        &["hysteresis", "stiffness"],
    );
}

#[test]
fn diagnosis_finds_hidden_asymmetry_and_magnetic_saturation_together() {
    check_diagnosis(
        case(Protocol::Triangle, 500.0, true, 1, 16.0, 10),
        &["asymmetry", "magnetic_saturation"],
    );
}

#[test]
fn fit_recovers_the_paper_device_parameters_from_noise_free_data() {
    let registry = Registry::builtin();
    let mut c = case(Protocol::Multisine, 1000.0, true, 2, 4.0, 11);
    c.velocity_noise_m_s = 0.0;
    let tests = synth(&c, &[], &registry, 1e-9);
    let model = Model::from_spec("bingham", &registry, LIMIT_A).expect("model");
    let r = fit(&model, &tests, &all_spans(&tests), &FitOptions::default());
    // Eq. (6)'s two lags in series are symmetric in Te and Tm: the data give the pair, not which is which.
    let (te, tm) = (r.params[3].max(r.params[4]), r.params[3].min(r.params[4]));
    let mut params = r.params.clone();
    (params[3], params[4]) = (te, tm);
    for (k, (got, want)) in params.iter().zip(PAPER_BASE).enumerate() {
        // Quantisation of force (0.01 N) and displacement (1 µm) limit the precision.
        assert!(
            (got - want).abs() <= 0.03 * want,
            "{}: {got} vs {want}",
            model.param_specs()[k].name
        );
        assert!(
            r.std_err[k].is_some(),
            "{} should be determined",
            model.param_specs()[k].name
        );
    }
    assert!(r.nrmse() < 0.01, "nrmse {}", r.nrmse());
}

#[test]
fn lag_time_constants_are_held_with_a_note_when_the_current_never_changes() {
    let registry = Registry::builtin();
    let model = Model::from_spec("bingham", &registry, LIMIT_A).expect("model");
    let mut tests = Vec::new();
    for (j, amps) in [3.0, 9.0].into_iter().enumerate() {
        let n = 3000;
        let inputs: Vec<Inputs> = (0..n)
            .map(|k| {
                let t = k as f64 * 1e-3;
                let (x, v, a) = motion(Protocol::Sine, j, t);
                Inputs {
                    t_s: t,
                    x_m: x,
                    v_m_s: v,
                    a_m_s2: a,
                    current_cmd_a: amps,
                }
            })
            .collect();
        let f = model.simulate(&PAPER_BASE, &inputs);
        tests.push(Test {
            path: format!("const{j}.csv").into(),
            name: format!("const{j}.csv"),
            group: format!("g{j}"),
            inputs,
            f_n: f,
            velocity_measured: true,
            velocity_noise_m_s: None,
            drive: None,
        });
    }
    let r = fit(&model, &tests, &all_spans(&tests), &FitOptions::default());
    let start = model.initial_guess(&data_stats(&tests));
    for name in ["te_s", "tm_s"] {
        let k = model.param_index(name).expect("param");
        assert!(
            r.std_err[k].is_none(),
            "{name} has a std error {:?}",
            r.std_err[k]
        );
        assert!(!r.notes[k].is_empty(), "{name} has no note");
        assert!(
            (r.params[k] - start[k]).abs() <= 1e-12 * start[k],
            "{name} wandered from its initial value"
        );
    }
    for name in ["fc_gain_n_per_a", "c0_n_s_per_m"] {
        let k = model.param_index(name).expect("param");
        assert!(
            (r.params[k] - PAPER_BASE[k]).abs() < 1e-3 * PAPER_BASE[k],
            "{name} {}",
            r.params[k]
        );
    }
}

/// A user's own effect, unknown to the library: a detent force that pulls the piston towards mid-stroke
/// only within ±2 mm (a magnetic latch).
struct Detent;

const DETENT: [ParamSpec; 1] = [ParamSpec::new(
    "detent_peak_n",
    "N",
    0.0,
    f64::INFINITY,
    "peak latch force",
)];

impl Effect for Detent {
    fn name(&self) -> &'static str {
        "detent"
    }
    fn describe(&self) -> &'static str {
        "a latch force -F sin(pi x / 2 mm) inside +-2 mm of mid-stroke"
    }
    fn stage(&self) -> EffectStage {
        EffectStage::Additive
    }
    fn params(&self) -> &'static [ParamSpec] {
        &DETENT
    }
    fn initial_guess(&self, stats: &DataStats) -> Vec<f64> {
        vec![0.02 * stats.f_max_n.max(1.0)]
    }
    fn typical_params(&self, stats: &DataStats) -> Vec<f64> {
        vec![0.3 * stats.f_max_n.max(1.0)]
    }
    fn apply(&self, p: &[f64], _s: &[f64], inp: &Inputs, stage: &mut Stage) {
        let u = inp.x_m / 0.002;
        if u.abs() < 1.0 {
            stage.extra_n -= p[0] * (std::f64::consts::PI * u).sin();
        }
    }
}

/// A second user effect that is not in the data: a constant offset force.
struct Offset;

const OFFSET: [ParamSpec; 1] = [ParamSpec::new(
    "offset_n",
    "N",
    f64::NEG_INFINITY,
    f64::INFINITY,
    "force offset",
)];

impl Effect for Offset {
    fn name(&self) -> &'static str {
        "offset"
    }
    fn describe(&self) -> &'static str {
        "a constant force offset (load-cell zero)"
    }
    fn stage(&self) -> EffectStage {
        EffectStage::Additive
    }
    fn params(&self) -> &'static [ParamSpec] {
        &OFFSET
    }
    fn initial_guess(&self, _stats: &DataStats) -> Vec<f64> {
        vec![0.0]
    }
    fn apply(&self, p: &[f64], _s: &[f64], _inp: &Inputs, stage: &mut Stage) {
        stage.extra_n += p[0];
    }
}

#[test]
fn a_users_own_effect_is_diagnosed_like_the_built_in_ones() {
    let mut registry = Registry::empty();
    registry.register(Detent).register(Offset);
    let c = case(Protocol::Sine, 1000.0, true, 1, 6.0, 12);
    let tests = synth(&c, &["detent"], &registry, 0.4);
    let base = ModelSpec::parse("bingham").expect("spec");
    let d = diagnose(
        &tests,
        &base,
        &registry,
        &DiagnoseOptions {
            current_limit_a: LIMIT_A,
            ..Default::default()
        },
    )
    .expect("diagnose");
    let report = mrfeel::ident::report::diagnose_table(&d);
    assert_eq!(d.missing, vec!["detent".to_string()], "{report}");
    assert!(d.final_heldout_nrmse < 0.5 * d.base_heldout_nrmse, "{report}");
}

// ---------------------------------------------------------------- CLI contract

fn write_tests(dir: &Path, tests: &[Test]) -> Vec<String> {
    tests
        .iter()
        .enumerate()
        .map(|(j, t)| {
            let m = Measurement {
                path: dir.join(format!("grp{j}_run.csv")),
                t_s: t.inputs.iter().map(|i| i.t_s).collect(),
                x_m: t.inputs.iter().map(|i| i.x_m).collect(),
                v_m_s: t.inputs.iter().map(|i| i.v_m_s).collect(),
                velocity_measured: true,
                i_a: t.inputs.iter().map(|i| i.current_cmd_a).collect(),
                f_n: t.f_n.clone(),
                ..Default::default()
            };
            m.write(&m.path).expect("write csv");
            m.path.display().to_string()
        })
        .collect()
}

/// Three MTS runs of one device with `effect` hidden, `cycles` cycles at each of 0, 7 and 14 A: a 1 Hz sine
/// that makes the device, a 2 Hz sine and a multisine at 500 Hz without the velocity channel; `extra` options
/// on each. Returns the saved device and the three files.
fn three_mts_runs(d: &Path, effect: &str, cycles: &str, extra: &str) -> (PathBuf, Vec<PathBuf>) {
    let truth = d.join("truth.json");
    let files: Vec<PathBuf> = (0..3).map(|k| d.join(format!("run{k}.csv"))).collect();
    let t = truth.display();
    let runs = [
        format!("--effects {effect} --amplitude-m 0.02 --frequency-hz 1 --save-device {t}"),
        format!("--device {t} --amplitude-m 0.01 --frequency-hz 2 --seed 2"),
        format!("--device {t} --protocol multisine --amplitude-m 0.02 --frequency-hz 0.5 --seed 3 --sample-rate-hz 500 --no-velocity"),
    ];
    for (r, f) in runs.iter().zip(&files) {
        mts_at_three_currents(cycles, &format!("{r} {extra} --out {}", f.display()));
    }
    (truth, files)
}

/// `mrfeel diagnose --json ARGS…`, which must succeed: its JSON, and the final model's held-out NRMSE with
/// the noise floor's.
fn diagnose_json<S: AsRef<str>>(args: &[S]) -> (serde_json::Value, f64, f64) {
    let args: Vec<&str> = ["diagnose", "--json"]
        .into_iter()
        .chain(args.iter().map(AsRef::as_ref))
        .collect();
    let out = mrfeel(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("diagnose --json");
    let (fin, floor) = (
        v["final"]["heldout_nrmse"].as_f64().unwrap(),
        v["noise_floor_nrmse"].as_f64().unwrap(),
    );
    (v, fin, floor)
}

/// Paths as command-line arguments.
fn args_of(paths: &[PathBuf]) -> Vec<String> {
    paths.iter().map(|p| p.display().to_string()).collect()
}

/// `mrfeel mts --current 0,7,14 --cycles CYCLES ARGS…`, which must succeed.
fn mts_at_three_currents(cycles: &str, args: &str) {
    let args: Vec<&str> = ["mts", "--current", "0,7,14", "--cycles", cycles]
        .into_iter()
        .chain(args.split_whitespace())
        .collect();
    let out = mrfeel(&args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_long_record_of_a_quantised_velocity_channel_leaves_only_noise_after_the_hidden_mass() {
    // The MTS's velocity channel reads 0.2 mm/s of noise on a 16-bit ADC step of 0.3 mm/s, so its third
    // differences take few values. A median of them that snaps to one level misreads the noise; over 12,000
    // samples the acceleration's window would then stop widening at its narrowest, the mass force would
    // carry about 20 times the acceleration's noise, and the verdict would call that noise structure. Read
    // right, the model that made the data leaves what the load cell's noise leaves.
    let dir = tempfile::tempdir().expect("tempdir");
    let (_, files) = three_mts_runs(dir.path(), "inertia", "4", "");
    let (v, fin, floor) = diagnose_json(&args_of(&files));
    assert_eq!(v["missing"], serde_json::json!(["inertia"]), "{v:#}");
    assert!(
        fin <= 1.3 * floor,
        "held-out NRMSE {fin} against a noise floor of {floor}"
    );
    assert!(v.get("unexplained").is_none(), "{v:#}");
}

#[test]
fn a_velocity_channel_on_a_coarse_adc_grid_leaves_only_noise_after_the_hidden_effect() {
    // A 12-bit velocity channel over ±10 m/s steps by 4.9 mm/s, 24 times its 0.2 mm/s noise: near each
    // reversal it reads 0 or one step, and its third differences read almost no noise. With that noise the
    // samples whose velocity sign is unknown would count, each a 2 Fy residual, and the diagnosis end at up
    // to 20 times the noise floor; the channel's rounding, step/√12, marks them.
    for effect in ["stiffness", "hysteresis"] {
        let dir = tempfile::tempdir().expect("tempdir");
        let (_, files) = three_mts_runs(dir.path(), effect, "6", "--adc-bits 12");
        let (v, fin, floor) = diagnose_json(&args_of(&files));
        assert_eq!(v["missing"], serde_json::json!([effect]), "{v:#}");
        assert!(
            fin <= 1.3 * floor,
            "{effect}: held-out NRMSE {fin} against a noise floor of {floor}"
        );
    }
}

#[test]
fn a_cooling_time_guessed_too_long_is_found_from_a_start_a_decade_below() {
    // Heating hidden in three MTS runs of 15 to 60 s whose fluid cools in 30 s. The guess for the cooling
    // time (three of the longest test's durations, 180 s) runs off to the bound, "no cooling", a local
    // minimum 3.2 times the noise; from a start a decade below, the fit finds the device.
    let dir = tempfile::tempdir().expect("tempdir");
    let (truth, files) = three_mts_runs(dir.path(), "thermal_drift", "10", "");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&truth).unwrap()).unwrap();
    let want = |name: &str| v["params"][name]["value"].as_f64().unwrap();
    let tests = mrfeel::ident::load_tests(&files).expect("runs");
    let model = Model::from_spec("bingham+thermal_drift", &Registry::builtin(), LIMIT_A).expect("model");
    let r = fit(&model, &tests, &all_spans(&tests), &FitOptions::default());
    let got = |name: &str| r.params[model.param_specs().iter().position(|p| p.name == name).unwrap()];
    for name in ["thermal_tau_s", "thermal_energy_j"] {
        assert!(
            (got(name) / want(name) - 1.0).abs() < 0.03,
            "{name}: fitted {}, truth {}",
            got(name),
            want(name)
        );
    }
    // The load cell's 0.15 N of noise is 0.0039 of the force's RMS here.
    assert!(r.nrmse() < 0.0045, "NRMSE {}", r.nrmse());
}

#[test]
fn mts_runs_of_one_saved_hidden_device_are_diagnosed_together() {
    // `mrfeel mts --effects` scales a hidden effect to its own run's test, so each run is another device;
    // `--save-device` writes the simulated device and `--device` runs it again under other protocols. The
    // runs then share one truth, and diagnosing them together names exactly the hidden effect.
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let data = d.join("data");
    std::fs::create_dir(&data).unwrap();
    let (truth, again, other) = (d.join("truth.json"), d.join("again.json"), d.join("other.json"));
    let s = |p: &Path| p.display().to_string();
    let (a, b, c, x) = (
        data.join("a.csv"),
        data.join("b.csv"),
        data.join("c.csv"),
        d.join("other.csv"),
    );
    let (a, b, c, x, truth_s, again_s, other_s) =
        (s(&a), s(&b), s(&c), s(&x), s(&truth), s(&again), s(&other));
    let runs = [
        // The first run makes the hidden device: inertia at this test's scale.
        format!("--effects inertia --protocol sine --amplitude-m 0.02 --frequency-hz 1 --out {a} --save-device {truth_s}"),
        // The same device under another amplitude, frequency and noise seed; then a multisine at another sample
        // rate with the velocity derived from displacement. (Not a triangle: its acceleration is a train of
        // impulses at the reversals that neither 1 kHz samples nor a derivative resolve.)
        format!("--device {truth_s} --protocol sine --amplitude-m 0.01 --frequency-hz 2 --seed 2 --out {b} --save-device {again_s}"),
        format!("--device {truth_s} --protocol multisine --amplitude-m 0.02 --frequency-hz 0.5 --seed 3 --sample-rate-hz 500 --no-velocity --out {c}"),
        // A separate `--effects` run with another test: another device (written outside the data).
        format!("--effects inertia --protocol sine --amplitude-m 0.01 --frequency-hz 2 --out {x} --save-device {other_s}"),
    ];
    for r in &runs {
        mts_at_three_currents("2", r);
    }
    let mass = |p: &Path| -> f64 {
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
        assert_eq!(v["model"], "bingham+inertia", "{}", p.display());
        v["params"]["inertia_mass_kg"]["value"].as_f64().unwrap()
    };
    let m = mass(&truth);
    assert!(m > 0.0);
    assert_eq!(
        mass(&again).to_bits(),
        m.to_bits(),
        "a reused device keeps its hidden parameters exactly"
    );
    assert!(
        (mass(&other) / m - 1.0).abs() > 0.1,
        "a separate --effects run scales the effect to its own test: {} vs {m} kg",
        mass(&other)
    );
    let out = mrfeel(&["diagnose", &s(&data), "--json", "--model", "bingham"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("diagnose --json");
    assert_eq!(v["missing"], serde_json::json!(["inertia"]), "{v:#}");
    let (base, fin) = (
        v["base"]["heldout_nrmse"].as_f64().unwrap(),
        v["final"]["heldout_nrmse"].as_f64().unwrap(),
    );
    assert!(
        fin <= 0.5 * base,
        "held-out NRMSE {base} -> {fin}: less than halved"
    );
    // A device file that cannot be written is an error naming it.
    let bad = d.join("no-such-dir").join("truth.json");
    let out = mrfeel(&[
        "mts",
        "--current",
        "7",
        "--effects",
        "inertia",
        "--out",
        &s(&d.join("x.csv")),
        "--save-device",
        &s(&bad),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && err.contains(&s(&bad)), "{err}");
}

/// Hysteresis and stiffness hidden in one record at two currents (0 and 1 A, four blocks: the current's only
/// step starts the third). Stiffness is added to the model with hysteresis and lowers the held-out error a
/// lot; the refit of every fold from the data-derived start must not undo it where it ends lower in
/// training only by less than noise: in the fold whose held-out block holds the current step, the
/// training samples do not determine the lags, and that refit moved one to 0.8 s for a fall of 0.006 %
/// and took the step's held-out error from 0.059 to 0.195, so that stiffness was then dropped as
/// redundant and the diagnosis ended at 3.6 times the noise floor.
#[test]
fn a_refit_that_fits_the_training_samples_no_better_than_noise_does_not_replace_a_fit() {
    let dir = tempfile::tempdir().expect("tempdir");
    let csv = dir.path().join("hs.csv").display().to_string();
    let out = mrfeel(&[
        "mts",
        "--current",
        "0,1",
        "--cycles",
        "5",
        "--effects",
        "hysteresis,stiffness",
        "--out",
        &csv,
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let (v, fin, floor) = diagnose_json(&[&csv, "--model", "bingham", "--named-only"]);
    assert_eq!(
        v["missing"],
        serde_json::json!(["hysteresis", "stiffness"]),
        "{v:#}"
    );
    assert!(
        fin <= 1.5 * floor,
        "held-out NRMSE {fin} against the noise floor {floor}"
    );
}

/// `--save` and `--save-device` write JSON, and a parameter file is read by its extension: a `.toml` name
/// would be written and then fail to load as a device file. Refused before any work, naming the flag and
/// the file; nothing is written.
#[test]
fn saving_parameters_under_a_name_that_is_not_json_is_refused_before_any_work() {
    let dir = tempfile::tempdir().expect("tempdir");
    let registry = Registry::builtin();
    let tests = synth(
        &case(Protocol::Sine, 500.0, true, 1, 3.0, 14),
        &[],
        &registry,
        0.3,
    );
    let files = write_tests(dir.path(), &tests);
    let toml = dir.path().join("params.toml");
    let out = mrfeel(&["fit", &files[0], "--save", toml.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains("--save") && err.contains("params.toml") && err.contains("saved as JSON"),
        "{err}"
    );
    assert!(!err.contains("fitting"), "refused before the fit: {err}");
    assert!(!toml.exists());
    let csv = dir.path().join("mts.csv");
    let out = mrfeel(&[
        "mts",
        "--current",
        "2",
        "--out",
        csv.to_str().unwrap(),
        "--save-device",
        toml.to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success() && err.contains("--save-device") && err.contains("saved as JSON"),
        "{err}"
    );
    assert!(!toml.exists() && !csv.exists(), "nothing written");
}

#[test]
fn fit_save_then_validate_reports_the_same_error_without_refitting() {
    let dir = tempfile::tempdir().expect("tempdir");
    let registry = Registry::builtin();
    let tests = synth(
        &case(Protocol::Sine, 500.0, true, 2, 3.0, 13),
        &["hysteresis"],
        &registry,
        0.3,
    );
    let files = write_tests(dir.path(), &tests);
    let params = dir.path().join("params.json");
    let out = mrfeel(&[
        "fit",
        &files[0],
        "--model",
        "bingham+hysteresis",
        "--json",
        "--save",
        params.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let fit: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("fit --json is JSON, alone on stdout");
    assert_eq!(fit["model"], "bingham+hysteresis");
    assert_eq!(fit["samples"], tests[0].len());
    let x = &fit["params"]["hyst_x_yield_m"];
    assert!(x["value"].as_f64().unwrap() > 0.0 && x["unit"] == "m", "{x}");
    assert!(fit["nrmse"].as_f64().unwrap() < 0.05, "{fit}");

    // Validate on the file it was fitted on: the same parameters and figures, to the bit (no refit; the
    // saved decimals read back as the numbers written, not one unit in the last place off).
    let out = mrfeel(&[
        "validate",
        &files[0],
        "--params",
        params.to_str().unwrap(),
        "--json",
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("validate --json");
    assert_eq!(v["params"], fit["params"]);
    assert_eq!(v["nrmse"], fit["nrmse"]);
    assert_eq!(v["rmse_n"], fit["rmse_n"]);
    // And on a test it never saw: the same device, so the error stays near the noise.
    let out = mrfeel(&[
        "validate",
        &files[1],
        "--params",
        params.to_str().unwrap(),
        "--json",
    ]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("validate --json");
    assert!(v["nrmse"].as_f64().unwrap() < 0.05, "{v}");
    assert_eq!(v["files"][0]["path"], files[1]);
}

#[test]
fn a_current_in_force_at_the_sample_it_is_logged_with_is_read_so_and_saved_with_the_parameters() {
    // Data as a generator writes them that forms each sample's force from that sample's current: a device
    // without lags (Eq. 2 alone, written here by hand), the current stepping inside each of three files.
    // Read after its sample (a DAQ that reads, then writes), every step leaves one sample off by the whole
    // change of the yield force, and the right model ends far above the noise.
    let dir = tempfile::tempdir().expect("tempdir");
    let d = dir.path();
    let c = case(Protocol::Sine, 1000.0, true, 3, 3.0, 31);
    let mut rng = ChaCha8Rng::seed_from_u64(c.seed);
    let noise = Normal::new(0.0, 0.2).expect("sigma");
    let mut forces = Vec::new();
    for file in 0..c.files {
        let (truth, mut m) = make_inputs(&c, file, &mut rng);
        m.f_n = truth
            .iter()
            .zip(&m.i_a)
            .map(|(tr, i)| (2.0 + 4.83 * i) * tr.v_m_s.signum() + 60.0 * tr.v_m_s + noise.sample(&mut rng))
            .collect();
        m.path = d.join(format!("g{file}_steps.csv"));
        m.write(&m.path).expect("write csv");
        forces.extend(m.f_n);
    }
    let floor = 0.2 / (forces.iter().map(|f| f * f).sum::<f64>() / forces.len() as f64).sqrt();
    let dir_s = d.display().to_string();
    let heldout = |timing: &str| {
        let out = mrfeel(&[
            "diagnose",
            &dir_s,
            "--json",
            "--model",
            "bingham",
            "--command-timing",
            timing,
        ]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let j: serde_json::Value = serde_json::from_slice(&out.stdout).expect("diagnose --json");
        assert_eq!(j["missing"], serde_json::json!([]), "{timing}: {j}");
        (
            j["final"]["heldout_nrmse"].as_f64().unwrap(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let (auto, note) = heldout("auto");
    assert!(note.contains("command timing: at-sample"), "{note}");
    assert!(auto < 1.2 * floor, "auto: held out {auto}, noise floor {floor}");
    let (after, _) = heldout("after-sample");
    assert!(
        after > 1.5 * floor,
        "read after the sample: held out {after}, noise floor {floor}"
    );

    // `fit --save` records the reading; `validate` reads the data the same way.
    let params = d.join("params.json");
    let p_s = params.display().to_string();
    let out = mrfeel(&["fit", &dir_s, "--json", "--save", &p_s]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let fit: serde_json::Value = serde_json::from_slice(&out.stdout).expect("fit --json");
    let saved = std::fs::read_to_string(&params).expect("params");
    assert!(saved.contains("\"command_timing\": \"at-sample\""), "{saved}");
    let validate = || {
        let out = mrfeel(&["validate", &dir_s, "--params", &p_s, "--json"]);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("validate --json");
        v["nrmse"].as_f64().unwrap()
    };
    let same = validate();
    assert!(
        (same - fit["nrmse"].as_f64().unwrap()).abs() < 1e-12,
        "{same} {fit}"
    );
    std::fs::write(&params, saved.replace("\"at-sample\"", "\"after-sample\"")).unwrap();
    assert!(validate() > 1.5 * same, "the saved reading is used");

    // On the command line, a reading that is neither is refused before any work, naming the option.
    let out = mrfeel(&["fit", &dir_s, "--command-timing", "sideways"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && out.stdout.is_empty(), "{err}");
    assert!(
        err.contains("--command-timing") && err.contains("sideways") && err.contains("at-sample"),
        "{err}"
    );

    // In a parameter file, a reading that is neither is refused with the file, line and field named.
    std::fs::write(&params, saved.replace("\"at-sample\"", "\"sideways\"")).unwrap();
    let out = mrfeel(&["validate", &dir_s, "--params", &p_s]);
    let err = String::from_utf8_lossy(&out.stderr);
    let line = saved.lines().position(|l| l.contains("command_timing")).unwrap() + 1;
    assert!(!out.status.success(), "{err}");
    assert!(
        err.contains(&format!("params.json:{line}: field `command_timing`")) && err.contains("sideways"),
        "{err}"
    );
}

#[test]
fn unknown_effect_is_an_error_listing_the_known_ones() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tests = synth(
        &case(Protocol::Sine, 500.0, true, 1, 1.0, 14),
        &[],
        &Registry::builtin(),
        0.3,
    );
    let files = write_tests(dir.path(), &tests);
    let out = mrfeel(&["fit", &files[0], "--model", "bingham+wobble"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("wobble") && err.contains("hysteresis") && err.contains("thermal_drift"),
        "{err}"
    );
    assert!(out.stdout.is_empty());
}

#[test]
fn too_few_samples_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().expect("tempdir");
    let path = dir.path().join("short.csv");
    std::fs::write(
        &path,
        "t_s,x_m,i_a,f_n\n0,0,1,1\n0.001,0.0001,1,2\n0.002,0.0002,1,3\n",
    )
    .unwrap();
    let out = mrfeel(&["fit", path.to_str().unwrap()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("short.csv") && err.contains("3 samples") && err.contains("parameters"),
        "{err}"
    );
}

#[test]
fn diagnose_json_follows_the_contract() {
    let dir = tempfile::tempdir().expect("tempdir");
    let registry = Registry::builtin();
    let tests = synth(
        &case(Protocol::Sine, 500.0, true, 3, 2.0, 15),
        &["stiffness"],
        &registry,
        0.3,
    );
    let files = write_tests(dir.path(), &tests);
    let plots = dir.path().join("plots");
    let mut args = vec!["diagnose"];
    args.extend(files.iter().map(String::as_str));
    args.extend(["--json", "--plot", plots.to_str().unwrap()]);
    let out = mrfeel(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let d: serde_json::Value = serde_json::from_slice(&out.stdout).expect("diagnose --json is JSON alone");
    assert_eq!(d["base_model"], "bingham");
    assert_eq!(d["samples"], tests.iter().map(Test::len).sum::<usize>());
    for k in ["nrmse", "rmse_n", "heldout_nrmse"] {
        assert!(d["base"][k].as_f64().is_some(), "base.{k}");
    }
    let cands = d["candidates"].as_array().expect("candidates");
    assert_eq!(cands.len(), registry.names().len());
    let h: Vec<f64> = cands
        .iter()
        .map(|c| c["heldout_nrmse"].as_f64().unwrap())
        .collect();
    assert!(
        h.windows(2).all(|w| w[0] <= w[1]),
        "candidates sorted best first: {h:?}"
    );
    let base_h = d["base"]["heldout_nrmse"].as_f64().unwrap();
    for c in cands {
        let imp = 1.0 - c["heldout_nrmse"].as_f64().unwrap() / base_h;
        assert!((c["improvement"].as_f64().unwrap() - imp).abs() < 1e-9);
        assert!(!c["evidence"].as_str().unwrap().is_empty());
    }
    assert_eq!(d["missing"], serde_json::json!(["stiffness"]));
    assert_eq!(d["final"]["model"], "bingham+stiffness");
    assert!(d["where"][0]["region"].as_str().unwrap().contains("m/s"));
    for f in [
        "error_falling.png",
        "error_falling.svg",
        "base_residual_heatmap.png",
        "final_force_velocity.svg",
    ] {
        assert!(plots.join(f).exists(), "{f} missing");
    }
    // The residual over time names each test beside the plot (a legend per file).
    let svg = std::fs::read_to_string(plots.join("base_residual_time.svg")).unwrap();
    for f in &files {
        let stem = Path::new(f).file_stem().unwrap().to_str().unwrap();
        assert!(svg.contains(stem), "{stem} not in the residual-over-time legend");
    }
}

/// A sine of displacement `x = amp sin(2π f t)` at a constant current, logged at `rate_hz` for `seconds`.
fn sine_inputs(amp_m: f64, freq_hz: f64, current_a: f64, rate_hz: f64, seconds: f64) -> Vec<Inputs> {
    let w = 2.0 * std::f64::consts::PI * freq_hz;
    (0..(seconds * rate_hz) as usize)
        .map(|k| {
            let t = k as f64 / rate_hz;
            Inputs {
                t_s: t,
                x_m: amp_m * (w * t).sin(),
                v_m_s: amp_m * w * (w * t).cos(),
                a_m_s2: -amp_m * w * w * (w * t).sin(),
                current_cmd_a: current_a,
            }
        })
        .collect()
}

/// MTS tests of a damper whose every test has its own force scale, as a measured damper's tests do (its
/// temperature, the fluid's settling, the fixture): the paper's device at one constant current per test,
/// its force times `1 + 0.1·N(0, 1)` per test, plus load-cell noise. Three sine protocols like the UTFSM
/// files': 10 mm 1 Hz logged at 1 kHz for 12 s, 25 mm 0.25 Hz at 200 Hz for 22 s, 2 mm 5 Hz at 200 Hz for
/// 2.2 s, so one protocol holds most of the samples.
fn tests_with_their_own_scales(seed: u64) -> Vec<Test> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let model = Model::from_spec("bingham", &Registry::builtin(), LIMIT_A).expect("model");
    let scale = Normal::new(1.0, 0.1).expect("sigma");
    let load_cell = Normal::new(0.0, 0.05).expect("sigma");
    let velocity = Normal::new(0.0, VELOCITY_NOISE_M_S).expect("sigma");
    let mut tests = Vec::new();
    for (group, amp_m, freq_hz, rate_hz, seconds) in [
        ("10mm1Hz", 0.010, 1.0, 1000.0, 12.0),
        ("25mm0p25Hz", 0.025, 0.25, 200.0, 22.0),
        ("2mm5Hz", 0.002, 5.0, 200.0, 2.2),
    ] {
        for current_a in [0.0, 3.5, 7.0, 10.5, 14.0] {
            let truth = sine_inputs(amp_m, freq_hz, current_a, rate_hz, seconds);
            let n = truth.len();
            let s = scale.sample(&mut rng);
            let f_n = model
                .simulate(&PAPER_BASE, &truth)
                .iter()
                .map(|f| s * f + load_cell.sample(&mut rng))
                .collect();
            let m = Measurement {
                path: PathBuf::from(format!("{group}_{current_a}A.csv")),
                t_s: truth.iter().map(|i| i.t_s).collect(),
                x_m: truth.iter().map(|i| i.x_m).collect(),
                v_m_s: truth
                    .iter()
                    .map(|i| i.v_m_s + velocity.sample(&mut rng))
                    .collect(),
                velocity_measured: true,
                i_a: vec![current_a; n],
                f_n,
                lines: (2..n + 2).collect(),
                ..Default::default()
            };
            let mut t = Test::from_measurement(&m);
            t.group = group.to_string();
            tests.push(t);
        }
    }
    tests
}

/// Counting each test once (`fit --weighting tests`, the default) costs nothing in accuracy where each
/// test's error is its own force scale and the model is right: leaving one protocol out at a time over 16
/// seeded data sets, the damper fitted with each test counting once predicts the tests it never saw as
/// well as the one fitted with each sample counting once (mean held-out MSE within 3 %; measured: 6 %
/// lower over these 16, 2.6 % lower over 40 seeds with `SCALE_SEEDS=40`, better in 21 of them). Where the
/// model is right, the weighting only changes how the tests' scales are averaged; what it changes on the
/// real damper is which protocol decides the parts of the model the protocols disagree on (README).
#[test]
fn counting_each_test_once_costs_nothing_where_each_test_has_its_own_scale() {
    use mrfeel::ident::diagnose::{cross_validate, make_folds};
    use mrfeel::ident::fit::Weighting;
    let model = Model::from_spec("bingham", &Registry::builtin(), LIMIT_A).expect("model");
    let (mut by_tests, mut by_samples) = (0.0, 0.0);
    let seeds = std::env::var("SCALE_SEEDS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(16u64);
    for seed in 0..seeds {
        let tests = tests_with_their_own_scales(seed);
        let (folds, how) = make_folds(&tests, 4, 5);
        assert_eq!(folds.len(), 3, "{how}");
        let heldout_mse = |weighting| {
            let opts = FitOptions {
                weighting,
                std_errors: false,
                ..Default::default()
            };
            let bar = indicatif::ProgressBar::hidden();
            cross_validate(&model, &tests, &folds, None, &opts, &bar)
                .total
                .mse()
        };
        let (t, s) = (heldout_mse(Weighting::Tests), heldout_mse(Weighting::Samples));
        eprintln!("seed {seed}: held-out MSE {t:.3} N² each test once, {s:.3} N² each sample once");
        by_tests += t;
        by_samples += s;
    }
    let ratio = by_tests / by_samples;
    eprintln!("over {seeds} seeds: each test once / each sample once = {ratio:.3}");
    assert!(ratio < 1.03, "{by_tests} vs {by_samples}");
}

/// `mrfeel fit --weighting`: two tests of the paper's device at 7 A whose force scales differ by 20 % (+10 %
/// and −10 %), one 10 s at 1 kHz, one 2 s at 200 Hz. By default each test counts once and both are missed
/// by about their 10 %; with `--weighting samples` the long test (25× the samples) decides the fit and the
/// short one carries the whole difference. Each run says on stderr which loss it used.
#[test]
fn fit_counts_each_test_once_unless_told_to_count_samples() {
    let model = Model::from_spec("bingham", &Registry::builtin(), LIMIT_A).expect("model");
    let tests: Vec<Test> = [(1000.0, 10.0, 1.1), (200.0, 2.0, 0.9)]
        .iter()
        .map(|&(rate_hz, seconds, scale)| {
            let inputs = sine_inputs(0.02, 1.0, 7.0, rate_hz, seconds);
            let f_n = model
                .simulate(&PAPER_BASE, &inputs)
                .iter()
                .map(|f| scale * f)
                .collect();
            Test {
                path: PathBuf::from("t.csv"),
                name: "t.csv".into(),
                group: "t".into(),
                f_n,
                inputs,
                velocity_measured: true,
                velocity_noise_m_s: None,
                drive: None,
            }
        })
        .collect();
    let dir = tempfile::tempdir().expect("tempdir");
    let files = write_tests(dir.path(), &tests);
    let run = |extra: &[&str]| {
        let mut args = vec!["fit", &files[0], &files[1], "--json"];
        args.extend_from_slice(extra);
        let out = mrfeel(&args);
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("fit --json");
        let per: Vec<f64> = v["files"]
            .as_array()
            .expect("files")
            .iter()
            .map(|f| f["nrmse"].as_f64().expect("nrmse"))
            .collect();
        (per, String::from_utf8_lossy(&out.stderr).into_owned())
    };
    let (by_tests, note) = run(&[]);
    assert!(note.contains("each test counts once"), "{note}");
    for e in &by_tests {
        assert!(
            (0.07..0.13).contains(e),
            "each test once: per-file NRMSE {by_tests:?}"
        );
    }
    let params = dir.path().join("p.json").display().to_string();
    let (by_samples, note) = run(&["--weighting", "samples", "--save", &params]);
    assert!(note.contains("every sample counts once"), "{note}");
    assert!(
        by_samples[0] < 0.01 && by_samples[1] > 0.17,
        "each sample once: per-file NRMSE {by_samples:?}"
    );
    // The saved parameters record the loss, and `validate` runs them as fitted.
    let saved = std::fs::read_to_string(&params).expect("saved");
    assert!(saved.contains("\"weighting\": \"samples\""), "{saved}");
    let out = mrfeel(&["validate", &files[1], "--params", &params, "--json"]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("validate --json");
    assert_eq!(v["nrmse"].as_f64(), Some(by_samples[1]), "{v}");
}

/// The real damper (`data/utfsm-mr-damper`): diagnosis from `bingham` finds hysteresis first, and its
/// final model meets the held-out NRMSE ≤ 0.08, judged by leaving one amplitude/frequency group out
/// at a time. Slow in the dev profile: run with
/// `cargo test --release --test integration ident::real_damper -- --ignored`.
#[test]
#[ignore]
fn real_damper_diagnosis_finds_hysteresis() {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/data/utfsm-mr-damper"));
    let tests = mrfeel::ident::load_tests(&[dir]).expect("real data");
    let registry = Registry::builtin();
    let base = ModelSpec::parse("bingham").expect("spec");
    let d = diagnose(
        &tests,
        &base,
        &registry,
        &DiagnoseOptions {
            current_limit_a: 14.0,
            ..Default::default()
        },
    )
    .expect("diagnose");
    let report = mrfeel::ident::report::diagnose_table(&d);
    eprintln!("{report}");
    assert_eq!(
        d.missing.first().map(String::as_str),
        Some("hysteresis"),
        "{report}"
    );
    assert!(d.final_heldout_nrmse < d.base_heldout_nrmse, "{report}");
    // The goal on tests of the same damper the model never saw (pooled over samples, as the
    // contract's NRMSE: the 10mm1Hz group holds 69 % of them).
    assert!(d.final_heldout_nrmse <= 0.08, "{report}");
}

/// Design rule: same inputs, same outputs, bit for bit. The diagnosis fits its candidates and folds in
/// parallel; its JSON, and a fit's saved parameters, are the same bytes on one thread and on four.
#[test]
fn diagnose_and_fit_give_the_same_bytes_on_any_number_of_threads() {
    let dir = tempfile::tempdir().expect("tempdir");
    let tests = synth(
        &case(Protocol::Sine, 500.0, true, 3, 2.0, 21),
        &["hysteresis"],
        &Registry::builtin(),
        0.3,
    );
    let files = write_tests(dir.path(), &tests);
    let run = |threads: &str, what: &str| -> Vec<u8> {
        let saved = dir.path().join(format!("p{threads}.json"));
        let mut args: Vec<String> = vec![what.into()];
        args.extend(files.iter().cloned());
        if what == "fit" {
            args.extend(["--model".into(), "bingham+hysteresis".into()]);
            args.extend(["--save".into(), saved.to_str().unwrap().into()]);
        } else {
            args.push("--json".into());
        }
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
            .args(&args)
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
        if what == "fit" {
            std::fs::read(&saved).unwrap()
        } else {
            out.stdout
        }
    };
    for what in ["diagnose", "fit"] {
        let one = run("1", what);
        assert!(!one.is_empty());
        assert!(
            one == run("4", what),
            "{what}: other bytes on 4 threads than on 1"
        );
    }
}
