//! The `run` and `daq-sweep` subcommands.

use std::path::{Path, PathBuf};

use anyhow::Context;
use indicatif::ProgressBar;

use mrfeel::device::{DeviceConfig, Registry};
use mrfeel::scenario::Scenario;
use mrfeel::sim::response;
use mrfeel::sim::{build_rig, CollectError, Collector, Devices, Plant, Results, RunOptions};

/// `mrfeel run SCENARIO`: run a stick-rig scenario headless.
#[derive(Debug, clap::Args)]
#[command(
    mut_arg("json", |a| a.help("Print the summary as JSON on stdout (nothing else on stdout)")),
    mut_arg("rerun", |a| a.help("Write a Rerun recording (`.rrd`) of the run")),
    mut_arg("plot", |a| a.help(
        "Write `run.png` and `run.svg` into this directory: forces, coil current, stick angle and the \
         pilot's hand force against time, and the force against the stick angle, with fault windows \
         shaded. A flight also writes `<scenario name>-stick-force-per-g.png` and `.svg`: stick force \
         against load factor, flown and steady, against the allowed band of the aircraft's basis"
    )),
)]
pub struct RunArgs {
    /// Scenario file (`scenarios/*.toml`).
    pub scenario: PathBuf,
    /// Write the time series as CSV.
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub output: super::OutputArgs,
    /// Stream the recording to a newly spawned Rerun viewer.
    #[arg(long, conflicts_with = "rerun")]
    pub spawn: bool,
    /// gRPC port of the viewer `--spawn` starts (or reuses, if one listens there).
    #[arg(long, default_value_t = 9876, requires = "spawn")]
    pub spawn_port: u16,
    /// Fly another aircraft backend than the scenario's `[aircraft] model`: a model name from
    /// `models/aircraft/` (`c172p`, `737`, `T37`) or `jsbsim:<name>`; a name, never a path (`/`, `\`, `..` are refused).
    #[arg(long)]
    pub aircraft: Option<String>,
    /// Simulate this damper instead of the scenario's `[device] file` (a device TOML or a `PARAMS.json`).
    #[arg(long, value_name = "PATH")]
    pub device: Option<PathBuf>,
    /// Give the controller this model instead of the scenario's `[controller] model` (a `PARAMS.json`
    /// from `fit`/`diagnose` or a device file).
    #[arg(long, value_name = "PATH")]
    pub controller_model: Option<PathBuf>,
    /// Replace a scenario value by its dotted key, checked as the file's own (repeatable):
    /// `--set feel.gradient_n_per_m=900 --set aircraft.airspeed_m_s=60`. Paths are relative to the
    /// working directory.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
}

impl RunArgs {
    /// The scenario with its `--set` overrides.
    pub fn load_scenario(&self) -> anyhow::Result<Scenario> {
        let overrides = self
            .set
            .iter()
            .map(|a| mrfeel::scenario::Override::parse_argument(a))
            .collect::<Result<Vec<_>, _>>()
            .map_err(anyhow::Error::msg)?;
        Ok(Scenario::load_with(&self.scenario, &overrides)?)
    }
}

/// `mrfeel daq-sweep SCENARIO`: force response time against the DAQ rate.
#[derive(Debug, clap::Args)]
pub struct DaqSweepArgs {
    /// Scenario with a `force-steps` feel law (e.g. `scenarios/response-time.toml`).
    pub scenario: PathBuf,
    /// DAQ rates to run, Hz (each at most the scenario's physics rate).
    #[arg(long, value_delimiter = ',', default_value = "100,200,500,1000,2000,5000")]
    pub rates: Vec<f64>,
    /// Write `daq-sweep.png` and `daq-sweep.svg` into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Print the table as JSON on stdout (nothing else on stdout).
    #[arg(long)]
    pub json: bool,
}

/// Every file `mrfeel run` or `daq-sweep` of the scenario `scn` (loaded from `path`) reads, which no output
/// may overwrite: the scenario and the files it names, flying `aircraft` (`--aircraft`) where given.
pub fn input_files(path: &Path, scn: &Scenario, aircraft: Option<&str>) -> Vec<(&'static str, PathBuf)> {
    let mut files = vec![("scenario", path.to_path_buf())];
    match aircraft.and_then(|m| scn.with_aircraft_model(m)) {
        Some(flown) => files.extend(flown.named_files()),
        None => files.extend(scn.named_files()),
    }
    files
}

/// A run's progress bar, named after its scenario.
fn progress_bar(len: u64, msg: &str) -> ProgressBar {
    let pb = super::progress_bar(len, "{msg} [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}");
    pb.set_message(msg.to_string());
    pb
}

