//! mrfeel: simulation and model discovery for magneto-rheological artificial feel systems.
pub mod aero;
pub mod device;
pub mod units;
