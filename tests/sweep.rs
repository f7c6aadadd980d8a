//! `mrfeel sweep`: shards merged equal one process to the byte, whatever the number of workers; a killed
//! sweep resumes without repeating or losing a run; bad plans, shards and merges are refused at their line.

use crate::common;

use std::path::{Path, PathBuf};

use common::mrfeel;

fn repo(p: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(p)
}

/// A plan of 12 short runs of the paper's feel loop: feel gradient × DAQ rate × load-cell noise (seeded),
/// 1.5 s each.
fn small_plan(dir: &Path, seed: u64) -> PathBuf {
    let text = format!(
        r#"name = "small"
scenario = "{}"
seed = {seed}

[[axis]]
key = "duration_s"
values = [1.5]

[[axis]]
key = "feel.gradient_n_per_m"
values = [800.0, 1400.0]

[[axis]]
key = "daq.sample_rate_hz"
values = [250.0, 500.0, 1000.0]

[[axis]]
key = "load_cell.noise_rms_n"
draw = {{ dist = "uniform", low = 0.5, high = 2.0, count = 2 }}
"#,
        repo("scenarios/paper-feel-loop.toml").display()
    );
    let p = dir.join(format!("plan-{seed}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

fn ok(out: &std::process::Output) -> String {
    let s = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{s}");
    s
}

fn bytes(dir: &Path, f: &str) -> Vec<u8> {
    std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(f).display()))
}

#[test]
fn shards_merged_equal_one_process_on_any_number_of_workers() {
    let t = tempfile::tempdir().unwrap();
    let plan = small_plan(t.path(), 7);
    let one = t.path().join("one");
    ok(&mrfeel(&[
        "sweep",
        plan.to_str().unwrap(),
        "--out",
        one.to_str().unwrap(),
        "--jobs",
        "2",
    ]));
    let mut shards = Vec::new();
    for k in 0..3 {
        let d = t.path().join(format!("shard{k}"));
        ok(&mrfeel(&[
            "sweep",
            plan.to_str().unwrap(),
            "--out",
            d.to_str().unwrap(),
            "--jobs",
            "1",
            "--shard",
            &format!("{k}/3"),
        ]));
        shards.push(d);
    }
    let merged = t.path().join("merged");
    let mut args = vec!["sweep".to_string(), "merge".into()];
    args.extend(shards.iter().map(|d| d.display().to_string()));
    args.extend(["--out".into(), merged.display().to_string()]);
    ok(&mrfeel(&args));
    for f in ["results.parquet", "results.csv", "runs.jsonl"] {
        assert!(
            bytes(&one, f) == bytes(&merged, f),
            "{f} differs between one process and merged shards"
        );
    }
    // 12 runs, each with its own seed, and the seeded noise makes them differ: the runs were run, not copied.
    let csv = String::from_utf8(bytes(&one, "results.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().skip(1).collect();
    assert_eq!(rows.len(), 12, "{csv}");
    let seeds: std::collections::BTreeSet<&str> = rows.iter().map(|r| r.split(',').nth(1).unwrap()).collect();
    assert_eq!(seeds.len(), 12);
    // A Parquet file with the CSV's columns and rows: read back, its index and seeds are the CSV's.
    let pq = bytes(&one, "results.parquet");
    assert!(pq.starts_with(b"PAR1") && pq.ends_with(b"PAR1"));
    let reader = parquet::arrow::arrow_reader::ParquetRecordBatchReaderBuilder::try_new(
        std::fs::File::open(one.join("results.parquet")).unwrap(),
    )
    .unwrap()
    .build()
    .unwrap();
    let batches: Vec<_> = reader.map(|b| b.unwrap()).collect();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let schema = batches[0].schema();
    let names: Vec<&str> = schema.fields().iter().map(|f| f.name().as_str()).collect();
    assert_eq!(names, header);
    assert_eq!(batches.iter().map(|b| b.num_rows()).sum::<usize>(), 12);
    let col = |name: &str| -> Vec<String> {
        let a = batches[0].column(header.iter().position(|h| *h == name).unwrap());
        let a = a.as_any().downcast_ref::<arrow_array::UInt64Array>().unwrap();
        a.values().iter().map(|v| v.to_string()).collect()
    };
    let csv_col = |k: usize| -> Vec<String> {
        rows.iter()
            .map(|r| r.split(',').nth(k).unwrap().to_string())
            .collect()
    };
    assert_eq!(col("index"), csv_col(0));
    assert_eq!(col("seed"), csv_col(1));
}

#[test]
fn a_run_seed_and_draws_do_not_depend_on_workers_or_shards() {
    let t = tempfile::tempdir().unwrap();
    let p = mrfeel::sweep::Plan::load(&small_plan(t.path(), 7)).unwrap();
    let q = mrfeel::sweep::Plan::load(&small_plan(t.path(), 8)).unwrap();
    // The same index gives the same run whatever order the runs are asked for in.
    let forward: Vec<_> = (0..12).map(|i| p.run(i)).collect();
    let backward: Vec<_> = (0..12).rev().map(|i| p.run(i)).collect();
    for (a, b) in forward.iter().zip(backward.iter().rev()) {
        assert_eq!(a, b);
    }
    // The grid's draws: two values of the noise axis, the same for every run that takes the same one.
    let noise: std::collections::BTreeSet<u64> = forward
        .iter()
        .map(|r| match r.params[3] {
            mrfeel::sweep::Param::Num(x) => x.to_bits(),
            _ => panic!("numeric"),
        })
        .collect();
    assert_eq!(noise.len(), 2);
    // Another plan seed: other run seeds.
    assert!((0..12).all(|i| p.run(i).seed != q.run(i).seed));
}

#[test]
fn a_killed_sweep_resumes_without_repeating_or_losing_a_run() {
    let t = tempfile::tempdir().unwrap();
    let plan = small_plan(t.path(), 3);
    let whole = t.path().join("whole");
    ok(&mrfeel(&[
        "sweep",
        plan.to_str().unwrap(),
        "--out",
        whole.to_str().unwrap(),
        "--jobs",
        "2",
    ]));

    let out = t.path().join("killed");
    let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args([
            "sweep",
            plan.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--jobs",
            "1",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let journal = out.join("runs.jsonl");
    let start = std::time::Instant::now();
    loop {
        let n = std::fs::read_to_string(&journal)
            .map(|s| s.lines().count())
            .unwrap_or(0);
        if n >= 3 || start.elapsed().as_secs() > 120 {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = std::fs::read_to_string(&journal).unwrap();
    let kept = before.lines().count();
    assert!(
        (3..12).contains(&kept),
        "killed after {kept} runs: too late to test a resume"
    );
    // A write cut short by the kill: half a line, dropped and run again.
    std::fs::write(&journal, format!("{before}{{\"index\": 11, \"seed\"")).unwrap();
    let again = ok(&mrfeel(&[
        "sweep",
        plan.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--jobs",
        "2",
    ]));
    assert!(again.contains(&format!("12 runs ({kept} resumed")), "{again}");
    for f in ["results.parquet", "results.csv", "runs.jsonl"] {
        assert!(bytes(&whole, f) == bytes(&out, f), "{f} differs after the resume");
    }
    let idx: Vec<u64> = String::from_utf8(bytes(&out, "runs.jsonl"))
        .unwrap()
        .lines()
        .map(|l| {
            serde_json::from_str::<serde_json::Value>(l).unwrap()["index"]
                .as_u64()
                .unwrap()
        })
        .collect();
    assert_eq!(idx, (0..12).collect::<Vec<_>>());
}

fn refused(args: &[&str], expect: &[&str]) {
    let out = mrfeel(args);
    let err = String::from_utf8_lossy(&out.stderr).to_string();
    assert!(!out.status.success(), "accepted: {args:?}");
    for e in expect {
        assert!(err.contains(e), "expected `{e}` in:\n{err}");
    }
}

#[test]
fn bad_axes_shards_and_merges_are_refused_at_their_line() {
    let t = tempfile::tempdir().unwrap();
    let base = repo("scenarios/c172p-pitch-tracking.toml");
    let write = |name: &str, axes: &str| {
        let p = t.path().join(name);
        std::fs::write(
            &p,
            format!(
                "name = \"bad\"\nscenario = \"{}\"\nseed = 1\n\n{axes}",
                base.display()
            ),
        )
        .unwrap();
        p
    };
    let out = t.path().join("out");
    let o = out.to_str().unwrap();
    // A key the scenario does not have: the plan's line 6 (the value).
    let p = write(
        "unknown.toml",
        "[[axis]]\nkey = \"feel.gradient_n_per_mm\"\nvalues = [900.0]\n",
    );
    refused(
        &["sweep", p.to_str().unwrap(), "--out", o],
        &["unknown.toml:7: field `feel.gradient_n_per_mm`", "unknown field"],
    );
    // A value outside the key's range, on its own line of a list.
    let p = write(
        "range.toml",
        "[[axis]]\nkey = \"aircraft.airspeed_m_s\"\nvalues = [\n  50.0,\n  5.0,\n]\n",
    );
    refused(
        &["sweep", p.to_str().unwrap(), "--out", o],
        &[
            "range.toml:9: field `aircraft.airspeed_m_s`",
            "value 5 outside the allowed range [10, 300]",
        ],
    );
    // Nothing was run or written for a refused plan.
    assert!(!out.join("runs.jsonl").exists());
    // A shard out of range.
    let good = write("good.toml", "[[axis]]\nkey = \"duration_s\"\nvalues = [0.5]\n");
    refused(
        &["sweep", good.to_str().unwrap(), "--out", o, "--shard", "3/3"],
        &["--shard", "3/3", "0..N-1"],
    );
    // Shards of two plans.
    let other = write("other.toml", "[[axis]]\nkey = \"duration_s\"\nvalues = [0.6]\n");
    let (a, b) = (t.path().join("a"), t.path().join("b"));
    ok(&mrfeel(&[
        "sweep",
        good.to_str().unwrap(),
        "--out",
        a.to_str().unwrap(),
        "--shard",
        "0/2",
    ]));
    ok(&mrfeel(&[
        "sweep",
        other.to_str().unwrap(),
        "--out",
        b.to_str().unwrap(),
        "--shard",
        "1/2",
    ]));
    refused(
        &[
            "sweep",
            "merge",
            a.to_str().unwrap(),
            b.to_str().unwrap(),
            "--out",
            o,
        ],
        &[
            &format!("{}:3: field `digest`", b.join("sweep.toml").display()),
            "another plan",
        ],
    );
    // A directory of one plan is not resumed with another.
    refused(
        &[
            "sweep",
            other.to_str().unwrap(),
            "--out",
            a.to_str().unwrap(),
            "--shard",
            "0/2",
        ],
        &["sweep.toml:3: field `digest`"],
    );
}

/// A plan of the c172p pitch-tracking task at 50 m/s, 1000 m, 14 s, one run per feel system given.
fn c172p_plan(dir: &Path, kinds: &[&str]) -> PathBuf {
    let cases: String = kinds
        .iter()
        .map(|k| {
            format!(
                "[[axis.case]]\nlabel = \"{k}\"\nset = {{ \"feel_system.kind\" = \"{k}\", \"feel_system.springs\" = \"{}\", \"feel_system.damping_n_s_per_m\" = 100.0 }}\n",
                repo("models/feel-springs.toml").display()
            )
        })
        .collect();
    let text = format!(
        "name = \"stop\"\nscenario = \"{}\"\nseed = 1\n\n[[axis]]\nkey = \"duration_s\"\nvalues = [14.0]\n\n[[axis]]\nname = \"feel\"\n{cases}",
        repo("scenarios/c172p-pitch-tracking.toml").display()
    );
    let p = dir.join("stop.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// A run that drives the load cell past its range is a design point with a failed verdict, not a lost
/// run: at 50 m/s the q-feel spring (243 N/m at the piston, a fifth of the centring spring's 1130) lets the
/// pilot drive the stick into its stop at about 0.9 rad/s, and stopping the 3.4 kg piston assembly in a
/// few milliseconds puts a few hundred newtons through the 250 N cell. The run keeps its figures and
/// verdicts with `load_cell_ok = false`; the stiffer centring spring at the same point stays in range.
#[test]
fn a_run_past_the_load_cell_range_is_a_failed_verdict_not_a_lost_run() {
    let t = tempfile::tempdir().unwrap();
    let plan = mrfeel::sweep::Plan::load(&c172p_plan(t.path(), &["q_feel", "centring_spring"])).unwrap();
    let q = mrfeel::sweep::run_one(&plan, &plan.run(0)).outcome;
    let c = mrfeel::sweep::run_one(&plan, &plan.run(1)).outcome;
    assert_eq!(q.error, None, "{q:?}");
    assert_eq!(q.load_cell_ok, Some(false), "{q:?}");
    let peak = q.load_cell_peak_n.unwrap();
    // Above the 250 N rating, and of the size of the impact: the piston assembly (3.36 kg in the URDF)
    // arriving at about 0.135 m/s and stopped within one 1 ms step would need 454 N.
    assert!(peak > 250.0 && peak < 454.0, "peak {peak} N");
    assert!(q.per_g_level.is_some() && q.grip_force_peak_n.is_some(), "{q:?}");
    assert_eq!(c.error, None, "{c:?}");
    assert_eq!(c.load_cell_ok, Some(true), "{c:?}");
    assert!(c.load_cell_peak_n.unwrap() < 250.0, "{c:?}");
}