/// `mrfeel run` of the scenario loaded from `args.scenario`.
pub fn run_cmd(args: &RunArgs, mut scn: Scenario) -> anyhow::Result<()> {
    if let Some(p) = &args.device {
        scn.device_path = p.clone();
    }
    let mut devices = Devices::load(&scn)?;
    if let Some(p) = &args.controller_model {
        devices.controller = DeviceConfig::load(p, &Registry::builtin()).context("--controller-model")?;
        devices.controller_is_plant = false;
    }
    let rig = build_rig(&scn, &devices.plant)?;
    if let Some(model) = &args.aircraft {
        scn = scn.with_aircraft_model(model).with_context(|| {
            format!(
                "--aircraft {model}: scenario {} has no `[aircraft]` section",
                args.scenario.display()
            )
        })?;
    }
    // A viewer is spawned before the run and shown the whole run after it.
    #[cfg(feature = "rerun")]
    let rec = if args.spawn {
        Some(mrfeel::viz::rerun_rig::spawn_on_port(args.spawn_port)?)
    } else {
        None
    };
    let opts = RunOptions {
        frames_hz: (args.output.rerun.is_some() || args.spawn).then_some(60.0),
    };
    // The rows are kept only where something needs the whole run (plots, an aircraft's metrics, a viewer):
    // otherwise memory does not grow with the run's length.
    let keep = args.output.plot.is_some() || scn.aircraft.is_some() || args.spawn;
    let (res, summary) = run_streamed(args, &scn, &devices, rig, opts, keep)?;
    #[cfg(feature = "rerun")]
    if let (Some(rec), Some(res)) = (&rec, &res) {
        mrfeel::sim::log_rerun(rec, res)?;
    }
    let mut plotted = Vec::new();
    if let (Some(dir), Some(res)) = (&args.output.plot, &res) {
        plotted = run_plots(res, dir)?;
        // A flight's chart reads its aircraft's model file again: only where it is drawn.
        let chart = mrfeel::sim::flight::stick_force_per_g_chart(res)
            .with_context(|| format!("--plot {}: the stick force per g chart", dir.display()))?;
        if let Some(chart) = chart {
            let name = format!("{}-stick-force-per-g", scn.name);
            plotted.extend(
                mrfeel::viz::plot::save_charts(&[chart], 1, dir, &name)
                    .with_context(|| format!("--plot {}", dir.display()))?,
            );
        }
    }
    if args.output.json {
        // A kept run's JSON adds its flight's figures (`prelude::run_summary`).
        let text = match &res {
            Some(res) => serde_json::to_string_pretty(&mrfeel::prelude::run_summary(res, &scn)?)?,
            None => serde_json::to_string_pretty(&summary)?,
        };
        return Ok(mrfeel::outln!("{text}")?);
    }
    mrfeel::outln!("{summary}")?;
    if let Some(m) = res
        .as_ref()
        .and_then(|res| mrfeel::sim::metrics::FlightMetrics::of(res, &scn))
    {
        mrfeel::outln!("{m}")?;
    }
    if let Some(f) = res.as_ref().and_then(|res| res.flight.as_ref()) {
        mrfeel::outln!(
            "  aircraft {}: {} parameters are estimates ([EST] in its model file, no source): {}",
            f.aircraft,
            f.estimates.len(),
            f.estimates.join(", ")
        )?;
    }
    if let Some(p) = &args.out {
        mrfeel::outln!("  results: {}", p.display())?;
    }
    if let Some(p) = &args.output.rerun {
        mrfeel::outln!("  recording: {} (open with `rerun {}`)", p.display(), p.display())?;
    }
    for p in plotted
        .iter()
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
    {
        mrfeel::outln!("  plot: {} and its .svg", p.display())?;
    }
    Ok(())
}

/// `write_whole` of `path` where there is one; else `write` with no file.
fn maybe_whole<T>(
    path: Option<&Path>,
    what: &str,
    write: impl FnOnce(Option<&Path>) -> anyhow::Result<T>,
) -> anyhow::Result<T> {
    match path {
        Some(p) => mrfeel::outputs::write_whole(
            p,
            |tmp| write(Some(tmp)),
            |e| anyhow::Error::new(e).context(format!("{what} {}", p.display())),
        ),
        None => write(None),
    }
}

