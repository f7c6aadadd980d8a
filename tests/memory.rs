//! Memory of `mrfeel diagnose` per sample of the record (`docs/benchmarks.md`, memory row): the peak
//! resident set of the command at two record lengths, so that the slope (bytes per extra sample) is told
//! apart from the fixed cost of the program.

#![cfg(target_os = "linux")]

use std::process::{Command, Stdio};

use crate::common::{ok, s};

/// Peak resident set of one run of `mrfeel ARGS`, bytes, from the kernel's account of the child
/// (`wait4`'s `ru_maxrss`, in KiB on Linux).
#[expect(
    clippy::zombie_processes,
    reason = "the child is reaped by wait4, which also gives its usage"
)]
fn peak_rss(args: &[&str]) -> u64 {
    let child = Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("start mrfeel");
    let pid = child.id() as libc::pid_t;
    let mut status: libc::c_int = 0;
    // SAFETY: `rusage` is plain data, valid when zeroed.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is this process's child, not yet waited for; `status` and `usage` are valid for writes.
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid, "wait4: {}", std::io::Error::last_os_error());
    assert!(
        libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0,
        "mrfeel {args:?} failed (status {status})"
    );
    u64::try_from(usage.ru_maxrss).expect("a peak resident set") * 1024
}

/// The diagnosis holds at most 400 bytes per sample of the record: its peak resident set grows by less
/// than that per extra sample between a 20,000- and an 80,000-sample record (a Bingham damper at two
/// currents, at its noise floor: the base's fit on all data, its cross-validation over four time blocks
/// and the verdict). The full Jacobians of fits that run side by side, one per fold and thread, are the
/// largest per-sample buffers: a thread that held a second fold's Jacobian while waiting for part of its
/// own fit would take this past the limit.
#[test]
fn diagnose_holds_under_400_bytes_per_sample() {
    let dir = tempfile::tempdir().expect("tempdir");
    let rss = |cycles: usize| {
        let csv = dir.path().join(format!("bingham_{cycles}.csv"));
        let cycles = cycles.to_string();
        ok(&crate::common::mrfeel(&[
            "mts",
            "--current",
            "0,1",
            "--cycles",
            &cycles,
            "--out",
            &s(&csv),
        ]));
        peak_rss(&[
            "diagnose",
            &s(&csv),
            "--json",
            "--model",
            "bingham",
            "--named-only",
        ])
    };
    // 2 current blocks × cycles × 2,000 samples (0.5 Hz at 1 kHz).
    let (short, long) = (rss(5), rss(20));
    let per_sample = (long as f64 - short as f64) / 60_000.0;
    assert!(
        per_sample < 400.0,
        "diagnose: {per_sample:.0} bytes of peak resident set per extra sample (20,000 samples: {:.1} MB, \
         80,000: {:.1} MB)",
        short as f64 / 1e6,
        long as f64 / 1e6
    );
}
