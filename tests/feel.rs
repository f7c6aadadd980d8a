//! Feel systems compared and under faults: physical facts on the multibody rig.

use std::path::Path;

use mrfeel::compare::metrics::{fault_metrics, system_metrics};
use mrfeel::compare::{run, CompareScenario, FeelKind, Segment, Trace};
use mrfeel::faults::{Fault, FaultKind, FaultSchedule};

fn scenario() -> CompareScenario {
    CompareScenario::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/compare-feel.toml"
    )))
    .unwrap()
}

fn main_run(scn: &CompareScenario, k: FeelKind, faults: &FaultSchedule) -> Trace {
    run(scn, k, &scn.main_task(), faults).unwrap()
}

fn release_angle(scn: &CompareScenario) -> f64 {
    scn.task.release_angle_rad
}

#[test]
fn passive_mr_damper_alone_keeps_the_stick_where_left_springs_and_hybrid_recentre() {
    let scn = scenario();
    let band = scn.task.recentre_band_rad;
    for k in [FeelKind::Mr, FeelKind::CentringSpring, FeelKind::MrSpring] {
        let main = main_run(&scn, k, &FaultSchedule::none());
        let brk = run(&scn, k, &scn.breakout_task(), &FaultSchedule::none()).unwrap();
        let m = system_metrics(&scn, &main, &brk);
        eprintln!(
            "{}: offset {:.4} rad, time {:.2} s",
            k.name(),
            m.recentre_offset_rad,
            m.recentre_time_s
        );
        if k == FeelKind::Mr {
            // A damper stores no energy: nothing can bring the stick back; the offset stays near where
            // the pilot let go.
            assert!(
                m.recentre_offset_rad > 0.8 * release_angle(&scn),
                "{k:?} {}",
                m.recentre_offset_rad
            );
            assert!(m.recentre_time_s.is_nan());
        } else {
            assert!(
                m.recentre_offset_rad < band,
                "{k:?} offset {}",
                m.recentre_offset_rad
            );
            assert!(m.recentre_time_s < 2.0, "{k:?} time {}", m.recentre_time_s);
        }
    }
}

#[test]
fn no_passive_feel_system_injects_energy() {
    let scn = scenario();
    // Every system but the motor-driven stick, which is not passive (see `the_active_stick_…`).
    for k in FeelKind::ALL.into_iter().filter(|&k| k != FeelKind::Active) {
        let main = main_run(&scn, k, &FaultSchedule::none());
        let brk = run(&scn, k, &scn.breakout_task(), &FaultSchedule::none()).unwrap();
        let m = system_metrics(&scn, &main, &brk);
        let work = main.rows.last().unwrap().hand_work_j;
        eprintln!(
            "{}: injected {:.2e} J of {:.3} J hand work, dissipated {:.3} J",
            k.name(),
            m.energy_injected_j,
            work,
            m.energy_dissipated_j
        );
        // Passive: the stored energy never exceeds the hand's work (1e-4 of it: f32 solver noise).
        assert!(
            m.energy_injected_j <= 1e-4 * work,
            "{k:?}: injected {}",
            m.energy_injected_j
        );
        assert!(m.energy_dissipated_j > 0.0);
    }
}

#[test]
fn q_feel_gradient_at_the_grip_scales_with_dynamic_pressure() {
    let mut scn = scenario();
    let slope_at = |scn: &CompareScenario, q: f64| {
        let mut s = scn.clone();
        s.qbar_pa = q;
        let main = main_run(&s, FeelKind::QFeel, &FaultSchedule::none());
        let brk = run(&s, FeelKind::QFeel, &scn.breakout_task(), &FaultSchedule::none()).unwrap();
        system_metrics(&s, &main, &brk).force_gradient_n_per_rad
    };
    scn.springs.q_feel.k0_n_per_m = 100.0;
    let (q1, q2) = (5_000.0, 20_000.0);
    let (g1, g2) = (slope_at(&scn, q1), slope_at(&scn, q2));
    // Grip gradient = k·g²/L (x = g θ at the piston, F_grip = F_piston·g/L); gravity, inertia and the
    // stick's own stiffness cancel in the difference.
    let rig = mrfeel::rig::Rig::new(&scn.rig, scn.devices.plant.damper()).unwrap();
    let (g, l) = (rig.gearing_m_per_rad(), rig.grip_lever_m());
    let expect = scn.springs.q_feel.kq_n_per_m_per_pa * (q2 - q1) * g * g / l;
    eprintln!(
        "grip gradient {g1:.1} N/rad at {q1} Pa, {g2:.1} at {q2} Pa; difference {:.1}, expected {expect:.1}",
        g2 - g1
    );
    assert!(
        ((g2 - g1) - expect).abs() < 0.06 * expect,
        "{} vs {expect}",
        g2 - g1
    );
}

