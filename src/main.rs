//! The `mrfeel` command line: parse, call the library, print. All work is in the library.

mod cli;

use std::path::PathBuf;

use mrfeel::outputs::{check_outputs, Kind, Output};

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// Simulation and model discovery for magneto-rheological (MR) artificial feel systems on aircraft
/// control sticks.
#[derive(Parser)]
#[command(name = "mrfeel", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Folder of model, rig, pilot, spring and aircraft files that a scenario names but that are not
    /// beside it (laid out as the repository: `models/…`, `models/aircraft/<name>.toml`, or flat); default
    /// the environment variable MRFEEL_DATA. Files still not found are the built-in ones of that name.
    #[arg(long, global = true, value_name = "DIR")]
    data_dir: Option<PathBuf>,
}

#[derive(Subcommand)]
enum Command {
    /// Virtual MTS machine: drive the damper with a displacement protocol and record the force (CSV).
    Mts(cli::mts::MtsArgs),
    /// Run a scenario headless: the stick rig, its feel loop and pilot, and the aircraft if it has one
    /// (CSV, Rerun recording, summary).
    Run(cli::sim::RunArgs),
    /// Force response time of the feel loop against the DAQ sample rate.
    DaqSweep(cli::sim::DaqSweepArgs),
    /// Compare feel systems (springs, MR damper, hybrid) on the same rig and pilot task, with faults.
    Compare(cli::compare::CompareArgs),
    /// Fit a model (`bingham+effect+...`) to measured tests, jointly, each from its own start.
    Fit(cli::ident::FitArgs),
    /// Run a saved model unchanged on other tests and report its error (no refit).
    Validate(cli::ident::ValidateArgs),
    /// Find where a model fails and name the missing effects by the held-out error they remove.
    Diagnose(cli::ident::DiagnoseArgs),
    /// The force of a saved model (or a device file) on your own motion and current (measurement CSV).
    Simulate(cli::ident::SimulateArgs),
    /// Discovery to feel: diagnose rig data, fit each stage, and run a scenario with each as the feel
    /// controller's model against the same plant.
    LoopStudy(cli::sim::LoopStudyArgs),
    /// Sweep a scenario over a plan's axes (in parallel, in shards, resumable) with handling-qualities
    /// verdicts per run; `sweep merge` joins shards.
    Sweep(cli::sweep::SweepArgs),
}

/// A command with the scenario it runs read, once, before anything else: a scenario given as a pipe
/// (`mrfeel run /dev/stdin`) cannot be read a second time.
enum Job {
    Mts(cli::mts::MtsArgs),
    Run(cli::sim::RunArgs, Box<mrfeel::scenario::Scenario>),
    DaqSweep(cli::sim::DaqSweepArgs, Box<mrfeel::scenario::Scenario>),
    Compare(cli::compare::CompareArgs, Box<mrfeel::compare::CompareScenario>),
    Fit(cli::ident::FitArgs),
    Validate(cli::ident::ValidateArgs),
    Diagnose(cli::ident::DiagnoseArgs),
    Simulate(cli::ident::SimulateArgs),
    LoopStudy(cli::sim::LoopStudyArgs, Box<mrfeel::scenario::Scenario>),
    Sweep(cli::sweep::SweepArgs),
}

impl Job {
    fn load(command: Command) -> anyhow::Result<Self> {
        use mrfeel::scenario::Scenario;
        Ok(match command {
            Command::Mts(a) => Job::Mts(a),
            Command::Run(mut a) => {
                a.scenario = mrfeel::builtin::scenario_arg(&a.scenario);
                let scn = a.load_scenario()?;
                Job::Run(a, Box::new(scn))
            }
            Command::DaqSweep(mut a) => {
                a.scenario = mrfeel::builtin::scenario_arg(&a.scenario);
                let scn = Scenario::load(&a.scenario)?;
                Job::DaqSweep(a, Box::new(scn))
            }
            Command::Compare(mut a) => {
                a.scenario = mrfeel::builtin::scenario_arg(&a.scenario);
                let scn = mrfeel::compare::CompareScenario::load(&a.scenario)?;
                Job::Compare(a, Box::new(scn))
            }
            Command::Fit(a) => Job::Fit(a),
            Command::Validate(a) => Job::Validate(a),
            Command::Diagnose(a) => Job::Diagnose(a),
            Command::Simulate(a) => Job::Simulate(a),
            Command::LoopStudy(mut a) => {
                a.scenario = mrfeel::builtin::scenario_arg(&a.scenario);
                let scn = Scenario::load(&a.scenario)?;
                Job::LoopStudy(a, Box::new(scn))
            }
            Command::Sweep(a) => Job::Sweep(a),
        })
    }

