//! Property tests across the parameter space (docs/reference/invariants.md): random valid scenarios, devices and
//! protocols within the schema's ranges.
//!
//! - every run either succeeds with finite results that keep the invariants, the feel system passive, or
//!   fails with an error that names the scenario's file, line and key;
//! - the rig's mechanics converge at first order as the physics step shrinks, and the closed loop, whose
//!   sampled decisions have no order of convergence, is converged at its default 1 kHz step;
//! - the damper alone is passive (`F·v ≥ 0`) for any device and protocol;
//! - a fit of data made by a known model recovers its parameters within twice their standard errors in
//!   most draws (nominal coverage 95 %; tested at least 85 %; the two lags as a pair).
//!
//! Small counts in the test command; `-- --ignored` runs the larger seeded sweep. `MRFEEL_PROPTEST_CASES=N`
//! sets the count of each, `MRFEEL_PROPTEST_SEED` the seed (default fixed).

use std::path::PathBuf;

use mrfeel::device::{Inputs, Model, Registry};
use mrfeel::ident::Test;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, TestRng, TestRunner};
use rand::SeedableRng;
use rand_distr::Distribution;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Cases of each property: `MRFEEL_PROPTEST_CASES`, else `default`.
fn cases(default: u32) -> u32 {
    std::env::var("MRFEEL_PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn runner(n: u32) -> TestRunner {
    let seed: u64 = std::env::var("MRFEEL_PROPTEST_SEED")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(30);
    let mut bytes = [0u8; 32];
    bytes[..8].copy_from_slice(&seed.to_le_bytes());
    TestRunner::new_with_rng(
        Config {
            cases: n,
            failure_persistence: None,
            ..Config::default()
        },
        TestRng::from_seed(RngAlgorithm::ChaCha, &bytes),
    )
}

/// The paper's feel loop with `edits` (`key = value` replaced inside its table), its paths absolute.
fn paper_loop_text(edits: &[(&str, &str, String)]) -> String {
    let text = std::fs::read_to_string(root().join("scenarios/paper-feel-loop.toml")).unwrap();
    let mut table = String::new();
    let mut out = Vec::new();
    for l in text.lines() {
        let t = l.trim();
        if t.starts_with('[') {
            table = t.trim_matches(|c| c == '[' || c == ']').to_string();
        }
        let hit = edits
            .iter()
            .find(|(tb, key, _)| *tb == table && t.split_once('=').is_some_and(|(k, _)| k.trim() == *key));
        out.push(match hit {
            Some((_, key, value)) => format!("{key} = {value}"),
            None => l.to_string(),
        });
    }
    (out.join("\n") + "\n").replace("\"../", &format!("\"{}/", root().display()))
}

/// Load and run a scenario text (as `s.toml`), the error as text.
fn run_text(text: &str) -> Result<mrfeel::sim::Results, String> {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.toml");
    std::fs::write(&path, text).unwrap();
    let (scn, devices, rig) = mrfeel::sim::load(&path).map_err(|e| format!("{e:#}"))?;
    mrfeel::sim::run(&scn, &devices, rig, Default::default(), |_| {}).map_err(|e| format!("{e:#}"))
}

/// A random valid variant of the paper's loop: the physics and DAQ rates, the pilot's sweep, the feel law,
/// the loop's gains and the seed, each within its schema range (narrowed where a wider one only makes the
/// run longer).
fn scenario() -> impl Strategy<Value = Vec<(&'static str, &'static str, String)>> {
    (
        (500.0..4000.0f64, 100.0..1000.0f64),
        (
            0.0..0.32f64,
            0.05..4.0f64,
            prop_oneof![Just("triangle"), Just("sine")],
        ),
        (0.0..30.0f64, 0.0..3000.0f64, 0.0..500.0f64, 0.0..250.0f64),
        (0.0..0.5f64, 0.0..20.0f64, 0.0..14.0f64),
        any::<u32>(),
    )
        .prop_map(
            |((phys, daq), (amp, freq, signal), (bo, grad, damp, fmax), (kp, ki, imax), seed)| {
                let f = |v: f64| format!("{v:?}");
                vec![
                    ("", "duration_s", "1.0".to_string()),
                    ("", "seed", seed.to_string()),
                    ("rig", "physics_hz", f(phys)),
                    ("daq", "sample_rate_hz", f(daq.min(phys))),
                    ("pilot", "amplitude_rad", f(amp)),
                    ("pilot", "frequency_hz", f(freq)),
                    ("pilot", "signal", format!("\"{signal}\"")),
                    ("feel", "breakout_n", f(bo)),
                    ("feel", "gradient_n_per_m", f(grad)),
                    ("feel", "damping_n_s_per_m", f(damp)),
                    ("feel", "max_force_n", f(fmax)),
                    ("controller", "kp_a_per_n", f(kp)),
                    ("controller", "ki_a_per_n_s", f(ki)),
                    ("controller", "current_max_a", f(imax)),
                ]
            },
        )
}

/// Every random valid run either keeps the invariants with finite figures and a passive feel system (the
/// damper never gives energy back: its dissipated energy never falls), or fails naming `s.toml:LINE` and
/// a key.
/// Largest fall of the damper's dissipated energy over a step, J: the rounding of the fluid's force, which
/// the rig infers from the piston's momentum balance (differences of forces of tens of newtons), a
/// millionth of the energy balance's 1 mJ floor. A damper giving energy back does so by far more.
const DIP_J: f64 = 1e-9;

fn every_run_is_finite_and_passive_or_fails_naming_the_setting(cases: u32) {
    let mut r = runner(cases);
    r.run(&scenario(), |edits| {
        match run_text(&paper_loop_text(&edits)) {
            Ok(res) => {
                let s = res.summary();
                let figures = [
                    s.pilot_work_j,
                    s.dissipated_j,
                    s.max_abs_load_cell_n,
                    s.max_abs_piston_x_m,
                ];
                prop_assert!(figures.iter().all(|v| v.is_finite()), "{s}");
                prop_assert!(s.tracking_nrmse.is_none_or(f64::is_finite), "{s}");
                // The documented tolerance: 5 % of the work exchanged, and at least 1 mJ.
                let work = s.work_exchanged_j;
                prop_assert!(
                    s.energy_residual
                        .is_none_or(|e| e.abs() <= 0.05 || e.abs() * work <= 1e-3),
                    "{s}"
                );
                prop_assert!(s.max_abs_load_cell_n <= 250.0, "{s}");
                // The damper's dissipated energy never falls by more than DIP_J.
                let (mut worst, mut at) = (0.0f64, 0.0);
                for w in res.rows.windows(2) {
                    let dip = w[0].dissipated_j - w[1].dissipated_j;
                    if dip > worst {
                        (worst, at) = (dip, w[1].t_s);
                    }
                }
                prop_assert!(
                    worst <= DIP_J,
                    "the damper gave {worst:e} J back at t = {at} s of {} J dissipated",
                    s.dissipated_j
                );
            }
            Err(e) => {
                let placed = e
                    .match_indices("s.toml:")
                    .any(|(k, m)| e[k + m.len()..].starts_with(|c: char| c.is_ascii_digit()));
                prop_assert!(
                    placed && e.contains('`'),
                    "an error that names no line and key: {e}"
                );
            }
        }
        Ok(())
    })
    .unwrap();
}

/// RMS difference of two paths over their common length.
fn rms_diff(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len());
    (a[..n].iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>() / n as f64).sqrt()
}

