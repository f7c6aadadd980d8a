//! Diagnosis on data whose effects mrfeel's own effect library did not make.
//!
//! `tests/ident.rs` hides mrfeel's effects (`device::effects`) in synthetic data; a tool tuned to its own
//! formulas would pass that and still fail on a real device. Here the truth is written from the physics
//! again, in other functional forms than the library's, with other parameter values, and only the names of
//! the vocabulary are shared:
//!
//! | hidden | truth here | mrfeel's effect |
//! |---|---|---|
//! | hysteresis | Bouc–Wen, n = 2, γ = 0 (also γ = β), no pre-yield dashpot | Dahl (n = 1) in series with a pre-yield dashpot |
//! | magnetic_saturation | `Fy = fc0 + Fs tanh(k i / Fs)` | its own knee law |
//! | asymmetry | +15 % yield extending, −10 % retracting | `Fy (1 ± a)` |
//! | current_viscosity | `C = C0 (1 + 2 (i/i_max)²)` (quadratic from C0) | `C0 + c1 h^n` (power law, n fitted) |
//! | stiffness | preload + linear + cubic spring | preload + linear |
//! | inertia | 3 kg | fitted mass |
//! | thermal_drift | temperature state lowering yield *and* viscosity (yield −7 % over the longest test) | heat lowering yield |
//!
//! The device is the paper's (Eq. 2 with fc0 = 2 N, 4.83 N/A, C0 = 60 N·s/m, 14 A), tested like the real
//! damper in `data/`: constant current per file (0, 3.5, 7, 10.5, 14 A), three amplitude/frequency
//! groups (one of them sampled at 500 Hz), load-cell and velocity noise; some cases without a velocity
//! channel. `diagnose` must name exactly the hidden effects, and the held-out error must at least halve.
//!
//! The same truth at the real damper's scale ([`REAL`]: 80 N + 900 N/A, 2 kN·s/m, 0–1 A, its kind of
//! amplitudes and frequencies) runs in the ignored sweep [`independent_sweep_over_seeds_and_scales`], with
//! every effect alone, none and nine pairs at both scales on other noise; [`PAPER_SPENCER`] is the paper's
//! device with Spencer et al. 1997's Bouc–Wen shape (γ = β) instead.

use std::path::PathBuf;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

use mrfeel::device::{Model, Registry};
use mrfeel::ident::fit::{all_spans, fit, FitOptions};
use mrfeel::ident::Test;
use mrfeel::measurement::{smooth_derivative, Measurement};

use crate::diagnosis_check;

/// The device under test and the size of each hidden effect on it.
struct Device {
    /// Yield force at zero current, N; its rise with current, N/A; post-yield damping, N·s/m.
    fc0_n: f64,
    gain_n_per_a: f64,
    c0_n_s_per_m: f64,
    /// The driver's limit and the constant currents of the tests, A.
    limit_a: f64,
    currents_a: [f64; 5],
    /// Force at which the tanh saturation levels off, N.
    saturation_n: f64,
    /// Spring preload N, rate N/m, cubic N/m³.
    spring: (f64, f64, f64),
    /// Moving mass, kg.
    mass_kg: f64,
    /// Heat that would remove the yield force / the viscosity at the linear rate, J.
    heat_yield_j: f64,
    heat_visc_j: f64,
    /// Load-cell noise (standard deviation), N.
    force_noise_n: f64,
    /// The Bouc–Wen law's share γ/(β + γ) (n = 2, A = 1, β + γ = 1): 0 sharpens the return after a
    /// reversal (`dz/dt = (v − |v| z|z|)/x0`), ½ is Spencer et al. 1997's γ = β (the return linear in x).
    bw_gamma_share: f64,
}

/// The paper's device (Eq. 2: fc0 = 2 N, 4.83 N/A, C0 = 60 N·s/m, 14 A).
const PAPER: Device = Device {
    fc0_n: 2.0,
    gain_n_per_a: 4.83,
    c0_n_s_per_m: 60.0,
    limit_a: 14.0,
    currents_a: [0.0, 3.5, 7.0, 10.5, 14.0],
    saturation_n: 80.0,
    spring: (2.0, 250.0, 3e5),
    mass_kg: 3.0,
    heat_yield_j: 250.0,
    heat_visc_j: 800.0,
    force_noise_n: 0.15,
    bw_gamma_share: 0.0,
};

/// The paper's device with Spencer et al. 1997's hysteresis shape (γ = β).
const PAPER_SPENCER: Device = Device {
    bw_gamma_share: 0.5,
    ..PAPER
};