/// A run whose rows go to its CSV (`--out`) and its recording (`--rerun FILE`) as they are made
/// ([`Collector`]), each file whole or not written. Returns the run's summary, and the run with its rows
/// where `keep` (and its frames for a spawned viewer).
fn run_streamed<P: Plant>(
    args: &RunArgs,
    scn: &Scenario,
    devices: &Devices,
    plant: P,
    opts: RunOptions,
    keep: bool,
) -> anyhow::Result<(Option<Results>, mrfeel::sim::Summary)> {
    #[cfg(feature = "rerun")]
    let rrd = args.output.rerun.as_deref();
    #[cfg(not(feature = "rerun"))]
    let rrd: Option<&Path> = None;
    let pb = progress_bar(1000, &scn.name);
    let run = maybe_whole(args.out.as_deref(), "writing", |csv_tmp| {
        maybe_whole(rrd, "--rerun", |_rrd_tmp| {
            let create =
                |p: &Path| std::fs::File::create(p).with_context(|| format!("creating {}", p.display()));
            let mut csv = csv_tmp.map(create).transpose()?.map(std::io::BufWriter::new);
            #[cfg(feature = "rerun")]
            let file_rec = match _rrd_tmp {
                Some(p) => Some(mrfeel::viz::rerun_rig::to_file(p)?),
                None => None,
            };
            let mut collector = Collector::keeping(keep, keep && args.spawn);
            if let Some(w) = csv.as_mut() {
                collector = collector.with_csv(w);
            }
            #[cfg(feature = "rerun")]
            if let Some(rec) = &file_rec {
                collector = collector.with_recording(rec);
            }
            collector
                .run(scn, devices, plant, opts, |f| {
                    pb.set_position((f * 1000.0) as u64)
                })
                .map_err(|e| match e {
                    CollectError::Csv(e) => anyhow::Error::new(e).context(format!(
                        "writing {}",
                        args.out.as_deref().unwrap_or(Path::new("")).display()
                    )),
                    CollectError::Run(e) => e.into(),
                    #[cfg(feature = "rerun")]
                    CollectError::Recording(e) => e.into(),
                })
        })
    });
    pb.finish_and_clear();
    let (res, summary) = run?;
    Ok((keep.then_some(res), summary))
}

/// The run drawn for `run --plot DIR`: `DIR/run.png` and `DIR/run.svg`.
pub fn run_plots(res: &Results, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    use mrfeel::viz::plot::{save_charts, Chart, Series};
    // At most about 4000 points a series: enough for the eye, small files.
    let every = res.rows.len().div_ceil(4000).max(1);
    let rows: Vec<_> = res.rows.iter().step_by(every).collect();
    let series = |name: &str, f: &dyn Fn(&mrfeel::sim::Row) -> (f64, f64)| {
        Series::line(name, rows.iter().map(|r| f(r)).collect())
    };
    // Fault windows: spans of the rows where some fault is active.
    let mut faults: Vec<(f64, f64)> = Vec::new();
    let mut open: Option<f64> = None;
    for r in &res.rows {
        match (r.faults != 0, open) {
            (true, None) => open = Some(r.t_s),
            (false, Some(t0)) => {
                faults.push((t0, r.t_s));
                open = None;
            }
            _ => {}
        }
    }
    if let (Some(t0), Some(last)) = (open, res.rows.last()) {
        faults.push((t0, last.t_s));
    }
    let deg = 180.0 / std::f64::consts::PI;
    let charts = [
        Chart::new(
            format!("{}: forces on the piston", res.scenario),
            "time (s)",
            "force (N)",
        )
        .with(series("desired", &|r| (r.t_s, r.desired_force_n)))
        .with(series("load cell", &|r| (r.t_s, r.load_cell_true_n)))
        .with(series("damper", &|r| (r.t_s, r.damper_force_n)))
        .with_bands("fault", faults.clone()),
        Chart::new("Coil current", "time (s)", "current (A)")
            .with(series("command", &|r| (r.t_s, r.current_a)))
            .with(series("coil", &|r| (r.t_s, r.coil_current_a)))
            .with_bands("fault", faults.clone()),
        Chart::new("Stick", "time (s)", "stick angle (deg)")
            .with(series("stick angle", &|r| (r.t_s, r.stick_angle_rad * deg)))
            .with_bands("fault", faults.clone()),
        Chart::new("Pilot", "time (s)", "hand force on the grip (N)")
            .with(series("pilot", &|r| (r.t_s, r.pilot_force_n)))
            .with_bands("fault", faults),
        Chart::new(
            "Feel: load cell against stick angle",
            "stick angle (deg)",
            "load cell (N)",
        )
        .with(Series::points(
            "",
            rows.iter()
                .map(|r| (r.stick_angle_rad * deg, r.load_cell_true_n))
                .collect(),
        )),
    ];
    save_charts(&charts, 2, dir, "run").with_context(|| format!("--plot {}", dir.display()))
}

