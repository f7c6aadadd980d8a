//! Control: feel laws, the PID, the MR feel loop (signals only: the loop sees sensor samples) and passive
//! feel systems.

pub mod controller;
pub mod feel;
pub mod law;
pub mod pid;

pub use controller::{ControlOutput, Feedforward, FeelController, LoopMode};
pub use law::FeelLaw;
pub use pid::{AntiWindup, Pid, PidGains};
