//! The stick rig's physical facts: geometry from the paper's Table 1, agreeing stops, the MR damper as an
//! implicit yield element (holds below yield, no creep, no chatter), Bingham steady speed, energy balance,
//! and the load cell's reading.

use std::path::{Path, PathBuf};

use mrfeel::control::feel::{self, FeelSprings, Spring};
use mrfeel::device::{DeviceConfig, Registry};
use mrfeel::rig::{Rig, RigConfig};

const IN: f64 = 0.0254;
const STEEL: f64 = 7850.0;
const PI: f64 = std::f64::consts::PI;

fn urdf_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("models/stick-rig.urdf")
}

/// A Bingham damper (Eq. 2 with Eq. 6's lags) with the given parameters.
fn damper(fc0_n: f64, gain_n_per_a: f64, c0: f64) -> mrfeel::device::Damper {
    let text = format!(
        "model = \"bingham\"\n[params]\nfc0_n = {fc0_n}\nfc_gain_n_per_a = {gain_n_per_a}\nc0_n_s_per_m = {c0}\n\
         te_s = 0.01\ntm_s = 0.02\n"
    );
    DeviceConfig::from_toml(&text, Path::new("test-device.toml"), &Registry::builtin())
        .unwrap()
        .damper()
}

fn rig(gravity: bool, fc0_n: f64, gain: f64, c0: f64) -> Rig {
    let mut cfg = RigConfig::new(urdf_path());
    cfg.gravity = gravity;
    Rig::new(&cfg, damper(fc0_n, gain, c0)).unwrap()
}

fn steps(rig: &Rig, seconds: f64) -> usize {
    (seconds / rig.dt_s()).round() as usize
}

#[test]
fn urdf_masses_limits_and_axes_match_table_1() {
    let robot = urdf_rs::read_file(urdf_path()).unwrap();
    let link = |n: &str| robot.links.iter().find(|l| l.name == n).unwrap();
    let joint = |n: &str| robot.joints.iter().find(|j| j.name == n).unwrap();
    // Table 1: cylinder OD 4 in, ID 3.5 in, length 7 in, low-carbon steel.
    let cyl = STEEL * PI / 4.0 * ((4.0 * IN).powi(2) - (3.5 * IN).powi(2)) * 7.0 * IN;
    assert!(
        (link("cylinder").inertial.mass.value - cyl).abs() < 1e-4 * cyl,
        "cylinder {cyl}"
    );
    // Piston: Ø3.125 in head, 3 in long (7 in − 2 × 2 in stroke), plus a 10 in rod of Ø0.5 in (estimate).
    let head = STEEL * PI / 4.0 * (3.125 * IN).powi(2) * 3.0 * IN;
    let rod = STEEL * PI / 4.0 * (0.5 * IN).powi(2) * 10.0 * IN;
    assert!((link("piston").inertial.mass.value - (head + rod)).abs() < 1e-4 * (head + rod));
    // Cylinder's axial inertia of a tube, m (ro² + ri²)/2.
    let ixx = cyl * ((2.0 * IN).powi(2) + (1.75 * IN).powi(2)) / 2.0;
    assert!((link("cylinder").inertial.inertia.ixx - ixx).abs() < 1e-4 * ixx);
    // Stroke ±2 in on a prismatic joint along +x.
    let slide = joint("piston_slide");
    assert!(matches!(slide.joint_type, urdf_rs::JointType::Prismatic));
    assert!((slide.limit.upper - 2.0 * IN).abs() < 1e-9 && (slide.limit.lower + 2.0 * IN).abs() < 1e-9);
    assert_eq!(slide.axis.xyz.0, [1.0, 0.0, 0.0]);
    // Stick: revolute about the lateral axis, ±18° travel.
    let pivot = joint("stick_pivot");
    assert!(matches!(pivot.joint_type, urdf_rs::JointType::Revolute));
    assert_eq!(pivot.axis.xyz.0, [0.0, 1.0, 0.0]);
    assert!((pivot.limit.upper - 18f64.to_radians()).abs() < 1e-6);

    let r = rig(true, 5.0, 5.0, 300.0);
    assert!((r.stroke_limit_m() - 2.0 * IN).abs() < 1e-12);
    assert!((r.grip_lever_m() - 0.40).abs() < 1e-9);
    assert!((r.piston_group_mass_kg() - (head + rod + STEEL * 0.03 * 0.025 * 0.025)).abs() < 1e-3);
}