/// A device on the scale of the real damper in `data/` (80 N + 900 N/A, 2 kN·s/m, 0–1 A, the
/// load cell's noise 5 N), its effects scaled to it: a 1.1 kN saturation, a 60 N + 20 kN/m + 2e7 N/m³
/// spring, a 15 kg moving mass (piston, rod and the fixture above the load cell).
const REAL: Device = Device {
    fc0_n: 80.0,
    gain_n_per_a: 900.0,
    c0_n_s_per_m: 2000.0,
    limit_a: 1.0,
    currents_a: [0.0, 0.25, 0.5, 0.75, 1.0],
    saturation_n: 1100.0,
    spring: (60.0, 2e4, 2e7),
    mass_kg: 15.0,
    heat_yield_j: 3000.0,
    heat_visc_j: 6000.0,
    force_noise_n: 5.0,
    bw_gamma_share: 0.0,
};

/// One group of tests: (group name, amplitude m, frequency Hz, cycles, sample rate Hz).
type Group = (&'static str, f64, f64, f64, f64);

/// The default groups.
const GROUPS: [Group; 3] = [
    ("s20mm1Hz", 0.02, 1.0, 3.0, 1000.0),
    ("s10mm2p5Hz", 0.01, 2.5, 4.0, 1000.0),
    ("s30mm0p4Hz", 0.03, 0.4, 2.0, 500.0),
];
/// Longer tests, all at 1 kHz (four cycles each): where a differentiator's window matters most.
const GROUPS_LONG: [Group; 3] = [
    ("s20mm1Hz", 0.02, 1.0, 4.0, 1000.0),
    ("s10mm2p5Hz", 0.01, 2.5, 4.0, 1000.0),
    ("s30mm0p4Hz", 0.03, 0.4, 4.0, 1000.0),
];
/// The real damper's kind of tests (its groups are 10 mm 1 Hz, 25 mm 0.25 Hz and 2 mm 5 Hz).
const GROUPS_REAL: [Group; 3] = [
    ("r10mm1Hz", 0.01, 1.0, 3.0, 1000.0),
    ("r2mm5Hz", 0.002, 5.0, 8.0, 1000.0),
    ("r20mm0p3Hz", 0.02, 0.3, 2.0, 500.0),
];
/// Two groups only, each one sine frequency.
const GROUPS_TWO: [Group; 2] = [
    ("s15mm1p5Hz", 0.015, 1.5, 3.0, 1000.0),
    ("s8mm3Hz", 0.008, 3.0, 6.0, 1000.0),
];
/// The groups of [`GROUPS`] sampled at 2 kHz.
const GROUPS_2K: [Group; 3] = [
    ("s20mm1Hz", 0.02, 1.0, 3.0, 2000.0),
    ("s10mm2p5Hz", 0.01, 2.5, 4.0, 2000.0),
    ("s30mm0p4Hz", 0.03, 0.4, 2.0, 2000.0),
];
/// Integration substeps per sample for the truth's states.
const SUB: usize = 20;

/// The truth's force and its states, for the hidden effects named in `hidden`.
struct Truth<'a> {
    dev: &'a Device,
    hidden: &'a [&'a str],
    /// Bouc–Wen state.
    z: f64,
    /// Heat above ambient, J.
    heat_j: f64,
}

impl Truth<'_> {
    fn has(&self, e: &str) -> bool {
        self.hidden.contains(&e)
    }

    /// Bouc–Wen yield displacement, m.
    const BW_X0_M: f64 = 4e-4;
    /// Cooling time of the heat, s.
    const COOL_S: f64 = 60.0;

    fn yield_n(&self, i: f64, v: f64) -> f64 {
        let d = self.dev;
        let mut fy = if self.has("magnetic_saturation") {
            d.fc0_n + d.saturation_n * (d.gain_n_per_a * i / d.saturation_n).tanh()
        } else {
            d.fc0_n + d.gain_n_per_a * i
        };
        if self.has("asymmetry") {
            fy *= if v > 0.0 { 1.15 } else { 0.9 };
        }
        if self.has("thermal_drift") {
            fy *= 1.0 - self.heat_j / d.heat_yield_j;
        }
        fy
    }

    fn damping(&self, i: f64) -> f64 {
        let d = self.dev;
        let mut c = d.c0_n_s_per_m;
        if self.has("current_viscosity") {
            c *= 1.0 + 2.0 * (i / d.limit_a).powi(2);
        }
        if self.has("thermal_drift") {
            c *= 1.0 - self.heat_j / d.heat_visc_j;
        }
        c
    }

    fn force(&self, i: f64, x: f64, v: f64, a: f64) -> f64 {
        let d = if self.has("hysteresis") {
            self.z
        } else {
            v.signum()
        };
        let mut f = self.yield_n(i, v) * d + self.damping(i) * v;
        if self.has("stiffness") {
            let (preload, k, k3) = self.dev.spring;
            f += preload + k * x + k3 * x.powi(3);
        }
        if self.has("inertia") {
            f += self.dev.mass_kg * a;
        }
        f
    }

    /// Advance the states over `h` at velocity `v` (RK4 for Bouc–Wen, Euler for the slow heat).
    fn advance(&mut self, i: f64, v: f64, h: f64) {
        if self.has("hysteresis") {
            let g = self.dev.bw_gamma_share;
            let r = |z: f64| (v - (1.0 - g) * v.abs() * z * z.abs() - g * v * z * z) / Self::BW_X0_M;
            let k1 = r(self.z);
            let k2 = r(self.z + 0.5 * h * k1);
            let k3 = r(self.z + 0.5 * h * k2);
            let k4 = r(self.z + h * k3);
            self.z = (self.z + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)).clamp(-1.0, 1.0);
        }
        if self.has("thermal_drift") {
            let p = ((self.yield_n(i, v) * v.signum() + self.damping(i) * v) * v).max(0.0);
            self.heat_j += h * (p - self.heat_j / Self::COOL_S);
        }
    }
}

