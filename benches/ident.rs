//! Speed of model discovery, each figure with its baseline in the same run:
//! - `fit/real`: one simulation pass of `bingham+hysteresis` over the 15 real tests (82,638 samples, the
//!   unit of work), the plain `bingham` fit, and the `bingham+hysteresis` fit (goal < 0.5 s; scipy ~10 s),
//!   beside the same fit as logged and with each sample counted once in the loss (baselines);
//! - `diagnose/60k`: a `bingham` fit of 60,000 synthetic samples (baseline), the reading of their current
//!   commands that `mrfeel fit` and `mrfeel diagnose` decide first where a test's current steps (`auto`: the
//!   starting model fitted both ways, without standard errors), and `diagnose` over the whole effect
//!   vocabulary on them (goal < 10 s on 2 cores, with the decision);
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
use mrfeel::ident::fit::{all_spans, fit, FitOptions, Weighting};
use mrfeel::ident::timing::{decide, TimingChoice};
use mrfeel::ident::{
    data_stats, diagnose, inputs_and_velocity_noise, load_tests, AcquisitionChoice, DiagnoseOptions, Test,
};
use mrfeel::measurement::Measurement;

fn real_tests() -> Vec<Test> {
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/utfsm-mr-damper"
    ));
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
    let dir = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/data/utfsm-mr-damper"
    ));
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
    g.bench_function("diagnose whole vocabulary", |b| {
        b.iter(|| diagnose(&tests, &base, &registry, &opts).expect("diagnose"))
    });
    g.finish();
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