/// The rig's mechanics (the multibody's semi-implicit Euler step with the damper as an implicit yield
/// element) under a prescribed hand force and coil current, gravity off, the stick clear of its stops:
/// every piston path (at 500 Hz) from 1 kHz up lies within 0.5 % of the stroke (254 µm RMS) of an 8 kHz
/// run (measured: up to 133 µm), and where the 1 kHz path is more than 50 µm off, halving the step cuts
/// the difference at least 1.5× (first order gives 2.33× against that reference). Below about 20 µm the
/// difference stops shrinking: against 16 kHz it stays at 10 to 18 µm at 8 kHz whether the solver makes
/// 3 or 30 Gauss-Seidel sweeps, so no order is claimed there (rapier's single precision is the suspect).
fn the_rig_converges_at_first_order(cases: u32) {
    let device = root().join("models/paper-device.toml");
    let device = mrfeel::device::DeviceConfig::load(&device, &Registry::builtin()).unwrap();
    let mut r = runner(cases);
    let strategy = (6.0..14.0f64, 0.7..3.0f64, 3.0..6.0f64, 0.0..0.9f64);
    r.run(&strategy, |(hand_n, f_hz, i0_a, i1)| {
        let path = |hz: f64| {
            let mut cfg = mrfeel::rig::RigConfig::new(root().join("models/stick-rig.urdf"));
            cfg.physics_hz = hz;
            cfg.gravity = false;
            let mut rig = mrfeel::rig::Rig::new(&cfg, device.damper()).unwrap();
            let every = (hz / 500.0).round() as usize;
            let mut out = Vec::new();
            for k in 0..hz as usize {
                let t = k as f64 / hz;
                if k % every == 0 {
                    out.push(rig.state().piston_x_m);
                }
                let w = 2.0 * std::f64::consts::PI * f_hz * t;
                rig.step(hand_n * w.sin(), i0_a * (1.0 + i1 * (0.5 * w).sin()));
            }
            (out, rig.stroke_limit_m())
        };
        let (fine, stroke) = path(8000.0);
        let travel = fine.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        prop_assume!(travel > 2e-3 && travel < 0.8 * stroke);
        let e: Vec<f64> = [1000.0, 2000.0, 4000.0]
            .iter()
            .map(|&h| rms_diff(&path(h).0, &fine))
            .collect();
        prop_assert!(
            (e[0] < 50e-6 || e[0] > 1.5 * e[1]) && e.iter().all(|&d| d < 254e-6),
            "{e:?}"
        );
        Ok(())
    })
    .unwrap();
}

