//! mrfeel: simulation and model discovery for magneto-rheological artificial feel systems.
pub mod control;
pub mod device;
pub mod ident;
pub mod measurement;
pub mod mts;
pub mod rig;
pub mod units;
pub mod viz;
