//! The stick rig in closed loop (issue 4): feel tracking, stroke, current, creep, energy, response time vs
//! DAQ rate, determinism, scenario errors, Rerun read-back.

use crate::common;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use mrfeel::control::{FeelLaw, LoopMode};
use mrfeel::pilot::{Signal, Task};
use mrfeel::scenario::Scenario;
use mrfeel::sim::{self, Devices, Results, RunOptions};
use mrfeel::units::IN_TO_M;

fn scenario_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join(name)
}

fn load(name: &str) -> (Scenario, Devices) {
    let (scn, device, _) = sim::load(&scenario_path(name)).unwrap_or_else(|e| panic!("{name}: {e:#}"));
    (scn, device)
}

fn run(scn: &Scenario, device: &Devices, opts: RunOptions) -> Results {
    let rig = sim::build_rig(scn, &device.plant).unwrap_or_else(|e| panic!("{e:#}"));
    sim::run(scn, device, rig, opts, |_| {}).unwrap_or_else(|e| panic!("{e}"))
}

/// The paper's bench, run once for all the tests that read it.
fn paper() -> &'static Results {
    static R: OnceLock<Results> = OnceLock::new();
    R.get_or_init(|| {
        let (scn, device) = load("paper-feel-loop.toml");
        run(&scn, &device, RunOptions::default())
    })
}

#[test]
fn paper_loop_load_cell_tracks_the_resisting_feel_force_within_10_percent_rms() {
    let s = paper().summary();
    eprintln!("{s}");
    // The comparison covers a real share of the run (the outward half of each sweep).
    assert!(
        s.resisting_samples > paper().rows.len() / 5,
        "only {} resisting samples",
        s.resisting_samples
    );
    let nrmse = s.tracking_nrmse.expect("the feel resists the sweep");
    assert!(nrmse < 0.10, "tracking NRMSE {nrmse:.3}");
    // The law asks for up to 70 N, and the loop delivers it.
    assert!(
        s.max_abs_load_cell_n > 60.0,
        "max load cell {:.1} N",
        s.max_abs_load_cell_n
    );
}

#[test]
fn paper_loop_piston_never_passes_the_2_in_stroke() {
    let s = paper().summary();
    assert!(
        s.max_abs_piston_x_m < 2.0 * IN_TO_M,
        "max |x| = {} m",
        s.max_abs_piston_x_m
    );
    // The pilot does sweep most of the stroke (the check is not vacuous).
    assert!(
        s.max_abs_piston_x_m > 1.2 * IN_TO_M,
        "max |x| = {} m",
        s.max_abs_piston_x_m
    );
}

#[test]
fn paper_loop_current_stays_within_0_to_14_a_and_uses_the_range() {
    let r = paper();
    for row in &r.rows {
        assert!(
            (0.0..=14.0).contains(&row.current_a),
            "t = {}: {} A",
            row.t_s,
            row.current_a
        );
    }
    let s = r.summary();
    assert!(s.current_max_a > 10.0, "max current {} A", s.current_max_a);
    assert_eq!(s.current_min_a, 0.0);
}

#[test]
fn paper_loop_releases_the_damper_when_the_stick_returns_to_centre() {
    // Moving back towards centre (x·v < 0, clear of the rest band) the spring law would need the damper
    // to push: the loop must command 0 A there.
    let r = paper();
    let returning: Vec<_> = r
        .rows
        .iter()
        .filter(|row| {
            row.piston_x_m * row.piston_v_m_s < 0.0
                && row.piston_v_m_s.abs() > 0.005
                && row.piston_x_m.abs() > 0.005
        })
        .collect();
    assert!(returning.len() > 1000);
    let released = returning
        .iter()
        .filter(|row| row.mode == LoopMode::Released && row.current_a == 0.0)
        .count();
    assert!(
        released as f64 > 0.95 * returning.len() as f64,
        "{released} of {}",
        returning.len()
    );
}

#[test]
fn paper_loop_pilot_work_equals_kinetic_energy_change_plus_damper_dissipation() {
    let s = paper().summary();
    assert!(s.pilot_work_j > 1.0, "pilot work {} J", s.pilot_work_j);
    assert!(s.energy_residual.is_some_and(|e| e.abs() < 0.01), "{s}");
}

