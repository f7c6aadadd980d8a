//! The fly-by-wire F-16 flown live through JSBSim's flight control system (`scenarios/f16-pullup.toml`):
//! the sidestick's position commands the FCS, no hinge moment reaches the stick, and the MR damper
//! renders the designed feel (src/aero/fbw.rs) on the sidestick rig (`models/sidestick.urdf`).
//!
//! Needs the repository's Python environment with jsbsim (made by the test command).
//! `cargo test --locked --test integration f16:: -- --nocapture` prints the figures of docs/explanation/flight.md.

use crate::common;

use std::path::{Path, PathBuf};

use mrfeel::aero::FlyByWire;
use mrfeel::sim::{self, Results, Row, RunOptions};

fn scenario_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios").join(name)
}

/// Fly a scenario file to its end.
fn fly(path: &Path) -> Results {
    common::venv_python();
    let (scn, devices, rig) = sim::load(path).unwrap_or_else(|e| panic!("{e:#}"));
    sim::run(&scn, &devices, rig, RunOptions::default(), |_| {}).unwrap_or_else(|e| panic!("{e}"))
}

fn f16() -> FlyByWire {
    FlyByWire::load(&mrfeel::aero::AircraftModel::builtin_path("f16")).unwrap_or_else(|e| panic!("{e}"))
}

/// Means over the rows with `t0 ≤ t < t1`.
fn mean(r: &Results, t0: f64, t1: f64, g: impl Fn(&Row) -> f64) -> f64 {
    let v: Vec<f64> = r
        .rows
        .iter()
        .filter(|x| x.t_s >= t0 && x.t_s < t1)
        .map(g)
        .collect();
    v.iter().sum::<f64>() / v.len() as f64
}

/// RMS of the relative difference between the hand's force and the designed force at the stick's
/// position, over the rows where the stick moves aft (faster than 0.01 rad/s) with the hand past the
/// breakout: where the passive damper can render the law.
fn rendering_error(r: &Results, f: &FlyByWire) -> (f64, usize) {
    let e: Vec<f64> = r
        .rows
        .iter()
        .filter(|x| x.stick_rate_rad_s > 0.01 && x.pilot_force_n > 2.0 * f.breakout_n)
        .map(|x| x.pilot_force_n / x.aero.unwrap().stick_force_n - 1.0)
        .collect();
    (
        (e.iter().map(|v| v * v).sum::<f64>() / e.len() as f64).sqrt(),
        e.len(),
    )
}

