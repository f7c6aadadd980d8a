//! Position-dependent force `k x + k3 x³ + F0` over the whole stroke: a gas accumulator, a soaked foam or a
//! centring spring, with a Duffing hardening towards the ends. Both rates are non-negative (a negative rate on
//! a sine test is `inertia`'s). Physics and sources: `docs/explanation/damper-models.md`.

use super::*;

/// Spring with preload over the whole stroke, see the module documentation.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Stiffness;

/// Indices of the parameters in the effect's slice.
pub const K: usize = 0;
pub(crate) const PRELOAD: usize = 1;
pub(crate) const K3: usize = 2;

const PARAMS: [ParamSpec; 3] = [
    ParamSpec::non_negative(
        "stiff_k_n_per_m",
        "N/m",
        // A passive element is stable about mid-stroke (k ≥ 0). This also keeps stiffness from imitating
        // inertia, which on a single-frequency sine is a negative stiffness −m ω².
        "spring rate over the whole stroke (gas accumulator, foam, centring spring)",
    ),
    ParamSpec::new(
        "stiff_preload_n",
        "N",
        f64::NEG_INFINITY,
        f64::INFINITY,
        "force at mid-stroke (accumulator pressure on the rod area, spring preload), either sign",
    ),
    ParamSpec::non_negative(
        "stiff_k3_n_per_m3",
        "N/m³",
        "cubic hardening towards the ends of the stroke (gas compression, foam densification), k3 x³",
    ),
];

impl Effect for Stiffness {
    effect_constants!(
        "stiffness",
        Additive,
        "Position force from a gas accumulator, foam or centring spring: k x + k3 x³ + F0 with x from \
         mid-stroke, over the whole stroke (the k1(x - x0) term of Spencer et al. 1997, hardening towards the \
         ends).",
        "residual proportional to displacement over the whole stroke (a straight line in residual versus x, \
         steepening towards the ends for a hardening spring, the same at every current and velocity), plus a \
         constant offset from the preload that, unlike asymmetry, does not grow with current",
    );

    // Guess: a spring giving 2 % of the force scale at the largest displacement, no preload (its sign is
    // unknown), a hardening adding 0.5 % there. Typical: 15 % and a preload of 5 %, linear (Spencer's spring).
    scaled_guesses!(
        s => vec![0.02 * s.force_n / s.x_m, 0.0, 0.005 * s.force_n / s.x_m.powi(3)],
        vec![0.15 * s.force_n / s.x_m, 0.05 * s.force_n, 0.0],
    );

    fn apply(&self, p: &[f64], _s: &[f64], inp: &Inputs, stage: &mut Stage) {
        let x = inp.x_m;
        stage.extra_n += (p[K] + p[K3] * x * x) * x + p[PRELOAD];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::effects::testkit::*;

    /// Parameters of `m` with the spring's rate `k`, preload `f0` and cubic rate `k3`.
    fn spring(m: &crate::device::Model, k: f64, f0: f64, k3: f64) -> Vec<f64> {
        let named = [
            ("stiff_k_n_per_m", k),
            ("stiff_preload_n", f0),
            ("stiff_k3_n_per_m3", k3),
        ];
        params(m, &named)
    }

    #[test]
    fn force_at_rest_is_spring_plus_preload() {
        let m = model("bingham+stiffness");
        let (k, f0, k3) = (2000.0, 15.0, 4.0e7);
        let p = spring(&m, k, f0, k3);
        let rest = |x: f64| {
            let at = Inputs {
                x_m: x,
                current_cmd_a: 7.0,
                ..Inputs::default()
            };
            m.simulate(&p, &[at])[0]
        };
        for x in [-0.02, -0.005, 0.0, 0.013] {
            // At v = 0 the Bingham yield has no direction: only the spring remains.
            let f = rest(x);
            assert!(
                (f - (k * x + k3 * x.powi(3) + f0)).abs() < 1e-9,
                "at x = {x}: {f}"
            );
        }
        // Hardening: at 20 mm the cubic term (320 N) outweighs the linear one (40 N), and the spring's rate
        // there (k + 3 k3 x² = 50 kN/m) is 25× its rate at mid-stroke.
        let rate = |x: f64| (rest(x + 1e-5) - rest(x - 1e-5)) / 2e-5;
        assert!(
            (rate(0.02) / rate(0.0) - 25.0).abs() < 1e-3,
            "{} vs {}",
            rate(0.02),
            rate(0.0)
        );
    }

    #[test]
    fn adds_the_same_position_force_to_both_directions_at_every_current() {
        let m = model("bingham+stiffness");
        let base = model("bingham");
        let (k, k3) = (3000.0, 2.0e7);
        let p = spring(&m, k, 0.0, k3);
        for i in [0.0, 10.0] {
            let inputs = sine(0.01, 1.0, i, 1e-3, 2.0);
            let f = m.simulate(&p, &inputs);
            let f0 = base.simulate(&BASE, &inputs);
            for ((a, b), inp) in f.iter().zip(&f0).zip(&inputs) {
                assert!((a - b - k * inp.x_m - k3 * inp.x_m.powi(3)).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn spring_stores_and_returns_energy_over_a_cycle() {
        // ∮ (k x + k3 x³) dx = 0: the spring adds no dissipation, unlike hysteresis.
        let m = model("bingham+stiffness");
        let base = model("bingham");
        let p = spring(&m, 5000.0, 30.0, 5.0e7);
        let inputs = sine(0.01, 1.0, 4.0, 1e-4, 1.0);
        let work = |f: &[f64]| -> f64 {
            (0..inputs.len() - 1)
                .map(|k| 0.5 * (f[k] + f[k + 1]) * (inputs[k + 1].x_m - inputs[k].x_m))
                .sum()
        };
        let w = work(&m.simulate(&p, &inputs));
        let w0 = work(&base.simulate(&BASE, &inputs));
        assert!(
            (w - w0).abs() < 1e-6 * w0.abs(),
            "cycle work {w} J vs base {w0} J"
        );
    }
}