#[test]
fn stick_stops_keep_the_piston_inside_its_stroke() {
    let r = rig(false, 2.0, 5.0, 300.0);
    let (lo, hi) = r.stick_limits_rad();
    let stroke = r.stroke_limit_m();
    for t in [lo, hi] {
        let x = r.linkage().piston_x_m(t).unwrap();
        assert!(x.abs() < stroke, "stick stop {t} rad drives the piston to {x} m");
    }
    // The gearing near centre is the clevis height (slider-crank): 0.15 m/rad.
    assert!((r.gearing_m_per_rad() - 0.15).abs() < 1e-6);
}

#[test]
fn stops_that_would_fight_are_rejected_with_the_line() {
    let text = std::fs::read_to_string(urdf_path()).unwrap();
    let bad = text.replace(
        r#"lower="-0.3141593" upper="0.3141593""#,
        r#"lower="-0.6" upper="0.6""#,
    );
    assert_ne!(bad, text);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.urdf");
    std::fs::write(&path, &bad).unwrap();
    let line = bad
        .lines()
        .position(|l| l.contains(r#"<joint name="stick_pivot""#))
        .unwrap()
        + 1;
    let e = Rig::new(&RigConfig::new(&path), damper(2.0, 5.0, 300.0))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&format!("bad.urdf:{line}")) && e.contains("stick_pivot") && e.contains("fight"),
        "{e}"
    );
}

#[test]
fn physics_rate_outside_its_range_is_an_error() {
    let mut cfg = RigConfig::new(urdf_path());
    cfg.physics_hz = 10.0;
    let e = Rig::new(&cfg, damper(2.0, 5.0, 300.0)).unwrap_err().to_string();
    assert!(e.contains("physics_hz") && e.contains("[100, 100000]"), "{e}");
}

#[test]
fn positive_hand_force_moves_grip_aft_and_piston_out() {
    let mut r = rig(false, 1.0, 0.0, 300.0);
    for _ in 0..steps(&r, 0.1) {
        r.step(10.0, 0.0);
    }
    let s = r.state();
    assert!(
        s.stick_angle_rad > 0.0 && s.grip_pos_m[0] > 0.0 && s.piston_x_m > 0.0,
        "{s:?}"
    );
    // The piston follows the closed-form linkage (the loop closure holds).
    let x = r.linkage().piston_x_m(s.stick_angle_rad).unwrap();
    assert!(
        (s.piston_x_m - x).abs() < 2e-5,
        "multibody {} vs slider-crank {x}",
        s.piston_x_m
    );
}

/// Push the stick to `target` rad with a hand force, then let go and let it settle.
fn park(r: &mut Rig, target: f64, force_n: f64) {
    let f = force_n * (target - r.state().stick_angle_rad).signum();
    for _ in 0..steps(r, 3.0) {
        if (r.state().stick_angle_rad - target) * f.signum() >= 0.0 {
            break;
        }
        r.step(f, 0.0);
    }
    for _ in 0..steps(r, 0.5) {
        r.step(0.0, 0.0);
    }
}

