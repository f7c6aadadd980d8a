//! mrfeel: simulation and model discovery for magneto-rheological artificial feel systems.
pub mod device;
pub mod units;