/// Rows of a trace inside `[a, b)`.
fn window(tr: &Trace, a: f64, b: f64) -> Vec<mrfeel::compare::Row> {
    tr.rows
        .iter()
        .filter(|r| r.t_s >= a && r.t_s < b)
        .copied()
        .collect()
}

#[test]
fn coil_open_drops_the_mr_force_to_the_zero_current_yield_and_stops_tracking() {
    let scn = scenario();
    let (a, b) = (scn.fault_test.start_s, scn.fault_test.end_s);
    let healthy = main_run(&scn, FeelKind::Mr, &FaultSchedule::none());
    let tr = main_run(
        &scn,
        FeelKind::Mr,
        &FaultSchedule::single(Fault::new(FaultKind::CoilOpen, a, b)),
    );
    let fc0 = scn.devices.plant.param("fc0_n").unwrap();
    // After the coil and fluid lags (Te + Tm = 23 ms; 0.2 s is > 8 of them), the yield is the zero-current one.
    let w = window(&tr, a + 0.2, b);
    let worst = w
        .iter()
        .map(|r| (r.yield_force_n - fc0).abs())
        .fold(0.0, f64::max);
    assert!(
        worst < 0.01 * scn.target.max_force_n,
        "yield departs from fc0 by {worst} N"
    );
    assert!(w.iter().all(|r| r.current_applied_a == 0.0));
    let m = fault_metrics(&scn, &tr, &healthy, a, b);
    eprintln!(
        "coil open: force error {:.2} N (healthy {:.2}), peak {:.1} N",
        m.force_rms_error_n, m.healthy_force_rms_error_n, m.peak_force_n
    );
    assert!(m.force_rms_error_n > 1.3 * m.healthy_force_rms_error_n);
    // The controller keeps asking (it winds to its limit) but nothing reaches the fluid.
    assert!(m.current_cmd_max_a > 13.9);
    // With the coil open the pilot never feels more than with it working.
    assert!(m.peak_force_n <= fault_metrics(&scn, &healthy, &healthy, a, b).peak_force_n + 0.5);
}

#[test]
fn driver_stuck_gives_the_14_a_force_whatever_the_target_and_the_stick_moves_only_when_pushed() {
    let scn = scenario();
    let (a, b) = (scn.fault_test.start_s, scn.fault_test.end_s);
    let healthy = main_run(&scn, FeelKind::Mr, &FaultSchedule::none());
    let tr = main_run(
        &scn,
        FeelKind::Mr,
        &FaultSchedule::single(Fault::new(FaultKind::DriverStuck, a, b)),
    );
    let limit = scn.devices.plant.model.current_limit_a;
    let f14 = scn.devices.plant.param("fc0_n").unwrap()
        + scn.devices.plant.param("fc_gain_n_per_a").unwrap() * limit;
    let w = window(&tr, a + 0.2, b);
    for r in &w {
        assert!(
            (r.yield_force_n - f14).abs() < 0.01 * f14,
            "t {} yield {}",
            r.t_s,
            r.yield_force_n
        );
        assert_eq!(r.current_applied_a, limit);
    }
    // Under a pilot force above the yield (at the grip), the stick still follows the pilot.
    let sine_end = scn.main_task().segment_start_s(1);
    let sweep = window(&tr, a, sine_end);
    let (lo, hi) = sweep.iter().fold((f64::MAX, f64::MIN), |(l, h), r| {
        (l.min(r.theta_rad), h.max(r.theta_rad))
    });
    assert!(
        hi - lo > 1.5 * scn.task.sweep_amplitude_rad,
        "stick range {} rad",
        hi - lo
    );
    let m = fault_metrics(&scn, &tr, &healthy, a, b);
    let f14_grip = f14 * scn_gear_over_lever(&scn);
    assert!(
        m.peak_force_n > f14_grip,
        "pilot force {} vs yield at the grip {f14_grip}",
        m.peak_force_n
    );
    // Hands off, the stick does not move by itself.
    assert!(
        m.hands_off_moved_rad < 1e-3,
        "moved {} rad hands off",
        m.hands_off_moved_rad
    );
    assert!(!m.moves_without_pilot);
}