#[test]
fn stick_does_not_creep_under_gravity_when_yield_exceeds_the_gravity_moment() {
    // Zero current: the yield force is fc0 = 6 N at the piston, i.e. 6·0.15 = 0.9 N·m at the pivot; the
    // gravity moment of the stick at 10° is about 0.38·9.81·0.33·sin 10° = 0.21 N·m.
    let mut r = rig(true, 6.0, 5.0, 300.0);
    park(&mut r, 10f64.to_radians(), 8.0);
    let t0 = r.state().stick_angle_rad;
    assert!(t0 > 9f64.to_radians(), "parked at {t0}");
    let mut flips = 0;
    let mut last = 0.0f64;
    for _ in 0..steps(&r, 5.0) {
        r.step(0.0, 0.0);
        let v = r.state().piston_v_m_s;
        if v != 0.0 && last != 0.0 && v.signum() != last.signum() {
            flips += 1;
        }
        if v != 0.0 {
            last = v;
        }
    }
    let drift = (r.state().stick_angle_rad - t0).abs();
    println!("parked at {t0} rad: drift {drift} rad in 5 s, {flips} velocity sign changes");
    assert!(drift < 1e-4, "stick crept {drift} rad in 5 s");
    assert!(
        flips < 5 * 5,
        "piston velocity changed sign {flips} times in 5 s at rest"
    );
}

#[test]
fn hand_force_below_yield_does_not_move_the_stick() {
    // Yield 5 + 5·2 A = 15 N at the piston; the hand's 4 N at 0.40 m gives 4·0.40/0.15 = 10.7 N.
    let mut r = rig(false, 5.0, 5.0, 300.0);
    for _ in 0..steps(&r, 0.3) {
        r.step(0.0, 2.0); // let the coil and fluid lags settle
    }
    let t0 = r.state().stick_angle_rad;
    let mut max_load = 0.0f64;
    for _ in 0..steps(&r, 5.0) {
        r.step(4.0, 2.0);
        max_load = max_load.max(r.state().load_cell_n);
    }
    let s = r.state();
    assert!(
        (s.stick_angle_rad - t0).abs() < 1e-4,
        "moved {} rad",
        s.stick_angle_rad - t0
    );
    // The load cell carries the hand's force through the lever: F·L/gearing (static, at neutral).
    let expect = 4.0 * 0.40 / 0.15;
    assert!(
        (s.load_cell_n - expect).abs() < 0.02 * expect,
        "load cell {} N, expected {expect}",
        s.load_cell_n
    );
    // The fluid holds it: the damper force balances the load cell.
    assert!((s.damper_force_n - s.load_cell_n).abs() < 0.02 * expect, "{s:?}");
    assert!(max_load < 1.1 * expect);
}

#[test]
fn hand_force_above_yield_gives_the_bingham_steady_speed() {
    // Gravity off. fc = 5 + 5·2 = 15 N, C0 = 400 N·s/m, hand 20 N: piston force 20·0.40/g(θ).
    let (fc0, gain, c0, i_a, f_hand) = (5.0, 5.0, 400.0, 2.0, 20.0);
    let mut r = rig(false, fc0, gain, c0);
    for _ in 0..steps(&r, 0.3) {
        r.step(0.0, i_a);
    }
    park_with_current(&mut r, -15f64.to_radians(), -40.0, i_a);
    let mut checked = 0;
    let mut worst = 0.0f64;
    for _ in 0..steps(&r, 2.0) {
        r.step(f_hand, i_a);
        let s = r.state();
        if s.stick_angle_rad.abs() < 2f64.to_radians() {
            let g = r.linkage().gearing_m_per_rad(s.stick_angle_rad).unwrap();
            let v_expect = (f_hand * r.grip_lever_m() / g - (fc0 + gain * i_a)) / c0;
            worst = worst.max(((s.piston_v_m_s - v_expect) / v_expect).abs());
            assert!(
                (s.piston_v_m_s - v_expect).abs() < 0.03 * v_expect,
                "v {} vs {v_expect}",
                s.piston_v_m_s
            );
            // Steady: the load cell carries the damper force (Eq. 2).
            let fd = (fc0 + gain * i_a) + c0 * s.piston_v_m_s;
            assert!(
                (s.damper_force_n - fd).abs() < 0.03 * fd,
                "Fd {} vs {fd}",
                s.damper_force_n
            );
            checked += 1;
        }
        if s.stick_angle_rad > 3f64.to_radians() {
            break;
        }
    }
    println!("steady speed: worst relative error {worst:.3e} over {checked} samples");
    assert!(checked > 10, "only {checked} samples near centre");
}

