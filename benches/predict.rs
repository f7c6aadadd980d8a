//! Speed of a model's prediction on 100,000 samples, the Rust side of the Python comparison
//! (`python/bench_predict.py` times `mrfeel.Model.predict` on the same motion):
//! - `predict/100k/simulate`: the model's simulation alone on inputs prepared beforehand (baseline);
//! - `predict/100k/from_columns`: what `Model.predict(t, x, i)` asks of the library: the columns checked
//!   ([`Measurement::from_columns`]), the velocity and acceleration derived, the model run
//!   ([`mrfeel::prelude::predict`]).
//!
//! `cargo bench --bench predict`

use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};

use mrfeel::device::{DeviceConfig, Registry};
use mrfeel::measurement::Measurement;

/// The motion of the comparison: 100 s at 1 kHz of an 8 mm sine at 1.5 Hz, the current stepping from
/// 0.2 A to 0.8 A every 10 s (`python/bench_predict.py` builds the same arrays).
pub fn motion() -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = 100_000;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
    let x = t
        .iter()
        .map(|t| 0.008 * (2.0 * std::f64::consts::PI * 1.5 * t).sin())
        .collect();
    let i = t
        .iter()
        .map(|t| {
            if (t / 10.0).floor() as i64 % 2 == 0 {
                0.2
            } else {
                0.8
            }
        })
        .collect();
    (t, x, i)
}

fn bench(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let cfg = DeviceConfig::load(&root.join("models/paper-device.toml"), &Registry::builtin())
        .expect("the paper's device");
    let (t, x, i) = motion();
    let zeros = vec![0.0; t.len()];
    let columns =
        || Measurement::from_columns("arrays", t.clone(), x.clone(), i.clone(), zeros.clone(), None);
    let m = columns().expect("valid columns");
    let inputs = mrfeel::ident::inputs_of(&m);
    let mut g = c.benchmark_group("predict/100k");
    g.sample_size(20);
    g.bench_function("simulate", |b| {
        b.iter(|| cfg.model.simulate(&cfg.params, &inputs))
    });
    g.bench_function("from_columns", |b| {
        b.iter(|| mrfeel::prelude::predict(&cfg, &columns().expect("valid columns")))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
