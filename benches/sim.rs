//! One full closed-loop step (rig multibody + MR damper, sensors and DAQ, feel controller with PID, pilot
//! hand) against a baseline in the same run: the rig step alone with the same kind of input. Plus the whole
//! `paper-feel-loop` scenario (12 s of 1 kHz physics), whose time gives the real-time factor.
//!
//! `cargo bench --bench sim`

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use mrfeel::sim::{self, cli, Loop, Plant, RunOptions};

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-feel-loop.toml");
    let (scn, device, _) = cli::load(&path).unwrap();
    let mut g = c.benchmark_group("sim_step_1khz");
    {
        let mut lp = Loop::new(&scn, &device, cli::build_rig(&scn, &device).unwrap()).unwrap();
        g.bench_function("full_loop_step", |b| {
            b.iter(|| black_box(lp.step().unwrap().load_cell_true_n))
        });
    }
    {
        // Baseline: the rig step alone, driven by a 0.25 Hz push so it moves as in the scenario.
        let mut rig = cli::build_rig(&scn, &device).unwrap();
        let mut k = 0u64;
        g.bench_function("baseline_rig_step_only", |b| {
            b.iter(|| {
                let f = 8.0 * (2.0 * std::f64::consts::PI * 0.25 * k as f64 * 1e-3).sin();
                Plant::step(&mut rig, black_box(f), black_box(4.0));
                k += 1;
                black_box(Plant::state(&rig).load_cell_n)
            })
        });
    }
    g.finish();
    let mut g = c.benchmark_group("scenario");
    g.sample_size(10);
    g.bench_function("paper_feel_loop_12s_at_1khz", |b| {
        b.iter(|| {
            let rig = cli::build_rig(&scn, &device).unwrap();
            black_box(
                sim::run(&scn, &device, rig, RunOptions::default(), |_| {})
                    .unwrap()
                    .rows
                    .len(),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
