//! Pilot-in-the-loop flights through `mrfeel run` (issue 5): the aircraft's stick force (hinge moment ×
//! gearing) is the feel target of the paper's loop (sensors, DAQ, PID with feedforward), the MR damper
//! renders it where it can (it only resists motion, up to its 14 A force), the McRuer pilot flies the
//! tasks through the hand, and live JSBSim agrees with the embedded model.
//!
//! `cargo test --test integration flight:: -- --nocapture --test-threads 1` prints the figures of docs/explanation/flight.md.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use mrfeel::control::LoopMode;
use mrfeel::device::DeviceConfig;
use mrfeel::scenario::Scenario;
use mrfeel::sim::metrics::FlightMetrics;
use mrfeel::sim::{self, Results, RunOptions};

fn scenario_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join(name)
}

fn load(name: &str) -> (Scenario, sim::Devices) {
    let (scn, device, _) = sim::load(&scenario_path(name)).unwrap_or_else(|e| panic!("{name}: {e:#}"));
    (scn, device)
}

fn fly(scn: &Scenario, device: &sim::Devices) -> Results {
    let rig = sim::build_rig(scn, &device.plant).unwrap_or_else(|e| panic!("{e:#}"));
    sim::run(scn, device, rig, RunOptions::default(), |_| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn pitch_tracking() -> &'static (Scenario, sim::Devices, Results) {
    static R: OnceLock<(Scenario, sim::Devices, Results)> = OnceLock::new();
    R.get_or_init(|| {
        let (s, d) = load("c172p-pitch-tracking.toml");
        let r = fly(&s, &d);
        (s, d, r)
    })
}

/// Largest pitch above the trim attitude over a flight, rad.
fn peak_pitch_above_trim(r: &Results) -> f64 {
    let trim = r.flight.as_ref().unwrap().trim.theta_rad;
    r.rows
        .iter()
        .filter_map(|x| x.aero)
        .map(|a| a.pitch_rad - trim)
        .fold(f64::NEG_INFINITY, f64::max)
}

fn rms(v: impl Iterator<Item = f64>) -> f64 {
    let (mut s, mut n) = (0.0, 0usize);
    for x in v {
        s += x * x;
        n += 1;
    }
    if n == 0 {
        f64::NAN
    } else {
        (s / n as f64).sqrt()
    }
}

/// The MR damper only resists motion: while the stick moves the way the desired force opposes (and the
/// force is inside the device's range), the load cell follows the desired force; while it moves the other
/// way the loop releases the coil and the damper adds little force against the pilot.
#[test]
fn load_cell_follows_the_desired_force_where_the_damper_can_resist() {
    let (s, _, r) = pitch_tracking();
    let m = FlightMetrics::of(r, s).unwrap();
    let rest = s.controller.rest_speed_m_s;
    let released: Vec<_> = r
        .rows
        .iter()
        .filter(|x| x.mode == LoopMode::Released && x.piston_v_m_s.abs() > 2.0 * rest)
        .collect();
    let released_lc = rms(released.iter().map(|x| x.load_cell_true_n));
    let released_desired = rms(released.iter().map(|x| x.desired_force_n));
    println!(
        "load cell vs desired where the damper can resist: RMS error {:.2} N of RMS desired {:.2} N over {:.1} % of the flight; \
         released (moving against the force, {} samples): load cell RMS {released_lc:.2} N while the desired force is RMS {released_desired:.2} N",
        m.follow_rms_n,
        m.follow_desired_rms_n,
        100.0 * m.follow_fraction,
        released.len()
    );
    assert!(
        m.follow_fraction > 0.02,
        "too little resisting motion to judge: {}",
        m.follow_fraction
    );
    assert!(m.follow_rms_n < 0.3 * m.follow_desired_rms_n, "{m}");
    assert!(
        released.len() > 100,
        "the stick never moved against the feel force"
    );
    assert!(
        released_lc < 0.3 * released_desired,
        "released damper still loads the stick: {released_lc} N"
    );
}

/// The pilot (McRuer crossover model, 0.2 s delay + the hand's 0.1 s lag) completes the tracking task:
/// after the first command the pitch error stays small against the 8° span of the commands, and the
/// aircraft does reach the +5° attitude.
#[test]
fn pilot_tracks_the_pitch_commands_through_the_mr_feel() {
    let (s, _, r) = pitch_tracking();
    let m = FlightMetrics::of(r, s).unwrap();
    let peak = peak_pitch_above_trim(r);
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

/// The pull-up asks for more stick force than the paper's damper has (32 N at the grip against its
/// 14 A ceiling): the pilot still reaches the commanded load factor, and where the desired force is
/// beyond the ceiling the driver is at its 14 A limit and the load cell at the device's force, not above.
#[test]
fn pull_up_reaches_the_load_factor_with_the_feel_capped_at_the_device_force() {
    let (s, d, r) = {
        let (s, d) = load("c172p-pullup.toml");
        let r = fly(&s, &d);
        (s, d, r)
    };
    let m = FlightMetrics::of(&r, &s).unwrap();
    let hold: Vec<_> = r.rows.iter().filter(|x| x.t_s >= 5.0 && x.t_s < 7.0).collect();
    let nz_hold = hold.iter().filter_map(|x| x.aero).map(|a| a.nz_g).sum::<f64>() / hold.len() as f64;
    // The whole hold with its onset, for the figure beside it in docs/explanation/flight.md (not judged).
    let whole: Vec<_> = r.rows.iter().filter(|x| x.t_s >= 3.0 && x.t_s < 7.0).collect();
    let nz_whole = whole.iter().filter_map(|x| x.aero).map(|a| a.nz_g).sum::<f64>() / whole.len() as f64;
    let ceiling = r.feel_ceiling_n;
    let capped: Vec<_> = r
        .rows
        .iter()
        .filter(|x| x.desired_force_n.abs() > 1.1 * ceiling)
        .collect();
    let lc_max = capped.iter().fold(0.0f64, |a, x| a.max(x.load_cell_true_n.abs()));
    let at_limit = capped
        .iter()
        .filter(|x| x.current_a >= s.controller.gains.out_max - 1e-9)
        .count() as f64
        / capped.len().max(1) as f64;
    let yield_14 = d.plant.param("fc0_n").unwrap() + d.plant.param("fc_gain_n_per_a").unwrap() * 14.0;
    println!(
        "pull-up: mean load factor over the last 2 s of the hold (5-7 s) {nz_hold:.3} g (command 1.3 g; over the whole \
         hold, 3-7 s, {nz_whole:.3} g); tracking RMS {:.3} g \
         (span {:.1} g); peak stick force {:.1} N at the grip vs the damper's ceiling there {:.1} N; where the desired force \
         exceeds the ceiling by over 10 % ({} samples) the current is at 14 A {:.1} % of the time and the load cell peaks at \
         {lc_max:.1} N (yield at 14 A {yield_14:.1} N)",
        m.tracking_rms,
        m.command_span,
        m.stick_force_peak_n,
        m.ceiling_at_grip_n,
        capped.len(),
        100.0 * at_limit
    );
    assert!(
        (nz_hold - 1.3).abs() < 0.06,
        "the pilot did not hold the pull-up: {nz_hold} g"
    );
    assert!(
        m.stick_force_peak_n > m.ceiling_at_grip_n,
        "the task should exceed the device"
    );
    assert!(
        capped.len() > 500,
        "the desired force should exceed the ceiling for a while"
    );
    assert!(
        at_limit > 0.95,
        "beyond the ceiling the loop should ask for the driver's 14 A: {at_limit}"
    );
    // The load cell carries the damper's force plus the piston's small inertia and the hand's dynamics.
    assert!(
        lc_max < 1.1 * yield_14,
        "load cell {lc_max} N above the device's {yield_14} N"
    );
    // Nowhere in this task is the desired force both resisting and within the damper's range while the
    // stick moves: the summary says it was not judged, not "RMS NaN N".
    assert_eq!(m.follow_fraction, 0.0, "the task never leaves the ceiling");
    let summary = m.to_string();
    assert!(
        !summary.contains("NaN") && summary.contains("not judged"),
        "{summary}"
    );
}

/// The T-37 pull-up (`scenarios/T37-pullup.toml`, 1 -> 1.2 g, a pilot adapted to the aircraft with no
/// gains typed in), where the aircraft's stick force stays inside the damper's ceiling at the grip: the
/// pilot holds the load factor; the force the pilot's hand puts on the grip is the aircraft's stick force
/// (the MR damper renders it through the linkage and the load-cell loop); and the stick force per g felt
/// in flight (the hold's stick force from a trimmed zero over the load factor gained) agrees with the
/// steady pull-up solution of the certification check (`FeelAssessment`, a separate solver with no time
/// stepping, at the speed flown; the speed bleeds at fixed throttle and the pull has pitch-rate terms, so
/// within 15 %, not exactly). A linkage or gearing wrong by a factor of two breaks the grip-force check; a
/// hinge path that differs between the flight and the steady solver breaks the per-g check. MIL-F-8785C
/// Level 1 is printed, not asserted: no published T-37 stick force per g was found and the elevator
/// geometry and gearing are `[EST]` (docs/explanation/aero.md).
#[test]
fn t37_pull_up_is_held_with_the_aircrafts_stick_force_at_the_grip_and_its_steady_per_g() {
    use mrfeel::aero::{Aircraft, AircraftModel, FeelAssessment};
    let (s, d) = load("T37-pullup.toml");
    let r = fly(&s, &d);
    let f = r.flight.as_ref().unwrap();
    assert_eq!(f.aircraft, "T37");
    let hold: Vec<_> = r.rows.iter().filter(|x| x.t_s >= 5.0 && x.t_s < 7.0).collect();
    let mean =
        |g: &dyn Fn(&mrfeel::sim::Row) -> f64| hold.iter().map(|x| g(x)).sum::<f64>() / hold.len() as f64;
    let aero = |x: &mrfeel::sim::Row| x.aero.unwrap();
    let (nz, force, v, hand) = (
        mean(&|x| aero(x).nz_g),
        mean(&|x| aero(x).stick_force_n),
        mean(&|x| aero(x).airspeed_m_s),
        mean(&|x| x.pilot_force_n),
    );
    let flown_per_g = force / (nz - 1.0);
    let m = AircraftModel::load(&AircraftModel::builtin_path("T37")).unwrap();
    let a = Aircraft::new(std::sync::Arc::new(m));
    let steady = FeelAssessment::assess(&a, v, 3000.0).unwrap();
    let (lo, hi) = steady.allowed_per_g_n;
    println!(
        "T-37 pull-up: load factor over the hold {nz:.3} g (command 1.2 g) at {v:.1} m/s; stick force {force:.1} N, \
         pilot's force at the grip {hand:.1} N (damper ceiling there {:.1} N); {flown_per_g:.1} N/g flown vs {:.1} N/g \
         from the steady pull-up at that speed; MIL-F-8785C Level 1 [{lo:.1}, {hi:.1}] N/g",
        FlightMetrics::of(&r, &s).unwrap().ceiling_at_grip_n,
        steady.stick_force_per_g_n
    );
    assert!(
        (nz - 1.2).abs() < 0.05,
        "the pilot did not hold the pull-up: {nz} g"
    );
    assert!(
        (hand / force - 1.0).abs() < 0.10,
        "the hand holds {hand} N at the grip, the aircraft's stick force is {force} N"
    );
    assert!(
        (flown_per_g / steady.stick_force_per_g_n - 1.0).abs() < 0.15,
        "flown {flown_per_g} N/g vs steady {} N/g",
        steady.stick_force_per_g_n
    );
}

/// The same task flown by a pilot adapted to the aircraft (McRuer's crossover model designed on the
/// linearised c172p at its trim, ω_c 1.5 rad/s, with the ~1 s stick lag through hand and MR feel in the
/// controlled element) instead of the file's gains: the pilot still completes it, no gain typed in.
#[test]
fn a_pilot_adapted_to_the_aircraft_flies_the_pitch_task_without_given_gains() {
    let p = scenario_path("c172p-pitch-tracking.toml");
    let text = std::fs::read_to_string(&p)
        .unwrap()
        .replace("gain = 0.6 ", "crossover_rad_s = 1.5\nstick_lag_s = 1.0 #")
        .replace("lead_s = 0.3", "")
        .replace("lag_s = 0.1 ", "#")
        .replace("integral_per_s = 0.1", "");
    let s = Scenario::parse(&text, &p).unwrap_or_else(|e| panic!("{e}"));
    let d =
        sim::Devices::same(DeviceConfig::load(&s.device_path, &mrfeel::device::Registry::builtin()).unwrap());
    let r = fly(&s, &d);
    let m = FlightMetrics::of(&r, &s).unwrap();
    let peak = peak_pitch_above_trim(&r);
    println!(
        "adapted pilot: pitch RMS error {:.3}° (span 8°), peak above trim {:.2}°",
        m.tracking_rms.to_degrees(),
        peak.to_degrees()
    );
    assert!(
        m.tracking_rms < 0.025,
        "adapted pilot RMS error {} rad",
        m.tracking_rms
    );
    assert!(
        peak > 0.8 * 5f64.to_radians() && peak < 2.0 * 5f64.to_radians(),
        "peak {}°",
        peak.to_degrees()
    );
}

/// The 737 approach: the throttle comes back to 0.6 of trim and the pilot pitches 2.5° nose-down and holds
/// it. The pilot holds the attitude and the aircraft descends (at about V·sin 2.5° ≈ 6 m/s), and the feel target
/// is the 737's feel computer (q-feel, not the air load on its powered elevator), zero at trim. (That the
/// desired force follows the aircraft's stick force is true by construction, a gearing: not asserted.)
#[test]
fn approach_737_holds_the_descent_attitude_and_descends() {
    let (s, d) = load("737-approach.toml");
    let r = fly(&s, &d);
    let m = FlightMetrics::of(&r, &s).unwrap();
    let trim = r.flight.as_ref().unwrap().trim;
    let last = r.rows.last().unwrap().aero.unwrap();
    let first = r.rows.first().unwrap().aero.unwrap();
    println!(
        "737 approach: pitch RMS error {:.3}° (span {:.1}°); altitude {:.0} -> {:.0} m, airspeed {:.1} -> {:.1} m/s; stick force at trim {:.3} N, peak {:.1} N; hand force per g felt {:.1} N/g",
        m.tracking_rms.to_degrees(),
        m.command_span.to_degrees(),
        trim.altitude_m,
        last.altitude_m,
        trim.airspeed_m_s,
        last.airspeed_m_s,
        first.stick_force_n,
        m.stick_force_peak_n,
        m.hand_force_per_g_n
    );
    assert!(
        m.tracking_rms < 0.2 * m.command_span,
        "pitch RMS error {} rad",
        m.tracking_rms
    );
    assert!(
        (last.pitch_rad - (trim.theta_rad - 2.5f64.to_radians())).abs() < 0.5f64.to_radians(),
        "final pitch {}° vs {}°",
        last.pitch_rad.to_degrees(),
        (trim.theta_rad - 2.5f64.to_radians()).to_degrees()
    );
    // 2.5° below the level attitude for ~33 s at ~140 m/s: a descent of roughly 200 m.
    let drop = trim.altitude_m - last.altitude_m;
    assert!((100.0..400.0).contains(&drop), "descent {drop} m");
    assert!(
        first.stick_force_n.abs() < 0.5,
        "the feel computer is trimmed to zero force at trim"
    );
    assert!(m.stick_force_peak_n > 10.0, "the task must load the stick");
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
    let (s, d, emb) = pitch_tracking();
    let live_s = s.with_aircraft_model("jsbsim:c172p").unwrap();
    let live = fly(&live_s, d);
    assert_eq!(live.rows.len(), emb.rows.len());
    let d = |f: fn(&mrfeel::sim::AeroRow) -> f64| {
        let e: Vec<f64> = emb
            .rows
            .iter()
            .zip(&live.rows)
            .map(|(a, b)| f(&a.aero.unwrap()) - f(&b.aero.unwrap()))
            .collect();
        (
            rms(e.iter().copied()),
            e.iter().fold(0.0f64, |m, x| m.max(x.abs())),
        )
    };
    let (p_rms, p_max) = d(|a| a.pitch_rad);
    let (n_rms, n_max) = d(|a| a.nz_g);
    let (f_rms, _) = d(|a| a.stick_force_n);
    let m = FlightMetrics::of(&live, &live_s).unwrap();
    let (count, mean, max) = live.flight.as_ref().unwrap().round_trip_us.unwrap_or_default();
    println!(
        "live JSBSim vs embedded: pitch RMS {:.4}° max {:.3}°, nz RMS {n_rms:.4} g max {n_max:.3} g, stick force RMS {f_rms:.2} N; \
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

/// Scenario errors name the file, the line and the field with the allowed range; the aircraft sections
/// must come together.
#[test]
fn flight_scenario_errors_name_file_line_and_field() {
    let p = scenario_path("c172p-pitch-tracking.toml");
    let text = std::fs::read_to_string(&p).unwrap();
    let line_of = |t: &str, prefix: &str| t.lines().position(|l| l.starts_with(prefix)).unwrap() + 1;
    let err = |t: &str| {
        Scenario::parse(t, &p)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default()
    };

    let bad = text.replace("delay_s = 0.2", "delay_s = 5.0");
    let e = err(&bad);
    assert!(
        e.contains(&format!(
            "c172p-pitch-tracking.toml:{}:",
            line_of(&bad, "delay_s")
        )),
        "{e}"
    );
    assert!(e.contains("outer_loop.delay_s") && e.contains("[0, 1]"), "{e}");

    let bad = text.replace("airspeed_m_s = 50.0", "airspeed_m_s = 500.0");
    let e = err(&bad);
    assert!(e.contains(&format!(":{}:", line_of(&bad, "airspeed_m_s"))), "{e}");
    assert!(
        e.contains("aircraft.airspeed_m_s") && e.contains("[10, 300]"),
        "{e}"
    );

    // A pitch command that goes back in time.
    let bad = text.replace("[3.0, 5.0], [8.0, 5.0]", "[3.0, 5.0], [2.5, 5.0]");
    let e = err(&bad);
    assert!(
        e.contains("outer_loop.command") && e.contains("increasing"),
        "{e}"
    );

    // `feel.law = "aircraft"` without an aircraft.
    let start = text.find("[aircraft]").unwrap();
    let end = start + text[start..].find("\n\n").unwrap();
    let no_aircraft = format!("{}{}", &text[..start], &text[end..]);
    let e = err(&no_aircraft);
    assert!(e.contains("feel.law") && e.contains("[aircraft]"), "{e}");

    // Given gains and an adapted pilot are exclusive; the adapted pilot needs the stick lag and chooses
    // its own equalisation.
    let bad = text.replace("gain = 0.6 ", "crossover_rad_s = 1.5\ngain = 0.6 ");
    let e = err(&bad);
    assert!(e.contains("outer_loop.gain") && e.contains("not both"), "{e}");
    let adapted = text
        .replace("gain = 0.6 ", "crossover_rad_s = 1.5 #")
        .replace("lag_s = 0.1 ", "#")
        .replace("integral_per_s = 0.1", "");
    let e = err(&adapted);
    assert!(e.contains("outer_loop.lead_s") && e.contains("adapted"), "{e}");
    let e = err(&adapted.replace("lead_s = 0.3", ""));
    assert!(
        e.contains("outer_loop.stick_lag_s") && e.contains("required"),
        "{e}"
    );

    // The outer loop needs the outer-loop signal.
    let bad = text.replace("signal = \"outer-loop\"", "signal = \"hold\"\nvalue_rad = 0.0");
    let e = err(&bad);
    assert!(e.contains("outer_loop") && e.contains("outer-loop"), "{e}");

    // An unknown aircraft fails when the run opens it, naming the scenario and the model files it knows.
    let (mut s, d) = load("c172p-pitch-tracking.toml");
    s.aircraft.as_mut().unwrap().model = "no-such-plane".into();
    let rig = sim::build_rig(&s, &d.plant).unwrap();
    let e = sim::run(&s, &d, rig, RunOptions::default(), |_| {})
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(
        e.contains("c172p-pitch-tracking.toml") && e.contains("no-such-plane"),
        "{e}"
    );
}

/// `mrfeel run --rerun` of a flight: the recording holds the aircraft's series (the same values as the
/// CSV's aircraft columns) and its attitude over time beside the rig, read back with the Rerun SDK.
#[test]
#[cfg(feature = "rerun")]
fn flight_recording_reads_back_with_the_aircraft_beside_the_stick() {
    crate::common::venv_python(); // before the flight: the read-back needs it
    let (mut s, d) = load("c172p-pitch-tracking.toml");
    s.duration_s = 4.0;
    let rig = sim::build_rig(&s, &d.plant).unwrap();
    let res = sim::run(
        &s,
        &d,
        rig,
        RunOptions {
            frames_hz: Some(30.0),
        },
        |_| {},
    )
    .unwrap();
    let (ok, text) = crate::common::record_and_read_back(&res);
    assert!(ok, "read-back failed:\n{text}");
    assert!(
        text.contains("ok /signals/aircraft/pitch == CSV pitch_rad"),
        "{text}"
    );
    assert!(text.contains("ok aircraft attitude over time"), "{text}");
}

/// A JSBSim aircraft given by its folder (`jsbsim:aircraft/mycessna`, holding `mycessna.xml` and the mrfeel
/// model `mrfeel.toml` beside it) flies exactly as the same aircraft named from JSBSim's package; a folder
/// without the mrfeel model is refused at the scenario's line, naming the file it needs.
#[test]
fn a_jsbsim_aircraft_folder_flies_as_the_named_aircraft() {
    let py = mrfeel::aero::jsbsim_bridge::python_path();
    let out = std::process::Command::new(&py)
        .args(["-c", "import jsbsim; print(jsbsim.get_default_root_dir())"])
        .output()
        .unwrap_or_else(|e| panic!("{}: {e} (run the test command, which makes .venv)", py.display()));
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let root = PathBuf::from(String::from_utf8_lossy(&out.stdout).trim());
    let tmp = tempfile::tempdir().unwrap();
    let folder = tmp.path().join("aircraft").join("mycessna");
    std::fs::create_dir_all(&folder).unwrap();
    std::fs::copy(root.join("aircraft/c172p/c172p.xml"), folder.join("mycessna.xml")).unwrap();
    let text = std::fs::read_to_string(scenario_path("c172p-pitch-tracking.toml"))
        .unwrap()
        .replace("duration_s = 26.0", "duration_s = 4.0");
    let write = |name: &str, model: &str| {
        let p = tmp.path().join(name);
        std::fs::write(
            &p,
            text.replace("model = \"c172p\"", &format!("model = \"{model}\"")),
        )
        .unwrap();
        p
    };
    let folder_scn = write("folder.toml", "jsbsim:aircraft/mycessna");
    let e = match sim::load(&folder_scn) {
        Ok(_) => panic!("a folder without mrfeel.toml was accepted"),
        Err(e) => format!("{e:#}"),
    };
    let line = text.lines().position(|l| l.starts_with("model = ")).unwrap() + 1;
    assert!(
        e.contains(&format!("folder.toml:{line}:"))
            && e.contains("aircraft.model")
            && e.contains("mrfeel.toml"),
        "{e}"
    );
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("models/aircraft/c172p.toml"),
        folder.join("mrfeel.toml"),
    )
    .unwrap();
    let (s_folder, d_folder, _) = sim::load(&folder_scn).unwrap_or_else(|e| panic!("{e:#}"));
    let (s_named, d_named, _) =
        sim::load(&write("named.toml", "jsbsim:c172p")).unwrap_or_else(|e| panic!("{e:#}"));
    let (a, b) = (fly(&s_folder, &d_folder), fly(&s_named, &d_named));
    assert_eq!(a.rows.len(), b.rows.len());
    assert!(a.rows.len() > 3000, "{} rows", a.rows.len());
    for (x, y) in a.rows.iter().zip(&b.rows) {
        let (x, y) = (x.aero.unwrap(), y.aero.unwrap());
        assert_eq!(
            (x.pitch_rad, x.nz_g, x.stick_force_n),
            (y.pitch_rad, y.nz_g, y.stick_force_n),
            "the folder's flight differs from the named aircraft's"
        );
    }
    // The flight moved: the pilot's pitch command loads the stick.
    let peak = a
        .rows
        .iter()
        .map(|r| r.aero.unwrap().stick_force_n.abs())
        .fold(0.0, f64::max);
    assert!(peak > 1.0, "peak stick force {peak} N");
}

/// `mrfeel --data-dir D run` of a flight of `D/models/aircraft/myplane.toml` (the C172P's file) whose model
/// file is deleted once the flight has opened it (after the CSV's first line reaches the pipe `--out`
/// names): the CSV streamed to the pipe, the run's exit status and stderr, and the deleted file's path.
#[cfg(unix)]
fn fly_and_lose_the_model_file(plot: bool) -> (String, std::process::Output, PathBuf) {
    use std::io::{BufRead, Read};
    let tmp = tempfile::tempdir().unwrap();
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let aircraft = tmp.path().join("data/models/aircraft");
    std::fs::create_dir_all(&aircraft).unwrap();
    let model = aircraft.join("myplane.toml");
    std::fs::copy(repo.join("models/aircraft/c172p.toml"), &model).unwrap();
    let text = std::fs::read_to_string(scenario_path("c172p-pitch-tracking.toml"))
        .unwrap()
        .replace("duration_s = 26.0", "duration_s = 3.0")
        .replace("model = \"c172p\"", "model = \"myplane\"")
        .replace("\"../models/", &format!("\"{}/models/", repo.display()));
    let scn = tmp.path().join("flight.toml");
    std::fs::write(&scn, text).unwrap();
    let fifo = tmp.path().join("run.csv");
    let made = std::process::Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .expect("mkfifo runs");
    assert!(made.success());
    let s = |p: &Path| p.to_str().unwrap().to_string();
    let mut args = vec![
        "--data-dir".into(),
        s(&tmp.path().join("data")),
        "run".into(),
        s(&scn),
    ];
    args.extend(["--out".into(), s(&fifo)]);
    if plot {
        args.extend(["--plot".into(), s(tmp.path())]);
    }
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_mrfeel"))
        .args(&args)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // The CSV is written from the first step on, after the flight has loaded and trimmed its model.
    let reader = {
        let (fifo, model) = (fifo.clone(), model.clone());
        std::thread::spawn(move || {
            let mut csv = std::io::BufReader::new(std::fs::File::open(fifo).unwrap());
            let mut text = String::new();
            csv.read_line(&mut text).unwrap();
            std::fs::remove_file(model).unwrap();
            csv.read_to_string(&mut text).unwrap();
            text
        })
    };
    let out = child.wait_with_output().unwrap();
    // A run that failed before opening the pipe leaves the reader waiting: its output tells why.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(30);
    while !reader.is_finished() && std::time::Instant::now() < deadline {
        std::thread::sleep(std::time::Duration::from_millis(10));
    }
    let csv = match reader.is_finished() {
        true => reader.join().expect("the CSV's reader"),
        false => String::new(),
    };
    (csv, out, model)
}

/// A flight's stick-force-per-g chart is made only for `--plot`: a run without it finishes and streams its
/// whole CSV although the aircraft's model file, which the chart reads again, is gone by the end; with
/// `--plot` the chart cannot be made and the error names that file.
#[test]
#[cfg(unix)]
fn a_flight_reads_its_model_again_only_for_the_plot() {
    let (csv, out, model) = fly_and_lose_the_model_file(false);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert!(!model.exists());
    let header = csv.lines().find(|l| l.starts_with("t_s,")).expect("a header");
    assert!(header.contains("stick_force_n"), "{header}");
    // 3 s at 1 kHz: every step's row, the last 1 ms before the end.
    let rows: Vec<&str> = csv
        .lines()
        .skip_while(|l| !l.starts_with("t_s,"))
        .skip(1)
        .collect();
    assert_eq!(rows.len(), 3000);
    let last_t: f64 = rows[2999].split(',').next().unwrap().parse().unwrap();
    assert!((last_t - 2.999).abs() < 1e-9, "{last_t}");

    let (_, out, model) = fly_and_lose_the_model_file(true);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "the chart was made without its model file");
    assert!(err.contains(&model.display().to_string()), "{err}");
}