/// The pull-up to 3 g at the design condition. The pilot holds the load factor by the force on the grip,
/// which the stick's force sensor hands to the FCS. Facts asserted:
/// - over the last 1.5 s of the hold the load factor is the commanded 3 g (within 0.15 g);
/// - the stick force per g the pilot felt there, hand force over the load factor gained, is inside
///   MIL-F-8785C Table V's Level 1 band at the design condition (computed from n/α and n_L, not from the
///   design value) and within 15 % of the designed `F_b/(n − 1) + F/n` (the FCS's g per command is
///   JSBSim's, flown, not the file's [RUN] figure; the speed bleeds at fixed throttle);
/// - the MR damper renders the law on the way out: where the stick moves aft, the hand's force is the
///   designed force at the stick's position within 15 % RMS (with the coil open the stick runs to its stop
///   under any pull: see the fault test);
/// - no hinge moment reaches the stick (every row's is 0).
#[test]
fn f16_pull_up_holds_3_g_with_a_level_1_force_per_g_rendered_by_the_damper() {
    let r = fly(&scenario_path("f16-pullup.toml"));
    let f = f16();
    assert_eq!(r.flight.as_ref().unwrap().aircraft, "jsbsim:f16");
    let aero = |x: &Row| x.aero.unwrap();
    let (t0, t1) = (4.5, 6.0);
    let nz = mean(&r, t0, t1, |x| aero(x).nz_g);
    let hand = mean(&r, t0, t1, |x| x.pilot_force_n);
    let v = mean(&r, t0, t1, |x| aero(x).airspeed_m_s);
    let stick_mm = mean(&r, t0, t1, |x| x.stick_angle_rad) * r.grip_arm_m * 1e3;
    let per_g = hand / (nz - 1.0);
    let design_per_g = f.designed_force_n(nz) / (nz - 1.0);
    let (lo, hi) = f.level1_per_g_n();
    let (render, n_render) = rendering_error(&r, &f);
    println!(
        "F-16 pull-up: {nz:.3} g (command 3 g) at {v:.1} m/s; grip {stick_mm:.2} mm aft; hand {hand:.1} N; \
         {per_g:.1} N/g flown vs {design_per_g:.1} N/g designed (secant with the breakout); MIL-F-8785C Level 1 \
         [{lo:.1}, {hi:.1}] N/g; hand vs designed force where the stick moves aft: {:.1} % RMS over {n_render} \
         samples",
        100.0 * render
    );
    assert!((nz - 3.0).abs() < 0.15, "the pilot did not hold 3 g: {nz} g");
    assert!(
        (lo..=hi).contains(&per_g),
        "{per_g} N/g outside Level 1 [{lo}, {hi}]"
    );
    assert!(
        (per_g / design_per_g - 1.0).abs() < 0.15,
        "flown {per_g} N/g vs designed {design_per_g} N/g"
    );
    assert!(n_render > 200, "the stick moved aft in {n_render} samples only");
    assert!(render < 0.15, "hand vs designed force {render} RMS");
    assert!(r.rows.iter().all(|x| aero(x).hinge_moment_nm == 0.0));
}

/// The paper's claim that an MR feel fails safe in a fly-by-wire aircraft: the same pull-up with the feel
/// loop failing from the start of the pull (1 s) to the end. The FCS reads the stick's own force sensor, so
/// each fault changes what the pilot feels and how the stick moves, never what the FCS is told; the damper
/// is passive, so no fault can move the stick. Facts asserted:
/// - in every case the load factor over the last 1.5 s is within 0.1 g of the healthy flight's and the
///   largest load factor of the flight within 0.2 g of the healthy one's (bounded, no hard-over);
/// - driver stuck at 14 A: the damper's yield (105 N at the grip) exceeds the pull, so the stick hardly
///   moves (under a fifth of the healthy travel): the fixed stick of the first YF-16;
/// - coil open: the damper's force falls to its zero-field yield, far below the pull, so the stick runs
///   to its aft stop (at least 95 % of the stop angle) and the pilot feels no gradient, only the stop;
///   the aircraft flies as healthy (the run's energy balance counts the energy the stop's bumper takes,
///   `sim::invariants`);
/// - load cell reading zero: the feel loop loses its force measurement; printed, with the aircraft
///   asserted as above.
#[test]
fn feel_faults_change_what_the_pilot_feels_never_what_the_fcs_is_told() {
    let healthy = fly(&scenario_path("f16-pullup.toml"));
    let f = f16();
    let aero = |x: &Row| x.aero.unwrap();
    let nz_end = |r: &Results| mean(r, 4.5, 6.0, |x| aero(x).nz_g);
    let nz_max = |r: &Results| r.rows.iter().map(|x| aero(x).nz_g).fold(f64::MIN, f64::max);
    let travel = |r: &Results| r.rows.iter().map(|x| x.stick_angle_rad).fold(f64::MIN, f64::max);
    let lc_hold = |r: &Results| {
        r.rows
            .iter()
            .filter(|x| x.t_s >= 3.0)
            .map(|x| x.load_cell_true_n.abs())
            .fold(0.0, f64::max)
    };
    let text = std::fs::read_to_string(scenario_path("f16-pullup.toml")).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let (h_nz, h_max, h_travel) = (nz_end(&healthy), nz_max(&healthy), travel(&healthy));
    println!(
        "healthy: {h_nz:.3} g at the end, {h_max:.3} g max, stick travel {:.2} mm, hand {:.1} N",
        h_travel * healthy.grip_arm_m * 1e3,
        mean(&healthy, 4.5, 6.0, |x| x.pilot_force_n)
    );
    for kind in ["coil_open", "driver_stuck", "load_cell_zero"] {
        let p = tmp.path().join(format!("{kind}.toml"));
        std::fs::write(
            &p,
            format!("{text}\n[[fault]]\nkind = \"{kind}\"\nstart_s = 1.0\nend_s = 6.0\n"),
        )
        .unwrap();
        let r = fly(&p);
        let (nz, max, tr, lc) = (nz_end(&r), nz_max(&r), travel(&r), lc_hold(&r));
        println!(
            "{kind}: {nz:.3} g at the end, {max:.3} g max, stick travel {:.2} mm (aft stop {:.2} mm), hand {:.1} N, \
             largest load-cell force after 3 s {lc:.1} N",
            tr * r.grip_arm_m * 1e3,
            f.full_command_stick_rad * r.grip_arm_m * 1e3,
            mean(&r, 4.5, 6.0, |x| x.pilot_force_n)
        );
        assert!((nz - h_nz).abs() < 0.1, "{kind}: {nz} g vs healthy {h_nz} g");
        assert!(
            (max - h_max).abs() < 0.2,
            "{kind}: max {max} g vs healthy {h_max} g"
        );
        match kind {
            "driver_stuck" => {
                assert!(
                    tr < 0.2 * h_travel,
                    "driver stuck: travel {tr} rad vs healthy {h_travel} rad"
                )
            }
            "coil_open" => {
                assert!(
                    tr >= 0.95 * f.full_command_stick_rad,
                    "coil open: travel {tr} rad, aft stop {} rad",
                    f.full_command_stick_rad
                )
            }
            _ => {}
        }
    }
}

