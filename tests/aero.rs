//! Aircraft models against their JSBSim 1.3.3 reference flights (scenarios/jsbsim/), flight-mechanics
//! estimates and the certification force limits. Figures quoted in docs/explanation/aero.md come from the
//! `eprintln!` lines here: `cargo test --test integration aero:: -- --nocapture`.

use std::path::Path;
use std::sync::Arc;

use mrfeel::aero::{
    AeroError, Aircraft, AircraftModel, AircraftState, FbwAircraft, FbwModel, FeelAssessment,
};
use mrfeel::input::reference::ReferenceRun;
use mrfeel::input::InputError;
use mrfeel::units::{G0_M_S2, LBF_TO_N};

fn aircraft(name: &str) -> Aircraft {
    let m = AircraftModel::load(&AircraftModel::builtin_path(name)).expect("shipped model loads");
    Aircraft::new(Arc::new(m))
}

fn run(name: &str, which: &str) -> ReferenceRun {
    ReferenceRun::load(
        &Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenarios/jsbsim")
            .join(format!("{name}_{which}.csv")),
    )
    .expect("shipped reference loads")
}

/// A replay's errors against its JSBSim reference; the tail's only for a fly-by-wire aircraft, whose FCS
/// moves it (0 otherwise).
#[derive(Default)]
struct Replay {
    q_max_err: f64,
    q_peak: f64,
    nz_max_err: f64,
    nz_peak: f64,
    q_rms_err: f64,
    nz_rms_err: f64,
    tail_max_err: f64,
    tail_peak: f64,
}

impl Replay {
    /// One row: the pitch rate and JSBSim's, the load factor's increment from trim and JSBSim's. The RMS
    /// fields hold sums of squares until [`Replay::finish`].
    fn row(&mut self, q: f64, q_ref: f64, dnz: f64, dnz_ref: f64) {
        let (dq, dn) = (q - q_ref, dnz - dnz_ref);
        self.q_max_err = self.q_max_err.max(dq.abs());
        self.nz_max_err = self.nz_max_err.max(dn.abs());
        self.q_peak = self.q_peak.max(q_ref.abs());
        self.nz_peak = self.nz_peak.max(dnz_ref.abs());
        self.q_rms_err += dq * dq;
        self.nz_rms_err += dn * dn;
    }

    /// The RMS errors over `n` rows.
    fn finish(mut self, n: usize) -> Self {
        self.q_rms_err = (self.q_rms_err / n as f64).sqrt();
        self.nz_rms_err = (self.nz_rms_err / n as f64).sqrt();
        self
    }

    fn summary(&self) -> String {
        let mut s = format!(
            "pitch rate max error {:.4} rad/s ({:.1} % of peak {:.4}), rms {:.4}; load factor max error {:.4} g \
             ({:.1} % of peak excursion {:.4} g), rms {:.4} g",
            self.q_max_err,
            100.0 * self.q_max_err / self.q_peak,
            self.q_peak,
            self.q_rms_err,
            self.nz_max_err,
            100.0 * self.nz_max_err / self.nz_peak,
            self.nz_peak,
            self.nz_rms_err
        );
        if self.tail_peak > 0.0 {
            s += &format!(
                "; tail max error {:.4} rad ({:.1} % of {:.4})",
                self.tail_max_err,
                100.0 * self.tail_max_err / self.tail_peak,
                self.tail_peak
            );
        }
        s
    }
}

/// Trim at the reference's first row, then replay its elevator (as increments on the trim
/// elevator) with the throttle held, at the reference's own 120 Hz steps.
fn replay_doublet(name: &str) -> Replay {
    let r = run(name, "doublet");
    let t = r.column("t_s").unwrap();
    let de = r.column("elevator_rad").unwrap();
    let q_ref = r.column("q_rad_s").unwrap();
    let nz_ref = r.column("nz_g").unwrap();
    let v = r.column("airspeed_m_s").unwrap();
    let h = r.column("altitude_m").unwrap();
    let mut a = aircraft(name);
    let trim = a.trim(v[0], h[0]).unwrap();
    let throttle = trim.throttle;
    let mut e = Replay::default();
    for k in 0..t.len() {
        let s = a.state();
        // compare increments from trim: both start at their own 1-g trim
        e.row(s.q_rad_s, q_ref[k], s.nz_g - trim.nz_g, nz_ref[k] - nz_ref[0]);
        if k + 1 < t.len() {
            // JSBSim integrates first in its frame (Propagate, then FCS and Aerodynamics), so the
            // elevator recorded in row k acts on the state from t_k to t_k+1
            let de_cmd = trim.elevator_rad + (de[k] - de[0]);
            a.step(de_cmd, throttle, t[k + 1] - t[k]);
        }
    }
    e.finish(t.len())
}

fn check_replay(name: &str, q_frac: f64, nz_frac: f64) {
    let r = replay_doublet(name);
    eprintln!("{name} doublet replay vs JSBSim: {}", r.summary());
    assert!(
        r.q_max_err <= q_frac * r.q_peak,
        "{name}: pitch-rate error {} > {} x peak {}",
        r.q_max_err,
        q_frac,
        r.q_peak
    );
    assert!(
        r.nz_max_err <= nz_frac * r.nz_peak,
        "{name}: nz error {} > {} x peak {}",
        r.nz_max_err,
        nz_frac,
        r.nz_peak
    );
}

#[test]
fn c172p_doublet_pitch_rate_and_load_factor_follow_jsbsim() {
    check_replay("c172p", 0.08, 0.08);
}

#[test]
fn b737_doublet_pitch_rate_and_load_factor_follow_jsbsim() {
    check_replay("737", 0.05, 0.05);
}

#[test]
fn t37_doublet_pitch_rate_and_load_factor_follow_jsbsim() {
    check_replay("T37", 0.08, 0.08);
}

/// Trim alpha and elevator over the JSBSim speed sweep.
fn check_trims(name: &str, alpha_tol: f64, de_tol: f64) {
    let mut a = aircraft(name);
    let (n, ea, ed) = trim_errors(name, |v, h| a.trim(v, h).map_err(|e| e.to_string())).unwrap();
    eprintln!(
        "{name} trims over {n} speeds: max |alpha error| {ea:.4} rad, max |elevator error| {ed:.4} rad"
    );
    assert!(ea < alpha_tol, "{name}: alpha error {ea}");
    assert!(ed < de_tol, "{name}: elevator error {ed}");
}

#[test]
fn c172p_trim_alpha_and_elevator_match_jsbsim_over_the_speed_range() {
    check_trims("c172p", 0.005, 0.01);
}

