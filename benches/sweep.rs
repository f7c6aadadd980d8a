//! A sweep's cost against the sum of its runs' own time, and its speed-up on two cores, in one run: the
//! 12 runs of `scenarios/sweeps/paper-feel-small.toml` (2 s of 1 kHz physics each)
//! - `runs_alone_sum`: each run by itself (`sweep::run_one`, its scenario checked, device loaded, run),
//!   one after another: the baseline;
//! - `sweep_jobs_1`: `sweep::execute` on one thread (the runs checked first, the journal, results CSV and
//!   Arrow): its time over the baseline's is the sweep's overhead (target < 5 %);
//! - `sweep_jobs_2`: the same on two threads (target ≥ 1.8× the runs per second of one).
//!
//! Throughput is in runs, so `thrpt` reads as runs per second.
//!
//! `cargo bench --bench sweep`

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mrfeel::sweep::{self, Plan, Shard, Store};

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/sweeps/paper-feel-small.toml");
    let plan = Plan::load(&path).unwrap();
    let n = plan.run_count();
    let mut g = c.benchmark_group("sweep_12_runs");
    g.sample_size(10);
    g.throughput(Throughput::Elements(n));
    g.bench_function("runs_alone_sum", |b| {
        b.iter(|| {
            for i in 0..n {
                black_box(sweep::run_one(&plan, &plan.run(i)));
            }
        })
    });
    for jobs in [1usize, 2] {
        g.bench_function(format!("sweep_jobs_{jobs}"), |b| {
            b.iter_batched(
                || tempfile::tempdir().unwrap(),
                |dir| {
                    let store = Store::open(dir.path(), &plan, Shard::ALL).unwrap();
                    black_box(sweep::execute(&plan, store, Shard::ALL, jobs, &|_| {}).unwrap());
                    dir
                },
                criterion::BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
