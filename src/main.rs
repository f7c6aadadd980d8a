//! The `mrfeel` command line: parse, call the library, print. All work is in the library.

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

fn main() -> std::process::ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Mts(a) => mrfeel::mts::cli::run(a),
        Command::Run(a) => mrfeel::sim::cli::run_cmd(&a),
        Command::DaqSweep(a) => mrfeel::sim::cli::daq_sweep_cmd(&a),
        Command::Compare(a) => mrfeel::compare::cli::run_cmd(a),
        Command::Fit(a) => mrfeel::ident::cli::run_fit(&a),
        Command::Validate(a) => mrfeel::ident::cli::run_validate(&a),
        Command::Diagnose(a) => mrfeel::ident::cli::run_diagnose(&a),
    };
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