#[test]
fn b737_trim_alpha_and_elevator_match_jsbsim_over_the_speed_range() {
    check_trims("737", 0.005, 0.01);
}

fn f16_text() -> String {
    std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("models/aircraft/f16.toml")).unwrap()
}

/// The embedded F-16 of a model text; a text the schema refuses is an error.
fn f16_from(text: &str) -> Result<FbwAircraft, String> {
    let model = FbwModel::from_toml(text, Path::new("f16.toml")).map_err(|e| e.to_string())?;
    Ok(FbwAircraft::new(
        model.expect("the F-16's file has an embedded model"),
    ))
}

/// The embedded F-16 under its FCS replays JSBSim's stick-command doublet (`f16_<which>.csv`): trim at
/// the first row, then the recorded `elevator-cmd-norm`. JSBSim's frame integrates, then runs its FCS on
/// the new state, then the forces: a row's command moves the tail of the next row, which acts over the
/// interval after it; the replay's frame runs the FCS on the state at its start, so it takes the command
/// of the row before and its tail is that row's.
fn replay_f16(mut a: FbwAircraft, which: &str) -> Result<Replay, AeroError> {
    let r = run("f16", which);
    let col = |c: &str| r.column(c).unwrap();
    let (t, cmd, q_ref, nz_ref, de_ref) = (
        col("t_s"),
        col("elevator_cmd_norm"),
        col("q_rad_s"),
        col("nz_g"),
        col("elevator_rad"),
    );
    let trim = a.trim(col("airspeed_m_s")[0], col("altitude_m")[0])?;
    let mut e = Replay::default();
    for k in 0..t.len() {
        let s = *a.state();
        e.row(s.q_rad_s, q_ref[k], s.nz_g - trim.nz_g, nz_ref[k] - nz_ref[0]);
        if k + 1 < t.len() {
            let c = if k == 0 { 0.0 } else { cmd[k - 1] };
            let tail = a.step(c, trim.throttle, t[k + 1] - t[k]).elevator_rad;
            let dd = (tail - trim.elevator_rad) - (de_ref[k] - de_ref[0]);
            e.tail_max_err = e.tail_max_err.max(dd.abs());
            e.tail_peak = e.tail_peak.max((de_ref[k] - de_ref[0]).abs());
        }
    }
    Ok(e.finish(t.len()))
}

/// Trim at every row of `<name>_trim.csv` with `trim`: the rows, and the largest |α error| and
/// |elevator error| against JSBSim's trims.
fn trim_errors(
    name: &str,
    mut trim: impl FnMut(f64, f64) -> Result<AircraftState, String>,
) -> Result<(usize, f64, f64), String> {
    let r = run(name, "trim");
    let col = |c: &str| r.column(c).unwrap();
    let (v, h, alpha, de) = (
        col("airspeed_m_s"),
        col("altitude_m"),
        col("alpha_rad"),
        col("elevator_rad"),
    );
    let (mut ea, mut ed) = (0.0_f64, 0.0_f64);
    for k in 0..v.len() {
        let s = trim(v[k], h[k])?;
        ea = ea.max((s.alpha_rad - alpha[k]).abs());
        ed = ed.max((s.elevator_rad - de[k]).abs());
    }
    Ok((v.len(), ea, ed))
}

/// The F-16's checks against JSBSim: both doublets (pitch rate within 2 % of its peak, load factor within
/// 6 % of its peak excursion, tail within 1 %) and the level trims (α and tail within 0.002 rad).
fn f16_checks(text: &str, print: bool) -> Result<(), String> {
    for which in ["doublet", "doublet_slow"] {
        let e = replay_f16(f16_from(text)?, which).map_err(|e| e.to_string())?;
        if print {
            eprintln!("f16 {which} replay vs JSBSim: {}", e.summary());
        }
        if !(e.q_max_err <= 0.02 * e.q_peak
            && e.nz_max_err <= 0.06 * e.nz_peak
            && e.tail_max_err <= 0.01 * e.tail_peak)
        {
            return Err(format!("{which}: {}", e.summary()));
        }
    }
    let mut a = f16_from(text)?;
    let (n, ea, ed) = trim_errors("f16", |v, h| a.trim(v, h).map_err(|e| e.to_string()))?;
    if print {
        eprintln!("f16 trims over {n} speeds: max |alpha error| {ea:.5} rad, max |tail error| {ed:.5} rad");
    }
    if !(ea < 0.002 && ed < 0.002) {
        return Err(format!("trims: alpha error {ea}, tail error {ed}"));
    }
    Ok(())
}

/// `text` with every number of `key`'s value (one line, or a multi-line table up to its closing `]`)
/// multiplied by `factor`.
fn scale_key(text: &str, key: &str, factor: f64) -> String {
    let mut out = String::new();
    let mut inside = false;
    for line in text.lines() {
        let (code, comment) = line.split_once('#').map_or((line, ""), |(c, k)| (c, k));
        let starts = code.trim_start().starts_with(&format!("{key} ="));
        if starts || inside {
            let value = if starts {
                code.split_once('=').unwrap().1
            } else {
                code
            };
            let scaled: String = value
                .split_inclusive(|c: char| "[], ".contains(c))
                .map(|tok| {
                    let (num, sep) = tok.split_at(tok.trim_end_matches(|c: char| "[], ".contains(c)).len());
                    match num.parse::<f64>() {
                        Ok(x) => format!("{:?}{sep}", x * factor),
                        Err(_) => tok.to_string(),
                    }
                })
                .collect();
            out += &if starts {
                format!("{key} ={scaled}")
            } else {
                scaled
            };
            inside = if starts {
                code.trim_end().ends_with('[')
            } else {
                code.trim() != "]"
            };
        } else {
            out += code;
        }
        if !comment.is_empty() {
            out += "#";
            out += comment;
        }
        out.push('\n');
    }
    out
}

/// The embedded F-16 (JSBSim's tables and pitch FCS in Rust, src/aero/fcs.rs) against JSBSim flown with
/// its FCS: two stick-command doublets, at the design condition (200 m/s, 3000 m, flap up) and slow
/// (110 m/s, 1000 m, where the push takes alpha below the leading-edge flap's step and the flap retracts),
/// and level trims from 140 to 260 m/s ([`f16_checks`]). The load factor's error sits where the tail jumps
/// (JSBSim reports the load factor of its frame's accelerations a frame late).
#[test]
fn f16_embedded_model_follows_jsbsim_doublets_through_the_fcs_and_its_trims() {
    f16_checks(&f16_text(), true).unwrap();
}

