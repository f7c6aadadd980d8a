//! Speed of model discovery, each figure with its baseline in the same run:
//! - `fit/real`: one simulation pass of `bingham+hysteresis` over the 15 real tests (82,638 samples, the
//!   unit of work), the plain `bingham` fit, and the `bingham+hysteresis` fit (goal < 0.5 s; scipy ~10 s),
//!   beside the same fit as logged and with each sample counted once in the loss (baselines);
//! - `diagnose/60k`: a `bingham` fit of 60,000 synthetic samples (baseline), the reading of their current
//!   commands that `mrfeel fit` and `mrfeel diagnose` decide first where a test's current steps (`auto`: the
//!   starting model fitted both ways, without standard errors), and `diagnose` over the named effects only
//!   (baseline) and with the open term search and the verdict on what is left (goal < 4 s on 2 cores), and
//!   with no base named (`bingham` ends at the noise floor here, so `spencer` is not fitted); with
//!   `MRFEEL_BENCH_BOUC_WEN=1` also a broadband Bouc–Wen record of 60,000 samples, where `spencer` is fitted,
//!   chosen and diagnosed from (minutes an iteration);
//! - `inputs/15000`: the model inputs of one displacement-only test (velocity, acceleration and the smoothed
//!   displacement derived, each by the widening quintic fits) on an even clock (baseline) and on a clock
//!   jittered by up to a quarter sample, where every sample gets its own fit.
//!
//! `cargo bench --bench ident`

use std::path::PathBuf;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};

use mrfeel::device::{Inputs, Model, ModelSpec, Registry};
use mrfeel::ident::diagnose::diagnose_choosing_base;
use mrfeel::ident::fit::{all_spans, fit, FitOptions, Weighting};
use mrfeel::ident::timing::{decide, TimingChoice};
use mrfeel::ident::{
    data_stats, diagnose, inputs_and_velocity_noise, load_tests, AcquisitionChoice, DiagnoseOptions, Test,
};
use mrfeel::measurement::Measurement;

fn real_tests() -> Vec<Test> {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/data/utfsm-mr-damper"));
    load_tests(&[dir]).expect("real data in data/utfsm-mr-damper")
}

fn bench_fit(c: &mut Criterion) {
    let tests = real_tests();
    let registry = Registry::builtin();
    let limit = mrfeel::ident::default_current_limit_a(&tests);
    let bing = Model::from_spec("bingham", &registry, limit).expect("model");
    let hyst = Model::from_spec("bingham+hysteresis", &registry, limit).expect("model");
    let spans = all_spans(&tests);
    let p = hyst.initial_guess(&data_stats(&tests));
    let mut g = c.benchmark_group("fit/real_15_files_82638_samples");
    g.sample_size(10).measurement_time(Duration::from_secs(20));
    g.bench_function("one simulation pass (bingham+hysteresis)", |b| {
        b.iter(|| mrfeel::ident::evaluate(&hyst, &p, &tests))
    });
    g.bench_function("fit bingham", |b| {
        b.iter(|| fit(&bing, &tests, &spans, &FitOptions::default()))
    });
    g.bench_function("fit bingham+hysteresis", |b| {
        b.iter(|| fit(&hyst, &tests, &spans, &FitOptions::default()))
    });
    // Baseline: the same files compared as logged, without the acquisition chain found in them.
    let plain: Vec<Test> = tests.iter().cloned().map(|t| Test { drive: None, ..t }).collect();
    g.bench_function("fit bingham+hysteresis, as logged (baseline)", |b| {
        b.iter(|| fit(&hyst, &plain, &spans, &FitOptions::default()))
    });
    // Baseline: each sample counted once in the loss (the default counts each test once).
    let by_samples = FitOptions {
        weighting: Weighting::Samples,
        ..FitOptions::default()
    };
    g.bench_function("fit bingham+hysteresis, each sample once (baseline)", |b| {
        b.iter(|| fit(&hyst, &tests, &spans, &by_samples))
    });
    g.finish();
}

/// Reading the 15 real files into tests: through the acquisition chain (its detection in the pooled spectra
/// and the deconvolution of the motion) against as logged (baseline), from the same parsed files.
fn bench_acquisition(c: &mut Criterion) {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/data/utfsm-mr-damper"));
    let ms = mrfeel::measurement::read_all(&[dir]).expect("real data");
    let mut g = c.benchmark_group("acquisition/real_15_files_82638_samples");
    g.sample_size(10).measurement_time(Duration::from_secs(10));
    g.bench_function("tests as logged (baseline)", |b| {
        b.iter(|| mrfeel::ident::tests_with(&ms, AcquisitionChoice::AsLogged))
    });
    g.bench_function("tests through the chain (detect + deconvolve)", |b| {
        b.iter(|| mrfeel::ident::tests_from(&ms))
    });
    g.finish();
}