fn park_with_current(r: &mut Rig, target: f64, force_n: f64, i_a: f64) {
    for _ in 0..steps(r, 3.0) {
        if (r.state().stick_angle_rad - target) * force_n.signum() >= 0.0 {
            break;
        }
        r.step(force_n, i_a);
    }
    for _ in 0..steps(r, 0.3) {
        r.step(0.0, i_a);
    }
}

#[test]
fn hand_work_equals_energy_change_plus_damper_dissipation() {
    // Gravity on, 5 s of a 1 Hz cosine push (the stick swings about neutral without reaching a stop).
    let mut r = rig(true, 3.0, 5.0, 300.0);
    let s0 = r.state();
    let mut min_step = f64::INFINITY;
    let mut max_angle = 0.0f64;
    for k in 0..steps(&r, 5.0) {
        let t = k as f64 * r.dt_s();
        let before = r.state().damper_dissipated_j;
        r.step(15.0 * (2.0 * PI * t).cos(), 1.0);
        let s = r.state();
        min_step = min_step.min(s.damper_dissipated_j - before);
        max_angle = max_angle.max(s.stick_angle_rad.abs());
        assert!(
            s.damper_power_w <= 1e-9,
            "damper power {} W > 0 at t = {t}",
            s.damper_power_w
        );
    }
    let s = r.state();
    assert!(
        max_angle < 0.9 * r.stick_limits_rad().1,
        "reached {max_angle} rad"
    );
    let lhs = s.hand_work_j - s0.hand_work_j;
    let rhs = (s.kinetic_energy_j - s0.kinetic_energy_j)
        + (s.potential_energy_j - s0.potential_energy_j)
        + s.damper_dissipated_j;
    println!(
        "hand work {lhs} J, ΔE + dissipated {rhs} J, error {:.3e}, max |θ| {max_angle}",
        (lhs - rhs) / lhs
    );
    assert!(lhs > 0.5, "hand work {lhs} J too small to test");
    assert!(
        (lhs - rhs).abs() < 0.01 * lhs,
        "hand work {lhs} J vs ΔE + dissipated {rhs} J"
    );
    assert!(min_step >= -1e-9, "damper gave back {min_step} J in one step");
}

#[test]
fn damper_never_returns_energy_to_the_mechanism() {
    // A hard, irregular workout: pushes above and below yield, current steps (the yield force changes
    // under a moving piston), reversals and hits on the stops, gravity on.
    let mut r = rig(true, 3.0, 6.0, 150.0);
    let mut worst = 0.0f64;
    for k in 0..steps(&r, 6.0) {
        let t = k as f64 * r.dt_s();
        let f = 40.0 * (2.0 * PI * 0.7 * t).sin() + 25.0 * (2.0 * PI * 3.1 * t).sin();
        let i = if (t * 2.0).floor() as i64 % 2 == 0 {
            0.5
        } else {
            8.0
        };
        let before = r.state().damper_dissipated_j;
        r.step(f, i);
        let s = r.state();
        worst = worst
            .max(s.damper_power_w)
            .max((before - s.damper_dissipated_j) / r.dt_s());
    }
    assert!(r.state().damper_dissipated_j > 1.0, "too little motion to test");
    // Numerical zero: f32 velocities of a stuck piston are ~1e-10 m/s, times tens of newtons.
    assert!(worst <= 1e-6, "the damper returned energy: {worst}");
}