fn scn_gear_over_lever(scn: &CompareScenario) -> f64 {
    let rig = mrfeel::rig::Rig::new(&scn.rig, scn.devices.plant.damper()).unwrap();
    rig.gearing_m_per_rad() / rig.grip_lever_m()
}

#[test]
fn stuck_or_zero_load_cell_winds_the_loop_to_its_limit_and_anti_windup_lets_go_after() {
    let scn = scenario();
    let limit = scn.devices.plant.model.current_limit_a;
    let (a, b) = (2.5, 4.0);
    for kind in [FaultKind::LoadCellStuck, FaultKind::LoadCellZero] {
        let tr = main_run(&scn, FeelKind::Mr, &FaultSchedule::single(Fault::new(kind, a, b)));
        let w = window(&tr, a, b);
        let at_limit = w.iter().filter(|r| r.current_cmd_a >= limit - 1e-9).count();
        assert!(tr
            .rows
            .iter()
            .all(|r| r.current_cmd_a <= limit && r.current_cmd_a >= 0.0));
        // While the stick moves out, the measured force cannot rise to the target: the loop saturates.
        assert!(
            at_limit > w.len() / 10,
            "{kind:?}: {at_limit} of {} samples at {limit} A",
            w.len()
        );
        // After the fault, the clamped integrator does not hold the coil at the limit: within 0.3 s the
        // command leaves 14 A (a wound-up integrator of ki·e·1.5 s would hold it for seconds).
        let after = window(&tr, b + 0.3, b + 1.0);
        let still = after.iter().filter(|r| r.current_cmd_a >= limit - 1e-9).count();
        assert!(
            still < after.len() / 4,
            "{kind:?}: {still} of {} samples still at the limit",
            after.len()
        );
    }
}

#[test]
fn every_fault_leaves_the_run_going_is_flagged_and_cannot_touch_a_spring_feel_unit() {
    let scn = scenario();
    let (a, b) = (scn.fault_test.start_s, scn.fault_test.end_s);
    let n = (scn.main_task().duration_s() / 1e-3).round() as usize;
    let window_steps = ((b.min(scn.main_task().duration_s()) - a) / 1e-3).round() as usize;
    let spring_healthy = main_run(&scn, FeelKind::CentringSpring, &FaultSchedule::none());
    let mr_healthy = main_run(&scn, FeelKind::Mr, &FaultSchedule::none());
    let limit = scn.devices.plant.model.current_limit_a;
    let f14 = scn.devices.plant.param("fc0_n").unwrap()
        + scn.devices.plant.param("fc_gain_n_per_a").unwrap() * limit;
    let f14_grip = f14 * scn_gear_over_lever(&scn);
    for &f in FaultKind::ALL {
        let sched = FaultSchedule::single(Fault::new(f, a, b));
        let mr = main_run(&scn, FeelKind::Mr, &sched);
        assert_eq!(mr.rows.len(), n, "{f:?}");
        assert!(
            mr.rows
                .iter()
                .all(|r| r.theta_rad.is_finite() && r.hand_force_n.is_finite()),
            "{f:?}"
        );
        let m = fault_metrics(&scn, &mr, &mr_healthy, a, b);
        assert!(
            m.fault_steps.abs_diff(window_steps) <= 1,
            "{f:?}: {} flagged steps",
            m.fault_steps
        );
        // Every fault changes what the MR pilot feels.
        assert!(
            (m.force_rms_error_n - m.healthy_force_rms_error_n).abs() > 0.01,
            "{f:?} has no effect"
        );
        // No fault asks more of the pilot than the device's 14 A yield (the driver's full scale) at the
        // grip, with a margin for the stick's inertia and gravity; far inside the Part 23 stick limit.
        assert!(
            m.peak_force_n < 1.5 * f14_grip,
            "{f:?}: peak {} N vs {f14_grip} N",
            m.peak_force_n
        );
        assert!(m.peak_force_n < scn.limits.newtons().0, "{f:?}");
        let sp = main_run(&scn, FeelKind::CentringSpring, &sched);
        assert!(sp.rows.iter().all(|r| r.faults == 0));
        assert_eq!(
            sp.rows.last().unwrap().theta_rad,
            spring_healthy.rows.last().unwrap().theta_rad,
            "{f:?} changed a spring feel unit"
        );
    }
}

