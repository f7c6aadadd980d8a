//! The active stick as a control-loading system (issue 31, item 5): a servo motor with its current loop,
//! a grip force sensor and an admittance loop. Its loops' margins and bandwidth, a wrong rate or gain
//! caught by the same computation, the feel it renders on the rig, and what its faults do.

use std::path::Path;

use mrfeel::compare::metrics::system_metrics;
use mrfeel::compare::{run, CompareScenario, FeelKind, Trace};
use mrfeel::control::active::{margins, model_bandwidth_hz, motion_bandwidth_hz, ActiveStickConfig};
use mrfeel::faults::{Fault, FaultKind, FaultSchedule};
use mrfeel::signal::slope;

fn stick() -> ActiveStickConfig {
    ActiveStickConfig::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/models/active-stick.toml"
    )))
    .unwrap()
}

fn scenario() -> CompareScenario {
    CompareScenario::load(Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/compare-feel.toml"
    )))
    .unwrap()
}

/// Stated requirements of the loops.
const MIN_PHASE_MARGIN_DEG: f64 = 45.0;
const MIN_GAIN_MARGIN_DB: f64 = 6.0;
const MIN_MOTION_BANDWIDTH_HZ: f64 = 25.0;

#[test]
fn the_catalogue_motor_gives_its_time_constant_and_force_limit() {
    let s = stick();
    // 0.301 mH / 0.573 Ω; 40.4 mN·m/A · 250 rad/m · 15 A; 181 g·cm² · 250².
    assert!((s.motor.electrical_time_constant_s() - 5.253e-4).abs() < 1e-6);
    assert!((s.max_force_n() - 151.5).abs() < 0.01, "{}", s.max_force_n());
    assert!((s.rotor_mass_kg() - 1.131).abs() < 1e-3, "{}", s.rotor_mass_kg());
}

#[test]
fn both_loops_have_their_stated_margins_and_the_motion_loop_its_bandwidth() {
    let s = stick();
    let m = margins(&s);
    eprintln!("{m:#?}");
    for (name, l) in [("current", m.current), ("outer", m.outer)] {
        assert!(l.phase_margin_deg >= MIN_PHASE_MARGIN_DEG, "{name}: {l:?}");
        assert!(l.gain_margin_db >= MIN_GAIN_MARGIN_DB, "{name}: {l:?}");
    }
    // The current PI cancels the winding's pole: L ≈ kp / (L s) · delay, crossing at kp / (2π L) = 1 kHz
    // (the delay of 1.5 periods at 20 kHz barely moves the magnitude).
    let hand = s.driver.kp_v_per_a / (std::f64::consts::TAU * s.motor.inductance_h);
    assert!(
        (m.current.crossover_hz / hand - 1.0).abs() < 0.1,
        "{} vs {hand}",
        m.current.crossover_hz
    );
    // The motion loop was designed for a 30 Hz crossover on the moving mass.
    assert!((m.outer.crossover_hz - 30.0).abs() < 5.0, "{:?}", m.outer);
    // Bandwidth by a sine sweep of the sampled, nonlinear stick, against the linearised model.
    let sim = motion_bandwidth_hz(&s);
    let model = model_bandwidth_hz(&s);
    eprintln!("motion bandwidth: sweep {sim:.1} Hz, linearised model {model:.1} Hz");
    assert!(sim >= MIN_MOTION_BANDWIDTH_HZ, "{sim}");
    assert!((sim / model - 1.0).abs() < 0.15, "sweep {sim} vs model {model}");
}