#[test]
fn holding_the_stick_on_its_stop_does_not_chatter() {
    // The pilot holds full aft stick (15 N) with the damper energised: stop and yield share the load.
    let mut r = rig(true, 3.0, 5.0, 300.0);
    for _ in 0..steps(&r, 2.0) {
        r.step(15.0, 1.0);
    }
    let (mut lc_min, mut lc_max, mut x_min, mut x_max) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for _ in 0..steps(&r, 1.0) {
        r.step(15.0, 1.0);
        let s = r.state();
        lc_min = lc_min.min(s.load_cell_n);
        lc_max = lc_max.max(s.load_cell_n);
        x_min = x_min.min(s.piston_x_m);
        x_max = x_max.max(s.piston_x_m);
    }
    assert!(
        (r.state().stick_angle_rad - r.stick_limits_rad().1).abs() < 2e-3,
        "not on the stop"
    );
    assert!(
        lc_max - lc_min < 0.5,
        "load cell swings {lc_min}..{lc_max} N on the stop"
    );
    assert!(
        x_max - x_min < 1e-6,
        "piston moves {} m on the stop",
        x_max - x_min
    );
}

#[test]
fn piston_never_passes_its_stroke_when_pushed_hard_into_the_stop() {
    // 300 N at the grip (above the FAA's 60 lbf temporary pitch force), slammed into both stops.
    let mut r = rig(true, 3.0, 5.0, 100.0);
    let stroke = r.stroke_limit_m();
    let (lo, hi) = r.stick_limits_rad();
    let (mut x_max, mut overshoot) = (0.0f64, 0.0f64);
    for (f, secs) in [(300.0, 1.0), (-300.0, 1.5), (300.0, 1.5)] {
        for _ in 0..steps(&r, secs) {
            r.step(f, 0.0);
            let s = r.state();
            x_max = x_max.max(s.piston_x_m.abs());
            overshoot = overshoot.max(s.stick_angle_rad - hi).max(lo - s.stick_angle_rad);
        }
        // It rests on the stick's stop.
        let s = r.state();
        assert!(
            (s.stick_angle_rad.abs() - hi).abs() < 2e-3,
            "stick at {} rad",
            s.stick_angle_rad
        );
    }
    println!("max |piston x| {x_max} m, max stop overshoot {overshoot} rad");
    assert!(x_max < stroke, "piston reached {x_max} m, stroke {stroke} m");
    // The stop is a stiff constraint, not a wall: at 1 kHz its overshoot on impact stays below 2°.
    assert!(
        overshoot < 2f64.to_radians(),
        "stick overshot its stop by {overshoot} rad"
    );
}

#[test]
fn body_poses_name_every_link_with_its_visuals() {
    let r = rig(true, 3.0, 5.0, 300.0);
    let poses = r.poses();
    let names: Vec<&str> = poses.iter().map(|p| p.name.as_str()).collect();
    for n in ["base", "stick", "push_rod", "load_cell", "piston", "cylinder"] {
        assert!(names.contains(&n), "{n} missing from {names:?}");
        let v = r.visuals().iter().find(|l| l.name == n).unwrap();
        assert!(!v.visuals.is_empty());
    }
    // The cylinder's frame sits on the damper axis, 0.5221 m forward of the pivot, 0.15 m up.
    let c = poses.iter().find(|p| p.name == "cylinder").unwrap();
    assert!((c.translation_m[0] + 0.5221).abs() < 1e-6 && (c.translation_m[2] - 0.15).abs() < 1e-6);
}

fn feel_springs() -> FeelSprings {
    FeelSprings::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("models/feel-springs.toml")).unwrap()
}

/// Step the rig with a feel element on the piston joint.
fn step_feel(r: &mut Rig, f: &dyn Spring, hand_n: f64) {
    feel::apply(f, r);
    r.step(hand_n, 0.0);
}