/// `mrfeel daq-sweep` of the scenario loaded from `args.scenario`.
pub fn daq_sweep_cmd(args: &DaqSweepArgs, scn: Scenario) -> anyhow::Result<()> {
    for (k, r) in args.rates.iter().enumerate() {
        if args.rates[..k].contains(r) {
            let list: Vec<String> = args.rates.iter().map(f64::to_string).collect();
            anyhow::bail!(
                "--rates {}: {r} Hz given twice; give each rate once (nothing was run)",
                list.join(",")
            );
        }
    }
    let devices = Devices::load(&scn)?;
    let pb = progress_bar(args.rates.len() as u64, "daq-sweep");
    let points = response::sweep(&scn, &devices, &args.rates, || pb.inc(1));
    pb.finish_and_clear();
    let points = points?;
    if let Some(dir) = &args.plot {
        response::plot(
            &points,
            dir,
            &format!("Feel-loop force response vs DAQ period ({})", scn.name),
        )?;
    }
    if args.json {
        mrfeel::outln!("{}", serde_json::to_string_pretty(&points)?)?;
    } else {
        mrfeel::out!("{}", response::markdown_table(&points))?;
        plots_line(args.plot.as_deref(), "daq-sweep")?;
    }
    Ok(())
}

/// The line naming the plots `DIR/STEM.png` and `.svg`, where they were asked for.
fn plots_line(dir: Option<&Path>, stem: &str) -> std::io::Result<()> {
    match dir {
        Some(d) => mrfeel::outln!("plots: {}/{stem}.png, {}/{stem}.svg", d.display(), d.display()),
        None => Ok(()),
    }
}

/// `mrfeel loop-study SCENARIO --data DIR`: discovery to feel.
#[derive(Debug, clap::Args)]
pub struct LoopStudyArgs {
    /// Scenario to run (its `[device] file` is the plant unless `--device` names another).
    pub scenario: PathBuf,
    /// Test-rig measurements of the damper (CSV files or directories of them): diagnosed, and each stage
    /// of the diagnosis fitted to them.
    #[arg(long, required = true, num_args = 1..)]
    pub data: Vec<PathBuf>,
    /// The plant the rig simulates instead of the scenario's `[device] file`.
    #[arg(long, value_name = "PATH")]
    pub device: Option<PathBuf>,
    /// Driver saturation of the fitted models, A (default: the data's, else the paper's 14 A).
    #[arg(long)]
    pub current_limit_a: Option<f64>,
    /// Write `loop-study.png` and `loop-study.svg` into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Print the stages as JSON on stdout (nothing else on stdout).
    #[arg(long)]
    pub json: bool,
}

/// `mrfeel loop-study` of the scenario loaded from `args.scenario`.
pub fn loop_study_cmd(args: &LoopStudyArgs, mut scn: Scenario) -> anyhow::Result<()> {
    if let Some(p) = &args.device {
        scn.device_path = p.clone();
    }
    let plant = Devices::load(&scn)?.plant;
    let registry = Registry::builtin();
    let tests = mrfeel::ident::load_tests(&args.data)?;
    let limit = args
        .current_limit_a
        .unwrap_or_else(|| mrfeel::ident::default_current_limit_a(&tests));
    anyhow::ensure!(
        limit.is_finite() && limit > 0.0,
        "--current-limit-a {limit}: a positive number of amperes"
    );
    mrfeel::noteln!(
        "loop-study: diagnosing {} tests and fitting each stage",
        tests.len()
    );
    let stages = mrfeel::sim::loop_study::stages_from_data(&tests, limit, &registry)?;
    mrfeel::noteln!(
        "loop-study: running {} with {} controller models",
        scn.name,
        stages.len()
    );
    let runs = mrfeel::sim::loop_study::run_stages(&scn, &plant, &stages)?;
    let figs: Vec<_> = runs.into_iter().map(|(f, _)| f).collect();
    if let Some(dir) = &args.plot {
        mrfeel::sim::loop_study::plot(
            &figs,
            dir,
            &format!("Feel error by discovery stage ({})", scn.name),
        )?;
    }
    if args.json {
        mrfeel::outln!("{}", serde_json::to_string_pretty(&figs)?)?;
    } else {
        mrfeel::outln!(
            "loop-study {}: plant {} ({}), controller model by discovery stage",
            scn.name,
            plant.model.name(),
            plant.path.display()
        )?;
        mrfeel::out!("{}", mrfeel::sim::loop_study::markdown_table(&figs))?;
        mrfeel::outln!(
            "where renderable: the resisting samples whose desired force lies between the plant's force at 0 A \
             and {:.0} % of its force at the driver's limit, at the sample's speed (the plant's model, not the \
             controller's)",
            100.0 * mrfeel::sim::loop_study::RENDERABLE_SHARE
        )?;
        plots_line(args.plot.as_deref(), "loop-study")?;
    }
    Ok(())
}