/// The design figure the F-16's feel law is sized on, `design.g_per_command` ([RUN] in the file: JSBSim's
/// load factor 2 s after the stick command steps to -0.3 from trim at 200 m/s, 3000 m, 2.749 g from
/// 0.996 g), flown on the embedded model: within 2 % of JSBSim's load factor gained (the step takes
/// alpha past the leading-edge flap's step, so the flap deploys on the way).
#[test]
fn f16_embedded_step_gives_the_files_g_per_command() {
    let mut a = f16_from(&f16_text()).unwrap();
    let trim = a.trim(200.0, 3000.0).unwrap();
    let dt = 1.0 / 120.0;
    let mut s = trim;
    for _ in 0..240 {
        s = *a.step(-0.3, trim.throttle, dt);
    }
    let fbw = mrfeel::aero::FlyByWire::load(&AircraftModel::builtin_path("f16")).unwrap();
    let flown = (s.nz_g - trim.nz_g) / 0.3;
    eprintln!(
        "f16 step to -0.3: {:.3} g from {:.3} g 2 s later, alpha {:.2} deg: {flown:.2} g per command (file {:.2})",
        s.nz_g,
        trim.nz_g,
        s.alpha_rad.to_degrees(),
        fbw.g_per_command
    );
    assert!(
        (flown / fbw.g_per_command - 1.0).abs() < 0.02,
        "{flown} g per command"
    );
}

/// The F-16's FCS bounds what a pilot can command, wherever it flies: over 48 seeded draws of airspeed
/// (100–300 m/s), altitude (0–9000 m) and a stick command held 3 s from trim (any value in [-1, 1]), the
/// aircraft either trims or is refused with a trim error, and then every state stays finite, the angle of
/// attack stays below the α limiter's 30° (its schedule takes the command to nothing there and the limiter
/// pushes), and a push (the command limiter's 44 %) never takes the load factor below −4 g.
#[test]
fn f16_fcs_bounds_alpha_and_push_over_random_conditions_and_commands() {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(35);
    let base = f16_from(&f16_text()).unwrap();
    let (mut flown, mut alpha_max, mut nz_min, mut nz_max) = (0, 0.0_f64, f64::INFINITY, f64::NEG_INFINITY);
    for _ in 0..48 {
        let (v, h, c) = (
            rng.random_range(100.0..300.0),
            rng.random_range(0.0..9000.0),
            rng.random_range(-1.0..1.0),
        );
        let mut a = base.clone();
        let trim = match a.trim(v, h) {
            Ok(t) => t,
            Err(AeroError::Trim { .. }) => continue,
            Err(e) => panic!("{v} m/s, {h} m: {e}"),
        };
        flown += 1;
        for _ in 0..360 {
            let s = *a.step(c, trim.throttle, 1.0 / 120.0);
            assert!(
                [s.u_m_s, s.w_m_s, s.q_rad_s, s.theta_rad, s.nz_g, s.elevator_rad]
                    .iter()
                    .all(|x| x.is_finite()),
                "{v} m/s, {h} m, command {c}: {s:?}"
            );
            alpha_max = alpha_max.max(s.alpha_rad);
            nz_min = nz_min.min(s.nz_g);
            nz_max = nz_max.max(s.nz_g);
            assert!(
                s.alpha_rad < 30f64.to_radians(),
                "{v} m/s, {h} m, command {c}: alpha {}",
                s.alpha_rad
            );
            assert!(s.nz_g > -4.0, "{v} m/s, {h} m, command {c}: {} g", s.nz_g);
        }
    }
    eprintln!(
        "f16 FCS over 48 draws: {flown} trimmed; alpha up to {:.1} deg, load factor {nz_min:.2} to {nz_max:.2} g",
        alpha_max.to_degrees()
    );
    assert!(flown >= 40, "only {flown} of 48 draws trimmed");
}

/// The checks fail when a coefficient table, the inertia or an FCS gain of the F-16's file is doubled,
/// halved or of the wrong sign (a negative inertia or gain is refused by the schema).
#[test]
fn f16_checks_fail_when_a_coefficient_or_gain_is_doubled_halved_or_of_the_wrong_sign() {
    let text = f16_text();
    for key in [
        "cm",
        "cl",
        "cm_q",
        "iyy_kg_m2",
        "pitch_rate_gain_s",
        "proportional_gain",
    ] {
        for factor in [2.0, 0.5, -1.0] {
            let bad = scale_key(&text, key, factor);
            assert_ne!(bad, text, "{key} not found");
            // a negative inertia or gain is refused by the schema, which counts as failing
            assert!(
                f16_checks(&bad, false).is_err(),
                "{key} x {factor} passes the checks"
            );
        }
    }
}

/// Short-period and phugoid roots of the linearised model against the classical approximations
/// (Etkin & Reid §6.4): short period `w^2 = -M_a + Z_a M_q / V`, `2 zeta w = -(M_q + M_adot + Z_a/V)`;
/// phugoid period Lanchester `pi sqrt(2) V / g`.
fn check_modes(name: &str, v: f64, h: f64) {
    let mut a = aircraft(name);
    let s = a.trim(v, h).unwrap();
    let m = a.model().clone();
    let modes = a.linear_modes();
    let mut osc: Vec<(f64, f64)> = modes.iter().copied().filter(|z| z.1 > 0.0).collect();
    osc.sort_by(|x, y| y.1.partial_cmp(&x.1).unwrap());
    assert_eq!(
        osc.len(),
        2,
        "{name}: expected two oscillatory modes, got {modes:?}"
    );
    let (sp, ph) = (osc[0], osc[1]);
    let wn = |z: (f64, f64)| (z.0 * z.0 + z.1 * z.1).sqrt();
    let (w_sp, zeta_sp) = (wn(sp), -sp.0 / wn(sp));
    let t_ph = 2.0 * std::f64::consts::PI / ph.1;

    let qsc = s.qbar_pa * m.wing_area_m2 * m.chord_m / m.iyy_kg_m2;
    let ci2v = m.chord_m / (2.0 * v);
    let cl_a = m.cl_alpha.slope(s.alpha_rad);
    let z_a = -s.qbar_pa * m.wing_area_m2 * cl_a / m.mass_kg;
    // lift acts at the aerodynamic reference point, (x_ref - x_cg) aft of the CG
    let cm_a = m.cm_alpha_per_rad - cl_a * (m.aero_ref_x_m - m.cg_x_m) / m.chord_m;
    let m_a = qsc * cm_a;
    let m_q = qsc * m.cm_q_per_rad * ci2v;
    let m_ad = qsc * m.cm_alphadot_per_rad * ci2v;
    let w_est = (-m_a + z_a * m_q / v).sqrt();
    let zeta_est = -(m_q + m_ad + z_a / v) / (2.0 * w_est);
    let t_lanchester = std::f64::consts::PI * 2f64.sqrt() * v / G0_M_S2;
    eprintln!(
        "{name} at {v} m/s: short period {w_sp:.3} rad/s, zeta {zeta_sp:.3} (approximation {w_est:.3} rad/s, \
         zeta {zeta_est:.3}); phugoid period {t_ph:.1} s (Lanchester {t_lanchester:.1} s), damping {:.3}",
        -ph.0 / wn(ph)
    );
    assert!(
        (w_sp / w_est - 1.0).abs() < 0.10,
        "{name}: short-period frequency {w_sp} vs {w_est}"
    );
    assert!(
        (zeta_sp - zeta_est).abs() < 0.1,
        "{name}: short-period damping {zeta_sp} vs {zeta_est}"
    );
    assert!(
        (t_ph / t_lanchester - 1.0).abs() < 0.25,
        "{name}: phugoid period {t_ph} vs Lanchester {t_lanchester}"
    );
}

