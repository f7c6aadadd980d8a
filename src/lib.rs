//! mrfeel: simulation and model discovery for magneto-rheological artificial feel systems.
#![warn(missing_docs)]
pub mod aero;
pub mod builtin;
pub mod compare;
pub mod control;
pub mod device;
pub mod faults;
pub mod ident;
pub mod input;
pub mod interrupt;
pub mod measurement;
pub mod mts;
pub mod outputs;
pub mod pilot;
pub mod prelude;
pub mod rig;
pub mod scenario;
pub mod sensors;
pub mod signal;
pub mod sim;
pub(crate) mod spikes;
pub mod sweep;
pub mod units;
pub mod viz;

/// `eprintln!` that never panics: a note on stderr (progress, what was written where, the final error) is
/// dropped if stderr cannot be written, where `eprintln!` panics (results go to checked files and stdout).
#[macro_export]
macro_rules! noteln {
    ($($arg:tt)*) => {
        $crate::note!("{}\n", format_args!($($arg)*))
    };
}

/// `eprint!` that never panics (see [`noteln!`]).
#[macro_export]
macro_rules! note {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stderr(), $($arg)*);
    }};
}

/// `print!` to stdout that returns the write's error (a full disk, a closed stream) to the caller instead
/// of panicking as `print!` does: `out!(...)?`. The files a command reports are put in place first.
#[macro_export]
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        $crate::outputs::commit_open_set().and_then(|()| {
            write!(std::io::stdout(), $($arg)*)
                .map_err(|e| std::io::Error::new(e.kind(), format!("writing to stdout: {e}")))
        })
    }};
}

/// `println!` that returns the write's error instead of panicking: `outln!(...)?`.
#[macro_export]
macro_rules! outln {
    ($($arg:tt)*) => {
        $crate::out!("{}\n", format_args!($($arg)*))
    };
}
