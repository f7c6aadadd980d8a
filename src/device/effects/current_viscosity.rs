//! Post-yield damping that rises with the coil current.
//!
//! Physics: in the post-yield (flow) regime the field-aligned particle chains keep breaking and re-forming,
//! so the apparent plastic viscosity of an MR fluid grows with the field, not only the yield stress; a
//! Bingham model with a constant `C0` (Eq. 2) then fits the slope of the force–velocity curve at one current
//! and misses it at others.
//!
//! Equation (the current-dependent damping coefficient of Spencer et al. 1997, J. Eng. Mech. 123(3),
//! `c0 = c0a + c0b u`, with `u` the filtered excitation; here the base's lagged excitation `h`):
//!
//! `C(h) = C0 + c1 · |h|`,  `F = Fy d + C(h) v + …`
//!
//! with `c1` = `visc_c1_n_s_per_m_per_a` ≥ 0. `C0` stays the base's damping at zero current.

use crate::device::effect::{Effect, EffectStage, Inputs, Stage};
use crate::device::params::{DataStats, ParamSpec};

use super::Scales;

/// Damping rising with current, see the module documentation.
#[derive(Debug, Clone, Copy, Default)]
pub struct CurrentViscosity;

/// Index of the parameter in the effect's slice.
pub const C1: usize = 0;

const PARAMS: [ParamSpec; 1] = [ParamSpec::new(
    "visc_c1_n_s_per_m_per_a",
    "N·s/m/A",
    // The field thickens the fluid, it does not thin it: c1 ≥ 0 keeps the damping positive at any current.
    0.0,
    f64::INFINITY,
    "increase of post-yield damping per ampere of lagged coil current, C = C0 + c1|h| (Spencer et al. 1997)",
)];

impl Effect for CurrentViscosity {
    fn name(&self) -> &'static str {
        "current_viscosity"
    }

    fn describe(&self) -> &'static str {
        "Post-yield damping rising with current (field-thickened plastic viscosity): C = C0 + c1|h| with h the \
         lagged excitation, as Spencer et al. 1997 made c0 a linear function of the filtered command."
    }

    fn stage(&self) -> EffectStage {
        EffectStage::Damping
    }

    fn params(&self) -> &'static [ParamSpec] {
        &PARAMS
    }

    /// Adds 2 % of the force scale at the largest velocity and current: a small, non-zero start.
    fn initial_guess(&self, stats: &DataStats) -> Vec<f64> {
        let s = Scales::of(stats);
        vec![0.02 * s.force_n / (s.v_m_s * s.i_a)]
    }

    /// Adds 25 % of the force scale at the largest velocity and current.
    fn typical_params(&self, stats: &DataStats) -> Vec<f64> {
        let s = Scales::of(stats);
        vec![0.25 * s.force_n / (s.v_m_s * s.i_a)]
    }

    fn apply(&self, p: &[f64], _s: &[f64], _inp: &Inputs, stage: &mut Stage) {
        stage.damping_n_s_per_m += p[C1] * stage.current_a.abs();
    }

    fn residual_signature(&self) -> &'static str {
        "residual slope versus velocity that changes with current: a constant-C0 model is too steep at low \
         current and too flat at high current; the residual is odd in velocity, zero at v = 0, and its slope \
         grows linearly with current"
    }
}

#[cfg(test)]
mod tests {
    use crate::device::effects::testkit::*;

    /// Post-yield slope dF/dv at a current, from two triangles at different speeds (same yield branch).
    fn slope_at(i: f64, c1: f64) -> f64 {
        let m = model("bingham+current_viscosity");
        let p = params(&m, &[("visc_c1_n_s_per_m_per_a", c1)]);
        let f_at = |v: f64| {
            let inputs = triangle(0.01, v, i, 1e-3, 1.0);
            let f = m.simulate(&p, &inputs);
            mean_where(&f, &inputs, |k| k.v_m_s > 0.0)
        };
        (f_at(0.08) - f_at(0.02)) / 0.06
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

    #[test]
    fn yield_force_is_unchanged() {
        // The intercept of the post-yield line at v = 0 stays the Bingham yield force.
        let m = model("bingham+current_viscosity");
        let p = params(&m, &[("visc_c1_n_s_per_m_per_a", 80.0)]);
        let i = 6.0;
        let f_at = |v: f64| {
            let inputs = triangle(0.01, v, i, 1e-3, 1.0);
            mean_where(&m.simulate(&p, &inputs), &inputs, |k| k.v_m_s > 0.0)
        };
        let intercept = f_at(0.02) - 0.02 * (f_at(0.08) - f_at(0.02)) / 0.06;
        assert!(
            (intercept - (BASE[0] + BASE[1] * i)).abs() < 1e-6 * intercept,
            "intercept {intercept}"
        );
    }
}
