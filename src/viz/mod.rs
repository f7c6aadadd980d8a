//! Read-only views of results: static plots and Rerun recordings.

pub mod plot;
pub mod rerun_rig;