    fn run(self) -> anyhow::Result<()> {
        match self {
            Job::Mts(a) => cli::mts::run(a),
            Job::Run(a, scn) => cli::sim::run_cmd(&a, *scn),
            Job::DaqSweep(a, scn) => cli::sim::daq_sweep_cmd(&a, *scn),
            Job::Compare(a, scn) => cli::compare::run_cmd(a, *scn),
            Job::Fit(a) => cli::ident::run_fit(&a),
            Job::Validate(a) => cli::ident::run_validate(&a),
            Job::Diagnose(a) => cli::ident::run_diagnose(&a),
            Job::Simulate(a) => cli::ident::run_simulate(&a),
            Job::LoopStudy(a, scn) => cli::sim::loop_study_cmd(&a, *scn),
            Job::Sweep(a) => cli::sweep::run_cmd(&a),
        }
    }

    /// Every file or directory the job will write, by option. The one list of a command's outputs: a new
    /// output option goes here, so that it is checked with the others before anything runs.
    fn outputs(&self) -> Vec<Output<'_>> {
        use Kind::{Dir, File};
        let list: Vec<(&'static str, Option<&PathBuf>, Kind)> = match self {
            Job::Mts(a) => vec![
                ("--out", Some(&a.out), File),
                ("--save-device", a.save_device.as_ref(), File),
                ("--plot", a.plot.as_ref(), Dir),
            ],
            Job::Run(a, _) => [vec![("--out", a.out.as_ref(), File)], a.output.files()].concat(),
            Job::DaqSweep(a, _) => vec![("--plot", a.plot.as_ref(), Dir)],
            Job::Compare(a, _) => a.output.files(),
            Job::Fit(a) => [vec![("--save", a.save.as_ref(), File)], a.output.files()].concat(),
            Job::Validate(a) => {
                // One test: `--out` is its file; several: a directory of them.
                let one = mrfeel::measurement::measurement_files(&a.data).is_ok_and(|f| f.len() == 1);
                let out = ("--out", a.out.as_ref(), if one { File } else { Dir });
                [a.output.files(), vec![out]].concat()
            }
            Job::Diagnose(a) => a.output.files(),
            Job::Simulate(a) => vec![("--out", Some(&a.out), File)],
            Job::LoopStudy(a, _) => vec![("--plot", a.plot.as_ref(), Dir)],
            Job::Sweep(a) => vec![("--out", a.out_dir(), Dir)],
        };
        list.into_iter()
            .filter_map(|(opt, p, kind)| p.map(|p| (opt, p.as_path(), kind)))
            .collect()
    }

    /// The files the job reads, which no output may overwrite: the files named, the CSVs of a named
    /// measurement directory, and the files a scenario names (device, URDF, pilot model, springs, aircraft).
    fn inputs(&self) -> Vec<(&'static str, PathBuf)> {
        // As the loader lists them; where it cannot, the command will say why before it writes anything.
        let data = |paths: &[PathBuf]| -> Vec<(&'static str, PathBuf)> {
            mrfeel::measurement::measurement_files(paths)
                .unwrap_or_else(|_| paths.to_vec())
                .into_iter()
                .map(|p| ("measurement", p))
                .collect()
        };
        match self {
            Job::Mts(a) => a.device.iter().map(|p| ("device file", p.clone())).collect(),
            Job::Run(a, scn) => {
                let mut v = cli::sim::input_files(&a.scenario, scn, a.aircraft.as_deref());
                v.extend(a.device.iter().map(|p| ("device file", p.clone())));
                v.extend(a.controller_model.iter().map(|p| ("controller model", p.clone())));
                v
            }
            Job::DaqSweep(a, scn) => cli::sim::input_files(&a.scenario, scn, None),
            Job::Compare(a, scn) => cli::compare::input_files(&a.scenario, scn),
            Job::Fit(a) => data(&a.data),
            Job::Validate(a) => {
                let mut v = data(&a.data);
                v.push(("params file", a.params.clone()));
                v
            }
            Job::Diagnose(a) => data(&a.data),
            Job::Simulate(a) => vec![
                ("motion file", a.input.clone()),
                ("params file", a.params.clone()),
            ],
            Job::LoopStudy(a, scn) => {
                let mut v = cli::sim::input_files(&a.scenario, scn, None);
                v.extend(data(&a.data));
                v.extend(a.device.iter().map(|p| ("device file", p.clone())));
                v
            }
            Job::Sweep(a) => a.plan.iter().map(|p| ("sweep plan", p.clone())).collect(),
        }
    }
}

