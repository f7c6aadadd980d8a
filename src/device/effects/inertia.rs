//! Inertia of the moving parts: `F_extra = m a`, `m` the fitted mass of piston, rod and the fluid they
//! push, `a` the piston acceleration.

use super::*;

/// Moving mass, see the module documentation.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Inertia;

/// Index of the parameter in the effect's slice.
pub(crate) const MASS: usize = 0;

const PARAMS: [ParamSpec; 1] = [ParamSpec::non_negative(
    "inertia_mass_kg",
    "kg",
    // A mass is not negative; this also keeps inertia from imitating a spring on a single-frequency sine.
    "effective moving mass of piston, rod and entrained fluid",
)];

impl Effect for Inertia {
    effect_constants!(
        "inertia",
        Additive,
        "Moving mass of piston, rod and entrained fluid: m a added to the damper force (Newton's second law on \
         the moving parts between actuator and load cell).",
        "residual proportional to acceleration: largest at the ends of the stroke where the velocity reverses, \
         growing with the square of frequency at a given amplitude, the same at every current; on one sine it \
         looks like a negative stiffness, so it separates from stiffness only across frequencies",
    );

    // A mass giving 1 % (guess) and 15 % (typical) of the force scale at the largest acceleration.
    scaled_guesses!(s => vec![0.01 * s.force_n / s.a_m_s2], vec![0.15 * s.force_n / s.a_m_s2]);

    fn apply(&self, p: &[f64], _s: &[f64], inp: &Inputs, stage: &mut Stage) {
        stage.extra_n += p[MASS] * inp.a_m_s2;
    }
}

#[cfg(test)]
mod tests {
    use crate::device::effects::testkit::*;

    #[test]
    fn adds_mass_times_acceleration() {
        let m = model("bingham+inertia");
        let base = model("bingham");
        let mass = 2.5;
        let p = params(&m, &[("inertia_mass_kg", mass)]);
        let inputs = sine(0.005, 4.0, 3.0, 1e-3, 1.0);
        let f = m.simulate(&p, &inputs);
        let f0 = base.simulate(&BASE, &inputs);
        for ((a, b), inp) in f.iter().zip(&f0).zip(&inputs) {
            assert!((a - b - mass * inp.a_m_s2).abs() < 1e-9);
        }
    }

    #[test]
    fn inertial_force_grows_with_frequency_squared() {
        // Same amplitude, double frequency: the peak of (F - F_base) quadruples, (2π f)² A m.
        let m = model("bingham+inertia");
        let base = model("bingham");
        let mass = 4.0;
        let p = params(&m, &[("inertia_mass_kg", mass)]);
        let peak = |freq: f64| {
            let inputs = sine(0.004, freq, 2.0, 1e-4, 1.0);
            let f = m.simulate(&p, &inputs);
            let f0 = base.simulate(&BASE, &inputs);
            f.iter().zip(&f0).map(|(a, b)| (a - b).abs()).fold(0.0, f64::max)
        };
        let (p2, p4) = (peak(2.0), peak(4.0));
        let expect = mass * 0.004 * (2.0 * std::f64::consts::PI * 2.0f64).powi(2);
        assert!((p2 - expect).abs() < 1e-3 * expect, "{p2} vs {expect}");
        assert!((p4 / p2 - 4.0).abs() < 1e-3, "ratio {}", p4 / p2);
    }
}