/// A force-task pilot pushes on a stick held by the damper at 30 N yield (a force-steps law at rest holds
/// with its level): below yield nothing moves, above yield the stick goes.
fn push_at_rest(grip_force_n: f64) -> (Results, f64) {
    let (mut scn, device) = load("paper-feel-loop.toml");
    scn.duration_s = 2.5;
    scn.feel = FeelLaw::ForceSteps {
        low_n: 30.0,
        high_n: 30.0,
        start_s: 0.0,
        period_s: 100.0,
    };
    scn.pilot.task = Task::Force;
    scn.pilot.command = Signal::Step {
        initial: 0.0,
        last: grip_force_n,
        at_s: 0.5,
    };
    let r = run(&scn, &device, RunOptions::default());
    let i0 = r.rows.partition_point(|row| row.t_s < 0.5);
    let travel = r.rows[i0..]
        .iter()
        .map(|row| (row.piston_x_m - r.rows[i0].piston_x_m).abs())
        .fold(0.0, f64::max);
    (r, travel)
}

#[test]
fn stick_at_rest_below_the_yield_force_does_not_creep() {
    let (r, travel) = push_at_rest(6.0);
    let last = r.rows.last().unwrap();
    // The set-up is what the test claims: the push reaches the load cell, below the 30 N yield force.
    assert!(
        last.load_cell_true_n.abs() > 5.0 && last.load_cell_true_n.abs() < 0.8 * last.yield_force_n,
        "{last:?}"
    );
    assert!(
        travel < 5e-5,
        "piston crept {travel} m under a push below the yield force"
    );
    let (_, travel_above) = push_at_rest(20.0);
    assert!(
        travel_above > 5e-3,
        "a push above the yield force moved the piston only {travel_above} m"
    );
}

#[test]
fn response_time_grows_by_the_daq_latency_as_the_rate_falls() {
    let (scn, device) = load("response-time.toml");
    let pts = sim::response::sweep(&scn, &device, &[100.0, 5000.0], || {}).unwrap();
    let (slow, fast) = (&pts[0], &pts[1]);
    eprintln!("{}", sim::response::markdown_table(&pts));
    assert!(slow.steps >= 5 && fast.steps >= 5, "{pts:?}");
    // The command reaches the coil `latency_samples` DAQ periods after sampling, and the set-point change is
    // seen at the next tick (0–1 period later): at 100 Hz the delay grows by 1–2 periods (10–20 ms) over
    // 5 kHz. Without the latency line it would grow by less than one period; counted twice, by more than 2.
    let latency = scn.sensors.daq.latency_samples as f64;
    let ms = |v: Option<f64>| v.expect("steps were measured, so they have times");
    let grow_ms = ms(slow.mean_delay_ms) - ms(fast.mean_delay_ms);
    let lo = latency * (1e3 / 100.0 - 1e3 / 5000.0);
    let hi = (latency + 1.0) * 1e3 / 100.0 + 2.0;
    assert!(
        grow_ms >= lo && grow_ms <= hi,
        "delay grew by {grow_ms:.2} ms, expected [{lo:.1}, {hi:.1}] ms"
    );
    // And the force reaches 90 % later at 100 Hz than at 5 kHz.
    assert!(
        ms(slow.mean_rise_ms) + ms(slow.mean_delay_ms) > ms(fast.mean_rise_ms) + ms(fast.mean_delay_ms),
        "{pts:?}"
    );
}

/// A DAQ too slow to follow the scenario's force steps measures none: the point says so (no times, `null`
/// in the JSON, `–` in the table), where it used to report delays and rises of 0 ms.
#[test]
fn a_rate_that_measures_no_step_reports_no_times() {
    let (scn, device) = load("response-time.toml");
    let pts = sim::response::sweep(&scn, &device, &[1.0], || {}).unwrap();
    let p = &pts[0];
    assert_eq!(p.steps, 0, "{p:?}");
    assert_eq!(
        (p.mean_delay_ms, p.mean_rise_ms, p.max_rise_ms),
        (None, None, None)
    );
    let json = serde_json::to_value(p).unwrap();
    assert!(
        json["mean_delay_ms"].is_null() && json["max_rise_ms"].is_null(),
        "{json}"
    );
    let table = sim::response::markdown_table(&pts);
    assert!(
        table.lines().last().unwrap().starts_with("| 1 | 0 | – | – / – |"),
        "{table}"
    );
}