/// The command line, parsed. Every subcommand takes `--option -0.01` as the option's value (refused, where
/// it must be positive, by the check that names the field), not as an unknown flag `-0`.
fn parse_cli() -> Cli {
    let effects = mrfeel::device::Registry::builtin().names().join(", ");
    let cmd = Cli::command()
        .mut_subcommands(|c| c.allow_negative_numbers(true))
        .mut_subcommand("mts", |c| {
            c.mut_arg("effects", |a| {
                a.help(format!(
                    "Hidden effects added to the device for synthetic data, comma-separated; one or more of: \
                     {effects}"
                ))
            })
        })
        .mut_subcommand("fit", |c| {
            c.mut_arg("model", |a| {
                a.help(format!(
                    "Model spec: `bingham` plus effects joined by `+` (effects: {effects})"
                ))
            })
        })
        .mut_subcommand("diagnose", |c| {
            c.mut_arg("model", |a| {
                a.help(format!(
                    "The model to start from: `bingham` plus effects joined by `+` (effects: {effects}); \
                     without it, `bingham`, or the `spencer` base where it ends significantly better held out \
                     (`bases_tried` in the JSON)"
                ))
            })
        });
    Cli::from_arg_matches(&cmd.get_matches())
        .map_err(|e| e.format(&mut Cli::command()))
        .unwrap_or_else(|e| e.exit())
}

fn main() -> std::process::ExitCode {
    // Rust ignores SIGPIPE, so a closed pipe (`mrfeel validate … --json | head`) made `println!` panic.
    // With the default action the process ends quietly when its reader has gone, as other Unix tools do.
    #[cfg(unix)]
    // SAFETY: called first thing in `main`, before any other thread exists; SIG_DFL is a valid action.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // glibc gives each thread that allocates its own arena and keeps what is freed in it, so a fit's
    // Jacobians freed on one worker are not reused by another and the resident set of a diagnosis grew
    // with the number of threads: two arenas hold it to what the work holds (`docs/reference/invariants.md`).
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: called before any other thread exists; M_ARENA_MAX only bounds how many arenas glibc makes.
    unsafe {
        libc::mallopt(libc::M_ARENA_MAX, 2);
    }
    let cli = parse_cli();
    if cli.data_dir.is_some() {
        mrfeel::builtin::set_data_dir(cli.data_dir);
    }
    let result = Job::load(cli.command).and_then(|job| {
        let read = job.inputs();
        let read: Vec<(&'static str, &std::path::Path)> =
            read.iter().map(|(w, p)| (*w, p.as_path())).collect();
        check_outputs(&job.outputs(), &read).map_err(anyhow::Error::msg)?;
        #[cfg(not(feature = "rerun"))]
        if job.outputs().iter().any(|(opt, ..)| *opt == "--rerun")
            || matches!(&job, Job::Run(a, _) if a.spawn)
        {
            anyhow::bail!(mrfeel::viz::NO_RERUN);
        }
        // Every output of the command as one set: renamed into place together, or not at all.
        let set = mrfeel::outputs::OutputSet::open();
        job.run()?;
        set.commit()
            .map_err(|e| anyhow::Error::new(e).context("putting the outputs in place"))
    });
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            // Errors quote input (a field, a name): bounded and with control characters escaped.
            mrfeel::noteln!(
                "{}",
                mrfeel::input::text::printable(&format!("error: {e:#}"), 2000)
            );
            std::process::ExitCode::FAILURE
        }
    }
}
