//! Pilot-in-the-loop flights on the stick rig (issue 5, parts 4 and 5): the aircraft's hinge moment
//! sets the feel force, the MR damper renders it where it can (it only resists motion), the McRuer
//! pilot completes the pitch task, and live JSBSim agrees with the embedded model.
//!
//! `cargo test --test flight -- --nocapture --test-threads 1` prints the figures of docs/flight.md.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use mrfeel::aero::flight_loop::{correlation, fly, FlightMetrics, FlightResults, FlightScenario};
use mrfeel::aero::AircraftModel;

fn scenario(name: &str) -> FlightScenario {
    let p = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/scenarios")).join(name);
    match FlightScenario::load(&p) {
        Ok(s) => s,
        Err(e) => panic!("{e}"),
    }
}

fn pitch_tracking() -> &'static (FlightScenario, FlightResults) {
    static R: OnceLock<(FlightScenario, FlightResults)> = OnceLock::new();
    R.get_or_init(|| {
        let s = scenario("c172p-pitch-tracking.toml");
        let r = fly(&s, |_| {}).unwrap_or_else(|e| panic!("{e}"));
        (s, r)
    })
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for x in v {
        s += x * x;
        n += 1;
    }
    (s / n.max(1) as f64).sqrt()
}

/// Virtual work at the stick (F l_s = H G k_fb): the desired feel force is the hinge moment times the
/// gearing over the stick arm, at every instant of the flight. Checked by regression against the
/// model file's geometry, not against the code's own conversion.
#[test]
fn desired_feel_force_is_the_hinge_moment_through_the_stick_gearing() {
    let (_, r) = pitch_tracking();
    let m = AircraftModel::load(&AircraftModel::builtin_path("c172p")).unwrap();
    let expected = m.elevator_per_stick_rad_per_rad / m.stick_arm_m * m.force_feedback_ratio;
    let h: Vec<f64> = r.rows.iter().map(|x| x.hinge_moment_nm).collect();
    let f: Vec<f64> = r.rows.iter().map(|x| x.desired_force_n).collect();
    let corr = correlation(&f, &h);
    let slope = f.iter().zip(&h).map(|(a, b)| a * b).sum::<f64>() / h.iter().map(|b| b * b).sum::<f64>();
    let peak = f.iter().fold(0.0f64, |a, b| a.max(b.abs()));
    println!(
        "desired force vs hinge moment: correlation {corr:.6}, slope {slope:.4} N/(N·m) (G/l_s·k_fb = {expected:.4}), peak {peak:.1} N"
    );
    assert!(
        peak > 10.0,
        "the task must load the stick: peak desired force {peak} N"
    );
    assert!(corr > 0.999, "correlation {corr}");
    assert!(
        (slope - expected).abs() < 0.01 * expected,
        "slope {slope} vs {expected}"
    );
}

/// The MR damper only resists motion: while the stick moves the way the desired force opposes (and the
/// force is inside the device's range), the load cell follows the desired force; while it moves the
/// other way the damper is released and adds no force against the pilot's wish.
#[test]
fn load_cell_follows_the_desired_force_where_the_damper_can_resist() {
    let (s, r) = pitch_tracking();
    let m = FlightMetrics::of(r, s);
    let rest = s.feel.rest_speed_m_s;
    let released = rms(r
        .rows
        .iter()
        .filter(|x| !x.providable && x.piston_v_m_s.abs() > 2.0 * rest)
        .map(|x| x.load_cell_grip_n));
    let released_desired = rms(r
        .rows
        .iter()
        .filter(|x| !x.providable && x.piston_v_m_s.abs() > 2.0 * rest)
        .map(|x| x.desired_force_n));
    println!(
        "load cell vs desired where the damper can resist: RMS error {:.2} N of RMS desired {:.2} N over {:.1} % of the flight; \
         released (moving against the force): load cell RMS {released:.2} N while the desired force is RMS {released_desired:.2} N",
        m.follow_rms_n,
        m.follow_desired_rms_n,
        100.0 * m.follow_fraction
    );
    assert!(
        m.follow_fraction > 0.03,
        "too little resisting motion to judge: {}",
        m.follow_fraction
    );
    assert!(m.follow_rms_n < 0.25 * m.follow_desired_rms_n, "{}", m.summary());
    assert!(
        released < 0.3 * released_desired.max(1.0),
        "released damper still loads the stick: {released} N"
    );
}