/// One hands-off case: the feel system's table (empty: the MR damper), its fault, what it is.
struct HandsOff {
    what: &'static str,
    feel_system: &'static str,
    fault: Option<&'static str>,
}

/// The pilot lets go at 3 s, in the 3 g hold of the pull-up, to the end of the run (6 s), with the feel
/// system failing at the same instant: the MR damper with its coil open, and a centring spring unit
/// (`models/feel-springs.toml`, 1130 N/m, 100 N·s/m), which has nothing to fail. (The active stick is not
/// flown here: on the sidestick its run breaks the energy balance before any fault.) The FCS reads the
/// stick's force sensor, and no hand on the grip is no force on it, so in every case the command falls
/// to zero and the FCS flies back to 1 g. Facts asserted, for each case:
/// - the aircraft: the load factor rises no more than 0.1 g above its value at the release (the FCS's
///   lag: the pull-up is still converging on 3 g at 3 s), never falls below 0.5 g (no push-over), and
///   over the last second is 1 g within 0.1 g;
/// - the stick: nothing holds the MR stick with its coil open (no field, no spring), and it ends on its
///   aft stop, where the pilot finds it on taking it again (the FCS never sees it); the spring brings it
///   back to centre (within a tenth of the deflection it had at the release).
#[test]
fn hands_off_the_fcs_flies_back_to_1_g_whatever_the_feel_system_does() {
    let text = std::fs::read_to_string(scenario_path("f16-pullup.toml")).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let aero = |x: &Row| x.aero.unwrap();
    let release = 3.0;
    let cases = [
        HandsOff {
            what: "MR damper, coil open",
            feel_system: "",
            fault: Some("coil_open"),
        },
        HandsOff {
            what: "centring spring",
            feel_system: "[feel_system]\nkind = \"centring_spring\"\nsprings = \"../models/feel-springs.toml\"\ndamping_n_s_per_m = 100.0\n",
            fault: None,
        },
    ];
    for (k, c) in cases.iter().enumerate() {
        let mut toml = format!(
            "{text}\n{}\n[[fault]]\nkind = \"hands_off\"\nstart_s = {release:?}\nend_s = 6.0\n",
            c.feel_system
        );
        if let Some(f) = c.fault {
            toml += &format!("\n[[fault]]\nkind = \"{f}\"\nstart_s = {release:?}\nend_s = 6.0\n");
        }
        let p = tmp.path().join(format!("hands-off-{k}.toml"));
        std::fs::write(&p, toml).unwrap();
        let r = fly(&p);
        let (lo, hi) = sim::load(&p).unwrap().2.stick_limits_rad();
        let at_release = mean(&r, release - 0.1, release, |x| x.stick_angle_rad);
        let at_end = mean(&r, 5.5, 6.0, |x| x.stick_angle_rad);
        let nz_release = mean(&r, release - 0.1, release, |x| aero(x).nz_g);
        let after = r.rows.iter().filter(|x| x.t_s >= release);
        let (nz_min, nz_max) = after
            .map(|x| aero(x).nz_g)
            .fold((f64::MAX, f64::MIN), |(a, b), v| (a.min(v), b.max(v)));
        let nz_end = mean(&r, 5.0, 6.0, |x| aero(x).nz_g);
        let rod_peak = r
            .rows
            .iter()
            .filter(|x| x.t_s >= release)
            .map(|x| x.load_cell_true_n.abs())
            .fold(0.0, f64::max);
        let hand_after = r
            .rows
            .iter()
            .filter(|x| x.t_s >= release)
            .map(|x| x.pilot_force_n.abs())
            .fold(0.0, f64::max);
        println!(
            "hands off at {release} s, {}: stick {:.2} mm at the release -> {:.2} mm at the end (stops {:.2}, \
             {:.2} mm); load factor {nz_release:.3} g at the release, {nz_min:.3} to {nz_max:.3} g after, \
             {nz_end:.3} g over the last second; hand force after the release {hand_after} N; largest rod force \
             after the release {rod_peak:.1} N",
            c.what,
            at_release * r.grip_arm_m * 1e3,
            at_end * r.grip_arm_m * 1e3,
            lo * r.grip_arm_m * 1e3,
            hi * r.grip_arm_m * 1e3,
        );
        assert_eq!(hand_after, 0.0, "{}: the hand pushed after letting go", c.what);
        assert!(
            nz_max <= nz_release + 0.1,
            "{}: {nz_max} g after letting go at {nz_release} g",
            c.what
        );
        assert!(nz_min >= 0.5, "{}: pushed over to {nz_min} g", c.what);
        assert!(
            (nz_end - 1.0).abs() < 0.1,
            "{}: {nz_end} g over the last second",
            c.what
        );
        let travel = hi - lo;
        match c.fault {
            Some("coil_open") => assert!(
                at_end >= hi - 0.05 * travel,
                "{}: the stick at {at_end} rad, not on its aft stop {hi} rad",
                c.what
            ),
            _ => assert!(
                at_end.abs() < 0.1 * at_release.abs(),
                "{}: the stick at {at_end} rad, let go at {at_release} rad",
                c.what
            ),
        }
    }
}

