//! The `mrfeel` command line.
use clap::{Parser, Subcommand};

#[derive(Parser, Debug)]
#[command(name = "mrfeel", version, about = "Simulation and model discovery for MR artificial feel systems")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Fit a model (`bingham+effect+...`) to measured tests, jointly.
    Fit(mrfeel::ident::cli::FitArgs),
    /// Run a saved model unchanged on other tests and report its error.
    Validate(mrfeel::ident::cli::ValidateArgs),
    /// Find where a model fails and name the missing effects by held-out error.
    Diagnose(mrfeel::ident::cli::DiagnoseArgs),
}

fn main() -> anyhow::Result<()> {
    match Cli::parse().command {
        Command::Fit(a) => mrfeel::ident::cli::run_fit(&a),
        Command::Validate(a) => mrfeel::ident::cli::run_validate(&a),
        Command::Diagnose(a) => mrfeel::ident::cli::run_diagnose(&a),
    }
}
