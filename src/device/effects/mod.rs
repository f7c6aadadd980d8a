//! The effect library: one file per physical effect of the model-discovery vocabulary (table:
//! `docs/reference/effects.md`). Each derives its initial guess and its typical strength (the hidden truth of synthetic
//! tests) from [`DataStats`] through `Scales`, never from numbers tuned to one data set.

/// The `Effect` methods of a built-in effect that only return its constants: its name, description, stage,
/// the module's `PARAMS` and its residual signature.
macro_rules! effect_constants {
    ($name:literal, $stage:ident, $describe:expr, $signature:expr $(,)?) => {
        fn name(&self) -> &'static str {
            $name
        }
        fn describe(&self) -> &'static str {
            $describe
        }
        fn stage(&self) -> EffectStage {
            EffectStage::$stage
        }
        fn params(&self) -> &'static [ParamSpec] {
            &PARAMS
        }
        fn residual_signature(&self) -> &'static str {
            $signature
        }
    };
}

/// `initial_guess` and `typical_params` of a built-in effect, each an expression of the data's [`Scales`]
/// (bound to `$s`).
macro_rules! scaled_guesses {
    ($s:ident => $guess:expr, $typical:expr $(,)?) => {
        fn initial_guess(&self, stats: &DataStats) -> Vec<f64> {
            let $s = Scales::of(stats);
            $guess
        }
        fn typical_params(&self, stats: &DataStats) -> Vec<f64> {
            let $s = Scales::of(stats);
            $typical
        }
    };
}

pub(crate) mod asymmetry;
pub(crate) mod current_viscosity;
pub(crate) mod hysteresis;
pub(crate) mod inertia;
pub(crate) mod magnetic_saturation;
pub(crate) mod stiffness;
pub(crate) mod thermal_drift;

use super::effect::{Effect, EffectStage, Inputs, Stage, Step};
use super::model::Registry;
use super::params::{DataStats, ParamSpec};

/// Register every effect of the canonical vocabulary.
pub(crate) fn register_builtin(r: &mut Registry) {
    r.register(hysteresis::Hysteresis)
        .register(asymmetry::Asymmetry)
        .register(magnetic_saturation::MagneticSaturation)
        .register(current_viscosity::CurrentViscosity)
        .register(stiffness::Stiffness)
        .register(inertia::Inertia)
        .register(thermal_drift::ThermalDrift);
}

/// `v` when it is a usable positive scale, else `fallback`.
fn positive_or(v: f64, fallback: f64) -> f64 {
    if v.is_finite() && v > 0.0 {
        v
    } else {
        fallback
    }
}

/// Data scales every effect derives its guesses from, with fallbacks for empty or degenerate statistics
/// (a fallback only keeps the guess finite and inside the bounds; it is not a device property).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Scales {
    /// Force scale, N: the largest |force|, else the RMS force, else 1 N.
    pub force_n: f64,
    /// Velocity scale, m/s.
    pub v_m_s: f64,
    /// Displacement scale, m.
    pub x_m: f64,
    /// Acceleration scale, m/s².
    pub a_m_s2: f64,
    /// Current scale, A (largest command; 1 A when every test is at zero current).
    pub i_a: f64,
    /// Duration of the longest test, s.
    pub duration_s: f64,
    /// Energy the damper dissipates over the longest test, J, estimated as `F_rms · v_rms · duration`.
    pub energy_j: f64,
}

impl Scales {
    pub fn of(stats: &DataStats) -> Self {
        let force_n = positive_or(stats.f_max_n, positive_or(stats.f_rms_n, 1.0));
        let f_rms = positive_or(stats.f_rms_n, force_n / std::f64::consts::SQRT_2);
        let x_m = positive_or(stats.x_max_m, 0.01);
        let v_m_s = positive_or(
            stats.v_max_m_s,
            positive_or(stats.v_rms_m_s * std::f64::consts::SQRT_2, 0.1),
        );
        let v_rms = positive_or(stats.v_rms_m_s, v_m_s / std::f64::consts::SQRT_2);
        // A sine of amplitude x and peak velocity v has peak acceleration v²/x.
        let a_m_s2 = positive_or(stats.a_max_m_s2, v_m_s * v_m_s / x_m);
        let i_a = positive_or(stats.i_max_a, 1.0);
        let duration_s = positive_or(stats.duration_s, 10.0);
        let energy_j = f_rms * v_rms * duration_s;
        Self {
            force_n,
            v_m_s,
            x_m,
            a_m_s2,
            i_a,
            duration_s,
            energy_j,
        }
    }
}