#[test]
fn c172p_short_period_and_phugoid_match_classical_estimates() {
    check_modes("c172p", 50.0, 1000.0);
}

#[test]
fn b737_short_period_and_phugoid_match_classical_estimates() {
    check_modes("737", 170.0, 3000.0);
}

#[test]
fn trimmed_flight_stays_trimmed() {
    for (name, v, h) in [("c172p", 50.0, 1000.0), ("737", 170.0, 3000.0)] {
        let mut a = aircraft(name);
        let s0 = a.trim(v, h).unwrap();
        for _ in 0..(10 * 120) {
            a.step(s0.elevator_rad, s0.throttle, 1.0 / 120.0);
        }
        let s = a.state();
        assert!(
            (s.airspeed_m_s - v).abs() < 0.05,
            "{name}: speed drifted to {}",
            s.airspeed_m_s
        );
        assert!(
            s.q_rad_s.abs() < 1e-4 && (s.nz_g - s0.nz_g).abs() < 1e-4,
            "{name}: {s:?}"
        );
        assert!(
            s.stick_force_n.abs() < 0.01,
            "{name}: trimmed stick force {}",
            s.stick_force_n
        );
    }
}

#[test]
fn trailing_edge_down_elevator_pushes_the_stick_forward_and_pitches_nose_down() {
    for (name, v, h) in [("c172p", 50.0, 1000.0), ("737", 170.0, 3000.0)] {
        let mut a = aircraft(name);
        let s0 = a.trim(v, h).unwrap();
        let s = *a.step(s0.elevator_rad + 0.03, s0.throttle, 1.0 / 120.0);
        // the air pushes a trailing-edge-down elevator back up: the pilot must push (F < 0)
        assert!(s.hinge_moment_nm < 0.0 && s.stick_force_n < 0.0, "{name}: {s:?}");
        for _ in 0..60 {
            a.step(s0.elevator_rad + 0.03, s0.throttle, 1.0 / 120.0);
        }
        assert!(
            a.state().q_rad_s < 0.0 && a.state().nz_g < s0.nz_g,
            "{name}: {:?}",
            a.state()
        );
    }
}

#[test]
fn stick_force_per_g_is_a_pull_across_the_speed_range() {
    for (name, speeds, h) in [
        ("c172p", [35.0, 45.0, 55.0], 1000.0),
        ("737", [130.0, 150.0, 210.0], 3000.0),
        ("T37", [100.0, 120.0, 140.0], 3000.0),
    ] {
        let a = aircraft(name);
        for v in speeds {
            let f = FeelAssessment::assess(&a, v, h).unwrap();
            eprintln!("{name}: {}", f.report());
            assert!(
                f.stick_force_per_g_n > 0.0 && f.speed_gradient_n_per_m_s > 0.0,
                "{name}: {}",
                f.report()
            );
        }
    }
}

#[test]
fn feel_sits_inside_the_far_control_force_limits() {
    for (name, v, h) in [("c172p", 50.0, 1000.0), ("737", 170.0, 3000.0)] {
        let a = aircraft(name);
        let f = FeelAssessment::assess(&a, v, h).unwrap();
        eprintln!("{name}: {}", f.report());
        assert!(
            f.stick_force_per_g_n > 0.0,
            "{name}: stick force per g must be a pull"
        );
        assert!(f.complies(), "{name}: {}", f.report());
        // pull below the trim speed, push above (14 CFR 23.173(a) / 25.173(a))
        assert!(a.off_trim_stick_force_n(v, 0.9 * v, h).unwrap() > 0.0);
        assert!(a.off_trim_stick_force_n(v, 1.1 * v, h).unwrap() < 0.0);
    }
}

/// Elevator angle per g of the Rust model against JSBSim's own trims (level flight and the bottom of a
/// steady pull-up, throttle trimmed in both, `scenarios/jsbsim/<ac>_per_g.csv`) at every flight
/// condition of the table (5 equivalent airspeeds x 4 altitudes). Each side's per-g figure uses its own
/// load factors, so JSBSim's round-earth 0.998 g in level flight does not count as an error.
fn check_elevator_per_g(name: &str, tol: f64) {
    let r = run(name, "per_g");
    let col = |c: &str| r.column(c).unwrap();
    let (v, h) = (col("airspeed_m_s"), col("altitude_m"));
    let (nz1, de1, nzn, den) = (
        col("nz1_g"),
        col("elevator1_rad"),
        col("nz_g"),
        col("elevator_rad"),
    );
    let a = aircraft(name);
    let (mut worst, mut sum_rel) = (0.0_f64, 0.0);
    for k in 0..v.len() {
        let jsb = (den[k] - de1[k]) / (nzn[k] - nz1[k]);
        let s1 = a.steady_state(v[k], h[k], 1.0).unwrap();
        let sn = a.steady_state(v[k], h[k], nzn[k]).unwrap();
        let ours = (sn.elevator_rad - s1.elevator_rad) / (sn.nz_g - s1.nz_g);
        let rel = (ours / jsb - 1.0).abs();
        worst = worst.max(rel);
        sum_rel += rel;
        assert!(
            jsb < 0.0,
            "{name}: JSBSim's elevator per g must be trailing edge up: {jsb}"
        );
        assert!(
            rel <= tol,
            "{name} at {:.1} m/s, {} m: elevator per g {ours:.5} rad/g vs JSBSim {jsb:.5} rad/g",
            v[k],
            h[k]
        );
    }
    eprintln!(
        "{name} elevator per g vs JSBSim's trims at {} conditions: worst {:.2} %, mean {:.2} %",
        v.len(),
        100.0 * worst,
        100.0 * sum_rel / v.len() as f64
    );
    assert!(v.len() >= 20, "{name}: only {} flight conditions", v.len());
}