/// One test of the truth at current steps ([`stepped_measurement`]).
fn stepped_file(
    dev: &Device,
    hidden: &[&str],
    group: Group,
    levels: &[f64],
    velocity_channel: bool,
    rng: &mut ChaCha8Rng,
) -> Test {
    Test::from_measurement(&stepped_measurement(
        dev,
        hidden,
        group,
        levels,
        velocity_channel,
        rng,
    ))
}

/// One test of the truth: a sine with the current stepping through `levels`, an equal time at each (one
/// level: constant current), sampled with noise. The truth's current steps at once (no lags).
fn stepped_measurement(
    dev: &Device,
    hidden: &[&str],
    group: Group,
    levels: &[f64],
    velocity_channel: bool,
    rng: &mut ChaCha8Rng,
) -> Measurement {
    let (name, amp, f_hz, cycles, rate) = group;
    let n = (cycles / f_hz * rate).round() as usize;
    let w = std::f64::consts::TAU * f_hz;
    let motion = |t: f64| {
        (
            amp * (w * t).sin(),
            amp * w * (w * t).cos(),
            -amp * w * w * (w * t).sin(),
        )
    };
    let mut truth = Truth {
        dev,
        hidden,
        z: 1.0,
        heat_j: 0.0,
    };
    let (fn_noise, xn_noise, vn_noise) = (
        Normal::new(0.0, dev.force_noise_n).unwrap(),
        Normal::new(0.0, 2e-6).unwrap(),
        Normal::new(0.0, 2e-4).unwrap(),
    );
    let h = 1.0 / rate / SUB as f64;
    let mut m = Measurement {
        path: PathBuf::from(format!("{name}_{:03}dA.csv", (levels[0] * 10.0).round() as i64)),
        velocity_measured: velocity_channel,
        ..Default::default()
    };
    let dwell = n as f64 / rate / levels.len() as f64;
    let current = |t: f64| levels[((t / dwell) as usize).min(levels.len() - 1)];
    for k in 0..n {
        let t = k as f64 / rate;
        let (x, v, a) = motion(t);
        let i = current(t);
        m.t_s.push(t);
        m.x_m.push(x + xn_noise.sample(rng));
        m.v_m_s.push(v + vn_noise.sample(rng));
        m.i_a.push(i);
        m.f_n.push(truth.force(i, x, v, a) + fn_noise.sample(rng));
        for s in 0..SUB {
            truth.advance(i, motion(t + s as f64 * h).1, h);
        }
    }
    if !velocity_channel {
        m.v_m_s = smooth_derivative(&m.t_s, &m.x_m);
    }
    m.lines = (2..n + 2).collect();
    m
}

/// The noise of every case: `INDEPENDENT_SEED_OFFSET=100 cargo test --test integration independent_truth::` reruns them all
/// on other noise.
fn rng_for(seed: u64) -> ChaCha8Rng {
    let offset: u64 = std::env::var("INDEPENDENT_SEED_OFFSET")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0);
    ChaCha8Rng::seed_from_u64(seed + offset)
}

fn check(hidden: &[&str], velocity_channel: bool, seed: u64) {
    check_on(&PAPER, &GROUPS, hidden, velocity_channel, seed);
}

/// One file per group and current, like the real damper's tests.
fn data_set(dev: &Device, groups: &[Group], hidden: &[&str], velocity_channel: bool, seed: u64) -> Vec<Test> {
    measurements(dev, groups, hidden, velocity_channel, seed)
        .iter()
        .map(Test::from_measurement)
        .collect()
}