#[test]
fn a_wrong_loop_rate_or_gain_is_caught_by_the_same_computation() {
    let s = stick();
    // The admittance loop at 200 Hz (the current loop still at 20 kHz): 5 ms of sampling and hold.
    let mut slow = s;
    slow.admittance.rate_hz = 200.0;
    let m = margins(&slow).outer;
    eprintln!("outer at 200 Hz: {m:?}");
    assert!(
        m.phase_margin_deg < MIN_PHASE_MARGIN_DEG || m.gain_margin_db < MIN_GAIN_MARGIN_DB,
        "{m:?}"
    );
    // The current loop's gain four times too high: its crossover runs into the sampling delay.
    let m = margins(&s.with_gains_scaled(4.0, 1.0)).current;
    eprintln!("current loop at 4x gain: {m:?}");
    assert!(
        m.gain_margin_db < 0.0 && m.phase_margin_deg < 0.0,
        "unstable: {m:?}"
    );
    // The motion loop's gain four times too high is not wrong: the PD's lead holds the phase margin
    // (a PD on a mass), and the gain margin falls by exactly 20·log10(4) = 12.04 dB (the phase crossover
    // does not move with the gain). Sixteen times spends the gain margin.
    let nominal = margins(&s).outer;
    let m = margins(&s.with_gains_scaled(1.0, 4.0)).outer;
    eprintln!("outer loop at 4x gain: {m:?}");
    assert!(m.phase_margin_deg >= MIN_PHASE_MARGIN_DEG, "{m:?}");
    assert!(
        (nominal.gain_margin_db - m.gain_margin_db - 12.04).abs() < 0.05,
        "{m:?}"
    );
    let m = margins(&s.with_gains_scaled(1.0, 16.0)).outer;
    eprintln!("outer loop at 16x gain: {m:?}");
    assert!(m.gain_margin_db < MIN_GAIN_MARGIN_DB, "{m:?}");
}

fn main_run(scn: &CompareScenario, faults: &FaultSchedule) -> Trace {
    run(scn, FeelKind::Active, &scn.main_task(), faults).unwrap()
}

/// Rows within `[a, b)` s with the hands on or off.
fn window(tr: &Trace, a: f64, b: f64) -> impl Iterator<Item = &mrfeel::compare::Row> + Clone {
    tr.rows.iter().filter(move |r| r.t_s >= a && r.t_s < b)
}

#[test]
fn the_modelled_stick_renders_the_target_gradient_and_recentres() {
    let scn = scenario();
    let none = FaultSchedule::none();
    let main = main_run(&scn, &none);
    let brk = run(&scn, FeelKind::Active, &scn.breakout_task(), &none).unwrap();
    let m = system_metrics(&scn, &main, &brk);
    eprintln!("{m:#?}");
    // The target's gradient at the grip: 1130 N/m on the piston through (0.15/0.40)² and the 0.40 m arm,
    // ≈ 63.6 N/rad; the feel has the virtual mass and damping on top, which a slope over a sine leaves out.
    let target = slope(window(&main, 2.0, 6.0).map(|r| (r.theta_rad, r.target_grip_n)));
    assert!(
        (m.force_gradient_n_per_rad / target - 1.0).abs() < 0.1,
        "gradient {} vs target {target}",
        m.force_gradient_n_per_rad
    );
    assert!(m.force_rms_error_n < 2.0, "{}", m.force_rms_error_n);
    // Breakout: 5 N on the piston is 1.9 N at the grip; the ramp finds it within 1 N.
    assert!((m.breakout_n - 5.0 * 0.15 / 0.40).abs() < 1.0, "{}", m.breakout_n);
    assert!(
        m.recentre_offset_rad < scn.task.recentre_band_rad,
        "{}",
        m.recentre_offset_rad
    );
}

