//! The `sweep` subcommand: `mrfeel sweep PLAN --out DIR [--jobs N] [--shard K/N]`,
//! `mrfeel sweep PLAN --out DIR --ray ADDRESS [--shards N]` and `mrfeel sweep merge DIR... --out OUT`.

use std::path::{Path, PathBuf};

use mrfeel::sweep::plan::Plan;
use mrfeel::sweep::report;
use mrfeel::sweep::store::{self, Shard, Store};

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
    #[arg(long, value_name = "K/N", conflicts_with = "ray")]
    pub shard: Option<Shard>,
    /// Run the sweep on a Ray cluster (`auto`: the cluster of this machine; `HOST:PORT`; `ray://HOST:PORT`):
    /// one Ray task per shard through `python/sweep_ray.py` in the project's Python, then merged here.
    #[arg(long, value_name = "ADDRESS", conflicts_with = "jobs")]
    pub ray: Option<String>,
    /// With `--ray`: the Ray tasks, one shard each (default: the cluster's CPUs, at most one per run).
    #[arg(long, requires = "ray")]
    pub shards: Option<u64>,
    /// With `--ray`: wait up to this many seconds for a cluster still starting (default: none).
    #[arg(long, requires = "ray", value_name = "SECONDS")]
    pub ray_wait_s: Option<f64>,
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
    // (`--shard` conflicts with `--ray`: a sweep on Ray checks every run.)
    let shard = args.shard.unwrap_or(Shard::ALL);
    // Every run's scenario checked before the output directory is made: a refused plan writes nothing.
    let runs = mrfeel::sweep::checked_runs(&plan, shard)?;
    if let Some(address) = &args.ray {
        return run_ray(args, plan_path, &plan, out, address);
    }
    let store = Store::open(out, &plan, shard)?;
    let total = runs.len() as u64;
    let already = store.done.len() as u64;
    let jobs = args.jobs.unwrap_or_else(rayon::current_num_threads);
    anyhow::ensure!(jobs >= 1, "--jobs 0: give at least 1");
    let pb = super::progress_bar(
        total,
        "sweep [{bar:40}] {pos}/{len} runs {elapsed_precise} eta {eta}",
    );
    pb.set_position(already);
    let records = mrfeel::sweep::execute(&plan, store, runs, jobs, &|_| pb.inc(1))?;
    pb.finish_and_clear();
    mrfeel::outln!(
        "{}: {} runs ({} resumed from {}), shard {}",
        plan.name,
        records.len(),
        already,
        out.join(store::JOURNAL).display(),
        shard.label()
    )?;
    if shard == Shard::ALL {
        finish(out, Some(&plan))
    } else {
        mrfeel::outln!("  merge the shards with: mrfeel sweep merge DIR... --out OUT")?;
        Ok(())
    }
}

/// The Ray driver, built in so that an installed binary carries it.
const RAY_DRIVER: &str = include_str!("../../python/sweep_ray.py");

/// The driver's exit status when its Python has no Ray (`NO_RAY` in `python/sweep_ray.py`).
const NO_RAY: i32 = 3;

/// How to get Ray into the project's Python.
const RAY_INSTALL_HINT: &str = "in an mrfeel checkout, `bash scripts/python-env.sh` creates .venv with the \
     pinned ray (python/requirements.txt); elsewhere, `python3 -m pip install ray==2.60.0` into a Python named \
     by MRFEEL_PYTHON";

