//! The subcommands, one file per family: their clap arguments, and the progress, tables, plots and
//! recordings around the library's calls.

pub mod compare;
pub mod mts;
pub mod sim;
pub mod sweep;

use std::io::IsTerminal;

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