/// The files of [`data_set`], as measurements.
fn measurements(
    dev: &Device,
    groups: &[Group],
    hidden: &[&str],
    velocity_channel: bool,
    seed: u64,
) -> Vec<Measurement> {
    let mut rng = rng_for(seed);
    groups
        .iter()
        .flat_map(|g| dev.currents_a.iter().map(move |&i| (*g, i)))
        .map(|(g, i)| stepped_measurement(dev, hidden, g, &[i], velocity_channel, &mut rng))
        .collect()
}

fn check_on(dev: &Device, groups: &[Group], hidden: &[&str], velocity_channel: bool, seed: u64) {
    let tests = data_set(dev, groups, hidden, velocity_channel, seed);
    if let Err(e) = diagnosis_check::verdict(&tests, hidden, dev.limit_a) {
        panic!("independent truth: {e}");
    }
}

/// The same data in files whose names group nothing (`test01.csv` … in a shuffled order): the diagnosis
/// groups the files by their motion (leave one motion out, every current in it) and names the same
/// effects. With one file per fold instead, the quadratic damping was missed (worse in one fold of five,
/// where the held-out currents were the low ones) and the cubic spring drew a false `inertia`.
fn check_unnamed(hidden: &[&str], velocity_channel: bool, seed: u64) {
    let mut tests = data_set(&PAPER, &GROUPS, hidden, velocity_channel, seed);
    let n = tests.len();
    for (j, t) in tests.iter_mut().enumerate() {
        let k = (j * 7 + 3) % n; // a fixed shuffle of the numbering
        t.name = format!("test{k:02}.csv");
        t.path = PathBuf::from(&t.name);
        t.group = format!("test{k:02}");
    }
    tests.sort_by(|a, b| a.name.cmp(&b.name));
    match diagnosis_check::verdict(&tests, hidden, PAPER.limit_a) {
        Ok(d) => assert!(
            d.cv_scheme
                .starts_with("leave one motion group out over 3 motion groups"),
            "{}",
            d.cv_scheme
        ),
        Err(e) => panic!("independent truth, files named test01.csv …: {e}"),
    }
}

#[test]
fn independent_none_is_left_alone() {
    check(&[], false, 1);
}

#[test]
fn independent_bouc_wen_hysteresis_is_named_hysteresis() {
    check(&["hysteresis"], true, 2);
}

/// Both truths' Bouc–Wen shapes (n = 2; γ = 0, and Spencer et al.'s γ = β) are inside the family of
/// `hysteresis`: fitted on all the data, `bingham+hysteresis` leaves the load cell's noise and finds the
/// truth's shape and yield displacement. With the shape held at Dahl's the error is 7-10 times the noise,
/// and a second, weaker effect beside hysteresis could hide in it.
#[test]
fn independent_bouc_wen_shapes_are_fitted_to_the_noise() {
    let registry = Registry::builtin();
    for (dev, share) in [(&PAPER, 0.0), (&PAPER_SPENCER, 0.5)] {
        let tests = data_set(dev, &GROUPS, &["hysteresis"], true, 21);
        let model = Model::from_spec("bingham+hysteresis", &registry, dev.limit_a).expect("model");
        let r = fit(&model, &tests, &all_spans(&tests), &FitOptions::default());
        let p = |name: &str| r.params[model.param_index(name).expect(name)];
        let ratio = r.rmse_n() / dev.force_noise_n;
        assert!(
            ratio < 1.1,
            "gamma share {share}: RMSE {:.3} N, {ratio:.2}x the noise",
            r.rmse_n()
        );
        assert!(
            (p("hyst_knee") - 1.0).abs() < 0.05,
            "knee {} (n = 2 is 1)",
            p("hyst_knee")
        );
        assert!(
            (p("hyst_gamma_share") - share).abs() < 0.05,
            "gamma share {} against {share}",
            p("hyst_gamma_share")
        );
        let xy = p("hyst_x_yield_m");
        assert!(
            (xy / Truth::BW_X0_M - 1.0).abs() < 0.03,
            "x_y {xy} m against {} m",
            Truth::BW_X0_M
        );
    }
}

