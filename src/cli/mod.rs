//! The subcommands, one file per family: their clap arguments, and the progress, tables, plots and
//! recordings around the library's calls.

pub mod compare;
pub mod ident;
pub mod mts;
pub mod sim;
pub mod sweep;

use std::io::IsTerminal;
use std::path::PathBuf;

use clap::builder::{PossibleValuesParser, TypedValueParser};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

/// The outputs a study writes besides its table: JSON on stdout, plots, a Rerun recording. A command
/// whose plots or recording hold something particular says so with `mut_arg` on its own arguments.
#[derive(clap::Args, Debug, Clone)]
pub struct OutputArgs {
    /// Print the contract's JSON on stdout instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Write PNG + SVG plots into this directory.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Write a Rerun recording (.rrd) of measured vs model force.
    #[arg(long)]
    pub rerun: Option<PathBuf>,
}

impl OutputArgs {
    /// The plot directory and the recording, by option, for the check of a command's outputs.
    pub fn files(&self) -> Vec<(&'static str, Option<&PathBuf>, mrfeel::outputs::Kind)> {
        use mrfeel::outputs::Kind::{Dir, File};
        vec![
            ("--plot", self.plot.as_ref(), Dir),
            ("--rerun", self.rerun.as_ref(), File),
        ]
    }
}

/// A progress bar of `len` steps drawn with `template` on stderr, hidden where stderr is not a terminal.
pub fn progress_bar(len: u64, template: &str) -> ProgressBar {
    let target = if std::io::stderr().is_terminal() {
        ProgressDrawTarget::stderr()
    } else {
        ProgressDrawTarget::hidden()
    };
    let pb = ProgressBar::with_draw_target(Some(len), target);
    if let Ok(style) = ProgressStyle::with_template(template) {
        pb.set_style(style.progress_chars("=> "));
    }
    pb
}

/// The value parser of an option that names one of a library enum's values (`all`, each named by `name`):
/// the names listed in `--help`, anything else refused by clap.
pub fn named<T: Copy + Send + Sync + 'static>(
    all: &'static [T],
    name: fn(T) -> &'static str,
) -> impl TypedValueParser<Value = T> {
    PossibleValuesParser::new(all.iter().map(|&v| name(v))).map(move |s| {
        *all.iter()
            .find(|&&v| name(v) == s)
            .expect("clap accepts only the possible values")
    })
}