/// The embedded F-16 (JSBSim's tables and pitch FCS in Rust, `model = "f16"`, no Python) flies the same
/// pilot-in-the-loop pull-up as live JSBSim: the pilot, the feel loop and the sidestick are the same, only
/// the aircraft differs. Facts asserted: load factor within 0.05 g RMS and pitch within 0.2° RMS of the live
/// flight over the whole run, the hand's force within 2 N RMS; the embedded flight holds 3 g as the live one
/// does (within 0.15 g over the last 1.5 s), with its flown force per g inside the Level 1 band.
#[test]
fn the_embedded_f16_flies_the_pilot_in_the_loop_pull_up_as_live_jsbsim_does() {
    let path = scenario_path("f16-pullup.toml");
    let live = fly(&path);
    let (scn, devices, rig) = sim::load(&path).unwrap_or_else(|e| panic!("{e:#}"));
    let scn = scn.with_aircraft_model("f16").unwrap();
    let emb = sim::run(&scn, &devices, rig, RunOptions::default(), |_| {}).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(emb.flight.as_ref().unwrap().aircraft, "f16");
    assert!(
        emb.flight.as_ref().unwrap().round_trip_us.is_none(),
        "no bridge for the embedded model"
    );
    assert_eq!(live.rows.len(), emb.rows.len());
    let rms = |g: &dyn Fn(&Row) -> f64| {
        let ss: f64 = live
            .rows
            .iter()
            .zip(&emb.rows)
            .map(|(a, b)| (g(a) - g(b)).powi(2))
            .sum();
        (ss / live.rows.len() as f64).sqrt()
    };
    let nz = rms(&|x| x.aero.unwrap().nz_g);
    let pitch = rms(&|x| x.aero.unwrap().pitch_rad);
    let hand = rms(&|x| x.pilot_force_n);
    let f = f16();
    let (t0, t1) = (4.5, 6.0);
    let nz_emb = mean(&emb, t0, t1, |x| x.aero.unwrap().nz_g);
    let per_g = mean(&emb, t0, t1, |x| x.pilot_force_n) / (nz_emb - 1.0);
    let (lo, hi) = f.level1_per_g_n();
    println!(
        "F-16 pull-up, embedded vs live JSBSim: load factor {nz:.4} g RMS, pitch {:.3}° RMS, hand force {hand:.2} N \
         RMS; embedded {nz_emb:.3} g over the last 1.5 s at {per_g:.1} N/g (Level 1 [{lo:.1}, {hi:.1}] N/g)",
        pitch.to_degrees()
    );
    assert!(nz < 0.05, "load factor disagreement {nz} g RMS");
    assert!(
        pitch.to_degrees() < 0.2,
        "pitch disagreement {}° RMS",
        pitch.to_degrees()
    );
    assert!(hand < 2.0, "hand force disagreement {hand} N RMS");
    assert!((nz_emb - 3.0).abs() < 0.15, "embedded: {nz_emb} g");
    assert!(
        (lo..=hi).contains(&per_g),
        "embedded: {per_g} N/g outside Level 1"
    );
}

