//! The subcommands, one file per family: their clap arguments, and the progress, tables, plots and
//! recordings around the library's calls.

pub mod compare;
pub mod ident;
pub mod mts;
pub mod sim;
pub mod sweep;

use std::io::IsTerminal;

use clap::builder::{PossibleValuesParser, TypedValueParser};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};

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