/// Shared test protocols and checks for the effect tests.
#[cfg(test)]
pub(crate) mod testkit {
    use crate::device::effect::Inputs;
    use crate::device::model::{Model, Registry};
    use crate::device::params::DataStats;
    use std::f64::consts::PI;

    /// Base parameters of a paper-sized damper: 20 N seal friction, 5 N/A, 300 N·s/m, Te 10 ms, Tm 20 ms.
    pub const BASE: [f64; 5] = [20.0, 5.0, 300.0, 0.010, 0.020];

    /// A sine of displacement `x = amp sin(2π f t)` at a constant current command.
    pub fn sine(amp_m: f64, freq_hz: f64, current_a: f64, dt_s: f64, duration_s: f64) -> Vec<Inputs> {
        let w = 2.0 * PI * freq_hz;
        let n = (duration_s / dt_s).round() as usize + 1;
        (0..n)
            .map(|k| {
                let t = k as f64 * dt_s;
                Inputs {
                    t_s: t,
                    x_m: amp_m * (w * t).sin(),
                    v_m_s: amp_m * w * (w * t).cos(),
                    a_m_s2: -amp_m * w * w * (w * t).sin(),
                    current_cmd_a: current_a,
                }
            })
            .collect()
    }

    /// A triangle of displacement (constant speed `v`, turning at ±`amp`), starting at 0 going up.
    pub fn triangle(amp_m: f64, speed_m_s: f64, current_a: f64, dt_s: f64, duration_s: f64) -> Vec<Inputs> {
        let period = 4.0 * amp_m / speed_m_s;
        let n = (duration_s / dt_s).round() as usize + 1;
        (0..n)
            .map(|k| {
                let t = k as f64 * dt_s;
                let ph = (t / period).fract();
                let (x, v) = if ph < 0.25 {
                    (ph * period * speed_m_s, speed_m_s)
                } else if ph < 0.75 {
                    (amp_m - (ph - 0.25) * period * speed_m_s, -speed_m_s)
                } else {
                    (-amp_m + (ph - 0.75) * period * speed_m_s, speed_m_s)
                };
                Inputs {
                    t_s: t,
                    x_m: x,
                    v_m_s: v,
                    a_m_s2: 0.0,
                    current_cmd_a: current_a,
                }
            })
            .collect()
    }

    /// A model from a spec with the builtin registry and the paper's 14 A driver limit.
    pub fn model(spec: &str) -> Model {
        match Model::from_spec(spec, &Registry::builtin(), crate::device::PAPER_CURRENT_LIMIT_A) {
            Ok(m) => m,
            Err(e) => panic!("{spec}: {e}"),
        }
    }

    /// Parameters: the base, then each named value set by name (the rest at the initial guess).
    pub fn params(m: &Model, named: &[(&str, f64)]) -> Vec<f64> {
        let mut p = m.initial_guess(&stats());
        p[..5].copy_from_slice(&BASE);
        for (name, v) in named {
            let k = m
                .param_index(name)
                .unwrap_or_else(|| panic!("no parameter {name} in {}", m.name()));
            p[k] = *v;
        }
        p
    }