#[test]
fn same_scenario_and_seed_give_the_same_csv_bytes_and_another_seed_does_not() {
    let (mut scn, device) = load("paper-feel-loop.toml");
    scn.duration_s = 1.5;
    let csv = |scn: &Scenario| {
        let mut buf = Vec::new();
        run(scn, &device, RunOptions::default())
            .write_csv(&mut buf)
            .unwrap();
        buf
    };
    let a = csv(&scn);
    let b = csv(&scn);
    assert!(a == b, "two runs of the same scenario differ");
    let header = String::from_utf8_lossy(&a)
        .lines()
        .find(|l| !l.starts_with('#'))
        .unwrap()
        .to_string();
    for col in [
        "t_s",
        "stick_angle_rad",
        "piston_x_m",
        "piston_v_m_s",
        "load_cell_n",
        "desired_force_n",
        "current_a",
        "pilot_force_n",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "missing column {col} in {header}"
        );
    }
    scn.seed += 1;
    assert!(csv(&scn) != a, "the seed does not reach the sensor noise");
}

fn write_variant(dir: &Path, from: &str, to: &str) -> PathBuf {
    let text = std::fs::read_to_string(scenario_path("paper-feel-loop.toml")).unwrap();
    assert!(text.contains(from), "{from}");
    let text = text.replace(from, to).replace(
        "\"../models/",
        &format!("\"{}/models/", env!("CARGO_MANIFEST_DIR")),
    );
    let p = dir.join("variant.toml");
    std::fs::write(&p, text).unwrap();
    p
}

#[test]
fn scenario_with_an_unknown_key_is_rejected_naming_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_variant(dir.path(), "adc_bits = 16", "adc_bits = 16\nadc_bitz = 12");
    let e = Scenario::load(&p).unwrap_err().to_string();
    let line = std::fs::read_to_string(&p)
        .unwrap()
        .lines()
        .position(|l| l.starts_with("adc_bitz"))
        .unwrap()
        + 1;
    assert!(
        e.contains("variant.toml") && e.contains(&format!(":{line}:")) && e.contains("adc_bitz"),
        "{e}"
    );
}

#[test]
fn scenario_with_an_out_of_range_value_names_the_key_and_the_allowed_range() {
    let dir = tempfile::tempdir().unwrap();
    let p = write_variant(dir.path(), "current_max_a = 14.0", "current_max_a = 17.0");
    let e = Scenario::load(&p).unwrap_err().to_string();
    assert!(
        e.contains("controller.current_max_a") && e.contains("[0, 14]") && e.contains("variant.toml:"),
        "{e}"
    );
    let p = write_variant(dir.path(), "law = \"spring\"", "law = \"sprung\"");
    let e = Scenario::load(&p).unwrap_err().to_string();
    assert!(e.contains("feel.law") && e.contains("spring, force-steps"), "{e}");
    let p = write_variant(dir.path(), "amplitude_rad = 0.28", "amplitude_n = 10.0");
    let e = Scenario::load(&p).unwrap_err().to_string();
    assert!(e.contains("amplitude_n") && e.contains("amplitude_rad"), "{e}");
}

#[test]
#[cfg(feature = "rerun")]
fn rerun_recording_reads_back_equal_to_the_csv() {
    common::venv_python();
    let (mut scn, device) = load("paper-feel-loop.toml");
    scn.duration_s = 1.0;
    let res = run(
        &scn,
        &device,
        RunOptions {
            frames_hz: Some(30.0),
        },
    );
    let (ok, text) = common::record_and_read_back(&res);
    assert!(ok, "read-back failed:\n{text}");
    for line in [
        "ok /signals/force/load_cell == CSV load_cell_n",
        "ok /signals/current/command == CSV current_a",
        "ok /forces/hand == CSV pilot_force_n",
        "ok /forces/damper == CSV damper_force_n",
        "ok view coordinates: right-handed, z up",
    ] {
        assert!(text.contains(line), "no `{line}` in:\n{text}");
    }
}