#[test]
fn coil_open_hands_off_leaves_a_free_stick_that_gravity_moves() {
    // The paper's fail-safe claim: with the power gone the MR stick can still be moved (no jam) and no
    // force is injected. What it cannot do is hold: the stick's centre of mass is above the pivot, so a
    // free stick let go off-centre falls away from the centre.
    let scn = scenario();
    let (a, b) = (scn.fault_test.start_s, scn.fault_test.end_s);
    let healthy = main_run(&scn, FeelKind::Mr, &FaultSchedule::none());
    let tr = main_run(
        &scn,
        FeelKind::Mr,
        &FaultSchedule::single(Fault::new(FaultKind::CoilOpen, a, b)),
    );
    let h = fault_metrics(&scn, &healthy, &healthy, a, b);
    let m = fault_metrics(&scn, &tr, &healthy, a, b);
    assert!(
        !h.moves_without_pilot && h.hands_off_moved_rad < 1e-3,
        "healthy moved {}",
        h.hands_off_moved_rad
    );
    assert!(
        m.moves_without_pilot,
        "coil open: moved {} rad",
        m.hands_off_moved_rad
    );
    // It falls away from the centre (the sign of the release angle), not back.
    let k = scn
        .main_task()
        .segments
        .iter()
        .position(|s| matches!(s, Segment::LetGo { .. }))
        .unwrap();
    let last = tr.rows.last().unwrap();
    let first_off = tr.rows.iter().find(|r| r.segment == k).unwrap();
    assert!(last.theta_rad.abs() > first_off.theta_rad.abs());
    assert_eq!(last.theta_rad.signum(), release_angle(&scn).signum());
}

#[test]
fn a_fault_scheduled_in_a_loop_scenario_reaches_the_coil_in_mrfeel_run() {
    // `[[fault]]` in any `mrfeel run` scenario: the coil-open window drops the yield to the zero-current
    // value while the loop keeps commanding current; outside it the loop works as before.
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios");
    let base = std::fs::read_to_string(format!("{dir}/paper-feel-loop.toml")).unwrap();
    let text = format!("{base}\n[[fault]]\nkind = \"coil_open\"\nstart_s = 2.0\nend_s = 3.0\n");
    let path = Path::new(dir).join("paper-feel-loop-coil-open.toml");
    let mut scn = mrfeel::scenario::Scenario::parse(&text, &path).unwrap();
    scn.duration_s = 3.5; // the triangle moves out from the centre over 0–1 s and 2–3 s
    assert_eq!(scn.faults.faults.len(), 1);
    let device =
        mrfeel::device::DeviceConfig::load(&scn.device_path, &mrfeel::device::Registry::builtin()).unwrap();
    let fc0 = device.param("fc0_n").unwrap();
    let rig = mrfeel::rig::Rig::new(&scn.rig, device.damper()).unwrap();
    let res = mrfeel::sim::run(
        &scn,
        &mrfeel::sim::Devices::same(device.clone()),
        rig,
        Default::default(),
        |_| {},
    )
    .unwrap();
    let inside: Vec<_> = res.rows.iter().filter(|r| r.t_s >= 2.2 && r.t_s < 3.0).collect();
    assert!(
        inside.iter().all(|r| (r.yield_force_n - fc0).abs() < 0.5),
        "yield not at fc0 with the coil open"
    );
    assert!(
        inside.iter().any(|r| r.current_a > 1.0),
        "the loop should still command current"
    );
    let before = res
        .rows
        .iter()
        .filter(|r| r.t_s >= 0.2 && r.t_s < 1.0)
        .map(|r| r.yield_force_n)
        .fold(0.0, f64::max);
    assert!(
        before > 5.0 + fc0,
        "the healthy loop yields {before} N before the fault"
    );
}