/// The designed feel across the envelope (`scenarios/sweeps/f16-envelope.toml` at 3000 m, embedded model):
/// each run of the sweep gets a MIL-F-8785C Level from the force per g the pilot flew and its own n/α, and a
/// Part 60 breakout verdict against the designed law's breakout, which the damper renders within ±2 lbf.
/// Facts asserted: at the design condition (200 m/s) the sweep's n/α, the lift table's slope, is within
/// 10 % of the file's figure from a JSBSim run (21.9 g/rad, which also counts the flap and pitch-rate lift),
/// and the run is Level 1; n/α rises with speed; from 150 to 250 m/s the airframe needs less tail per g as
/// the dynamic pressure rises, so the FCS gives more load factor per command and the force per g flown
/// falls by more than 30 % per 50 m/s (beyond, the FCS's own pitch-rate and α terms set it: 15.4 N/g at 250
/// m/s, 15.9 at 300).
#[test]
fn the_f16_envelope_sweep_gives_each_condition_a_level_from_the_force_per_g_flown() {
    let plan = mrfeel::sweep::Plan::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/sweeps/f16-envelope.toml"),
    )
    .unwrap();
    // a grid, the last axis (altitude: 1000, 3000, 6000 m) fastest
    assert_eq!(plan.run_count(), 12);
    let runs: Vec<_> = [1, 4, 7, 10]
        .iter()
        .map(|&k| mrfeel::sweep::run_one(&plan, &plan.run(k)).outcome)
        .collect();
    assert_eq!(runs.len(), 4);
    for (v, o) in [150.0, 200.0, 250.0, 300.0].iter().zip(&runs) {
        println!(
            "F-16 at {v} m/s, 3000 m: {:.1} N/g flown, n/α {:.1} g/rad, Level {:?}",
            o.stick_force_per_g_flown_n.unwrap_or(f64::NAN),
            o.n_per_alpha_g_per_rad.unwrap_or(f64::NAN),
            o.per_g_level
        );
        assert_eq!(o.error, None);
        assert!(o.per_g_level.is_some(), "{v} m/s: no Level");
        // the damper renders the designed breakout within 14 CFR Part 60's ±2 lbf
        assert_eq!(o.breakout_ref_n, Some(f16().breakout_n));
        assert_eq!(
            o.part60_breakout_ok,
            Some(true),
            "{v} m/s: breakout {:?} N",
            o.breakout_n
        );
    }
    let design = &runs[1];
    let na = design.n_per_alpha_g_per_rad.unwrap();
    assert!((na / f16().n_alpha_per_rad - 1.0).abs() < 0.10, "n/α {na} g/rad");
    assert_eq!(design.per_g_level, Some(1));
    for w in runs.windows(2) {
        assert!(w[1].n_per_alpha_g_per_rad.unwrap() > w[0].n_per_alpha_g_per_rad.unwrap());
    }
    for w in runs[..3].windows(2) {
        assert!(w[1].stick_force_per_g_flown_n.unwrap() < 0.7 * w[0].stick_force_per_g_flown_n.unwrap());
    }
}