#[test]
fn pilot_key_of_another_signal_is_rejected_naming_file_line_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let sweep = "signal = \"triangle\"\namplitude_rad = 0.28\nfrequency_hz = 0.25";
    let line_of = |p: &Path, key: &str| {
        std::fs::read_to_string(p)
            .unwrap()
            .lines()
            .position(|l| l.starts_with(key))
            .unwrap()
            + 1
    };
    // A valid step loads (the variants below differ from it by one key).
    let step = "signal = \"step\"\ninitial_rad = 0.0\nfinal_rad = 0.1\nat_s = 1.0";
    let p = write_variant(dir.path(), sweep, step);
    Scenario::load(&p).unwrap_or_else(|e| panic!("{e}"));
    for (variant, key) in [
        // `frequency_hz` belongs to sine/triangle, not to a step.
        (format!("{step}\nfrequency_hz = 0.25"), "frequency_hz"),
        // `at_s` belongs to a step, not to a ramp.
        (
            "signal = \"ramp\"\nfrom_rad = 0.0\nto_rad = 0.2\nstart_s = 0.0\nramp_duration_s = 2.0\nat_s = 1.0"
                .to_string(),
            "at_s",
        ),
        // A command value of another signal, in the task's own unit.
        (format!("{sweep}\nfinal_rad = 0.1"), "final_rad"),
        // `cutoff_hz` belongs to random tracking, not to a triangle.
        (format!("{sweep}\ncutoff_hz = 2.0"), "cutoff_hz"),
    ] {
        let p = write_variant(dir.path(), sweep, &variant);
        let e = Scenario::load(&p).unwrap_err().to_string();
        let line = line_of(&p, key);
        assert!(
            e.contains("variant.toml")
                && e.contains(&format!(":{line}:"))
                && e.contains(&format!("pilot.{key}"))
                && e.contains("not used by signal"),
            "{key}: {e}"
        );
    }
}