/// Delay (in physics steps, 0..=max) that best aligns `seen[k]` with `truth[k - d]` over `range`.
fn best_delay(seen: &[f64], truth: &[f64], range: std::ops::Range<usize>, max: usize) -> usize {
    (0..=max)
        .min_by(|&a, &b| {
            let err = |d: usize| -> f64 { range.clone().map(|k| (seen[k] - truth[k - d]).powi(2)).sum() };
            err(a).total_cmp(&err(b))
        })
        .unwrap()
}

#[test]
fn a_latency_spike_in_a_run_delays_what_the_controller_sees_and_is_marked_in_the_results() {
    // `mrfeel run` with a 50 ms latency spike from 2 s to 3 s: the load cell the controller sees (the
    // `load_cell_n` column) lags the true force by the DAQ's own sample (1 ms) outside the spike and by
    // 50 ms more inside it; the rows and the CSV's `fault_mask` column mark exactly the spike's window.
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios");
    let base = std::fs::read_to_string(format!("{dir}/paper-feel-loop.toml")).unwrap();
    let text = format!(
        "{base}\n[[fault]]\nkind = \"latency_spike\"\nstart_s = 2.0\nend_s = 3.0\nextra_latency_s = 0.05\n"
    );
    let path = Path::new(dir).join("paper-feel-loop-latency.toml");
    let mut scn = mrfeel::scenario::Scenario::parse(&text, &path).unwrap();
    scn.duration_s = 3.5;
    let device =
        mrfeel::device::DeviceConfig::load(&scn.device_path, &mrfeel::device::Registry::builtin()).unwrap();
    let rig = mrfeel::rig::Rig::new(&scn.rig, device.damper()).unwrap();
    let res = mrfeel::sim::run(
        &scn,
        &mrfeel::sim::Devices::same(device.clone()),
        rig,
        Default::default(),
        |_| {},
    )
    .unwrap();
    let bit = mrfeel::faults::FaultKind::LatencySpike.bit();
    for r in &res.rows {
        let inside = r.t_s >= 2.0 && r.t_s < 3.0;
        assert_eq!(
            r.faults,
            if inside { bit } else { 0 },
            "fault mask at t = {}",
            r.t_s
        );
    }
    // The controller sees the calibrated reading: compare with gain·F + offset of the load cell section.
    let lc = scn.sensors.load_cell;
    let truth: Vec<f64> = res
        .rows
        .iter()
        .map(|r| lc.gain * r.load_cell_true_n + lc.offset_n)
        .collect();
    let seen: Vec<f64> = res.rows.iter().map(|r| r.load_cell_n).collect();
    let healthy = best_delay(&seen, &truth, 1200..1900, 80);
    let spiked = best_delay(&seen, &truth, 2100..2900, 80);
    eprintln!("controller's view of the load cell lags by {healthy} ms healthy, {spiked} ms in the spike");
    assert!((1..=2).contains(&healthy), "healthy lag {healthy} ms");
    assert!((50..=53).contains(&spiked), "lag in the spike {spiked} ms");
    // The CSV carries the mask in its `fault_mask` column and names the bit in its header.
    let mut csv = Vec::new();
    res.write_csv(&mut csv).unwrap();
    let csv = String::from_utf8(csv).unwrap();
    assert!(
        csv.contains(&format!("{bit}=latency_spike")),
        "header must name the bit"
    );
    let header = csv.lines().find(|l| l.starts_with("t_s,")).unwrap();
    let col = header.split(',').position(|c| c == "fault_mask").unwrap();
    let marked: Vec<f64> = csv
        .lines()
        .skip_while(|l| !l.starts_with("t_s,"))
        .skip(1)
        .filter(|l| l.split(',').nth(col) == Some(&bit.to_string()))
        .map(|l| l.split(',').next().unwrap().parse::<f64>().unwrap())
        .collect();
    assert_eq!(marked.len(), 1000, "one marked row per millisecond of the spike");
    assert!(marked.iter().all(|&t| (2.0..3.0).contains(&t)));
}