/// Both truths scale the yield force by the sign of the velocity (`Fy (1 ± a)`, a seal's drag) while their
/// Bouc-Wen state still sits on the old branch after a reversal. `asymmetry`'s share that follows the motion
/// takes that form: fitted on all the data, the truth's model leaves the load cell's noise with the share
/// near 1; held at 0 (the asymmetry following the yield state alone) it does not.
#[test]
fn independent_seal_asymmetry_beside_hysteresis_is_fitted_to_the_noise() {
    let registry = Registry::builtin();
    let tests = data_set(&PAPER, &GROUPS, &["hysteresis", "asymmetry"], true, 23);
    let model = Model::from_spec("bingham+hysteresis+asymmetry", &registry, PAPER.limit_a).expect("model");
    let spans = all_spans(&tests);
    let r = fit(&model, &tests, &spans, &FitOptions::default());
    let share = model.param_index("asym_motion_share").expect("share");
    let fraction = r.params[model.param_index("asym_fraction").expect("fraction")];
    let ratio = r.rmse_n() / PAPER.force_noise_n;
    assert!(ratio < 1.2, "RMSE {:.3} N, {ratio:.2}x the noise", r.rmse_n());
    assert!(r.params[share] > 0.9, "motion share {}", r.params[share]);
    // Fy (1.15, 0.9) = Fy' (1 ± a) with a = 0.125 / 1.025.
    assert!((fraction - 0.125 / 1.025).abs() < 0.01, "fraction {fraction}");
    let mut start = model.initial_guess(&mrfeel::ident::fit::span_stats(&tests, &spans));
    start[share] = 0.0;
    let state_only = fit(
        &model,
        &tests,
        &spans,
        &FitOptions {
            start: Some(start),
            hold: vec![share],
            ..Default::default()
        },
    );
    let held = state_only.rmse_n() / PAPER.force_noise_n;
    assert!(
        held > 3.0 * ratio,
        "share held at 0: {held:.2}x the noise, free {ratio:.2}x"
    );
}

/// A model that the diagnosis names is fitted again from the data-derived start, not only from the fits of the
/// model it grew from. The sweep's case `seed 300015 paper ["current_viscosity", "thermal_drift"]`, velocity
/// derived: staged from the earlier fits, a fold's fit stopped short at the cross-validation tolerance and
/// the right model was held out at 1.32x the noise floor (0.0041 against 0.0031: it passed only by halving
/// the base's error); fitted afresh, at the floor.
#[test]
fn independent_named_model_fitted_afresh_ends_at_the_noise_floor() {
    let hidden = ["current_viscosity", "thermal_drift"];
    let tests = data_set(&PAPER, &GROUPS, &hidden, false, 300_015);
    let d = diagnosis_check::verdict(&tests, &hidden, PAPER.limit_a).unwrap_or_else(|e| panic!("{e}"));
    assert!(
        d.final_heldout_nrmse <= 1.1 * d.noise_floor_nrmse,
        "held out {:.4}, floor {:.4}",
        d.final_heldout_nrmse,
        d.noise_floor_nrmse
    );
}

#[test]
fn independent_tanh_saturation_is_named_magnetic_saturation() {
    check(&["magnetic_saturation"], true, 3);
}

#[test]
fn independent_direction_dependent_yield_is_named_asymmetry() {
    check(&["asymmetry"], false, 4);
}

#[test]
fn independent_quadratic_current_viscosity_is_named_current_viscosity() {
    check(&["current_viscosity"], true, 5);
}

#[test]
fn independent_cubic_spring_is_named_stiffness() {
    check(&["stiffness"], false, 6);
}

#[test]
fn independent_moving_mass_is_named_inertia() {
    check(&["inertia"], true, 7);
}

/// The real damper's scale with a load cell four times as noisy (20 N): the 15 kg mass leaves `bingham` held
/// out at only 1.09× the noise floor. `diagnose` stops within 1.05× of the floor (not 1.1×, where it would
/// name nothing), and the mass removes the rest in every fold (0.0328 → 0.0296, floor
/// 0.0302). Nearer the floor still (25 N: 1.06–1.07×) it is named on two seeds of three.
#[test]
fn independent_moving_mass_near_the_noise_at_the_real_scale_is_named_inertia() {
    let noisy = Device {
        force_noise_n: 20.0,
        ..REAL
    };
    check_on(&noisy, &GROUPS_REAL, &["inertia"], true, 23);
}

/// Without a velocity channel the acceleration comes from the displacement twice. On these longer tests the
/// differentiator's window used to stay at its narrowest (its widening rule was a coin toss that long
/// files decide one way), the acceleration was as noisy as the signal, and the mass was missed.
#[test]
fn independent_moving_mass_without_a_velocity_channel_is_named_inertia() {
    check_on(&PAPER, &GROUPS_LONG, &["inertia"], false, 13);
}