/// The closed feel loop samples its sensors, quantises them and switches its rest mode at the DAQ's
/// instants, so a difference far below one ADC step can change one decision and its effect does not
/// shrink with the physics step: the loop's path has no order of convergence, but the default 1 kHz
/// step must already be converged for what a user reads. Its piston path stays within 0.5 % of the
/// stroke (254 µm RMS; measured up to 75 µm) of an 8 kHz run, and its force tracking error within 20 % (or 0.2 N) of the
/// 8 kHz run's (the largest difference measured: 12 %, 2.59 against 2.92 N).
fn the_closed_loop_at_1_khz_agrees_with_8_khz(cases: u32) {
    let mut r = runner(cases);
    let strategy = (0.05..0.25f64, 0.2..1.0f64, 500.0..2000.0f64);
    r.run(&strategy, |(amp, freq, grad)| {
        let edits = vec![
            ("", "duration_s", "1.0".to_string()),
            ("pilot", "amplitude_rad", format!("{amp:?}")),
            ("pilot", "frequency_hz", format!("{freq:?}")),
            ("feel", "gradient_n_per_m", format!("{grad:?}")),
            ("daq", "sample_rate_hz", "500.0".into()),
            ("load_cell", "noise_rms_n", "0.0".into()),
            ("laser", "noise_rms_m", "0.0".into()),
        ];
        let run = |hz: f64| {
            let mut e = edits.clone();
            e.push(("rig", "physics_hz", format!("{hz:?}")));
            let res = run_text(&paper_loop_text(&e)).unwrap();
            let every = (hz / 500.0).round() as usize;
            let path: Vec<f64> = res.rows.iter().step_by(every).map(|r| r.piston_x_m).collect();
            (path, res.summary().tracking_rmse_n.unwrap())
        };
        let ((coarse, err_1k), (fine, err_8k)) = (run(1000.0), run(8000.0));
        let e = rms_diff(&coarse, &fine);
        prop_assert!(e < 254e-6, "RMS piston path difference 1 kHz vs 8 kHz: {e:e} m");
        prop_assert!(
            (err_1k - err_8k).abs() < (0.2 * err_8k).max(0.2),
            "force tracking error {err_1k} N at 1 kHz against {err_8k} N at 8 kHz"
        );
        Ok(())
    })
    .unwrap();
}

/// Inputs of a sine of `amp_m` at `f_hz`, sampled at 1 kHz for `dur_s`, its current stepping through
/// `levels` every `dwell_s`.
fn stepped_sine(amp_m: f64, f_hz: f64, dur_s: f64, levels: &[f64], dwell_s: f64) -> Vec<Inputs> {
    let dt = 1e-3;
    let w = std::f64::consts::TAU * f_hz;
    (0..(dur_s / dt) as usize)
        .map(|k| {
            let t = k as f64 * dt;
            Inputs {
                t_s: t,
                x_m: amp_m * (w * t).sin(),
                v_m_s: amp_m * w * (w * t).cos(),
                a_m_s2: -amp_m * w * w * (w * t).sin(),
                current_cmd_a: levels[((t / dwell_s) as usize) % levels.len()],
            }
        })
        .collect()
}

/// The damper alone is passive: for random Bingham devices with both lags and random sine protocols with
/// current steps, the force never pushes along the motion (`F·v ≥ 0` at every sample).
fn the_damper_is_passive_for_any_device_and_protocol(cases: u32) {
    let model = Model::from_spec("bingham", &Registry::builtin(), 14.0).unwrap();
    let mut r = runner(cases);
    let strategy = (
        (
            0.0..50.0f64,
            0.0..10.0f64,
            0.0..500.0f64,
            1e-4..0.05f64,
            1e-4..0.05f64,
        ),
        (
            1e-3..0.05f64,
            0.1..10.0f64,
            proptest::collection::vec(0.0..14.0f64, 1..5),
        ),
    );
    r.run(&strategy, |((fc0, gain, c0, te, tm), (amp, f, levels))| {
        let inputs = stepped_sine(amp, f, 2.0, &levels, 0.13);
        let force = model.simulate(&[fc0, gain, c0, te, tm], &inputs);
        for (i, fo) in inputs.iter().zip(&force) {
            prop_assert!(fo * i.v_m_s >= 0.0, "F·v = {} at t = {}", fo * i.v_m_s, i.t_s);
        }
        Ok(())
    })
    .unwrap();
}