/// Text of a scenario with a `[feel_system]` section appended.
fn with_feel_system(name: &str, section: &str) -> (String, std::path::PathBuf) {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios");
    let base = std::fs::read_to_string(format!("{dir}/{name}")).unwrap();
    (
        format!("{base}\n[feel_system]\n{section}\n"),
        Path::new(dir).join(name),
    )
}

#[test]
fn a_q_feel_spring_named_in_a_flight_scenario_follows_the_aircrafts_dynamic_pressure() {
    // `[feel_system] kind = "q_feel"` in the c172p flight without a fixed q̄: the spring's gradient is
    // k0 + kq·q̄ with the aircraft's q̄ at every step (read back from the stored energy ½ k x²), the coil
    // is never energised, and the energy balance closes with the spring's energy in it.
    let (text, path) = with_feel_system(
        "c172p-pitch-tracking.toml",
        "kind = \"q_feel\"\nsprings = \"../models/feel-springs.toml\"\ndamping_n_s_per_m = 100.0",
    );
    let mut scn = mrfeel::scenario::Scenario::parse(&text, &path).unwrap();
    // The first pitch command (2–3 s) and its capture; later, the same pilot gains over this much lighter
    // feel than the MR loop's drive the stick into its stops (a pilot-induced oscillation, not a q-feel
    // property).
    scn.duration_s = 4.0;
    let device =
        mrfeel::device::DeviceConfig::load(&scn.device_path, &mrfeel::device::Registry::builtin()).unwrap();
    let springs =
        mrfeel::control::feel::FeelSprings::load(&path.parent().unwrap().join("../models/feel-springs.toml"))
            .unwrap();
    let rig = mrfeel::sim::build_rig(&scn, &device).unwrap();
    let res = mrfeel::sim::run(
        &scn,
        &mrfeel::sim::Devices::same(device.clone()),
        rig,
        Default::default(),
        |_| {},
    )
    .unwrap();
    let mut checked = 0;
    for r in res.rows.iter().filter(|r| r.piston_x_m.abs() > 5e-4) {
        let q = r.aero.unwrap().qbar_pa;
        let k_expected = springs.q_feel.k0_n_per_m + springs.q_feel.kq_n_per_m_per_pa * q;
        let k = 2.0 * r.spring_energy_j / r.piston_x_m.powi(2);
        assert!(
            (k - k_expected).abs() < 1e-6 * k_expected,
            "k {k} vs {k_expected} at q̄ {q}"
        );
        checked += 1;
    }
    assert!(checked > 500, "the stick must move off centre ({checked} rows)");
    assert!(
        res.rows.iter().all(|r| r.current_applied_a == 0.0),
        "a spring unit has no coil"
    );
    let s = res.summary();
    assert!(
        s.energy_residual.is_some_and(|e| e.abs() < 0.01),
        "energy balance with the spring: {s}"
    );
}

