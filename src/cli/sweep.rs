//! The `sweep` subcommand: `mrfeel sweep PLAN --out DIR [--jobs N] [--shard K/N]` and
//! `mrfeel sweep merge DIR... --out OUT`.

use std::path::{Path, PathBuf};

use mrfeel::sweep::plan::Plan;
use mrfeel::sweep::store::{self, Shard, Store};
use mrfeel::sweep::{report, Record};

/// `mrfeel sweep`.
#[derive(Debug, clap::Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    pub command: Option<SweepCommand>,
    /// Sweep plan (`scenarios/sweeps/*.toml`).
    #[arg(required = true)]
    pub plan: Option<PathBuf>,
    /// Output directory: `sweep.toml`, `runs.jsonl` (what a rerun skips), `results.csv`,
    /// `results.parquet`, `report.md`, maps.
    #[arg(long, required = true)]
    pub out: Option<PathBuf>,
    /// Runs in parallel on this machine (threads; default: every core).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Run only shard K of N (0-based: the runs whose index is K modulo N), e.g. under Slurm
    /// `--shard $SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT` with `--array=0-(N-1)`.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
}

#[derive(Debug, clap::Subcommand)]
pub enum SweepCommand {
    /// Join the output directories of a plan's shards into one, as one process would have written it.
    Merge(MergeArgs),
}

#[derive(Debug, clap::Args)]
pub struct MergeArgs {
    /// The shards' output directories.
    #[arg(required = true)]
    pub dirs: Vec<PathBuf>,
    /// The merged output directory.
    #[arg(long)]
    pub out: PathBuf,
}

impl SweepArgs {
    /// The directories the command writes.
    pub fn out_dir(&self) -> Option<&PathBuf> {
        match &self.command {
            Some(SweepCommand::Merge(m)) => Some(&m.out),
            None => self.out.as_ref(),
        }
    }
}

/// `mrfeel sweep ...`.
pub fn run_cmd(args: &SweepArgs) -> anyhow::Result<()> {
    if let Some(SweepCommand::Merge(m)) = &args.command {
        let n = store::merge(&m.dirs, &m.out)?;
        mrfeel::outln!("merged {n} runs into {}", m.out.display())?;
        return finish(&m.out, None);
    }
    let (Some(plan_path), Some(out)) = (&args.plan, &args.out) else {
        anyhow::bail!("give a plan and --out DIR (or `mrfeel sweep merge DIR... --out OUT`)");
    };
    let plan = Plan::load(plan_path)?;
    let shard = args.shard.unwrap_or(Shard::ALL);
    // Every run's scenario checked before the output directory is made: a refused plan writes nothing.
    for i in (0..plan.run_count()).filter(|&i| shard.contains(i)) {
        plan.scenario(&plan.run(i))?;
    }
    let store = Store::open(out, &plan, shard)?;
    let total = (0..plan.run_count()).filter(|&i| shard.contains(i)).count() as u64;
    let already = store.done.len() as u64;
    let jobs = args.jobs.unwrap_or_else(rayon::current_num_threads);
    anyhow::ensure!(jobs >= 1, "--jobs 0: give at least 1");
    let pb = super::progress_bar(
        total,
        "sweep [{bar:40}] {pos}/{len} runs {elapsed_precise} eta {eta}",
    );
    pb.set_position(already);
    let records = mrfeel::sweep::execute(&plan, store, shard, jobs, &|_| pb.inc(1))?;
    pb.finish_and_clear();
    mrfeel::outln!(
        "{}: {} runs ({} resumed from {}), shard {}",
        plan.name,
        records.len(),
        already,
        out.join(store::JOURNAL).display(),
        if shard == Shard::ALL {
            "all".to_string()
        } else {
            format!("{}/{}", shard.k, shard.n)
        }
    )?;
    if shard == Shard::ALL {
        finish(out, Some(&plan))
    } else {
        mrfeel::outln!("  merge the shards with: mrfeel sweep merge DIR... --out OUT")?;
        Ok(())
    }
}

/// The summary, report and maps of a complete output directory.
fn finish(dir: &Path, plan: Option<&Plan>) -> anyhow::Result<()> {
    let (columns, records) = store::read_results(dir)?;
    let name = plan.map_or_else(|| dir.display().to_string(), |p| p.name.clone());
    let maps = match plan.and_then(|p| p.map.as_ref()) {
        Some(spec) => report::maps(dir, spec, &columns, &records).map_err(anyhow::Error::msg)?,
        None => Vec::new(),
    };
    let text = report::report(&name, &columns, &records, &maps);
    std::fs::write(dir.join("report.md"), &text)?;
    print_summary(&columns, &records)?;
    mrfeel::outln!(
        "  results: {}, {}; report: {}",
        dir.join(store::RESULTS_PARQUET).display(),
        dir.join(store::RESULTS_CSV).display(),
        dir.join("report.md").display()
    )?;
    for m in &maps {
        mrfeel::outln!("  map: {}", m.display())?;
    }
    Ok(())
}

fn print_summary(columns: &[String], records: &[Record]) -> anyhow::Result<()> {
    let by = report::group_axis(columns, records);
    mrfeel::out!("{}", report::summary_table(columns, records, by))?;
    Ok(())
}