/// 60,000 samples: 4 tests of 15 s at 1 kHz, sine displacement at four amplitude/frequency pairs, current
/// stepping over 0–14 A, the paper's device with hidden hysteresis, 0.4 N noise.
fn synthetic_60k(registry: &Registry) -> Vec<Test> {
    let model = Model::from_spec("bingham+hysteresis", registry, 14.0).expect("model");
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(60_000);
    let noise = Normal::new(0.0, 0.4).expect("sigma");
    let mut tests: Vec<Test> = (0..4)
        .map(|j| {
            let (a, f) = (0.02 / (1.0 + 0.3 * j as f64), 1.0 + 0.5 * j as f64);
            let w = 2.0 * std::f64::consts::PI * f;
            let inputs: Vec<Inputs> = (0..15_000)
                .map(|k| {
                    let t = k as f64 * 1e-3;
                    Inputs {
                        t_s: t,
                        x_m: a * (w * t).sin(),
                        v_m_s: a * w * (w * t).cos(),
                        a_m_s2: -a * w * w * (w * t).sin(),
                        current_cmd_a: 3.5 * ((k / 400 + j) % 5) as f64,
                    }
                })
                .collect();
            Test {
                path: format!("g{j}_run.csv").into(),
                name: format!("g{j}_run.csv"),
                group: format!("g{j}"),
                inputs,
                f_n: Vec::new(),
                velocity_measured: true,
                velocity_noise_m_s: None,
                drive: None,
            }
        })
        .collect();
    // The effect's typical strength follows the base device's statistics on these inputs (as `mrfeel mts
    // --effects` does): run the base model first.
    let base = Model::from_spec("bingham", registry, 14.0).expect("model");
    for t in &mut tests {
        t.f_n = base.simulate(&[2.0, 4.83, 60.0, 0.015, 0.008], &t.inputs);
    }
    let stats = data_stats(&tests);
    let p = model
        .typical_params(&[2.0, 4.83, 60.0, 0.015, 0.008], &stats)
        .expect("typical");
    for t in &mut tests {
        t.f_n = model
            .simulate(&p, &t.inputs)
            .into_iter()
            .map(|f| f + noise.sample(&mut rng))
            .collect();
    }
    tests
}

fn bench_diagnose(c: &mut Criterion) {
    let registry = Registry::builtin();
    let tests = synthetic_60k(&registry);
    let bing = Model::from_spec("bingham", &registry, 14.0).expect("model");
    let spans = all_spans(&tests);
    let base = ModelSpec::parse("bingham").expect("spec");
    let opts = DiagnoseOptions {
        current_limit_a: 14.0,
        open_search: true,
        ..Default::default()
    };
    let mut g = c.benchmark_group("diagnose/60000_samples");
    g.sample_size(10).measurement_time(Duration::from_secs(60));
    g.bench_function("fit bingham", |b| {
        b.iter(|| fit(&bing, &tests, &spans, &FitOptions::default()))
    });
    let quick = FitOptions {
        std_errors: false,
        ..FitOptions::default()
    };
    g.bench_function("decide command timing (auto)", |b| {
        b.iter_batched(
            || tests.clone(),
            |t| decide(&bing, t, TimingChoice::Auto, &quick),
            BatchSize::LargeInput,
        )
    });
    let named_only = DiagnoseOptions {
        open_search: false,
        ..opts.clone()
    };
    g.bench_function("diagnose, named effects only (baseline)", |b| {
        b.iter(|| diagnose(&tests, &base, &registry, &named_only).expect("diagnose"))
    });
    g.bench_function("diagnose with the open search and the verdict", |b| {
        b.iter(|| diagnose(&tests, &base, &registry, &opts).expect("diagnose"))
    });
    // No base named: `bingham`'s diagnosis ends at the noise floor here, so no other base is fitted.
    g.bench_function("diagnose, base chosen by held-out error", |b| {
        b.iter(|| diagnose_choosing_base(&tests, &registry, &opts).expect("diagnose"))
    });
    // A Bouc–Wen damper on broadband motion: `spencer` is fitted, chosen, and diagnosed from. Minutes an
    // iteration (stiff 14-parameter fits): only with MRFEEL_BENCH_BOUC_WEN=1.
    if std::env::var("MRFEEL_BENCH_BOUC_WEN").is_ok_and(|v| v == "1") {
        let bw = broadband_bouc_wen_60k(&registry);
        let bw_opts = DiagnoseOptions {
            current_limit_a: 1.0,
            ..opts.clone()
        };
        g.bench_function("diagnose, base chosen, broadband Bouc-Wen at 3 kHz", |b| {
            b.iter(|| diagnose_choosing_base(&bw, &registry, &bw_opts).expect("diagnose"))
        });
    }
    g.finish();
}