/// At 2 kHz without a velocity channel: the file's 7-sample differentiator turns the 2 µm displacement
/// noise into 2 mm/s of velocity noise, which the damping (60 N·s/m) made a force noise of 0.12 N beside
/// the load cell's 0.15 N: a right model was held out at 1.28× the noise floor. The velocity is derived
/// again with the widest window that leaves the signal unbent. And near the ends of each test, where the
/// centred windows do not reach, that differentiator's acceleration was 17 m/s² off: the mass was missed
/// (40 % better held out, but worse in one fold) until the end windows were fitted off-centre.
#[test]
fn independent_velocity_derived_at_2_khz_leaves_a_right_model_at_the_noise_floor() {
    check_on(&PAPER, &GROUPS_2K, &[], false, 17);
    check_on(&PAPER, &GROUPS_2K, &["inertia"], false, 18);
}

#[test]
fn independent_heating_is_named_thermal_drift() {
    check(&["thermal_drift"], true, 8);
}

#[test]
fn independent_pairs_are_both_named() {
    check(&["hysteresis", "stiffness"], false, 9);
    check(&["asymmetry", "magnetic_saturation"], true, 10);
    check(&["current_viscosity", "thermal_drift"], true, 11);
    check(&["hysteresis", "inertia"], true, 12);
}

/// A spring and a moving mass, each tested at one frequency per group: within a group `k x` and `m a = −m ω² x`
/// are the same signal, so either alone, fitted on two groups, takes the other's part at their frequencies and
/// mispredicts the third (the spring alone lowered the held-out error by a third, but in two folds of three;
/// the mass alone in one). Only the two together predict every group; `diagnose` used to name neither.
#[test]
fn independent_spring_and_mass_separable_only_together_are_both_named() {
    check(&["stiffness", "inertia"], true, 14);
}

/// The same pair in two groups only. Left out a group at a time, each fold is fitted on one frequency, where
/// the spring and the mass are one signal even together: only `stiffness` was named (held out 0.079 →
/// 0.068, 22× the noise floor). With two groups the folds are time blocks of every test, each fitted on
/// both frequencies; and nothing is named where nothing is hidden.
#[test]
fn independent_spring_and_mass_in_two_groups_are_both_named() {
    check_on(&PAPER, &GROUPS_TWO, &["stiffness", "inertia"], true, 19);
    check_on(&PAPER, &GROUPS_TWO, &[], true, 20);
}

/// Heating beside a hysteresis whose shape mrfeel's (Dahl) does not match: after `hysteresis` most of the
/// error left is that difference of shape, 10 to 15 times the noise, and the heating removes only 15–16 % of
/// it, though in every fold and 14–16 % of the held-out error. Both were missed while an effect had to remove
/// a fifth of the error above the noise floor; a tenth names them (`DiagnoseOptions::min_excess_removed`).
#[test]
fn independent_heating_beside_an_unmatched_hysteresis_is_named() {
    check_on(
        &PAPER_SPENCER,
        &GROUPS,
        &["hysteresis", "thermal_drift"],
        false,
        15,
    );
    check_on(&REAL, &GROUPS_REAL, &["hysteresis", "thermal_drift"], false, 16);
}

#[test]
fn independent_effects_in_files_whose_names_group_nothing() {
    check_unnamed(&["current_viscosity"], true, 21);
    check_unnamed(&["stiffness"], false, 22);
}

/// One file (blocked cross-validation in time), the current stepping through six levels over 15 s of a
/// 1.3 Hz sine: the current-dependent effects are still named, and the error at least halves. With
/// hysteresis alone, a second effect must not be named for the sake of a better fit of the first: without
/// the refit of the current model from the best candidate's fit, a candidate that merely leads a fold's fit
/// out of a local minimum is named (`inertia` with this seed; `inertia` or `stiffness` on seeds 44 and 45).
/// With the refit, seeds 33–45 pass.
#[test]
fn independent_effects_in_one_file_with_current_steps() {
    for (hidden, seed) in [
        ("current_viscosity", 31u64),
        ("magnetic_saturation", 32),
        ("hysteresis", 42),
    ] {
        let mut rng = rng_for(seed);
        let tests = vec![stepped_file(
            &PAPER,
            &[hidden],
            ("steps", 0.02, 1.3, 19.5, 1000.0),
            &[7.0, 0.0, 14.0, 3.5, 10.5, 7.0],
            true,
            &mut rng,
        )];
        if let Err(e) = diagnosis_check::verdict(&tests, &[hidden], PAPER.limit_a) {
            panic!("independent truth, one file with current steps: {e}");
        }
    }
}