#[test]
fn c172p_elevator_per_g_matches_jsbsim_trims_at_20_conditions() {
    check_elevator_per_g("c172p", 0.05);
}

#[test]
fn b737_elevator_per_g_matches_jsbsim_trims_at_20_conditions() {
    check_elevator_per_g("737", 0.05);
}

#[test]
fn t37_elevator_per_g_matches_jsbsim_trims_at_20_conditions() {
    check_elevator_per_g("T37", 0.05);
}

#[test]
fn t37_trim_alpha_and_elevator_match_jsbsim_over_the_speed_range() {
    check_trims("T37", 0.005, 0.01);
}

/// The c172p's stick force per g at cruise (50 m/s, 1000 m, tab trimmed), lbf/g; `None` when the
/// aircraft cannot be trimmed (the tab cannot zero the force).
fn c172p_per_g_lbf(m: AircraftModel) -> Option<f64> {
    let a = Aircraft::new(Arc::new(m));
    let f = FeelAssessment::assess(&a, 50.0, 1000.0).ok()?;
    Some(f.stick_force_per_g_n / LBF_TO_N)
}

/// The c172p's stick force per g from the derived hinge moments against figures it was not built from:
/// its Part 23 type certificate bounds it (14 CFR 23.155(a): at least W/100 = 24 lbf, 23.143(c): at
/// most 75 lbf, from 1 g to the 3.8 g limit, so 8.6 to 26.8 lbf/g), and the C172's "more than 20 lb/G"
/// (E. Kolano, AOPA, *Flight Control Forces*, aopa.org/training-and-safety/students/presolo/topics/
/// flight-control-forces; no speed, weight or CG given) is printed beside it, not asserted: the model
/// reads 12 % below it (docs/explanation/aero.md). The band catches `Ch_δ` of the wrong sign or wrong by a factor of
/// two, and `Ch_α` of the wrong sign; a factor of two in `Ch_α` stays inside it (the section test
/// against the discrete-vortex solution catches that, `aero::hinge_theory`).
#[test]
fn c172p_stick_force_per_g_from_derived_hinge_moments_sits_in_its_certification_band() {
    let m = AircraftModel::load(&AircraftModel::builtin_path("c172p")).unwrap();
    eprintln!(
        "c172p hinge derivatives from geometry: Ch_alpha {:.3}, Ch_delta {:.3}, Ch_tab {:.3} per rad",
        m.hinge.ch_alpha_per_rad, m.hinge.ch_elevator_per_rad, m.hinge.ch_tab_per_rad
    );
    let (lo, hi) = (24.0 / 2.8, 75.0 / 2.8);
    let per_g = c172p_per_g_lbf(m.clone()).unwrap();
    eprintln!(
        "c172p stick force per g at 50 m/s, 1000 m: {per_g:.1} lbf/g (Part 23 band [{lo:.1}, {hi:.1}] lbf/g; \
         AOPA: more than 20 lbf/g)"
    );
    assert!((lo..=hi).contains(&per_g), "{per_g} lbf/g outside [{lo}, {hi}]");
    type Mutation = (&'static str, fn(&mut AircraftModel));
    let mutations: [Mutation; 6] = [
        ("Ch_delta x 2", |m| m.hinge.ch_elevator_per_rad *= 2.0),
        ("Ch_delta / 2", |m| m.hinge.ch_elevator_per_rad *= 0.5),
        ("Ch_delta sign", |m| m.hinge.ch_elevator_per_rad *= -1.0),
        ("Ch_alpha sign", |m| m.hinge.ch_alpha_per_rad *= -1.0),
        ("Ch_alpha x 2 (not caught here)", |m| {
            m.hinge.ch_alpha_per_rad *= 2.0
        }),
        ("Ch_alpha / 2 (not caught here)", |m| {
            m.hinge.ch_alpha_per_rad *= 0.5
        }),
    ];
    for (what, mutate) in mutations {
        let mut bad = m.clone();
        mutate(&mut bad);
        let f = c172p_per_g_lbf(bad);
        eprintln!("  {what}: {f:?} lbf/g");
        if !what.contains("not caught") {
            assert!(
                f.is_none_or(|f| !(lo..=hi).contains(&f)),
                "{what}: {f:?} lbf/g still inside the band"
            );
        }
    }
}

/// What the c172p's checks against figures it was not built from say of a model: `Ok` with the figures
/// when every check passes, `Err` naming the first that fails. The checks: the stick force per g at
/// 35, 45, 50 and 55 m/s, 1000 m inside its Part 23 band (14 CFR 23.155(a) and 23.143(c) over the 3.8 g
/// limit: 8.6 to 26.8 lbf/g), and at 35, 45 and 55 m/s the stable stick-force-versus-speed slope 14 CFR 23.173(a) and
/// 23.175(b) ask (a pull to fly below the trim speed, a push above), each with the tab trimmed, as a
/// pilot trims (the model must trim: the tab zeroes the force within its travel); and the C172's "more
/// than 20 lb/G" (E. Kolano, AOPA, *Flight Control Forces*, no speed, weight or CG given), read as
/// reached somewhere from 35 to 55 m/s.
fn c172p_point_2_checks(m: &AircraftModel) -> Result<String, String> {
    let a = Aircraft::new(Arc::new(m.clone()));
    let (lo, hi) = (24.0 / 2.8, 75.0 / 2.8);
    let f = FeelAssessment::assess(&a, 50.0, 1000.0).map_err(|e| format!("no trim at 50 m/s: {e}"))?;
    let per_g = f.stick_force_per_g_n / LBF_TO_N;
    if !(lo..=hi).contains(&per_g) {
        return Err(format!(
            "{per_g:.1} lbf/g outside the Part 23 band [{lo:.1}, {hi:.1}]"
        ));
    }
    let mut out = format!("{per_g:.1} lbf/g at 50 m/s;");
    let mut most_per_g = per_g;
    for v in [35.0, 45.0, 55.0] {
        let f = FeelAssessment::assess(&a, v, 1000.0).map_err(|e| format!("no trim at {v} m/s: {e}"))?;
        let per_g = f.stick_force_per_g_n / LBF_TO_N;
        most_per_g = most_per_g.max(per_g);
        if !(lo..=hi).contains(&per_g) {
            return Err(format!(
                "{per_g:.1} lbf/g at {v} m/s outside the Part 23 band [{lo:.1}, {hi:.1}]"
            ));
        }
        // lbf per knot
        let g = f.speed_gradient_n_per_m_s / LBF_TO_N * (1852.0 / 3600.0);
        if g <= 0.0 {
            return Err(format!(
                "unstable stick force versus speed at {v} m/s: {g:.3} lbf/kt"
            ));
        }
        out += &format!(" {per_g:.1} lbf/g and {g:.3} lbf/kt at {v} m/s;");
    }
    if most_per_g <= 20.0 {
        return Err(format!(
            "at most {most_per_g:.1} lbf/g over 35 to 55 m/s, never AOPA's more than 20 lbf/g"
        ));
    }
    Ok(out)
}

/// The c172p's checks of point 2 (issue 35) can fail: each hinge derivative the model derives from the
/// elevator's geometry, doubled or halved, makes at least one of them fail, while the model as derived
/// passes them all. Doubling `Ch_α` (a stronger floating tendency: the elevator floats up with the angle
/// of attack, taking the force out of a pull) leaves the stick force per g inside the wide Part 23 band
/// and the speed slope stable, but halves the force per g, far below AOPA's figure at every speed.
#[test]
fn c172p_checks_fail_when_a_hinge_derivative_is_doubled_or_halved() {
    let m = AircraftModel::load(&AircraftModel::builtin_path("c172p")).unwrap();
    let healthy = c172p_point_2_checks(&m);
    eprintln!("c172p as derived: {healthy:?}");
    assert!(healthy.is_ok(), "{healthy:?}");
    type Mutation = (&'static str, fn(&mut AircraftModel));
    let mutations: [Mutation; 4] = [
        ("Ch_alpha x 2", |m| m.hinge.ch_alpha_per_rad *= 2.0),
        ("Ch_alpha / 2", |m| m.hinge.ch_alpha_per_rad *= 0.5),
        ("Ch_delta x 2", |m| m.hinge.ch_elevator_per_rad *= 2.0),
        ("Ch_delta / 2", |m| m.hinge.ch_elevator_per_rad *= 0.5),
    ];
    for (what, mutate) in mutations {
        let mut bad = m.clone();
        mutate(&mut bad);
        let r = c172p_point_2_checks(&bad);
        eprintln!("  {what}: {r:?}");
        assert!(r.is_err(), "{what}: every check still passes: {r:?}");
    }
}

#[test]
fn bad_model_file_names_file_line_and_field() {
    let path = AircraftModel::builtin_path("c172p");
    let text = mrfeel::input::text::read_text(&path).unwrap();
    let bad = text.replace("mass_kg = 852.753644", "mass_kg = -5.0");
    let line = bad.lines().position(|l| l.starts_with("mass_kg = -5.0")).unwrap() + 1;
    match AircraftModel::from_toml(&bad, Path::new("c172p.toml")) {
        Err(e) if e.field.is_some() => {
            let msg = e.to_string();
            assert!(msg.starts_with(&format!("c172p.toml:{line}:")), "{msg}");
            assert!(
                msg.contains("mass.mass_kg") && msg.contains("allowed range"),
                "{msg}"
            );
        }
        other => panic!("expected a field error, got {other:?}"),
    }
    let unknown = text.replace("cd0 = 0.027", "cd0 = 0.027\ncd_typo = 1.0");
    let line = unknown.lines().position(|l| l.starts_with("cd_typo")).unwrap() + 1;
    match AircraftModel::from_toml(&unknown, Path::new("c172p.toml")) {
        Err(e) => {
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!("c172p.toml:{line}:")) && msg.contains("cd_typo"),
                "{msg}"
            );
        }
        other => panic!("expected a parse error, got {other:?}"),
    }
    // a stick with no hinge feedback and no feel computer would have no feel at all
    let no_feel = text.replace("force_feedback_ratio = 1.0", "force_feedback_ratio = 0.0");
    let line = no_feel
        .lines()
        .position(|l| l.starts_with("force_feedback_ratio"))
        .unwrap()
        + 1;
    match AircraftModel::from_toml(&no_feel, Path::new("c172p.toml")) {
        Err(e) if e.field.is_some() => {
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!("c172p.toml:{line}:")) && msg.contains("[feel_computer]"),
                "{msg}"
            );
        }
        other => panic!("expected a field error, got {other:?}"),
    }
    let table = text.replace("[0.09, 0.73], [0.10, 0.83]", "[0.10, 0.73], [0.09, 0.83]");
    assert!(matches!(
        AircraftModel::from_toml(&table, Path::new("x.toml")),
        Err(InputError { field: Some(_), .. })
    ));
}

