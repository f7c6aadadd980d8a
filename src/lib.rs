//! mrfeel: simulation and model discovery for magneto-rheological artificial feel systems.
pub mod aero;
pub mod compare;
pub mod control;
pub mod device;
pub mod faults;
pub mod ident;
pub mod measurement;
pub mod mts;
pub mod outputs;
pub mod pilot;
pub mod rig;
pub mod scenario;
pub mod sensors;
pub mod sim;
pub mod units;
pub mod viz;
