use clap::{Parser, Subcommand};

/// mrfeel: simulation and model discovery for MR artificial feel systems.
#[derive(Debug, Parser)]
#[command(name = "mrfeel", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a stick-rig scenario headless (CSV, Rerun recording, summary).
    Run(mrfeel::sim::cli::RunArgs),
    /// Force response time of the feel loop against the DAQ sample rate.
    DaqSweep(mrfeel::sim::cli::DaqSweepArgs),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Run(a) => mrfeel::sim::cli::run_cmd(&a),
        Command::DaqSweep(a) => mrfeel::sim::cli::daq_sweep_cmd(&a),
    }
}
