//! A request to stop long work early, made from another thread (the Python bindings make it on Ctrl-C):
//! a fit's search stops at its next evaluation and a run at its next progress report. What the stopped
//! work returns is meaningless; the one who asked discards it. One flag for the process, as Ctrl-C is.

use std::sync::atomic::{AtomicBool, Ordering};

static STOP: AtomicBool = AtomicBool::new(false);

/// Ask the work under way to stop.
pub fn request() {
    STOP.store(true, Ordering::Relaxed);
}

/// Withdraw the request (before new work starts).
pub fn clear() {
    STOP.store(false, Ordering::Relaxed);
}

/// Whether a stop was asked for.
pub(crate) fn requested() -> bool {
    STOP.load(Ordering::Relaxed)
}
