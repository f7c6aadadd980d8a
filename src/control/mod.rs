//! Control: feel laws, the PID and the MR feel loop (signals only: the loop sees sensor samples), and the
//! passive spring feel systems it is compared with.

pub mod controller;
pub mod feel;
pub mod law;
pub mod pid;

pub use controller::{ControlOutput, FeelController, Hybrid, LoopMode};
pub use law::FeelLaw;
pub use pid::{AntiWindup, Pid, PidGains};