/// [`GROUPS`] sampled four times as fast, for [`jittered`] to keep about every fourth sample of.
const GROUPS_X4: [Group; 3] = [
    ("s20mm1Hz", 0.02, 1.0, 3.0, 4000.0),
    ("s10mm2p5Hz", 0.01, 2.5, 4.0, 4000.0),
    ("s30mm0p4Hz", 0.03, 0.4, 2.0, 2000.0),
];

/// A test on a clock that jitters by up to a quarter of a sample (the format asks for strictly increasing
/// times, not a constant rate): of a test sampled four times as fast, the fourth, eighth, … sample or one of
/// its two neighbours, at random, so the intervals are 0.5–1.5 of the nominal one. The truth's force at each
/// kept sample is the force at its own time. Without a velocity channel the velocity is derived again, on
/// the kept samples.
fn jittered(m: &Measurement, rng: &mut ChaCha8Rng) -> Measurement {
    use rand::Rng;
    let n = m.len();
    let keep: Vec<usize> = std::iter::once(0)
        .chain(
            (4..n - 1)
                .step_by(4)
                .map(|k| (k as i64 + rng.random_range(-1i64..=1)) as usize),
        )
        .collect();
    let pick = |c: &[f64]| keep.iter().map(|&k| c[k]).collect::<Vec<f64>>();
    let mut j = Measurement {
        path: m.path.clone(),
        velocity_measured: m.velocity_measured,
        t_s: pick(&m.t_s),
        x_m: pick(&m.x_m),
        v_m_s: pick(&m.v_m_s),
        i_a: pick(&m.i_a),
        f_n: pick(&m.f_n),
        lines: (2..keep.len() + 2).collect(),
        ..Default::default()
    };
    if !j.velocity_measured {
        j.v_m_s = smooth_derivative(&j.t_s, &j.x_m);
    }
    j
}

/// Data on a jittered clock ([`jittered`]). With derivatives that ignore the uneven grid and noise estimates
/// that take the samples as evenly spaced, a hidden mass is not named without a velocity channel (held out
/// 11.6× the noise floor on data of this kind from `python/independent_truth.py`), and hysteresis is named
/// but leaves 3.7× the floor (the displacement's noise, overestimated from its jitter, is not smoothed out
/// of the hysteresis law's path). Both reach the floor, as on an even clock, which this asserts.
#[test]
fn independent_effects_on_a_jittered_clock_are_fitted_to_the_noise() {
    for (hidden, velocity_channel, seed) in [("inertia", false, 51u64), ("hysteresis", true, 52)] {
        let mut rng = rng_for(seed);
        let ms = measurements(&PAPER, &GROUPS_X4, &[hidden], velocity_channel, seed);
        let tests: Vec<Test> = ms
            .iter()
            .map(|m| Test::from_measurement(&jittered(m, &mut rng)))
            .collect();
        let uneven = tests.iter().all(|t| {
            let ts: Vec<f64> = t.inputs.iter().map(|i| i.t_s).collect();
            mrfeel::measurement::uniform_interval(&ts).is_none()
        });
        assert!(uneven, "the clock must be uneven");
        named_at_the_noise_floor(&tests, hidden, "on a jittered clock");
    }
}

/// The diagnosis names exactly `hidden` and ends within 1.2× the noise floor (`what`: the case, for the
/// message).
fn named_at_the_noise_floor(tests: &[Test], hidden: &str, what: &str) {
    match diagnosis_check::verdict(tests, &[hidden], PAPER.limit_a) {
        Ok(d) => assert!(
            d.final_heldout_nrmse <= 1.2 * d.noise_floor_nrmse,
            "{hidden} {what}: held out {:.4}, noise floor {:.4}:\n{}",
            d.final_heldout_nrmse,
            d.noise_floor_nrmse,
            mrfeel::ident::report::diagnose_table(&d)
        ),
        Err(e) => panic!("independent truth, {hidden} {what}: {e}"),
    }
}

/// Records with a hole: 100 samples lost in the middle of every test (a DAQ that stalled), the velocity
/// derived from the displacement, a hidden mass. A local fit across the hole bent the velocity: at the first
/// sample after it, where the sine reverses, 5 of its noise standard deviations off, a sign taken as known and
/// wrong (probe set of `python/independent_truth.py`: held out 3.6x the noise floor). Each side is now
/// differentiated on its own.
#[test]
fn independent_mass_in_records_with_a_hole_is_fitted_to_the_noise() {
    let mut ms = measurements(&PAPER, &GROUPS, &["inertia"], false, 61);
    for m in &mut ms {
        for c in [&mut m.t_s, &mut m.x_m, &mut m.i_a, &mut m.f_n] {
            c.drain(1000..1100);
        }
        m.v_m_s = smooth_derivative(&m.t_s, &m.x_m);
        m.lines = (2..m.t_s.len() + 2).collect();
    }
    let tests: Vec<Test> = ms.iter().map(Test::from_measurement).collect();
    named_at_the_noise_floor(&tests, "inertia", "in records with a hole");
}