#[test]
fn driver_stuck_freezes_the_torque_the_spring_is_gone_and_the_stick_runs_away_hands_off() {
    let scn = scenario();
    let (a, b) = (scn.fault_test.start_s, scn.fault_test.end_s);
    let healthy = main_run(&scn, &FaultSchedule::none());
    let stuck = main_run(
        &scn,
        &FaultSchedule::single(Fault::new(FaultKind::DriverStuck, a, b)),
    );
    // Hands on, from the onset to the end of the sine: the pilot pushes against a constant torque, so
    // the force no longer rises with deflection.
    let k = |tr: &Trace| slope(window(tr, a + 0.2, 6.0).map(|r| (r.theta_rad, r.hand_force_n)));
    let (kh, ks) = (k(&healthy), k(&stuck));
    eprintln!("grip gradient: healthy {kh:.1} N/rad, driver stuck {ks:.1} N/rad");
    assert!(ks.abs() < 0.3 * kh, "stuck {ks} vs healthy {kh}");
    // Hands off: nothing pulls the stick back; the frozen torque drives it away from the centre.
    let last = stuck.rows.last().unwrap();
    let off = healthy.rows.last().unwrap();
    eprintln!(
        "hands off at the end: stuck {:.3} rad, healthy {:.4} rad",
        last.theta_rad, off.theta_rad
    );
    assert!(off.theta_rad.abs() < scn.task.recentre_band_rad);
    assert!(last.theta_rad.abs() > 0.1, "{}", last.theta_rad);
}

#[test]
fn a_stuck_grip_sensor_holds_the_stick_where_the_reading_puts_it() {
    let scn = scenario();
    let (a, b) = (scn.fault_test.start_s, scn.fault_test.end_s);
    let healthy = main_run(&scn, &FaultSchedule::none());
    // The motor's force limit felt at the grip: 151.5 N on the piston through 0.15 m/rad and 0.40 m.
    let limit_grip_n = stick().max_force_n() * 0.15 / 0.40;
    let peak = |tr: &Trace| {
        window(tr, a + 0.3, 6.0)
            .map(|r| r.hand_force_n.abs())
            .fold(0.0, f64::max)
    };
    for kind in [FaultKind::LoadCellStuck, FaultKind::LoadCellZero] {
        let tr = main_run(&scn, &FaultSchedule::single(Fault::new(kind, a, b)));
        // The virtual model sees a constant force: its reference settles where the law balances it and
        // the motion loop holds the stick there. To follow the sine the pilot must overpower the motor:
        // the grip force rises to the motor's limit instead of the feel's 17 N.
        let at = |t: f64| tr.rows.iter().find(|r| r.t_s >= t).unwrap().theta_rad;
        let end = tr.rows.last().unwrap().theta_rad;
        eprintln!(
            "{}: peak grip force {:.1} N (healthy {:.1}, motor limit at the grip {limit_grip_n:.1}), hands \
             off at 8 s {:.4} rad, at the end {end:.4} rad (healthy {:.4})",
            kind.name(),
            peak(&tr),
            peak(&healthy),
            at(8.0),
            healthy.rows.last().unwrap().theta_rad
        );
        assert!(peak(&tr) > 0.9 * limit_grip_n, "{}", kind.name());
        assert!(peak(&healthy) < 0.4 * limit_grip_n);
        // Hands off it stays where the frozen reading holds it: still over the last 2 s.
        assert!(
            (end - at(8.0)).abs() < 0.002,
            "{}: {} → {end}",
            kind.name(),
            at(8.0)
        );
        if kind == FaultKind::LoadCellZero {
            // A zero reading: the virtual model rests at the centre, and holds the stick there.
            assert!(end.abs() < scn.task.recentre_band_rad, "{end}");
        } else {
            // The reading froze mid-sweep with the pilot pushing: held off the centre.
            assert!(end.abs() > 5.0 * scn.task.recentre_band_rad, "{end}");
        }
    }
}