/// 60,000 samples of one record at 3 kHz: a Spencer et al. (1997) damper (the paper's parameters, forces
/// ×0.6 over lengths ×0.4, 1 A standing for 2 V) on a random multisine of 60 lines in 0.2–12 Hz (peak 10 mm),
/// the command switched between random levels in 0–1 A, 4 N of load-cell noise.
fn broadband_bouc_wen_60k(registry: &Registry) -> Vec<Test> {
    use rand::Rng;
    let model = Model::from_spec("spencer", registry, 1.0).expect("model");
    // In `spencer::PARAMS` order: αa, αb, c0a, c0b, c1a, c1b, k0, k1, x0, β, γ, A, n, 1/η.
    let (f, l, v) = (0.6 / 0.4, 0.4, 2.0);
    let factor = [
        f,
        f * v,
        f,
        f * v,
        f,
        f * v,
        f,
        f,
        l,
        1.0 / (l * l),
        1.0 / (l * l),
        1.0,
        1.0,
        1.0,
    ];
    let p: Vec<f64> = mrfeel::device::spencer::SPENCER_1997
        .iter()
        .zip(factor)
        .map(|(p, s)| p * s)
        .collect();
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3_000);
    let lines: Vec<(f64, f64, f64)> = (0..60)
        .map(|_| {
            let f: f64 = rng.random_range(0.2..12.0);
            (
                std::f64::consts::TAU * f,
                rng.random_range(0.5..1.5) / f,
                rng.random_range(0.0..std::f64::consts::TAU),
            )
        })
        .collect();
    let n = 60_000;
    let dt = 1.0 / 3000.0;
    let raw = |t: f64| -> (f64, f64, f64) {
        lines.iter().fold((0.0, 0.0, 0.0), |(x, v, a), (w, c, ph)| {
            let (s, co) = (w * t + ph).sin_cos();
            (x + c * s, v + c * w * co, a - c * w * w * s)
        })
    };
    let peak = (0..n).map(|k| raw(k as f64 * dt).0.abs()).fold(0.0, f64::max);
    let scale = 0.01 / peak;
    let mut level = 0.5;
    let mut next_switch = 0.0;
    let inputs: Vec<Inputs> = (0..n)
        .map(|k| {
            let t = k as f64 * dt;
            if t >= next_switch {
                level = 0.25 * rng.random_range(0..5) as f64;
                next_switch = t + rng.random_range(0.2..1.2);
            }
            let (x, v, a) = raw(t);
            Inputs {
                t_s: t,
                x_m: scale * x,
                v_m_s: scale * v,
                a_m_s2: scale * a,
                current_cmd_a: level,
            }
        })
        .collect();
    let noise = Normal::new(0.0, 4.0).expect("sigma");
    let f_n = model
        .simulate(&p, &inputs)
        .into_iter()
        .map(|f| f + noise.sample(&mut rng))
        .collect();
    vec![Test {
        path: "broadband.csv".into(),
        name: "broadband.csv".into(),
        group: "broadband".into(),
        inputs,
        f_n,
        velocity_measured: true,
        velocity_noise_m_s: None,
        drive: None,
    }]
}

/// A 1 Hz, 20 mm sine without a velocity channel, 15,000 samples at 1 kHz with 2 µm of noise, on an even
/// clock or one jittered by up to ¼ sample.
fn displacement_only(jittered: bool) -> Measurement {
    use rand::Rng;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(15_000);
    let noise = Normal::new(0.0, 2e-6).expect("sigma");
    let t: Vec<f64> = (0..15_000)
        .map(|k| {
            (k as f64
                + if jittered {
                    rng.random_range(-0.25..0.25)
                } else {
                    0.0
                })
                * 1e-3
        })
        .collect();
    let w = std::f64::consts::TAU;
    let x: Vec<f64> = t
        .iter()
        .map(|t| 0.02 * (w * t).sin() + noise.sample(&mut rng))
        .collect();
    Measurement {
        path: "bench.csv".into(),
        v_m_s: mrfeel::measurement::smooth_derivative(&t, &x),
        i_a: vec![1.0; t.len()],
        f_n: vec![0.0; t.len()],
        x_m: x,
        t_s: t,
        velocity_measured: false,
        ..Default::default()
    }
}

fn bench_inputs(c: &mut Criterion) {
    let mut g = c.benchmark_group("inputs/15000_samples_displacement_only");
    for (name, jittered) in [("even clock", false), ("jittered clock", true)] {
        let m = displacement_only(jittered);
        g.bench_function(name, |b| b.iter(|| inputs_and_velocity_noise(&m)));
    }
    g.finish();
}

criterion_group!(
    benches,
    bench_fit,
    bench_diagnose,
    bench_inputs,
    bench_acquisition
);
criterion_main!(benches);
