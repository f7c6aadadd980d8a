//! A sweep's speed, its cost against the sum of its runs' own time, and its speed-up on two cores, in one
//! run: the 12 runs of `scenarios/sweeps/paper-feel-small.toml` (2 s of 1 kHz physics each, the paper's
//! whole feel loop: rig, MR damper, sensors and DAQ, PID, pilot)
//! - `runs_alone_sum`: each run by itself (`sweep::run_one`: its scenario built and checked, device loaded,
//!   run, verdicts), one after another on one core: the baseline, and the runs against real time (issue
//!   goal: ≥ 250× on one core);
//! - `sweep_jobs_1`: `sweep::execute` on one thread (the runs checked first, the journal, results Parquet
//!   and CSV): its time over the baseline's is the sweep's overhead (goal < 5 %);
//! - `sweep_jobs_2`: the same on two threads (goal ≥ 1.8× the throughput of `sweep_jobs_1`);
//! - `sweep_without_runs`: what `sweep_jobs_1` does besides the runs (the scenarios checked, the journal,
//!   the results written), with the runs' records made beforehand: the part of the overhead that does not
//!   grow with the runs' length.
//!
//! Throughput is in **simulated seconds** (`elem` = 1 s simulated), so `thrpt: N elem/s` reads as "N×
//! faster than real time"; runs per second are that over 2 (each run simulates 2 s).
//!
//! With `MRFEEL_BENCH_RAY=HOST:PORT` (a Ray cluster of 2 CPUs that `ray start --head --num-cpus 2` started),
//! a second group compares the command line's two ways of running the same sweep, each a whole `mrfeel`
//! process with its results, report and maps written:
//! - `local_jobs_2`: `mrfeel sweep PLAN --out DIR --jobs 2`: the baseline;
//! - `ray_2_shards`: `mrfeel sweep PLAN --out DIR --ray HOST:PORT --shards 2`: the shards as two Ray tasks
//!   (the driver `python/sweep_ray.py` in the checkout's Python, each task a `mrfeel sweep --shard`), then
//!   merged: its time over the baseline's is Ray's overhead on this plan.
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
    let simulated_s: f64 = (0..n)
        .map(|i| plan.scenario(&plan.run(i)).unwrap().duration_s)
        .sum();
    assert_eq!(simulated_s.fract(), 0.0, "whole simulated seconds: {simulated_s}");
    let mut g = c.benchmark_group("sweep_12_runs");
    g.sample_size(10);
    g.throughput(Throughput::Elements(simulated_s as u64));
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
                    let runs = sweep::checked_runs(&plan, Shard::ALL).unwrap();
                    black_box(sweep::execute(&plan, store, runs, jobs, &|_| {}).unwrap());
                    dir
                },
                criterion::BatchSize::PerIteration,
            )
        });
    }
    // What `sweep_jobs_1` does besides the runs, with their records already made: the scenarios checked,
    // the journal appended to, the results written.
    let records: Vec<_> = (0..n).map(|i| sweep::run_one(&plan, &plan.run(i))).collect();
    g.bench_function("sweep_without_runs", |b| {
        b.iter_batched(
            || tempfile::tempdir().unwrap(),
            |dir| {
                let mut store = Store::open(dir.path(), &plan, Shard::ALL).unwrap();
                for i in 0..n {
                    black_box(plan.scenario(&plan.run(i)).unwrap());
                }
                for r in &records {
                    store.append(r).unwrap();
                }
                store.finish(&mut records.clone()).unwrap();
                dir
            },
            criterion::BatchSize::PerIteration,
        )
    });
    g.finish();

    let Ok(address) = std::env::var("MRFEEL_BENCH_RAY") else {
        return;
    };
    let mrfeel = env!("CARGO_BIN_EXE_mrfeel");
    let sweep_cli = |extra: &[&str]| {
        let dir = tempfile::tempdir().unwrap();
        let out = std::process::Command::new(mrfeel)
            .arg("sweep")
            .arg(&path)
            .arg("--out")
            .arg(dir.path().join("out"))
            .args(extra)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "mrfeel sweep {extra:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        dir
    };
    let mut g = c.benchmark_group("sweep_12_runs_cli");
    g.sample_size(10);
    g.throughput(Throughput::Elements(simulated_s as u64));
    g.bench_function("local_jobs_2", |b| b.iter(|| sweep_cli(&["--jobs", "2"])));
    g.bench_function("ray_2_shards", |b| {
        b.iter(|| sweep_cli(&["--ray", &address, "--shards", "2"]))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
