//! Read-only views of results: static plots and Rerun recordings.

pub mod plot;
#[cfg(feature = "rerun")]
pub mod rerun_rig;

/// Why `--rerun` or `--spawn` is refused by a build without the `rerun` feature.
pub const NO_RERUN: &str =
    "this mrfeel was built without Rerun support (cargo feature `rerun`, on by default): no `--rerun` or `--spawn`";
