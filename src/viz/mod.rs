//! Views of results: Rerun recordings and static plots.

pub mod rerun_rig;