/// McRuer's adapted pilot on the fly-by-wire F-16 (`outer_loop.crossover_rad_s`, designed on the embedded
/// model with its FCS, `aero::linear::adapted_fly_by_wire_pilot`) flies the pull-up of
/// `scenarios/f16-pullup.toml` on the embedded model: it tracks the load-factor command with a smaller RMS
/// error than the scenario's hand-set gains, and is within 0.25 g of 3 g over the last 1.5 s (its integral
/// corner sits at a tenth of the crossover, so it is still taking out the last tenth of a g when the run
/// ends: 2.81 g).
#[test]
fn the_adapted_pilot_flies_the_f16_pull_up_better_than_the_given_gains() {
    let text = std::fs::read_to_string(scenario_path("f16-pullup.toml")).unwrap();
    let given_text = text.replace("model = \"jsbsim:f16\"", "model = \"f16\"");
    let (i, j) = (
        given_text.find("[outer_loop]").unwrap(),
        given_text.find("# [t_s, load factor, g]").unwrap(),
    );
    let adapted_text = format!(
        "{}[outer_loop]\nloop = \"load-factor\"\ncrossover_rad_s = 1.5\nstick_lag_s = 0.1\ndelay_s = 0.2\n{}",
        &given_text[..i],
        &given_text[j..]
    );
    let dir = scenario_path("");
    let fly_text = |t: &str, name: &str| {
        let tmp = tempfile::Builder::new()
            .prefix(name)
            .suffix(".toml")
            .tempfile_in(&dir)
            .unwrap();
        std::fs::write(tmp.path(), t).unwrap();
        let (scn, devices, rig) = sim::load(tmp.path()).unwrap_or_else(|e| panic!("{e:#}"));
        let r =
            sim::run(&scn, &devices, rig, RunOptions::default(), |_| {}).unwrap_or_else(|e| panic!("{e}"));
        let m = mrfeel::sim::metrics::FlightMetrics::of(&r, &scn).unwrap();
        (r, m.tracking_rms)
    };
    let (given, given_rms) = fly_text(&given_text, "given");
    let (adapted, adapted_rms) = fly_text(&adapted_text, "adapted");
    let nz = |r: &Results| mean(r, 4.5, 6.0, |x| x.aero.unwrap().nz_g);
    println!(
        "F-16 pull-up, embedded: load-factor tracking RMS {adapted_rms:.4} g adapted (1.5 rad/s) against \
         {given_rms:.4} g with the given gains; last 1.5 s {:.3} g and {:.3} g",
        nz(&adapted),
        nz(&given)
    );
    assert!((nz(&adapted) - 3.0).abs() < 0.25, "adapted: {} g", nz(&adapted));
    assert!(
        adapted_rms < given_rms,
        "adapted {adapted_rms} vs given {given_rms}"
    );
}
