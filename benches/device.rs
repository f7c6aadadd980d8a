//! Device-model steps per second: the paper's model stepped in time (eval + exact lag advance), against a
//! baseline of the bare Eq. (2) expression with no state, in the same run.
//!
//! `cargo bench --bench device`

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mrfeel::device::{DeviceConfig, Inputs, Registry, Step};

const N: usize = 10_000;

fn inputs() -> Vec<Inputs> {
    (0..N)
        .map(|k| {
            let t = k as f64 * 1e-3;
            let w = 2.0 * std::f64::consts::PI;
            Inputs {
                t_s: t,
                x_m: 0.02 * (w * t).sin(),
                v_m_s: 0.02 * w * (w * t).cos(),
                a_m_s2: 0.0,
                current_cmd_a: if (k / 500) % 2 == 0 { 2.2 } else { 14.0 },
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let dev = DeviceConfig::from_toml(
        mrfeel::builtin::PAPER_DEVICE,
        Path::new("models/paper-device.toml"),
        &Registry::builtin(),
    )
    .expect("paper device");
    let inp = inputs();
    let mut g = c.benchmark_group("device_step");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function("baseline: bare Eq. (2), no lags, no state", |b| {
        let (fc, c0) = (
            dev.param("fc_gain_n_per_a").unwrap(),
            dev.param("c0_n_s_per_m").unwrap(),
        );
        b.iter(|| {
            let mut s = 0.0;
            for i in &inp {
                s += fc * i.current_cmd_a.min(14.0) * i.v_m_s.signum() + c0 * i.v_m_s;
            }
            black_box(s)
        })
    });
    g.bench_function("bingham: Damper eval + advance (Eq. 2-6)", |b| {
        let mut d = dev.damper();
        b.iter(|| {
            d.reset(&inp[0]);
            let mut s = 0.0;
            for w in inp.windows(2) {
                let st = d.eval(&w[0]);
                s += st.force_n(w[0].v_m_s);
                d.advance(
                    &w[0],
                    &st,
                    Step {
                        dt_s: w[1].t_s - w[0].t_s,
                        dx_m: w[1].x_m - w[0].x_m,
                    },
                );
            }
            black_box(s)
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