#[test]
fn centring_spring_recentres_the_stick_when_the_hand_lets_go() {
    // Unpowered damper: 1 N of residual friction, 60 N·s/m. Gravity on.
    let (fc0, c0) = (1.0, 60.0);
    let mut r = rig(true, fc0, 0.0, c0);
    let spring = feel_springs().centring;
    for _ in 0..steps(&r, 1.0) {
        step_feel(&mut r, &spring, 25.0);
    }
    let x_held = r.state().piston_x_m;
    assert!(x_held > 0.02, "pushed only to {x_held} m");
    for _ in 0..steps(&r, 3.0) {
        step_feel(&mut r, &spring, 0.0);
    }
    let x = r.state().piston_x_m;
    // The stick's weight acts as a negative spring at the piston: (m_s g z_s + m_r g z_r) / gearing².
    let k_grav = (0.383035 * 9.80665 * 0.330536 + 0.042412 * 9.80665 * 0.15) / (0.15 * 0.15);
    let dead_band = fc0 / (spring.k_n_per_m - k_grav);
    assert!(
        x.abs() <= 1.05 * dead_band,
        "stick rests at x = {x} m, dead band {dead_band} m"
    );
    assert!(r.state().piston_v_m_s.abs() < 1e-4);
}

#[test]
fn passive_feel_systems_never_inject_energy() {
    let springs = feel_springs();
    let mut q = springs.q_feel;
    q.set_dynamic_pressure(10_000.0);
    let systems: [(&str, &dyn Spring); 3] = [
        ("centring", &springs.centring),
        ("variable gradient", &springs.variable_gradient),
        ("q-feel", &q),
    ];
    for (name, f) in systems {
        let mut r = rig(true, 0.5, 0.0, 20.0);
        let e0 = r.state().kinetic_energy_j + r.state().potential_energy_j + f.stored_energy_j(0.0);
        let mut worst_gain = f64::MIN;
        let mut worst_loss = 0.0f64;
        for k in 0..steps(&r, 4.0) {
            let t = k as f64 * r.dt_s();
            let hand = if t < 1.5 { 20.0 * (2.0 * PI * t).sin() } else { 0.0 };
            step_feel(&mut r, f, hand);
            let s = r.state();
            let e = s.kinetic_energy_j + s.potential_energy_j + f.stored_energy_j(s.piston_x_m);
            // Mechanical + stored energy never exceeds what the hand put in.
            worst_gain = worst_gain.max((e - e0) - s.hand_work_j);
            // The element is conservative: its work is minus the change of its stored energy.
            let w_spring = s.external_work_j;
            let du = f.stored_energy_j(s.piston_x_m) - f.stored_energy_j(0.0);
            // The element only stores and returns energy: its work never exceeds its energy drop.
            assert!(
                w_spring <= -du + 1e-9,
                "{name}: spring did {w_spring} J, its energy fell by {} J",
                -du
            );
            worst_loss = worst_loss.max(-(w_spring + du) / s.hand_work_j.abs().max(1e-3));
        }
        println!(
            "{name}: worst energy gain over hand work {worst_gain} J, spring's numerical loss {worst_loss}"
        );
        // The implicit tangent's dissipation stays a small part of the energy put in.
        assert!(
            worst_loss < 0.05,
            "{name}: the spring lost {worst_loss} of the hand's work"
        );
        assert!(worst_gain < 1e-3, "{name} injected {worst_gain} J");
    }
}

#[test]
fn q_feel_static_deflection_scales_inversely_with_dynamic_pressure() {
    let mut q = feel_springs().q_feel;
    let mut x_at = |qbar: f64| {
        q.set_dynamic_pressure(qbar);
        let mut r = rig(false, 0.05, 0.0, 150.0);
        for _ in 0..steps(&r, 2.0) {
            step_feel(&mut r, &q, 6.0);
        }
        (r.state().piston_x_m, q.stiffness_n_per_m())
    };
    let (x1, k1) = x_at(10_000.0);
    let (x2, k2) = x_at(20_000.0);
    assert!(k2 > k1, "stiffness did not rise with q");
    let ratio = x1 / x2;
    assert!(
        (ratio - k2 / k1).abs() < 0.03 * k2 / k1,
        "deflection ratio {ratio}, stiffness ratio {}",
        k2 / k1
    );
}