/// `mrfeel sweep PLAN --out DIR --ray ADDRESS`: `python/sweep_ray.py` in the project's Python (the JSBSim
/// bridge's: `MRFEEL_PYTHON`, the checkout's `.venv`, `python3`) runs the shards as Ray tasks, each
/// `mrfeel sweep --shard K/N` of this binary into `DIR/shards/K-of-N`; the progress bar counts the runs in
/// the shards' journals; the shards are merged here, with the report and maps of a local sweep.
fn run_ray(args: &SweepArgs, plan_path: &Path, plan: &Plan, out: &Path, address: &str) -> anyhow::Result<()> {
    use std::io::{BufRead, Read};
    use std::process::{Command, Stdio};
    let (python, found) = mrfeel::aero::jsbsim_bridge::python();
    eprintln!("Ray driver: Python {} ({found})", python.display());
    let exe = std::env::current_exe()?;
    let scripts = tempfile::Builder::new().prefix("mrfeel-sweep-ray-").tempdir()?;
    let driver = scripts.path().join("sweep_ray.py");
    std::fs::write(&driver, RAY_DRIVER)?;
    std::fs::create_dir_all(out)?;
    let mut cmd = Command::new(&python);
    cmd.arg(&driver)
        .arg(plan_path)
        .arg("--out")
        .arg(out)
        .arg("--address")
        .arg(address)
        .arg("--mrfeel")
        .arg(&exe)
        .arg("--max-shards")
        .arg(plan.run_count().to_string())
        .arg("--connect-timeout-s")
        .arg(args.ray_wait_s.unwrap_or(0.0).to_string())
        .arg("--no-merge");
    if let Some(n) = args.shards {
        anyhow::ensure!(n >= 1, "--shards 0: give at least 1");
        cmd.arg("--shards").arg(n.to_string());
    }
    let mut child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| {
            anyhow::anyhow!(
                "the Ray driver's Python {} ({found}) does not start: {e}; {RAY_INSTALL_HINT}",
                python.display()
            )
        })?;
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    let stdout = child.stdout.take().expect("piped");
    let reader = std::thread::spawn(move || {
        for line in std::io::BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut stderr = child.stderr.take().expect("piped");
    let errors = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stderr.read_to_string(&mut s);
        s
    });
    let pb = super::progress_bar(
        plan.run_count(),
        "sweep on Ray [{bar:40}] {pos}/{len} runs {elapsed_precise} eta {eta} {msg}",
    );
    let mut shards: Option<u64> = None;
    let mut shards_done = 0u64;
    loop {
        match rx.recv_timeout(std::time::Duration::from_millis(250)) {
            Ok(line) => {
                if let Some(n) = line.strip_prefix("shards ").and_then(|n| n.parse().ok()) {
                    shards = Some(n);
                } else if line.starts_with("done ") {
                    shards_done += 1;
                }
            }
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => break,
        }
        if let Some(n) = shards {
            pb.set_position(journal_runs(out, n));
            pb.set_message(format!("({shards_done}/{n} shards)"));
        }
    }
    let status = child.wait()?;
    let _ = reader.join();
    let stderr = errors.join().unwrap_or_default();
    pb.finish_and_clear();
    if status.code() == Some(NO_RAY) {
        anyhow::bail!("{}", stderr.trim_end());
    }
    let Some(n) = shards.filter(|_| status.success()) else {
        anyhow::bail!(
            "the sweep on Ray at `{address}` failed ({status}; driver {} in {}):\n{}",
            "python/sweep_ray.py",
            python.display(),
            stderr.trim_end()
        );
    };
    let dirs: Vec<PathBuf> = (0..n).map(|k| shard_dir(out, k, n)).collect();
    let merged = store::merge(&dirs, out)?;
    mrfeel::outln!(
        "{}: {merged} runs in {n} shards on Ray at `{address}`, merged from {}",
        plan.name,
        out.join("shards").display()
    )?;
    finish(out, Some(plan))
}

/// The output directory of shard `k` of `n` of a sweep on Ray (`shard_dir` in `python/sweep_ray.py`).
fn shard_dir(out: &Path, k: u64, n: u64) -> PathBuf {
    out.join("shards").join(format!("{k}-of-{n}"))
}

/// Runs finished in the journals of the `n` shards under `out` (whole lines).
fn journal_runs(out: &Path, n: u64) -> u64 {
    (0..n)
        .map(|k| {
            std::fs::read(shard_dir(out, k, n).join(store::JOURNAL))
                .map_or(0, |b| b.iter().filter(|&&c| c == b'\n').count() as u64)
        })
        .sum()
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
    let by = report::group_axis(&columns, &records);
    mrfeel::out!("{}", report::summary_table(&columns, &records, by))?;
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