/// A fit of data made by a known Bingham device (both lags; current steps so that they show) with white
/// force noise recovers each parameter (the two lags as a pair) within twice its standard error in at least
/// 85 % of the (draw, parameter) pairs; the nominal coverage of ±2 standard errors is 95 % (measured: 302
/// of 320 pairs over 64 draws, `-- --ignored`).
fn a_fit_recovers_a_known_device_within_its_standard_errors(cases: u32) {
    let model = Model::from_spec("bingham", &Registry::builtin(), 14.0).unwrap();
    let (pairs, covered) = (std::cell::Cell::new(0usize), std::cell::Cell::new(0usize));
    let per_param = std::cell::RefCell::new([(0usize, 0usize); 5]);
    let mut r = runner(cases);
    let strategy = (
        (
            5.0..40.0f64,
            2.0..8.0f64,
            20.0..200.0f64,
            0.005..0.03f64,
            0.003..0.02f64,
        ),
        (0.01..0.025f64, 0.5..2.0f64, 0.2..2.0f64, any::<u64>()),
    );
    r.run(&strategy, |(truth, (amp, f, noise, seed))| {
        let truth = [truth.0, truth.1, truth.2, truth.3, truth.4];
        let inputs = stepped_sine(amp, f, 4.0, &[0.0, 14.0, 3.5, 10.5, 7.0], 0.25);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let normal = rand_distr::Normal::new(0.0, noise).unwrap();
        let f_n: Vec<f64> = model
            .simulate(&truth, &inputs)
            .into_iter()
            .map(|y| y + normal.sample(&mut rng))
            .collect();
        let tests = vec![Test {
            path: "known.csv".into(),
            name: "known.csv".into(),
            group: "known".into(),
            inputs,
            f_n,
            velocity_measured: true,
            velocity_noise_m_s: None,
            drive: None,
        }];
        let spans = mrfeel::ident::fit::all_spans(&tests);
        let fr = mrfeel::ident::fit::fit(&model, &tests, &spans, &Default::default());
        // The coil's and the fluid's lags are in series with the current's effect linear between them, so
        // they commute: the data tell the two lags as a pair, not which is which. Each fitted lag is
        // compared with the true lag of its rank.
        let mut truth_ranked = truth;
        if (fr.params[3] - fr.params[4]) * (truth[3] - truth[4]) < 0.0 {
            truth_ranked.swap(3, 4);
        }
        for (k, ((p, t), se)) in fr.params.iter().zip(&truth_ranked).zip(&fr.std_err).enumerate() {
            if let Some(se) = se {
                let hit = usize::from((p - t).abs() <= 2.0 * se);
                pairs.set(pairs.get() + 1);
                covered.set(covered.get() + hit);
                let mut pp = per_param.borrow_mut();
                pp[k].0 += hit;
                pp[k].1 += 1;
            }
        }
        Ok(())
    })
    .unwrap();
    let (pairs, covered) = (pairs.get(), covered.get());
    let coverage = covered as f64 / pairs as f64;
    eprintln!(
        "±2 standard errors covered the truth in {covered} of {pairs} (draw, parameter) pairs; per parameter \
         (fc0, gain, c0, tau_e, tau_m): {:?}",
        per_param.borrow()
    );
    assert!(
        pairs >= 5 * cases as usize / 2,
        "too few standard errors: {pairs}"
    );
    assert!(coverage >= 0.85, "coverage {coverage:.3} ({covered} of {pairs})");
}

/// Each property at its small count in the test command (a few seconds in all).
#[test]
fn every_random_run_keeps_the_invariants_or_names_the_setting() {
    every_run_is_finite_and_passive_or_fails_naming_the_setting(cases(12));
}

#[test]
fn the_rig_mechanics_converge_at_first_order() {
    the_rig_converges_at_first_order(cases(4));
}

#[test]
fn the_closed_loop_is_converged_at_its_default_step() {
    the_closed_loop_at_1_khz_agrees_with_8_khz(cases(4));
}

#[test]
fn the_damper_alone_is_passive() {
    the_damper_is_passive_for_any_device_and_protocol(cases(64));
}

#[test]
fn a_fit_of_a_known_device_covers_the_truth() {
    a_fit_recovers_a_known_device_within_its_standard_errors(cases(8));
}

/// The larger seeded sweep of every property.
#[test]
#[ignore = "a larger sweep: cargo test --test integration properties:: -- --ignored"]
fn larger_sweep_of_every_property() {
    every_run_is_finite_and_passive_or_fails_naming_the_setting(cases(200));
    the_damper_is_passive_for_any_device_and_protocol(cases(1000));
    a_fit_recovers_a_known_device_within_its_standard_errors(cases(64));
    the_rig_converges_at_first_order(cases(32));
    the_closed_loop_at_1_khz_agrees_with_8_khz(cases(32));
}