    /// Statistics of a 10 mm, 1 Hz sine at up to 10 A on the base damper (computed by hand from the protocol).
    pub fn stats() -> DataStats {
        let (amp, w) = (0.01, 2.0 * PI);
        let f_max = BASE[0] + BASE[1] * 10.0 + BASE[2] * amp * w;
        DataStats {
            f_rms_n: 0.8 * f_max,
            f_max_n: f_max,
            v_max_m_s: amp * w,
            v_rms_m_s: amp * w / 2f64.sqrt(),
            x_max_m: amp,
            a_max_m_s2: amp * w * w,
            i_max_a: 10.0,
            i_mean_a: 5.0,
            dt_s: 0.001,
            duration_s: 20.0,
            fc0_n: BASE[0],
            fc_gain_n_per_a: BASE[1],
            c0_n_s_per_m: BASE[2],
        }
    }

    /// Mean force on the rising (`v > 0`) samples of a 1 s triangle of 10 mm at `speed_m_s` and `current_a`.
    pub fn rising_mean(m: &Model, p: &[f64], speed_m_s: f64, current_a: f64) -> f64 {
        let inputs = triangle(0.01, speed_m_s, current_a, 1e-3, 1.0);
        mean_where(&m.simulate(p, &inputs), &inputs, |k| k.v_m_s > 0.0)
    }

    /// Mean force on the rising (`v > 0`) and on the falling (`v < 0`) samples of `inputs`.
    pub fn up_down(m: &Model, p: &[f64], inputs: &[Inputs]) -> (f64, f64) {
        let f = m.simulate(p, inputs);
        let up = mean_where(&f, inputs, |i| i.v_m_s > 0.0);
        (up, mean_where(&f, inputs, |i| i.v_m_s < 0.0))
    }

    /// Mean of the values where the mask holds.
    pub fn mean_where(f: &[f64], inputs: &[Inputs], keep: impl Fn(&Inputs) -> bool) -> f64 {
        let (s, n) = f
            .iter()
            .zip(inputs)
            .filter(|(_, i)| keep(i))
            .fold((0.0, 0usize), |(s, n), (f, _)| (s + f, n + 1));
        assert!(n > 0, "no sample selected");
        s / n as f64
    }
}

#[cfg(test)]
mod tests {
    use super::testkit::*;
    use super::*;
    use crate::device::model::{Model, ModelSpec};

    const NAMES: [&str; 7] = [
        "hysteresis",
        "asymmetry",
        "magnetic_saturation",
        "current_viscosity",
        "stiffness",
        "inertia",
        "thermal_drift",
    ];

    #[test]
    fn every_vocabulary_effect_is_registered_with_tagged_unique_parameters() {
        let r = Registry::builtin();
        assert_eq!(r.names().len(), NAMES.len());
        let tags = [
            "hyst_", "asym_", "sat_", "visc_", "stiff_", "inertia_", "thermal_",
        ];
        let mut all = Vec::new();
        for (name, tag) in NAMES.iter().zip(tags) {
            let e = r.get(name).unwrap_or_else(|| panic!("{name} not registered"));
            assert!(
                !e.describe().is_empty() && !e.residual_signature().is_empty(),
                "{name} undocumented"
            );
            for text in [e.describe(), e.residual_signature()] {
                assert!(!text.contains("  "), "{name}: run of spaces in {text:?}");
            }
            for p in e.params() {
                assert!(p.name.starts_with(tag), "{} lacks the tag {tag}", p.name);
                assert!(p.lower < p.upper, "{}: empty bounds", p.name);
                // The docs are printed in reports: a broken string continuation shows as a run of spaces.
                assert!(!p.doc.contains("  "), "{}: run of spaces in its doc", p.name);
                all.push(p.name);
            }
        }
        let n = all.len();
        all.sort();
        all.dedup();
        assert_eq!(all.len(), n, "parameter names clash");
    }

    #[test]
    fn guesses_and_typical_strengths_are_inside_bounds_and_differ() {
        let r = Registry::builtin();
        // Scale-free: the same rules on full statistics and on empty ones must give finite in-bounds values.
        for stats in [stats(), DataStats::default()] {
            for name in NAMES {
                let e = r.get(name).unwrap_or_else(|| panic!("{name}"));
                let g = e.initial_guess(&stats);
                let t = e.typical_params(&stats);
                assert_eq!(g.len(), e.params().len());
                assert_eq!(t.len(), e.params().len());
                for ((ps, g), t) in e.params().iter().zip(&g).zip(&t) {
                    for (what, v) in [("guess", g), ("typical", t)] {
                        let inside = v.is_finite() && *v >= ps.lower && *v <= ps.upper;
                        assert!(inside, "{}: {what} {v}", ps.name);
                    }
                }
                assert_ne!(g, t, "{name}: the typical strength equals the initial guess");
            }
        }
    }

