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

/// Bytes of peak resident set per extra sample of `mrfeel diagnose` between two records that `mts` makes
/// with `--cycles short` and `--cycles long` (2,000 samples per current and cycle), with the other `mts`
/// and `diagnose` arguments given.
fn diagnose_bytes_per_sample(
    mts: &[&str],
    diagnose: &[&str],
    currents: usize,
    cycles: (usize, usize),
) -> f64 {
    let dir = tempfile::tempdir().expect("tempdir");
    let rss = |cycles: usize| {
        let csv = dir.path().join(format!("record_{cycles}.csv"));
        let cycles = cycles.to_string();
        let mut args = vec!["mts", "--cycles", &cycles, "--out"];
        let path = s(&csv);
        args.push(&path);
        args.extend(mts);
        ok(&crate::common::mrfeel(&args));
        let mut args = vec!["diagnose", &path, "--json", "--model", "bingham"];
        args.extend(diagnose);
        peak_rss(&args)
    };
    let (short, long) = (rss(cycles.0), rss(cycles.1));
    let extra = (currents * (cycles.1 - cycles.0) * 2000) as f64;
    let per_sample = (long as f64 - short as f64) / extra;
    eprintln!(
        "diagnose {mts:?} {diagnose:?}: {per_sample:.0} bytes per extra sample ({:.1} MB, {:.1} MB)",
        short as f64 / 1e6,
        long as f64 / 1e6
    );
    per_sample
}

/// The diagnosis holds at most 400 bytes per sample of the record: its peak resident set grows by less
/// than that per extra sample between a 20,000- and an 80,000-sample record (a Bingham damper at two
/// currents, at its noise floor: the base's fit on all data, its cross-validation over four time blocks
/// and the verdict).
#[test]
fn diagnose_holds_under_400_bytes_per_sample() {
    let per_sample = diagnose_bytes_per_sample(&["--current", "0,1"], &["--named-only"], 2, (5, 20));
    assert!(per_sample < 400.0, "{per_sample:.0} bytes per extra sample");
}

/// The same limit for the default diagnosis, open term search on, on a record with a hidden hysteresis
/// (four currents, 16,000 and 64,000 samples): every candidate's cross-validation, the step that names
/// hysteresis and the verdict on what is left. The binary caps glibc at two arenas, so that worker threads
/// do not each keep their freed buffers.
#[test]
fn the_searching_diagnosis_holds_under_400_bytes_per_sample() {
    let per_sample = diagnose_bytes_per_sample(
        &["--current", "0,0.5,1,1.5", "--effects", "hysteresis"],
        &[],
        4,
        (2, 8),
    );
    assert!(per_sample < 400.0, "{per_sample:.0} bytes per extra sample");
}

/// The same limit for the diagnosis that takes three steps (hidden hysteresis and stiffness, four currents,
/// 40,000 and 120,000 samples), where the fits carry the most parameters: the Jacobian goes into its
/// triangular factor a block of rows at a time, so no fit holds it whole.
#[test]
fn the_three_step_diagnosis_holds_under_400_bytes_per_sample() {
    let per_sample = diagnose_bytes_per_sample(
        &["--current", "0,0.5,1,1.5", "--effects", "hysteresis,stiffness"],
        &[],
        4,
        (5, 15),
    );
    assert!(per_sample < 400.0, "{per_sample:.0} bytes per extra sample");
}