#[test]
fn impossible_trims_are_errors_not_panics() {
    let mut a = aircraft("c172p");
    // 15 m/s needs CL ~ 3.4, far beyond the c172p's 1.47
    assert!(matches!(a.trim(15.0, 1000.0), Err(AeroError::Trim { .. })));
    assert!(matches!(a.trim(f64::NAN, 1000.0), Err(AeroError::Trim { .. })));
    // 737 at 60 m/s: below the stall speed
    let mut b = aircraft("737");
    assert!(matches!(b.trim(60.0, 3000.0), Err(AeroError::Trim { .. })));
}

/// 14 CFR 25.143(d) and 25.173(c) for the 737's feel computer over its clean speed range at 3000 m:
/// the stick force per g inside the band (pull to the 2.5 g limit within the 75 lbf short-term
/// two-hand force) and the stable speed gradient at least 1 lbf per 6 kt, at every 10 m/s from 130 to
/// 210 m/s. The limits are converted here from the regulation's pounds and knots.
#[test]
fn b737_feel_computer_meets_25_143_and_25_173c_from_130_to_210_m_s() {
    let a = aircraft("737");
    let knot_m_s = 1852.0 / 3600.0;
    let min_gradient_n_per_m_s = 1.0 * LBF_TO_N / (6.0 * knot_m_s); // 25.173(c)
    let short_term_n = 75.0 * LBF_TO_N; // 25.143(d), two hands, short term
    let n_limit = 2.5; // 25.337(b) for W > 50 000 lb
    for k in 0..=8 {
        let v = 130.0 + 10.0 * k as f64;
        let f = FeelAssessment::assess(&a, v, 3000.0).unwrap();
        eprintln!("737: {}", f.report());
        assert!(
            f.stick_force_per_g_n > 0.0 && f.stick_force_per_g_n * (n_limit - 1.0) <= short_term_n,
            "737 at {v} m/s: stick force per g {} N/g outside (0, {}]",
            f.stick_force_per_g_n,
            short_term_n / (n_limit - 1.0)
        );
        assert!(
            f.force_at_limit_n <= short_term_n,
            "737 at {v} m/s: pull to the limit {} N",
            f.force_at_limit_n
        );
        assert!(
            f.speed_gradient_n_per_m_s >= min_gradient_n_per_m_s,
            "737 at {v} m/s: speed gradient {} N per m/s < {min_gradient_n_per_m_s} (1 lbf per 6 kt)",
            f.speed_gradient_n_per_m_s
        );
        assert!(f.complies(), "{}", f.report());
    }
}

