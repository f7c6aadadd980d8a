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
    let outcome = match plan.scenario(run) {
        Err(e) => Outcome::failed(e.to_string()),
        Ok(scn) => outcome(plan, &scn),
    };
    record(run, outcome)
}

fn record(run: &Run, outcome: Outcome) -> Record {
    Record {
        index: run.index,
        seed: run.seed,
        params: run.params.clone(),
        outcome,
    }
}

/// A run of `plan` with its scenario `scn`, as `mrfeel run` runs it, to its outcome, except that a run
/// whose only broken invariant is the load cell's range is a design point (a real rig would do the same),
/// not a failed run: its figures are kept, with `load_cell_ok = false` and the peak. Every other invariant
/// still fails the run.
fn outcome(plan: &Plan, scn: &crate::scenario::Scenario) -> Outcome {
    match run_kept(scn, &plan.scenario_path) {
        Ok(res) => Outcome::of(&res, scn, plan.prolonged_window_s),
        Err(msg) => Outcome::failed(msg),
    }
}

/// The run of [`outcome`], its rows kept; an error is the run's failure, in words.
fn run_kept(scn: &crate::scenario::Scenario, path: &std::path::Path) -> Result<crate::sim::Results, String> {
    use crate::sim::{CollectError, SimError};
    let devices = crate::sim::Devices::load(scn).map_err(|e| format!("{e:#}"))?;
    let rig = crate::sim::build_rig(scn, &devices.plant).map_err(|e| format!("{e:#}"))?;
    let stops_rad = rig.stick_limits_rad();
    let steps = (scn.duration_s * scn.physics_rate_hz()).round() as usize;
    let mut collector = crate::sim::Collector::keeping(true, false);
    let run = collector.run(scn, &devices, rig, crate::sim::RunOptions::default(), |_| {});
    let failed = |e: &dyn std::fmt::Display| format!("running scenario {}: {e}", path.display());
    match (run, collector.stopped()) {
        (Ok((res, _)), _) => Ok(res),
        // Run to its end (the range is judged there): the other invariants judged with the range lifted.
        (Err(CollectError::Run(e @ SimError::Invariant { .. })), Some(mut res))
            if res.rows.len() == steps =>
        {
            // The stick's end stops take energy at an impact, as in the run's own check.
            let mut check = crate::sim::invariants::Checker::new(scn)
                .with_stops(stops_rad)
                .without_range();
            let judged = res
                .rows
                .iter()
                .try_for_each(|r| check.push(r))
                .and_then(|()| check.finish(res.summary()));
            res.stops_j = judged.map_err(|_| failed(&e))?.stops_j;
            Ok(res)
        }
        (Err(e), _) => Err(failed(&e)),
    }
}

/// The runs of `shard` of `plan`, each with its scenario built and checked: a bad value stops a sweep
/// before it starts.
pub fn checked_runs(plan: &Plan, shard: Shard) -> Result<Vec<(Run, crate::scenario::Scenario)>, PlanError> {
    (0..plan.run_count())
        .filter(|&i| shard.contains(i))
        .map(|i| {
            let run = plan.run(i);
            plan.scenario(&run).map(|scn| (run, scn))
        })
        .collect()
}

/// Run the `runs` of a shard of `plan` ([`checked_runs`]) into `store`: every one not in it yet, on `jobs`
/// threads, each appended to the journal as it finishes (`progress` told of it); then the results of the
/// whole shard.
pub fn execute(
    plan: &Plan,
    store: Store,
    runs: Vec<(Run, crate::scenario::Scenario)>,
    jobs: usize,
    progress: &(dyn Fn(u64) + Sync),
) -> anyhow::Result<Vec<Record>> {
    use rayon::prelude::*;
    use std::sync::Mutex;
    let done: std::collections::HashSet<u64> = store.done.iter().map(|r| r.index).collect();
    let todo: Vec<_> = runs
        .into_iter()
        .filter(|(run, _)| !done.contains(&run.index))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new().num_threads(jobs.max(1)).build()?;
    let store = Mutex::new(store);
    let fresh = Mutex::new(Vec::with_capacity(todo.len()));
    pool.install(|| {
        todo.par_iter().try_for_each(|(run, scn)| -> anyhow::Result<()> {
            let rec = record(run, outcome(plan, scn));
            store
                .lock()
                .map_err(|_| anyhow::anyhow!("a worker failed while writing the journal"))?
                .append(&rec)?;
            fresh
                .lock()
                .map_err(|_| anyhow::anyhow!("a worker failed while collecting results"))?
                .push(rec);
            progress(run.index);
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
