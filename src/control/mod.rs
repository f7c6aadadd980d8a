//! Control: feel laws, the PID, the MR feel loop (it sees sensor samples only), the passive springs, and
//! the feel system that puts one of them on the rig ([`FeelSystem`]).

pub mod active;
pub(crate) mod controller;
pub mod feel;
pub(crate) mod law;
pub(crate) mod pid;
pub(crate) mod system;

pub use controller::{ControlOutput, FeelController, Hybrid, LoopMode};
pub use law::FeelLaw;
pub use pid::{AntiWindup, Pid, PidGains};
pub use system::{FeelSystem, Motor};