/// The 737's column force for the same displacement from trim grows with the impact pressure the
/// feel pitot senses (q-feel), not with the elevator's air load (the PCUs hold that): from 130 to
/// 210 m/s the force above the breakout scales as `q_c` (isentropic, computed here from q̄ and M)
/// within the centring spring's share.
#[test]
fn b737_feel_force_scales_with_impact_pressure() {
    let model = AircraftModel::load(&AircraftModel::builtin_path("737")).unwrap();
    let fc = model.hinge.feel_computer.expect("the 737 has a feel computer");
    assert_eq!(
        model.hinge.force_feedback_ratio, 0.0,
        "irreversible: no hinge feedback"
    );
    let displacement_rad = 0.02; // column aft of the trimmed neutral
    let mut out = Vec::new();
    for v in [130.0, 210.0] {
        let mut a = aircraft("737");
        let s = a.trim(v, 3000.0).unwrap();
        let g = a.hinge().elevator_per_stick_rad_per_rad;
        let pulled = AircraftState {
            elevator_rad: s.elevator_rad - g * displacement_rad,
            ..s
        };
        let f = a.hinge().stick_force_n(&pulled) - fc.breakout_n;
        let p = s.qbar_pa / (0.7 * s.mach * s.mach);
        let qc = p * ((1.0 + 0.2 * s.mach * s.mach).powf(3.5) - 1.0);
        out.push((f, qc, s.qbar_pa));
    }
    let (force_ratio, qc_ratio) = (out[1].0 / out[0].0, out[1].1 / out[0].1);
    eprintln!(
        "737 feel for 0.02 rad of column: {:.1} N at 130 m/s, {:.1} N at 210 m/s (ratio {force_ratio:.3});          q_c ratio {qc_ratio:.3}, qbar ratio {:.3}",
        out[0].0,
        out[1].0,
        out[1].2 / out[0].2
    );
    assert!(out[0].0 > 0.0, "aft column needs a pull");
    assert!(
        (force_ratio / qc_ratio - 1.0).abs() < 0.05,
        "force ratio {force_ratio} vs q_c ratio {qc_ratio}"
    );
}

/// Where `|L|` = 1 between three frequencies `w` (ascending) with open-loop magnitudes `m`, by
/// log-log interpolation on the bracketing pair.
fn log_crossing(w: [f64; 3], m: [f64; 3]) -> Option<f64> {
    (0..2).find(|&i| m[i] >= 1.0 && m[i + 1] < 1.0).map(|i| {
        let f = m[i].ln() / (m[i].ln() - m[i + 1].ln());
        (w[i].ln() + f * (w[i + 1].ln() - w[i].ln())).exp()
    })
}

/// McRuer's adapted pilot, designed on the linearised aircraft (with the hand's 0.1 s activation
/// lag), closes the loop at the chosen crossover frequency on the **nonlinear** aircraft: the open
/// loop built from the stick response measured by simulation crosses unity within 3 % of ω_c, for
/// pitch and load factor, c172p and 737.
#[test]
fn adapted_pilot_crosses_at_the_chosen_frequency_on_the_nonlinear_aircraft() {
    use mrfeel::aero::linear::{adapted_pilot, simulated_stick_response};
    use mrfeel::pilot::attitude::{CrossoverDesign, PilotLoop};
    let hand_lag_s = 0.1;
    for (name, v, h, w_c) in [("c172p", 50.0, 1000.0, 2.5), ("737", 170.0, 3000.0, 2.0)] {
        let mut a = aircraft(name);
        a.trim(v, h).unwrap();
        for output in [PilotLoop::Pitch, PilotLoop::LoadFactor] {
            let d = CrossoverDesign::new(w_c, 0.2);
            let p = adapted_pilot(&a, output, &d, hand_lag_s).unwrap();
            let amplitude = match output {
                PilotLoop::Pitch => 0.005,
                PilotLoop::LoadFactor => 0.002,
            };
            let ws = [0.9 * w_c, w_c, 1.1 * w_c];
            let m = ws.map(|w| {
                let yc = simulated_stick_response(&a, output, w, amplitude, 1.0 / 240.0);
                (p.describing_function(w) * yc / mrfeel::aero::linear::Complex::new(1.0, w * hand_lag_s))
                    .norm()
            });
            let wx = log_crossing(ws, m).unwrap_or(f64::NAN);
            eprintln!(
                "{name} {output:?} at {v} m/s: adapted pilot K {:.4}, T_L {:.3} s, T_I {:.3} s, K_i {:.4}/s; \
                 |L| on the nonlinear model {:.3} / {:.3} / {:.3} at 0.9 / 1 / 1.1 w_c; crossover {wx:.3} rad/s \
                 (chosen {w_c})",
                p.gain, p.lead_s, p.lag_s, p.integral_per_s, m[0], m[1], m[2]
            );
            assert!(
                (wx / w_c - 1.0).abs() < 0.03,
                "{name} {output:?}: crossover {wx} vs {w_c}"
            );
        }
    }
}

