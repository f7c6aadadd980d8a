//! Post-yield damping that rises with the coil current, `C(h) = C0 + c1 |h| (|h| / 1 A)^(n−1)` (Spencer et
//! al. 1997's `c0 = c0a + c0b u` for `n = 1`): the plastic viscosity of an MR fluid grows with the field.
//! Physics and sources: `docs/explanation/damper-models.md`.

use super::*;

/// Damping rising with current, see the module documentation.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct CurrentViscosity;

/// Indices of the parameters in the effect's slice.
pub(crate) const C1: usize = 0;
pub(crate) const EXPONENT: usize = 1;

const PARAMS: [ParamSpec; 2] = [
    ParamSpec::non_negative(
        "visc_c1_n_s_per_m_per_a",
        "N·s/m/A",
        // The field thickens the fluid, it does not thin it: c1 ≥ 0 keeps the damping positive at any current.
        "increase of post-yield damping per ampere of lagged coil current at 1 A, C = C0 + c1|h|(|h|/1 A)^(n-1) (Spencer et al. 1997 for n = 1)",
    ),
    ParamSpec::new(
        "visc_exponent",
        "1",
        // 0.25–4: from a rise that is nearly all at the lowest current (saturated) to one that is nearly all at
        // the highest (the square-law of dipole interaction, and more); 1 is linear.
        0.25,
        4.0,
        "exponent n of the damping's rise with current (1: linear, 2: with the square of the field)",
    ),
];

impl Effect for CurrentViscosity {
    effect_constants!(
        "current_viscosity",
        Damping,
        "Post-yield damping rising with current (field-thickened plastic viscosity): C = C0 + c1|h|(|h|/1 A)^(n-1) \
         with h the lagged excitation; n = 1 is Spencer et al. 1997's linear c0 = c0a + c0b u.",
        "residual slope versus velocity that changes with current: a constant-C0 model is too steep at low \
         current and too flat at high current; the residual is odd in velocity, zero at v = 0, and its slope \
         grows with current (linearly, or faster or slower)",
    );

    // Adds 2 % (a small, non-zero start) and 25 % of the force scale at the largest velocity and current,
    // linearly.
    scaled_guesses!(
        s => vec![0.02 * s.force_n / (s.v_m_s * s.i_a), 1.0],
        vec![0.25 * s.force_n / (s.v_m_s * s.i_a), 1.0],
    );

    fn apply(&self, p: &[f64], _s: &[f64], _inp: &Inputs, stage: &mut Stage) {
        let h = stage.current_a.abs();
        let rise = if p[EXPONENT] == 1.0 || h == 0.0 {
            h
        } else {
            h.powf(p[EXPONENT])
        };
        stage.damping_n_s_per_m += p[C1] * rise;
    }
}

#[cfg(test)]
mod tests {
    use crate::device::effects::testkit::*;

    /// Post-yield slope dF/dv at a current, from two triangles at different speeds (same yield branch).
    fn slope_at(i: f64, c1: f64) -> f64 {
        let m = model("bingham+current_viscosity");
        let p = params(&m, &[("visc_c1_n_s_per_m_per_a", c1)]);
        (rising_mean(&m, &p, 0.08, i) - rising_mean(&m, &p, 0.02, i)) / 0.06
    }

    #[test]
    fn damping_slope_grows_linearly_with_current() {
        let c1 = 40.0;
        let s0 = slope_at(0.0, c1);
        let s5 = slope_at(5.0, c1);
        let s10 = slope_at(10.0, c1);
        assert!(
            (s0 - BASE[2]).abs() < 1e-6 * BASE[2],
            "zero-current slope {s0} is C0"
        );
        assert!(
            (s5 - (BASE[2] + 5.0 * c1)).abs() < 1e-6 * s5,
            "slope at 5 A: {s5}"
        );
        assert!(
            ((s10 - s5) - (s5 - s0)).abs() < 1e-6 * s10,
            "not linear: {s0} {s5} {s10}"
        );
    }

    /// With `n = 2` the added slope is `c1 h²`: 4× from 5 A to 10 A (linear: 2×).
    #[test]
    fn damping_rise_follows_the_exponent() {
        let m = model("bingham+current_viscosity");
        let p = params(&m, &[("visc_c1_n_s_per_m_per_a", 3.0), ("visc_exponent", 2.0)]);
        let slope = |i: f64| (rising_mean(&m, &p, 0.08, i) - rising_mean(&m, &p, 0.02, i)) / 0.06 - BASE[2];
        let (a5, a10) = (slope(5.0), slope(10.0));
        assert!((a5 - 3.0 * 25.0).abs() < 1e-6 * a5, "added slope at 5 A: {a5}");
        assert!((a10 / a5 - 4.0).abs() < 1e-6, "10 A vs 5 A: {}", a10 / a5);
    }

    #[test]
    fn yield_force_is_unchanged() {
        // The intercept of the post-yield line at v = 0 stays the Bingham yield force.
        let m = model("bingham+current_viscosity");
        let p = params(&m, &[("visc_c1_n_s_per_m_per_a", 80.0)]);
        let i = 6.0;
        let f_at = |v: f64| rising_mean(&m, &p, v, i);
        let intercept = f_at(0.02) - 0.02 * (f_at(0.08) - f_at(0.02)) / 0.06;
        assert!(
            (intercept - (BASE[0] + BASE[1] * i)).abs() < 1e-6 * intercept,
            "intercept {intercept}"
        );
    }
}