#[test]
fn a_bad_value_or_loop_rate_names_the_file_line_and_field() {
    let text =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/models/active-stick.toml")).unwrap();
    let dir = std::env::temp_dir().join(format!("mrfeel-active-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let check = |from: &str, to: &str, field: &str, says: &str| {
        let bad = dir.join("bad.toml");
        assert!(text.contains(from), "{from}");
        let t = text.replacen(from, to, 1);
        std::fs::write(&bad, &t).unwrap();
        let line = t.lines().position(|l| l.starts_with(to)).unwrap() + 1;
        let e = ActiveStickConfig::load(&bad).unwrap_err().to_string();
        assert!(
            e.contains(&format!("bad.toml:{line}: field `{field}`")) && e.contains(says),
            "{e}"
        );
    };
    check(
        "inductance_h = 0.301e-3",
        "inductance_h = -1.0",
        "motor.inductance_h",
        "allowed range",
    );
    check(
        "current_loop_hz = 20000.0",
        "current_loop_hz = 10100.0",
        "driver.current_loop_hz",
        "whole multiple",
    );
    check(
        "adc_bits = 16",
        "adc_bits = 64",
        "grip_sensor.adc_bits",
        "allowed range",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_comparison_naming_the_motor_file_refuses_the_ideal_sources_keys_and_a_wrong_file() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios/compare-feel.toml");
    let text = std::fs::read_to_string(path).unwrap();
    let model = "model = \"../models/active-stick.toml\"";
    assert!(text.contains(model));
    let err = |t: &str| {
        CompareScenario::parse(t, Path::new(path))
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };
    let t = text.replacen(model, &format!("{model}\nmax_force_n = 150.0"), 1);
    let line = t
        .lines()
        .position(|l| l.starts_with("max_force_n = 150"))
        .unwrap()
        + 1;
    let e = err(&t);
    assert!(
        e.contains(&format!("compare-feel.toml:{line}: field `active.max_force_n`"))
            && e.contains("not used with `active.model`"),
        "{e}"
    );
    // A device file where the motor file belongs: refused at `active.model`, naming what is missing.
    let t = text.replacen(model, "model = \"../models/paper-device.toml\"", 1);
    let line = t.lines().position(|l| l.starts_with("model = ")).unwrap() + 1;
    let e = err(&t);
    assert!(
        e.contains(&format!("compare-feel.toml:{line}: field `active.model`"))
            && e.contains("paper-device.toml"),
        "{e}"
    );
}

/// `scenarios/paper-feel-loop.toml` (the pilot sweeps ±16° at 0.25 Hz against the 70 N spring feel) with
/// `[feel_system]` set to `section`.
fn paper_active(section: &str) -> mrfeel::scenario::Scenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-feel-loop.toml");
    let text = std::fs::read_to_string(&path).unwrap();
    mrfeel::scenario::Scenario::parse(&format!("{text}\n[feel_system]\n{section}\n"), &path).unwrap()
}

/// The rows of a scenario's run through `sim::run`, which checks its invariants (the energy balance among
/// them) and fails the test on a broken one; the run's energy residual is within 1 % of the work exchanged.
fn run_scenario(scn: &mrfeel::scenario::Scenario) -> Vec<mrfeel::sim::Row> {
    let devices = mrfeel::sim::Devices::load(scn).unwrap();
    let rig = mrfeel::sim::build_rig(scn, &devices.plant).unwrap();
    let res = mrfeel::sim::run(scn, &devices, rig, mrfeel::sim::RunOptions::default(), |_| {})
        .unwrap_or_else(|e| panic!("{e}"));
    let s = res.summary();
    assert!(s.energy_residual.is_some_and(|e| e.abs() < 0.01), "{s}");
    res.rows
}

/// What the pilot feels beyond the feel law, fitted over a run: the hand's force at the push rod minus the
/// law's force at the rod's position and velocity, by least squares on the rod's acceleration and velocity
/// (and a constant), away from the breakout's centre: (mass kg, damping N·s/m, RMS residual N).
fn felt_mass_and_damping(scn: &mrfeel::scenario::Scenario, rows: &[mrfeel::sim::Row]) -> (f64, f64, f64) {
    use mrfeel::sim::Plant;
    let devices = mrfeel::sim::Devices::load(scn).unwrap();
    let rig = mrfeel::sim::build_rig(scn, &devices.plant).unwrap();
    let dt = 1.0 / scn.physics_rate_hz();
    let mut fit = Vec::new();
    for w in rows.windows(3) {
        let r = &w[1];
        if r.t_s < 1.0 || r.piston_x_m.abs() < 0.002 {
            continue;
        }
        let a = (w[2].piston_v_m_s - w[0].piston_v_m_s) / (2.0 * dt);
        let rod_n =
            r.pilot_force_n * Plant::grip_arm_m(&rig) / Plant::gearing_m_per_rad(&rig, r.stick_angle_rad);
        let law = scn.feel.force_n(r.t_s, r.piston_x_m, r.piston_v_m_s, 0.0, None);
        fit.push(([a, r.piston_v_m_s, 1.0], rod_n - law));
    }
    let mut ata = nalgebra::Matrix3::<f64>::zeros();
    let mut atb = nalgebra::Vector3::<f64>::zeros();
    for (x, y) in &fit {
        let x = nalgebra::Vector3::from(*x);
        ata += x * x.transpose();
        atb += x * *y;
    }
    let c = ata.lu().solve(&atb).unwrap();
    let rms = (fit
        .iter()
        .map(|(x, y)| (y - nalgebra::Vector3::from(*x).dot(&c)).powi(2))
        .sum::<f64>()
        / fit.len() as f64)
        .sqrt();
    (c[0], c[1], rms)
}

/// A scenario's `kind = "active"` runs the modelled control-loading system (`models/active-stick.toml`,
/// built in): the pilot feels the law plus the admittance's virtual damping (10 N·s/m at the push rod) and
/// a mass between the virtual 2 kg and the rig's, the motion loop hiding the rig's inertia up to its
/// bandwidth. The ideal force source of the same limit pushes the law's force at the DAQ's ticks and leaves
/// the rig's inertia and friction to the pilot: the fitted damping and mass tell them apart (measured
/// 11.3 N·s/m, 4.2 kg against 1.6 N·s/m, 9.3 kg). The grip sensor's noise follows the scenario's seed.
#[test]
fn a_scenarios_active_stick_is_the_modelled_control_loading_system() {
    let stick = stick();
    let modelled = paper_active("kind = \"active\"");
    assert_eq!(modelled.feel_system.active_stick, Some(stick));
    let ideal = paper_active(&format!(
        "kind = \"active\"\nmotor_max_force_n = {}\ndamping_n_s_per_m = {}",
        stick.max_force_n(),
        stick.rod_damping_n_s_per_m()
    ));
    let (m_res, i_res) = (run_scenario(&modelled), run_scenario(&ideal));
    let (mm, bm, em) = felt_mass_and_damping(&modelled, &m_res);
    let (mi, bi, ei) = felt_mass_and_damping(&ideal, &i_res);
    eprintln!(
        "felt beyond the law: modelled stick {mm:.2} kg, {bm:.2} N·s/m (residual {em:.2} N RMS); ideal \
         source {mi:.2} kg, {bi:.2} N·s/m ({ei:.2} N)"
    );
    let a = stick.admittance;
    // The admittance's damping is felt; the ideal source leaves only the rotor's friction and the rig's.
    assert!((bm / a.virtual_damping_n_s_per_m - 1.0).abs() < 0.25, "{bm}");
    assert!(bi < 0.3 * a.virtual_damping_n_s_per_m, "{bi}");
    // The motion loop hides most of the rig's inertia, which the ideal source leaves to the pilot, but not
    // all of it: with a finite bandwidth the felt mass lies above the virtual 2 kg.
    assert!(mm < 0.6 * mi, "modelled {mm} kg, ideal {mi} kg");
    assert!(mm > 1.5 * a.virtual_mass_kg, "{mm}");
    // The seed reaches the grip sensor: another seed moves the stick differently, the same seed the same.
    let mut reseeded = modelled.clone();
    reseeded.seed += 1;
    let other = run_scenario(&reseeded);
    let again = run_scenario(&modelled);
    let x = |rows: &[mrfeel::sim::Row]| rows.iter().map(|r| r.piston_x_m).collect::<Vec<_>>();
    assert_eq!(x(&again), x(&m_res));
    assert_ne!(x(&other), x(&m_res));
}