/// McRuer's adapted pilot on the fly-by-wire F-16, designed on the embedded model's frame map linearised
/// with its FCS (the grip force to the FCS's command through the designed law, the hand's 0.1 s lag), closes
/// the loop at the chosen crossover on the **nonlinear** model: the open loop built from the response to a
/// force sinusoid measured by simulation crosses unity within 3 % of ω_c, for pitch and load factor.
#[test]
fn adapted_pilot_crosses_at_the_chosen_frequency_on_the_fly_by_wire_f16() {
    use mrfeel::aero::linear::{adapted_fly_by_wire_pilot, simulated_response, Complex};
    use mrfeel::pilot::attitude::{CrossoverDesign, PilotLoop};
    let (hand_lag_s, dt) = (0.1, 1.0 / 120.0);
    let stick = mrfeel::aero::FlyByWire::load(&AircraftModel::builtin_path("f16")).unwrap();
    let per_newton = 1.0 / stick.full_command_force_n();
    let mut a = f16_from(&f16_text()).unwrap();
    let trim = a.trim(200.0, 3000.0).unwrap();
    for (output, w_c, amplitude_n) in [(PilotLoop::Pitch, 2.0, 1.0), (PilotLoop::LoadFactor, 1.5, 1.0)] {
        let d = CrossoverDesign::new(w_c, 0.2);
        let p = adapted_fly_by_wire_pilot(&a, output, &d, hand_lag_s, per_newton, dt).unwrap();
        let ws = [0.9 * w_c, w_c, 1.1 * w_c];
        let m = ws.map(|w| {
            let mut ac = a.clone();
            // a pull of F newtons (beyond the breakout) is the command F / F_c, JSBSim's sign negative
            let yc = simulated_response(
                |f| *ac.step(-f * per_newton, trim.throttle, dt),
                &trim,
                output,
                w,
                amplitude_n,
                dt,
            );
            (p.describing_function(w) * yc / Complex::new(1.0, w * hand_lag_s)).norm()
        });
        let wx = log_crossing(ws, m).unwrap_or(f64::NAN);
        eprintln!(
            "f16 {output:?} at 200 m/s: adapted pilot K {:.4}, T_L {:.3} s, T_I {:.3} s, K_i {:.4}/s; |L| on the \
             nonlinear model {:.3} / {:.3} / {:.3} at 0.9 / 1 / 1.1 w_c; crossover {wx:.3} rad/s (chosen {w_c})",
            p.gain, p.lead_s, p.lag_s, p.integral_per_s, m[0], m[1], m[2]
        );
        assert!(
            (wx / w_c - 1.0).abs() < 0.03,
            "{output:?}: crossover {wx} vs {w_c}"
        );
    }
}

/// The c172p pull-up task of `scenarios/c172p-pullup.toml` (1 → 1.3 g in 1 s from 2 s, held to 7 s,
/// back to 1 g by 8 s) flown by a pilot whose stick reaches the elevator through the hand's 0.1 s
/// activation lag only (no rig, no feel device): RMS load-factor error from the first command on.
fn fly_c172p_pullup(
    p: mrfeel::pilot::attitude::CrossoverPilotConfig,
    feedforward_rad_per_g: f64,
    preview_s: f64,
) -> f64 {
    use mrfeel::pilot::attitude::{PursuitPilot, Schedule};
    let command = Schedule {
        points: vec![
            (0.0, 1.0),
            (2.0, 1.0),
            (3.0, 1.3),
            (7.0, 1.3),
            (8.0, 1.0),
            (10.0, 1.0),
        ],
    };
    let dt = 1.0 / 120.0;
    let mut a = aircraft("c172p");
    let trim = a.trim(50.0, 1000.0).unwrap();
    let g = a.hinge().elevator_per_stick_rad_per_rad;
    let mut pilot = PursuitPilot::new(p, feedforward_rad_per_g, dt);
    let (mut stick, mut ss, mut n) = (0.0, 0.0, 0.0);
    let hand = 1.0 - (-dt / 0.1_f64).exp();
    for k in 0..(10.0 / dt) as usize {
        let t = k as f64 * dt;
        let e = command.value(t) - a.state().nz_g;
        if t >= command.first_change_s() {
            ss += e * e;
            n += 1.0;
        }
        let cmd = pilot.step(e, command.value(t + preview_s) - trim.nz_g);
        stick += (cmd - stick) * hand;
        a.step(trim.elevator_rad - g * stick, trim.throttle, dt);
    }
    (ss / n).sqrt()
}

/// The load-factor pilot on the c172p pull-up with an ideal stick (the stick reaches the elevator
/// through the hand's 0.1 s activation lag only). The compensatory pilot adapted by the crossover
/// model (ω_c = 2.5 rad/s, τ = 0.2 s) tracks better than the scenario's hand-tuned gains; a pilot
/// who knows the briefed schedule (precognitive: the aircraft's stick per g as feedforward on the
/// command 0.3 s ahead, the pilot's delay plus the hand's lag) tracks better still. What is left is
/// the 1-s ramps seen through the delay and the speed bleeding off at fixed throttle (50 → 37 m/s over
/// the 10 s: ever more stick for the same g).
#[test]
fn adapted_and_precognitive_pilots_track_the_c172p_pull_up_better_than_hand_tuned_gains() {
    use mrfeel::aero::linear::adapted_pilot;
    use mrfeel::pilot::attitude::{CrossoverDesign, CrossoverPilotConfig, PilotLoop};
    let mut a = aircraft("c172p");
    a.trim(50.0, 1000.0).unwrap();
    let adapted = adapted_pilot(&a, PilotLoop::LoadFactor, &CrossoverDesign::new(2.5, 0.2), 0.1).unwrap();
    let hand_tuned = CrossoverPilotConfig {
        gain: 0.02,
        lead_s: 0.0,
        lag_s: 0.0,
        delay_s: 0.2,
        integral_per_s: 0.06,
        ..adapted
    };
    let ff = a.stick_per_g_rad(50.0, 1000.0, 1.3).unwrap();
    let rms_tuned = fly_c172p_pullup(hand_tuned, 0.0, 0.0);
    let rms_adapted = fly_c172p_pullup(adapted, 0.0, 0.0);
    let rms_pursuit = fly_c172p_pullup(adapted, ff, 0.0);
    let rms_precog = fly_c172p_pullup(adapted, ff, 0.3);
    eprintln!(
        "c172p pull-up, ideal stick, load-factor RMS error (command span 0.3 g): hand-tuned {rms_tuned:.4} g \
         (K 0.02 rad/g, K_i 0.06 rad/(g s)); adapted {rms_adapted:.4} g (K {:.4} rad/g, K_i {:.4} rad/(g s)); \
         + pursuit feedforward ({ff:.4} rad/g) {rms_pursuit:.4} g; + precognitive (0.3 s ahead) {rms_precog:.4} g",
        adapted.gain, adapted.integral_per_s
    );
    assert!(ff > 0.0, "a pull-up needs aft stick");
    assert!(
        rms_adapted < 0.9 * rms_tuned,
        "adapted {rms_adapted} vs hand-tuned {rms_tuned}"
    );
    assert!(
        rms_precog < 0.85 * rms_adapted,
        "precognitive {rms_precog} vs adapted {rms_adapted}"
    );
    assert!(rms_precog < 0.06, "precognitive RMS {rms_precog}");
}
