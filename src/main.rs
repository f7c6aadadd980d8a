//! The `mrfeel` command line: parse, call the library, print. All work is in the library.

use std::path::PathBuf;

use mrfeel::outputs::{check_outputs, Kind, Output};

use clap::{Parser, Subcommand};

/// Simulation and model discovery for magneto-rheological (MR) artificial feel systems on aircraft
/// control sticks.
#[derive(Parser)]
#[command(name = "mrfeel", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Virtual MTS machine: drive the damper with a displacement protocol and record the force (CSV).
    Mts(mrfeel::mts::cli::MtsArgs),
    /// Run a scenario headless: the stick rig, its feel loop and pilot, and the aircraft if it has one
    /// (CSV, Rerun recording, summary).
    Run(mrfeel::sim::cli::RunArgs),
    /// Force response time of the feel loop against the DAQ sample rate.
    DaqSweep(mrfeel::sim::cli::DaqSweepArgs),
    /// Compare feel systems (springs, MR damper, hybrid) on the same rig and pilot task, with faults.
    Compare(mrfeel::compare::cli::CompareArgs),
    /// Fit a model (`bingham+effect+...`) to measured tests, jointly, each from its own start.
    Fit(mrfeel::ident::cli::FitArgs),
    /// Run a saved model unchanged on other tests and report its error (no refit).
    Validate(mrfeel::ident::cli::ValidateArgs),
    /// Find where a model fails and name the missing effects by the held-out error they remove.
    Diagnose(mrfeel::ident::cli::DiagnoseArgs),
}

/// Every file or directory the command will write, by option. The one list of a command's outputs: a new
/// output option goes here, so that it is checked with the others before anything runs.
fn outputs(command: &Command) -> Vec<Output<'_>> {
    use Kind::{Dir, File};
    let list: Vec<(&'static str, Option<&PathBuf>, Kind)> = match command {
        Command::Mts(a) => vec![
            ("--out", Some(&a.out), File),
            ("--save-device", a.save_device.as_ref(), File),
            ("--plot", a.plot.as_ref(), Dir),
        ],
        Command::Run(a) => vec![
            ("--out", a.out.as_ref(), File),
            ("--rerun", a.rerun.as_ref(), File),
        ],
        Command::DaqSweep(a) => vec![("--plot", a.plot.as_ref(), Dir)],
        Command::Compare(a) => vec![
            ("--plot", a.plot.as_ref(), Dir),
            ("--rerun", a.rerun.as_ref(), File),
        ],
        Command::Fit(a) => vec![
            ("--save", a.save.as_ref(), File),
            ("--plot", a.plot.as_ref(), Dir),
            ("--rerun", a.rerun.as_ref(), File),
        ],
        Command::Validate(a) => vec![
            ("--plot", a.plot.as_ref(), Dir),
            ("--rerun", a.rerun.as_ref(), File),
        ],
        Command::Diagnose(a) => vec![
            ("--plot", a.plot.as_ref(), Dir),
            ("--rerun", a.rerun.as_ref(), File),
        ],
    };
    list.into_iter()
        .filter_map(|(opt, p, kind)| p.map(|p| (opt, p.as_path(), kind)))
        .collect()
}

/// The files a command reads, which no output may overwrite: the files named, the CSVs of a named
/// measurement directory, and the files a scenario names (device, URDF, pilot model, springs, aircraft).
fn inputs(command: &Command) -> Vec<(&'static str, PathBuf)> {
    // As the loader lists them; where it cannot, the command will say why before it writes anything.
    let data = |paths: &[PathBuf]| -> Vec<(&'static str, PathBuf)> {
        mrfeel::measurement::measurement_files(paths)
            .unwrap_or_else(|_| paths.to_vec())
            .into_iter()
            .map(|p| ("measurement", p))
            .collect()
    };
    match command {
        Command::Mts(a) => a.device.iter().map(|p| ("device file", p.clone())).collect(),
        Command::Run(a) => mrfeel::sim::cli::input_files(&a.scenario, a.aircraft.as_deref()),
        Command::DaqSweep(a) => mrfeel::sim::cli::input_files(&a.scenario, None),
        Command::Compare(a) => mrfeel::compare::cli::input_files(&a.scenario),
        Command::Fit(a) => data(&a.data),
        Command::Validate(a) => {
            let mut v = data(&a.data);
            v.push(("params file", a.params.clone()));
            v
        }
        Command::Diagnose(a) => data(&a.data),
    }
}

fn main() -> std::process::ExitCode {
    // Rust ignores SIGPIPE, so a closed pipe (`mrfeel validate … --json | head`) made `println!` panic.
    // With the default action the process ends quietly when its reader has gone, as other Unix tools do.
    #[cfg(unix)]
    // SAFETY: called first thing in `main`, before any other thread exists; SIG_DFL is a valid action.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::parse();
    let read = inputs(&cli.command);
    let read: Vec<(&'static str, &std::path::Path)> = read.iter().map(|(w, p)| (*w, p.as_path())).collect();
    let result = match check_outputs(&outputs(&cli.command), &read) {
        Err(msg) => Err(anyhow::Error::msg(msg)),
        Ok(()) => match cli.command {
            Command::Mts(a) => mrfeel::mts::cli::run(a),
            Command::Run(a) => mrfeel::sim::cli::run_cmd(&a),
            Command::DaqSweep(a) => mrfeel::sim::cli::daq_sweep_cmd(&a),
            Command::Compare(a) => mrfeel::compare::cli::run_cmd(a),
            Command::Fit(a) => mrfeel::ident::cli::run_fit(&a),
            Command::Validate(a) => mrfeel::ident::cli::run_validate(&a),
            Command::Diagnose(a) => mrfeel::ident::cli::run_diagnose(&a),
        },
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            mrfeel::noteln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