#[test]
fn feel_system_section_errors_name_the_file_line_and_key() {
    let err = |section: &str| {
        let (text, path) = with_feel_system("paper-feel-loop.toml", section);
        mrfeel::scenario::Scenario::parse(&text, &path)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    let e = err("kind = \"bungee\"");
    assert!(
        e.contains("paper-feel-loop.toml:") && e.contains("feel_system.kind"),
        "{e}"
    );
    assert!(
        e.contains("centring_spring") && e.contains("mr_spring"),
        "must list the kinds: {e}"
    );
    let e = err("kind = \"centring_spring\"\ndamping_n_s_per_m = 100.0");
    assert!(e.contains("feel_system.springs") && e.contains("required"), "{e}");
    // A q-feel spring with neither a fixed q̄ nor an aircraft to follow.
    let e = err("kind = \"q_feel\"\nsprings = \"../models/feel-springs.toml\"\ndamping_n_s_per_m = 100.0");
    assert!(e.contains("feel_system.qbar_pa"), "{e}");
    let e = err("kind = \"active\"\ndamping_n_s_per_m = 20.0");
    assert!(
        e.contains("feel_system.motor_max_force_n") && e.contains("required by `active`"),
        "{e}"
    );
    // The modelled stick's file gives the force limit: the ideal source's keys are refused beside it, and
    // a file of another kind is refused at `model`.
    let e = err("kind = \"active\"\nmodel = \"../models/active-stick.toml\"\nmotor_max_force_n = 150.0");
    assert!(
        e.contains("feel_system.motor_max_force_n") && e.contains("not used with `feel_system.model`"),
        "{e}"
    );
    let e = err("kind = \"active\"\nmodel = \"../models/paper-device.toml\"");
    assert!(
        e.contains("feel_system.model") && e.contains("paper-device.toml"),
        "{e}"
    );
    let e = err("kind = \"mr\"\nmodel = \"../models/active-stick.toml\"");
    assert!(
        e.contains("feel_system.model") && e.contains("not used by `mr`"),
        "{e}"
    );
    // A key of another kind is refused, not ignored.
    let e = err("kind = \"mr\"\nhybrid_k_n_per_m = 500.0");
    assert!(
        e.contains("feel_system.hybrid_k_n_per_m") && e.contains("not used by `mr`"),
        "{e}"
    );
    let e = err(
        "kind = \"centring_spring\"\nsprings = \"../models/feel-springs.toml\"\ndamping_n_s_per_m = -1.0",
    );
    assert!(
        e.contains("feel_system.damping_n_s_per_m") && e.contains("[0, 100000]"),
        "{e}"
    );
}

#[test]
fn the_active_stick_renders_the_feel_best_but_a_stuck_motor_drives_the_stick_by_itself() {
    // The motor-driven stick renders the target by impedance control: the smallest force error and
    // phase lag of all systems, and it re-centres. It is not passive: with its driver stuck at full force
    // (or with its position sensor frozen) the stick moves away from the centre with nobody on it: the
    // back-drive hazard the MR damper cannot have (its driver stuck only makes the stick heavy).
    let scn = scenario();
    let none = FaultSchedule::none();
    let metrics = |k: FeelKind| {
        let main = main_run(&scn, k, &none);
        let brk = run(&scn, k, &scn.breakout_task(), &none).unwrap();
        (system_metrics(&scn, &main, &brk), main)
    };
    let (active, healthy) = metrics(FeelKind::Active);
    for k in [
        FeelKind::CentringSpring,
        FeelKind::VariableGradientSpring,
        FeelKind::QFeel,
        FeelKind::Mr,
        FeelKind::MrSpring,
    ] {
        let (m, _) = metrics(k);
        assert!(
            active.force_rms_error_n < 0.5 * m.force_rms_error_n,
            "active {} N vs {} {} N",
            active.force_rms_error_n,
            k.name(),
            m.force_rms_error_n
        );
        assert!(
            active.phase_lag_deg.abs() < m.phase_lag_deg.abs(),
            "{} phase",
            k.name()
        );
    }
    assert!(
        active.recentre_offset_rad < scn.task.recentre_band_rad,
        "{}",
        active.recentre_offset_rad
    );
    let (a, b) = (scn.fault_test.start_s, scn.fault_test.end_s);
    let stuck = |k: FeelKind| {
        let tr = main_run(
            &scn,
            k,
            &FaultSchedule::single(Fault::new(FaultKind::DriverStuck, a, b)),
        );
        let h = if k == FeelKind::Active {
            healthy.clone()
        } else {
            main_run(&scn, k, &none)
        };
        fault_metrics(&scn, &tr, &h, a, b)
    };
    let act = stuck(FeelKind::Active);
    let mr = stuck(FeelKind::Mr);
    eprintln!(
        "driver stuck, hands off: active moved {:.1}° away from the centre, MR {:.2}°",
        act.hands_off_away_rad.to_degrees(),
        mr.hands_off_away_rad.to_degrees()
    );
    // From the 0.2 rad release point to the 0.31 rad stop: 0.1 rad further out, with nobody on the stick.
    assert!(
        act.moves_without_pilot && act.hands_off_away_rad > 0.05,
        "active: {act:?}"
    );
    assert!(
        !mr.moves_without_pilot && mr.hands_off_away_rad < 1e-3,
        "MR: {mr:?}"
    );
    // A frozen position sensor leaves the motor pushing towards where it believes the centre is.
    let tr = main_run(
        &scn,
        FeelKind::Active,
        &FaultSchedule::single(Fault::new(FaultKind::DisplacementDropout, a, b)),
    );
    let drop = fault_metrics(&scn, &tr, &healthy, a, b);
    assert!(drop.moves_without_pilot, "dropout: {drop:?}");
    // The motor has no coil: nothing reaches the (absent) MR element.
    assert!(tr.rows.iter().all(|r| r.current_applied_a == 0.0));
}

/// `compare --help` names every feel system that `--feel` accepts (it left out `active`).
#[test]
fn compare_help_names_every_feel_system() {
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args(["compare", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&o.stdout);
    let line = help
        .lines()
        .find(|l| l.contains("--feel"))
        .expect("a --feel line");
    for k in FeelKind::ALL {
        assert!(
            line.contains(k.name()),
            "--help does not name {}: {line}",
            k.name()
        );
    }
}

/// Every run of a comparison is checked as `mrfeel run` checks its own. The active stick driving into a
/// stop with its encoder frozen (`displacement_dropout`) is not resolved at the base's 1 kHz: stepped
/// there, the run is refused naming the system, the fault and the energy balance, where it once went
/// into the fault table unchecked; at the comparison's 2 kHz for the active stick the balance closes.
#[test]
fn a_comparison_run_that_breaks_the_energy_balance_is_refused_naming_system_and_fault() {
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/compare-feel.toml"
    ));
    let text = std::fs::read_to_string(path).unwrap();
    assert!(text.contains("physics_hz = 2000.0"));
    let coarse = CompareScenario::parse(&text.replace("physics_hz = 2000.0", ""), path).unwrap();
    let dropout = FaultSchedule::single(Fault::new(FaultKind::DisplacementDropout, 3.0, 10.0));
    let Err(e) = run(&coarse, FeelKind::Active, &coarse.main_task(), &dropout) else {
        panic!("the 1 kHz run is refused");
    };
    let msg = format!("{:#}", anyhow::Error::from(e));
    assert!(
        msg.contains("active, with displacement_dropout from 3 s to 10 s")
            && msg.contains("energy balance")
            && msg.contains("rig.physics_hz"),
        "{msg}"
    );
    let scn = scenario();
    let tr = run(&scn, FeelKind::Active, &scn.main_task(), &dropout).unwrap();
    assert!(
        (tr.dt_s - 5e-4).abs() < 1e-12,
        "the active stick's runs step at 2 kHz"
    );
    // A rate outside the rig's range is refused at its line.
    let line = text.lines().position(|l| l.starts_with("physics_hz")).unwrap() + 1;
    let Err(e) = CompareScenario::parse(&text.replace("physics_hz = 2000.0", "physics_hz = 5.0"), path)
    else {
        panic!("a 5 Hz rate is refused");
    };
    let e = e.to_string();
    assert!(
        e.contains("active.physics_hz") && e.contains(&format!(":{line}")),
        "{e}"
    );
}