/// Every effect alone, none, and nine pairs, on the paper's device (the hysteresis cases also in Spencer's
/// shape; all also in two groups only) and at the real damper's scale, on other noise:
/// `INDEPENDENT_SWEEP=300..303 cargo test --release --test integration independent_truth::independent_sweep_over_seeds_and_scales -- --ignored --nocapture`
/// (default seeds 300..301; `INDEPENDENT_SWEEP_ONLY=inertia` the cases whose hidden effects contain that word;
/// `INDEPENDENT_SWEEP_REPORT=1` prints the report of the cases that pass too; `INDEPENDENT_SWEEP_DUMP=DIR`
/// writes each data set's files into `DIR/<scale>_<effects>_<seed>/` for `mrfeel diagnose`). Prints each verdict and fails
/// with every failure's report at the end.
#[test]
#[ignore]
fn independent_sweep_over_seeds_and_scales() {
    let vocabulary = mrfeel::device::Registry::builtin().names();
    let range = std::env::var("INDEPENDENT_SWEEP").unwrap_or_else(|_| "300..301".into());
    let (a, b) = range.split_once("..").expect("INDEPENDENT_SWEEP=A..B");
    let seeds = a.parse::<u64>().expect("A")..b.parse::<u64>().expect("B");
    let only = std::env::var("INDEPENDENT_SWEEP_ONLY").ok();
    let report = std::env::var("INDEPENDENT_SWEEP_REPORT").is_ok();
    let mut cases: Vec<Vec<&str>> = vec![vec![]];
    cases.extend(vocabulary.iter().map(|e| vec![*e]));
    cases.extend(
        [
            ["hysteresis", "stiffness"],
            ["hysteresis", "inertia"],
            ["hysteresis", "current_viscosity"],
            ["hysteresis", "asymmetry"],
            ["hysteresis", "magnetic_saturation"],
            ["hysteresis", "thermal_drift"],
            ["asymmetry", "magnetic_saturation"],
            ["current_viscosity", "thermal_drift"],
            ["stiffness", "inertia"],
        ]
        .map(|p| p.to_vec()),
    );
    let mut failures = Vec::new();
    let mut runs = 0;
    for seed in seeds {
        let scales: [(&str, &Device, &[Group]); 4] = [
            ("paper", &PAPER, &GROUPS),
            ("paper-spencer", &PAPER_SPENCER, &GROUPS),
            ("paper-two-groups", &PAPER, &GROUPS_TWO),
            ("real", &REAL, &GROUPS_REAL),
        ];
        for (scale, dev, groups) in scales {
            for (k, hidden) in cases.iter().enumerate() {
                if only.as_ref().is_some_and(|o| !format!("{hidden:?}").contains(o)) {
                    continue;
                }
                // The hysteresis shape matters only where hysteresis is hidden.
                if dev.bw_gamma_share != PAPER.bw_gamma_share && !hidden.contains(&"hysteresis") {
                    continue;
                }
                // Velocity measured on even cases, derived on odd ones.
                let velocity_channel = k % 2 == 0;
                let s = 1000 * seed + k as u64;
                let tests = data_set(dev, groups, hidden, velocity_channel, s);
                if let Ok(dir) = std::env::var("INDEPENDENT_SWEEP_DUMP") {
                    let dir = PathBuf::from(dir).join(format!("{scale}_{}_{s}", hidden.join(",")));
                    std::fs::create_dir_all(&dir).expect("dump directory");
                    for m in measurements(dev, groups, hidden, velocity_channel, s) {
                        m.write(&dir.join(&m.path)).expect("dump file");
                    }
                }
                runs += 1;
                let r = diagnosis_check::verdict(&tests, hidden, dev.limit_a);
                eprintln!(
                    "seed {s} {scale} {hidden:?} velocity {}: {}",
                    if velocity_channel { "measured" } else { "derived" },
                    match &r {
                        Ok(d) => format!(
                            "ok ({:.4} -> {:.4}, floor {:.4})",
                            d.base_heldout_nrmse, d.final_heldout_nrmse, d.noise_floor_nrmse
                        ),
                        Err(_) => "FAIL".into(),
                    }
                );
                if let (Ok(d), true) = (&r, report) {
                    eprintln!("{}", mrfeel::ident::report::diagnose_table(d));
                }
                if let Err(e) = r {
                    failures.push(format!("seed {s} {scale} {hidden:?}: {e}"));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {runs} failed:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