/// The pilot (McRuer crossover model, 0.2 s delay + the hand's 0.1 s lag) completes the tracking task:
/// after the first command the pitch error stays small against the 8° span of the commands, and the
/// aircraft does reach the +5° attitude.
#[test]
fn pilot_tracks_the_pitch_commands_through_the_mr_feel() {
    let (s, r) = pitch_tracking();
    let m = FlightMetrics::of(r, s);
    let peak = r
        .rows
        .iter()
        .map(|x| x.pitch_rad - r.trim.theta_rad)
        .fold(f64::NEG_INFINITY, f64::max);
    println!(
        "pitch tracking: RMS error {:.3}° after the first command (command span {:.1}°), peak pitch above trim {:.2}°",
        m.tracking_rms.to_degrees(),
        m.command_span.to_degrees(),
        peak.to_degrees()
    );
    assert!(
        m.tracking_rms < 0.025,
        "pitch RMS error {} rad (bound 0.025 rad = 1.43°)",
        m.tracking_rms
    );
    assert!(
        peak > 0.8 * 5f64.to_radians(),
        "never reached the +5° command: {}°",
        peak.to_degrees()
    );
}

/// Live JSBSim 1.3.3 through the bridge flies the same scenario as the embedded model: pitch and load
/// factor agree. Needs the repository's Python environment (made by the test command).
#[test]
fn live_jsbsim_cosimulation_agrees_with_the_embedded_model() {
    let py = mrfeel::aero::jsbsim_bridge::python_path();
    assert!(
        Path::new(&py).exists(),
        "{} is missing: run the test command `bash scripts/test-all.sh` (it creates .venv with jsbsim), \
         or `bash scripts/python-env.sh` before `cargo test`",
        py.display()
    );
    let (s, emb) = pitch_tracking();
    let live_s = s.with_aircraft_model("jsbsim:c172p");
    let live = fly(&live_s, |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(live.rows.len(), emb.rows.len());
    let d = |f: fn(&mrfeel::aero::flight_loop::FlightRow) -> f64| {
        let e: Vec<f64> = emb
            .rows
            .iter()
            .zip(&live.rows)
            .map(|(a, b)| f(a) - f(b))
            .collect();
        (
            rms(e.iter().copied()),
            e.iter().fold(0.0f64, |m, x| m.max(x.abs())),
        )
    };
    let (p_rms, p_max) = d(|r| r.pitch_rad);
    let (n_rms, n_max) = d(|r| r.nz_g);
    let (f_rms, _) = d(|r| r.desired_force_n);
    let m = FlightMetrics::of(&live, &live_s);
    let (count, mean, max) = live.round_trip_us.unwrap_or_default();
    println!(
        "live JSBSim vs embedded: pitch RMS {:.4}° max {:.3}°, nz RMS {n_rms:.4} g max {n_max:.3} g, desired force RMS {f_rms:.2} N; \
         live tracking RMS {:.3}°; bridge round trip over {count} steps: mean {mean:.0} µs, max {max:.0} µs",
        p_rms.to_degrees(),
        p_max.to_degrees(),
        m.tracking_rms.to_degrees()
    );
    assert!(
        p_rms < 0.005 && p_max < 0.015,
        "pitch disagreement RMS {p_rms} rad, max {p_max} rad"
    );
    assert!(
        n_rms < 0.04 && n_max < 0.15,
        "load factor disagreement RMS {n_rms} g, max {n_max} g"
    );
    assert!(m.tracking_rms < 0.025, "live pilot RMS error {}", m.tracking_rms);
    assert!(count > 3000, "one request per JSBSim frame expected, got {count}");
}

/// Scenario errors name the file, the line and the field with the allowed range.
#[test]
fn out_of_range_pilot_delay_is_an_error_with_file_line_and_range() {
    let p = PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenarios/c172p-pitch-tracking.toml"
    ));
    let text = std::fs::read_to_string(&p)
        .unwrap()
        .replace("delay_s = 0.2", "delay_s = 5.0");
    let line = text.lines().position(|l| l.starts_with("delay_s")).unwrap() + 1;
    let e = FlightScenario::parse(&text, &p)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(e.contains(&format!("c172p-pitch-tracking.toml:{line}:")), "{e}");
    assert!(e.contains("pilot.delay_s") && e.contains("[0, 1]"), "{e}");
}