    #[test]
    fn every_effect_composes_with_bingham_and_order_does_not_matter() {
        let st = stats();
        let r = Registry::builtin();
        let mut inputs = sine(0.01, 1.5, 8.0, 0.001, 2.0);
        // A current step half-way through exercises the lags with every effect.
        for inp in inputs.iter_mut().skip(1000) {
            inp.current_cmd_a = 2.0;
        }
        for a in NAMES {
            for b in NAMES {
                if a >= b {
                    continue;
                }
                let ab = model(&format!("bingham+{a}+{b}"));
                let ba = model(&format!("bingham+{b}+{a}"));
                assert_eq!(ab.n_params(), ba.n_params());
                // Same values by name in both layouts.
                let pab = ab.typical_params(&BASE, &st).expect("typical");
                let pba: Vec<f64> = ba
                    .param_specs()
                    .iter()
                    .map(|s| pab[ab.param_index(s.name).expect("same parameter names")])
                    .collect();
                let fab = ab.simulate(&pab, &inputs);
                let fba = ba.simulate(&pba, &inputs);
                for (x, y) in fab.iter().zip(&fba) {
                    assert!(
                        (x - y).abs() <= 1e-9 * (1.0 + x.abs()),
                        "{a}+{b}: {x} vs {b}+{a}: {y}"
                    );
                }
                // And the effect really acts: the pair differs from the base.
                let base = model("bingham");
                let f0 = base.simulate(&BASE, &inputs);
                let diff = fab
                    .iter()
                    .zip(&f0)
                    .map(|(x, y)| (x - y).abs())
                    .fold(0.0, f64::max);
                assert!(diff > 1.0, "{a}+{b} indistinguishable from bingham ({diff} N)");
            }
        }
        assert!(ModelSpec::parse("bingham+hysteresis+hysteresis").is_err());
        assert!(Model::from_spec("bingham+not_an_effect", &r, 14.0).is_err());
    }

    fn assert_passive(spec: &str, named: &[(&str, f64)]) {
        let m = model(spec);
        let p = params(&m, named);
        let protocols = [
            sine(0.01, 2.0, 6.0, 0.001, 3.0),
            sine(0.002, 8.0, 12.0, 0.0005, 1.0),
            triangle(0.01, 0.05, 3.0, 0.001, 3.0),
        ];
        for inputs in &protocols {
            let f = m.simulate(&p, inputs);
            for (f, inp) in f.iter().zip(inputs) {
                assert!(
                    f * inp.v_m_s >= -1e-9,
                    "{spec}: F·v = {} < 0 at t = {}",
                    f * inp.v_m_s,
                    inp.t_s
                );
            }
        }
    }

    #[test]
    fn base_model_is_passive_on_sine_and_triangle() {
        assert_passive("bingham", &[]);
    }

    #[test]
    fn dissipative_effects_keep_the_model_passive() {
        assert_passive("bingham+asymmetry", &[("asym_fraction", 0.5)]);
        assert_passive("bingham+asymmetry", &[("asym_fraction", -0.5)]);
        assert_passive("bingham+magnetic_saturation", &[("sat_current_a", 2.0)]);
        assert_passive("bingham+current_viscosity", &[("visc_c1_n_s_per_m_per_a", 100.0)]);
        assert_passive(
            "bingham+thermal_drift",
            &[("thermal_energy_j", 20.0), ("thermal_tau_s", 5.0)],
        );
        assert_passive(
            "bingham+asymmetry+magnetic_saturation+current_viscosity+thermal_drift",
            &[
                ("asym_fraction", 0.3),
                ("sat_current_a", 3.0),
                ("thermal_energy_j", 50.0),
            ],
        );
    }
}
