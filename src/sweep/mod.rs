//! Sweeps: one scenario run over a plan's axes (feel law, controller gains, DAQ rate, device, flight
//! condition, pilot, faults), in parallel, in shards any scheduler can run, resumable, with
//! handling-qualities verdicts per run.
//!
//! An output directory holds `sweep.toml` (which plan, which shard), `runs.jsonl` (one line per finished
//! run, appended as runs finish: what a rerun skips), and when its runs are all done `results.parquet`,
//! `results.csv` (one row per run, by index), `report.md` and the maps. Every file but the journal's
//! order depends only on the plan and the runs' results, so shards merged equal one process to the byte.

pub(crate) mod hq;
pub(crate) mod outcome;
pub mod plan;
pub mod report;
pub(crate) mod steady;
pub mod store;

pub use outcome::Outcome;
pub use plan::{Param, Plan, PlanError, Run};
pub use store::{Record, Shard, Store};

/// Run one run of a plan to its outcome (an error of the run itself is its outcome, not the sweep's).
pub fn run_one(plan: &Plan, run: &Run) -> Record {
    // The run as `mrfeel run` runs it (the prelude's one path: device, rig, loop).
    let outcome = match plan.scenario(run) {
        Err(e) => Outcome::failed(e.to_string()),
        Ok(scn) => match crate::prelude::run_scenario(&scn, &plan.scenario_path) {
            Err(e) => Outcome::failed(format!("{e:#}")),
            Ok(res) => Outcome::of(&res, &scn, plan.prolonged_window_s),
        },
    };
    Record {
        index: run.index,
        seed: run.seed,
        params: run.params.clone(),
        outcome,
    }
}

/// Run `shard` of `plan` into `store`: every run of the shard not in it yet, on `jobs` threads, each
/// appended to the journal as it finishes; then the results of the whole shard. `progress` is told of each
/// run finished. Every run's scenario is checked before any runs, so a bad axis value stops nothing
/// half-way.
pub fn execute(
    plan: &Plan,
    store: Store,
    shard: Shard,
    jobs: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> anyhow::Result<Vec<Record>> {
    use rayon::prelude::*;
    use std::sync::Mutex;
    let done: std::collections::HashSet<u64> = store.done.iter().map(|r| r.index).collect();
    let todo: Vec<u64> = (0..plan.run_count())
        .filter(|&i| shard.contains(i) && !done.contains(&i))
        .collect();
    for &i in &todo {
        plan.scenario(&plan.run(i))?;
    }
    let pool = rayon::ThreadPoolBuilder::new().num_threads(jobs.max(1)).build()?;
    let store = Mutex::new(store);
    let fresh = Mutex::new(Vec::with_capacity(todo.len()));
    pool.install(|| {
        todo.par_iter().try_for_each(|&i| -> anyhow::Result<()> {
            let rec = run_one(plan, &plan.run(i));
            store
                .lock()
                .map_err(|_| anyhow::anyhow!("a worker failed while writing the journal"))?
                .append(&rec)?;
            fresh
                .lock()
                .map_err(|_| anyhow::anyhow!("a worker failed while collecting results"))?
                .push(rec);
            progress(i);
            Ok(())
        })
    })?;
    let store = store
        .into_inner()
        .map_err(|_| anyhow::anyhow!("a worker failed while writing the journal"))?;
    let mut records = store.done.clone();
    records.extend(fresh.into_inner().unwrap_or_default());
    store.finish(&mut records)?;
    records.sort_by_key(|r| r.index);
    Ok(records)
}