#[test]
fn same_inputs_give_bit_identical_runs_on_any_thread() {
    // Determinism (design rule) and `Send` (scenarios run in parallel): two rigs on two threads.
    let run = || {
        let mut r = rig(true, 3.0, 5.0, 300.0);
        for k in 0..steps(&r, 1.0) {
            let t = k as f64 * r.dt_s();
            r.step(25.0 * (2.0 * PI * 1.3 * t).sin(), 2.0 + (3.0 * t).sin());
        }
        r.state()
    };
    let a = std::thread::spawn(run);
    let b = std::thread::spawn(run);
    let (a, b) = (a.join().unwrap(), b.join().unwrap());
    assert!(a.stick_angle_rad.abs() > 1e-3, "the stick did not move");
    assert_eq!(a, b);
}

#[test]
fn fused_fixed_links_and_planar_loop_rows_leave_the_motion_and_the_load_cell_unchanged() {
    // The speed-ups (fixed links folded into their parents, only the planar pin's in-plane rows) must not
    // change the physics: the same 4 s workout (1 Hz push above and below yield, a current step, gravity
    // on) on the rig built both ways.
    let run = |fast: bool| {
        let mut cfg = RigConfig::new(urdf_path());
        cfg.fuse_fixed_links = fast;
        cfg.planar_loop_rows = fast;
        let mut r = Rig::new(&cfg, damper(3.0, 5.0, 300.0)).unwrap();
        let mut out = Vec::new();
        for k in 0..steps(&r, 4.0) {
            let t = k as f64 * r.dt_s();
            r.step(20.0 * (2.0 * PI * t).cos(), if t < 2.0 { 1.0 } else { 2.0 });
            out.push(r.state());
        }
        (out, r.poses())
    };
    let (fast, fast_poses) = run(true);
    let (full, full_poses) = run(false);
    let rms = |f: &dyn Fn(&mrfeel::rig::RigState) -> f64| {
        (full.iter().map(|s| f(s).powi(2)).sum::<f64>() / full.len() as f64).sqrt()
    };
    let worst = |f: &dyn Fn(&mrfeel::rig::RigState) -> f64| {
        fast.iter()
            .zip(&full)
            .map(|(a, b)| (f(a) - f(b)).abs())
            .fold(0.0, f64::max)
    };
    let angle = worst(&|s| s.stick_angle_rad);
    let lc_rms_diff = (fast
        .iter()
        .zip(&full)
        .map(|(a, b)| (a.load_cell_n - b.load_cell_n).powi(2))
        .sum::<f64>()
        / full.len() as f64)
        .sqrt();
    let lc_rms = rms(&|s| s.load_cell_n);
    let (a, b) = (fast.last().unwrap(), full.last().unwrap());
    println!(
        "max |Δθ| {angle:.2e} rad of {:.3} rad RMS; load cell RMS difference {lc_rms_diff:.3} N of {lc_rms:.2} N RMS; \
         dissipated {:.5} vs {:.5} J",
        rms(&|s| s.stick_angle_rad),
        a.damper_dissipated_j,
        b.damper_dissipated_j
    );
    assert!(
        rms(&|s| s.stick_angle_rad) > 0.05,
        "the workout hardly moved the stick"
    );
    assert!(
        angle < 1e-3 * rms(&|s| s.stick_angle_rad),
        "stick angle differs by {angle} rad"
    );
    assert!(
        lc_rms_diff < 0.01 * lc_rms,
        "load cell differs by {lc_rms_diff} N RMS"
    );
    assert!(
        (a.damper_dissipated_j - b.damper_dissipated_j).abs() < 1e-3 * b.damper_dissipated_j,
        "{} vs {} J",
        a.damper_dissipated_j,
        b.damper_dissipated_j
    );
    assert!((a.kinetic_energy_j - b.kinetic_energy_j).abs() < 1e-3 * b.kinetic_energy_j.max(1e-3));
    // Every URDF link is still posed, where the unfused multibody puts it.
    assert_eq!(fast_poses.len(), full_poses.len());
    for (p, q) in fast_poses.iter().zip(&full_poses) {
        assert_eq!(p.name, q.name);
        let d = (0..3)
            .map(|k| (p.translation_m[k] - q.translation_m[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(d < 1e-4, "{}: {d} m apart", p.name);
    }
}