/// Time for the unit-step response of two first-order lags in series (the coil's `Te`, Eq. 3, and the
/// fluid's `Tm`, Eq. 4) to stay within 5 % of its final value, s.
fn two_lag_settling_s(te: f64, tm: f64) -> f64 {
    let left = |t: f64| {
        if (te - tm).abs() < 1e-9 * te {
            (1.0 + t / te) * (-t / te).exp()
        } else {
            (te * (-t / te).exp() - tm * (-t / tm).exp()) / (te - tm)
        }
    };
    let (mut lo, mut hi) = (0.0, 20.0 * (te + tm));
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if left(mid) > 0.05 {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

#[test]
fn force_settles_as_fast_as_the_coil_and_fluid_lags_allow_and_later_at_a_slow_daq() {
    let (scn, device) = load("response-time.toml");
    let pts = sim::response::sweep(&scn, &device, &[100.0, 5000.0], || {}).unwrap();
    eprintln!("{}", sim::response::markdown_table(&pts));
    let (slow, fast) = (&pts[0], &pts[1]);
    assert!(slow.steps >= 5 && fast.steps >= 5, "{pts:?}");
    assert!(slow.unsettled == 0 && fast.unsettled == 0, "{pts:?}");
    let te = device.plant.param("te_s").unwrap();
    let tm = device.plant.param("tm_s").unwrap();
    let latency = scn.sensors.daq.latency_samples as f64;
    // With a fast DAQ the feedforward's current step reaches the force through the coil and the fluid lags
    // in series, after the DAQ's delay ((latency + ½) periods on average): the force settles when that
    // two-lag response does. The coil lag alone (Te ln 20 = 45 ms) or the fluid lag alone (24 ms) would
    // settle more than 15 % sooner, both lags doubled twice as late.
    let ideal_ms = 1e3 * (two_lag_settling_s(te, tm) + (latency + 0.5) / 5000.0);
    let fast_ms = fast.mean_settling_ms.unwrap();
    assert!(
        (fast_ms / ideal_ms - 1.0).abs() < 0.15,
        "settling at 5 kHz {fast_ms:.1} ms, two-lag response {ideal_ms:.1} ms"
    );
    // Every step, not just the mean (the steps are alike).
    assert!(fast.max_settling_ms.unwrap() < 1.15 * ideal_ms, "{pts:?}");
    // At 100 Hz the command reaches the coil later by at least the latency line's extra periods, and the
    // PI loop's correction comes in 10 ms steps: settling degrades by at least the added latency.
    let slow_ms = slow.mean_settling_ms.unwrap();
    let added_ms = latency * (1e3 / 100.0 - 1e3 / 5000.0);
    assert!(
        slow_ms - fast_ms >= added_ms,
        "settling at 100 Hz {slow_ms:.1} ms vs 5 kHz {fast_ms:.1} ms: degraded by less than the added latency {added_ms:.1} ms"
    );
}

/// Waits until `path` exists and its size has not changed for `quiet`; false if `deadline` comes first.
fn wait_until_quiet(path: &Path, quiet: std::time::Duration, deadline: std::time::Instant) -> bool {
    let mut last = (None, std::time::Instant::now());
    while std::time::Instant::now() < deadline {
        let size = std::fs::metadata(path).ok().map(|m| m.len());
        if size != last.0 {
            last = (size, std::time::Instant::now());
        } else if size.is_some() && last.1.elapsed() >= quiet {
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    false
}

/// Stops the viewer the test spawned (by the pid its stand-in recorded), also when the test fails.
struct Viewer(PathBuf);

impl Viewer {
    fn pid(&self) -> Option<String> {
        std::fs::read_to_string(&self.0)
            .ok()
            .map(|s| s.trim().to_string())
    }

    /// SIGINT (the viewer's Ctrl-C: it closes the file it saves to), then wait up to 20 s for it to exit.
    fn stop(&self) -> bool {
        let Some(pid) = self.pid() else {
            return true;
        };
        if !Path::new(&format!("/proc/{pid}")).exists() {
            return true;
        }
        let _ = std::process::Command::new("kill").args(["-INT", &pid]).status();
        for _ in 0..200 {
            if !Path::new(&format!("/proc/{pid}")).exists() {
                return true;
            }
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
        false
    }
}

impl Drop for Viewer {
    fn drop(&mut self) {
        if !self.stop() {
            if let Some(pid) = self.pid() {
                let _ = std::process::Command::new("kill").args(["-KILL", &pid]).status();
            }
        }
    }
}

#[test]
fn run_with_spawn_streams_the_recording_to_the_spawned_viewer() {
    // `mrfeel run --spawn` starts `rerun` from PATH the way the Rerun SDK does. Headless and in CI: a
    // stand-in `rerun` first on PATH records the arguments it was started with and runs the real viewer
    // CLI of the venv's rerun-sdk (same version as the crate) as a windowless gRPC server that saves
    // everything it receives (`--save`); that file is read back and checked against the run's CSV.
    let py = common::venv_python();
    let out = std::process::Command::new(&py)
        .args([
            "-c",
            "import os, rerun_cli; print(os.path.join(os.path.dirname(rerun_cli.__file__), 'rerun'))",
        ])
        .output()
        .unwrap();
    let real = String::from_utf8_lossy(&out.stdout).trim().to_string();
    assert!(
        Path::new(&real).is_file(),
        "no viewer binary in the venv's rerun-sdk: {real:?} {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (args_txt, pid_txt, received) = (d.join("args.txt"), d.join("viewer.pid"), d.join("received.rrd"));
    let bin = d.join("bin");
    std::fs::create_dir(&bin).unwrap();
    let standin = bin.join("rerun");
    std::fs::write(
        &standin,
        format!(
            "#!/bin/sh\n\
             # Stand-in viewer for mrfeel's --spawn test: the real CLI, windowless, saving what it receives.\n\
             if [ \"$1\" = \"--version\" ]; then exec '{real}' --version; fi\n\
             printf '%s\\n' \"$@\" > '{args}'\n\
             echo $$ > '{pid}'\n\
             exec '{real}' \"$@\" --save '{received}'\n",
            args = args_txt.display(),
            pid = pid_txt.display(),
            received = received.display(),
        ),
    )
    .unwrap();
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&standin, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    // A free port, so that a viewer the developer has open on the default port is not reused.
    let port = std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let scn = write_variant(d, "duration_s = 12.0", "duration_s = 1.0");
    let csv = d.join("run.csv");
    let path = std::env::join_paths(std::iter::once(bin.clone()).chain(std::env::split_paths(
        &std::env::var_os("PATH").unwrap_or_default(),
    )))
    .unwrap();
    let _viewer = Viewer(pid_txt.clone());
    // Output to files, not pipes: the viewer inherits them and outlives the run (pipes would block the
    // wait for the run's output until the viewer exits).
    let (out_txt, err_txt) = (d.join("run.out"), d.join("run.err"));
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .arg("run")
        .arg(&scn)
        .arg("--out")
        .arg(&csv)
        .args(["--spawn", "--spawn-port", &port.to_string()])
        .env("PATH", path)
        // Debug builds of the SDK look for `$CARGO_TARGET_DIR/debug/rerun` before PATH.
        .env_remove("CARGO_TARGET_DIR")
        .env("RERUN_ANALYTICS", "0")
        .stdout(std::fs::File::create(&out_txt).unwrap())
        .stderr(std::fs::File::create(&err_txt).unwrap())
        .status()
        .unwrap();
    let text = format!(
        "{}{}",
        std::fs::read_to_string(&out_txt).unwrap_or_default(),
        std::fs::read_to_string(&err_txt).unwrap_or_default()
    );
    assert!(status.success(), "mrfeel run --spawn failed:\n{text}");
    assert!(text.contains("scenario paper-feel-loop"), "{text}");
    // The SDK started the viewer from PATH on the requested port, expecting data.
    let args = std::fs::read_to_string(&args_txt)
        .unwrap_or_else(|e| panic!("the stand-in viewer was not started ({e}):\n{text}"));
    assert!(
        args.lines().any(|a| a == format!("--port={port}"))
            && args.lines().any(|a| a == "--expect-data-soon"),
        "viewer arguments: {args}"
    );
    // The run's recording stream delivered everything to the viewer's gRPC server before the run exited,
    // but the viewer writes what it received to its file on a thread of its own, which on a loaded
    // machine can lag behind (CI once read the file before the rig poses were in it). The file is
    // readable while the viewer runs (it has no footer either way), so read it back each time it has
    // stopped growing, for up to 60 s, then stop the viewer.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    let (ok, text) = loop {
        let quiet = wait_until_quiet(&received, std::time::Duration::from_secs(1), deadline);
        let (ok, text) = common::rerun_readback(&received, &csv);
        if ok || !quiet || std::time::Instant::now() >= deadline {
            break (ok, text);
        }
        std::thread::sleep(std::time::Duration::from_millis(500));
    };
    // The viewer is stopped when `viewer` drops (SIGINT, then SIGKILL if a loaded machine keeps it past
    // 20 s): how fast it exits is not what this test checks.
    assert!(
        ok,
        "read-back of what the viewer received (up to 60 s after the run) failed:\n{text}"
    );
    assert!(
        text.contains("ok /signals/force/load_cell == CSV load_cell_n"),
        "{text}"
    );
}

fn run_json(extra: &[&str]) -> serde_json::Value {
    let scn = scenario_path("paper-feel-loop.toml");
    let mut args = vec!["run", scn.to_str().unwrap(), "--json", "--set", "duration_s=2"];
    args.extend_from_slice(extra);
    let out = common::mrfeel(&args);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn run_set_changes_the_physics_its_key_names() {
    // The spring feel tops out at `feel.max_force_n` (70 N in the file). In 2 s the pilot's 0.25 Hz
    // triangle takes the stick to 16° and back (piston about 41 mm out), where the 1400 N/m gradient asks
    // 5 + 1400 * 0.041 ≈ 62 N: capped at 20 N the load cell must stay near 20 N (the damper has no force
    // of its own at 0 A), uncapped it must go well past it.
    let free = run_json(&[]);
    let capped = run_json(&["--set", "feel.max_force_n=20"]);
    assert!(
        (free["duration_s"].as_f64().unwrap() - 2.0).abs() < 0.01,
        "{free}"
    );
    let peak = |v: &serde_json::Value| v["max_abs_load_cell_n"].as_f64().unwrap();
    assert!(peak(&free) > 30.0, "{free}");
    assert!(peak(&capped) < 26.0, "{capped}");
    // A key the scenario does not have: refused with the argument and the key, nothing run.
    let scn = scenario_path("paper-feel-loop.toml");
    let out = common::mrfeel(&[
        "run",
        scn.to_str().unwrap(),
        "--set",
        "feel.gradient_n_per_mm=900",
    ]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("--set feel.gradient_n_per_mm=900: field `feel.gradient_n_per_mm`: unknown field"),
        "{err}"
    );
}
