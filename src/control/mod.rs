//! Control: feel laws, the PID and passive feel systems.

pub mod feel;
