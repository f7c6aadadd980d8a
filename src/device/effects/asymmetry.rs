//! Direction-dependent yield force `Fy (1 + a·s)`, `s = d + w (sgn v − d)`: a misaligned piston, an uneven
//! bore or a seal that drags more one way (the seed paper's 70 N against 100 N at 14 A). `d` is the direction
//! function, `w` whether the scale follows the motion (a seal, 1) or the yield state (the fluid's path, 0).
//! Physics and sources: `docs/explanation/damper-models.md`.

use super::*;

/// Direction-dependent yield force, see the module documentation.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Asymmetry;

/// Index of the parameter in the effect's slice.
pub(crate) const FRACTION: usize = 0;

/// Index of the share of the asymmetry that follows the direction of motion.
pub(crate) const MOTION_SHARE: usize = 1;

const PARAMS: [ParamSpec; 2] = [
    ParamSpec::new(
        "asym_fraction",
        "1",
        // |a| < 1 keeps the yield force positive both ways; ±0.9 is a 19:1 ratio, beyond any working damper.
        -0.9,
        0.9,
        "yield force asymmetry: Fy(1 + a) for v > 0, Fy(1 - a) for v < 0 (paper, Section 4: 70 N vs 100 N at 14 A)",
    ),
    ParamSpec::new(
        "asym_motion_share",
        "1",
        0.0,
        1.0,
        "share of the asymmetry that switches with the direction of motion, sgn v (a seal's drag), rather than \
         with the yield state (the fluid's path); the two are one without hysteresis (absent from a parameter \
         file: 0)",
    )
    .absent_means(0.0),
];

impl Effect for Asymmetry {
    effect_constants!(
        "asymmetry",
        DirectionDependence,
        "Direction-dependent yield force from misalignment or seal drag: Fy(1 + a s), s = d + w (sgn v - d) \
         with d the direction function (the hysteresis state, or sgn v), so |F(+v)|/|F(-v)| = (1 + a)/(1 - a) on \
         the yield branches; the seed paper measured 70 N one way and 100 N the other at 14 A (a = -0.18). w \
         is the share that switches with the motion (a seal) rather than with the yield state (the fluid).",
        "|F| larger in one direction: a model without it has mean residual of opposite sign for v > 0 and v < 0 \
         relative to the force magnitude (a signed offset a·Fy on both yield branches), proportional to the \
         yield force and so growing linearly with current; zero at zero current if the seal friction is small",
    );

    /// A symmetric damper: the sign of the asymmetry is not known before the fit, and zero is the nested
    /// base model (the force is smooth in `a` there, so the fit moves off it in either direction). The share
    /// halfway, the data not yet asked (the force does not depend on it while `a = 0`; the fit frees it once
    /// `a` has moved).
    fn initial_guess(&self, _stats: &DataStats) -> Vec<f64> {
        vec![0.0, 0.5]
    }

    /// The paper's own asymmetry: 70 N with, 100 N against the positive direction, following the yield state.
    fn typical_params(&self, _stats: &DataStats) -> Vec<f64> {
        vec![(70.0 - 100.0) / (70.0 + 100.0), 0.0]
    }

    fn apply(&self, p: &[f64], _s: &[f64], inp: &Inputs, stage: &mut Stage) {
        let d = stage.direction;
        // `d + w (sgn v − d)`: exactly `d` where the two agree (no hysteresis), whatever `w`.
        let s = d + p[MOTION_SHARE] * (crate::device::bingham::sgn(inp.v_m_s) - d);
        let scale = 1.0 + p[FRACTION] * s;
        stage.yield_n *= scale;
        stage.yield_field_n *= scale;
    }
}

#[cfg(test)]
mod tests {
    use crate::device::effects::testkit::*;

    #[test]
    fn force_ratio_between_directions_is_one_plus_a_over_one_minus_a() {
        let m = model("bingham+asymmetry");
        let a = 0.25;
        let mut p = params(&m, &[("asym_fraction", a)]);
        p[2] = 0.0; // no viscous term: the yield branches alone
        let inputs = triangle(0.01, 0.05, 8.0, 1e-3, 2.0);
        let (up, down) = up_down(&m, &p, &inputs);
        let ratio = up.abs() / down.abs();
        assert!((ratio - (1.0 + a) / (1.0 - a)).abs() < 1e-9, "ratio {ratio}");
        // The paper's sign: negative a means more force in the negative direction.
        p[m.param_index("asym_fraction").expect("param")] = -0.18;
        let (up, down) = up_down(&m, &p, &inputs);
        assert!(down.abs() > up.abs() * 1.4, "70 N vs 100 N: {up} vs {down}");
    }

    #[test]
    fn direction_difference_grows_linearly_with_current() {
        let m = model("bingham+asymmetry");
        let a = 0.2;
        let p = params(&m, &[("asym_fraction", a)]);
        let diff = |i: f64| {
            let (up, down) = up_down(&m, &p, &triangle(0.01, 0.05, i, 1e-3, 2.0));
            up.abs() - down.abs()
        };
        let (d2, d6, d10) = (diff(2.0), diff(6.0), diff(10.0));
        // |F+| - |F-| = 2 a (fc0 + k i): equal increments for equal current steps, slope 2 a k.
        assert!(d2 > 0.0 && d10 > d6 && d6 > d2);
        assert!(
            ((d10 - d6) - (d6 - d2)).abs() < 1e-6 * d10,
            "not linear: {d2} {d6} {d10}"
        );
        let slope = (d10 - d2) / 8.0;
        assert!((slope - 2.0 * a * BASE[1]).abs() < 1e-6, "slope {slope} N/A");
    }

    #[test]
    fn without_hysteresis_the_motion_share_changes_nothing() {
        let m = model("bingham+asymmetry");
        let inputs = sine(0.01, 1.0, 5.0, 1e-3, 1.0);
        let force = |w: f64| {
            let p = params(&m, &[("asym_fraction", 0.2), ("asym_motion_share", w)]);
            m.simulate(&p, &inputs)
        };
        assert_eq!(force(0.0), force(1.0));
    }

    /// Just after a reversal the hysteresis state is still on the old branch: a seal's asymmetry (share 1)
    /// has already switched with the velocity, the fluid's (share 0) has not; once the state has crossed
    /// over, the two are the same force.
    #[test]
    fn after_a_reversal_a_seal_switches_with_the_motion_and_the_fluid_with_the_yield_state() {
        let m = model("bingham+hysteresis+asymmetry");
        let a = 0.2;
        let inputs = triangle(0.01, 0.05, 8.0, 1e-3, 0.8);
        let force = |w: f64| {
            let mut p = params(
                &m,
                &[
                    ("asym_fraction", a),
                    ("asym_motion_share", w),
                    ("hyst_x_yield_m", 1e-3),
                    ("hyst_v_yield_m_s", 0.0),
                ],
            );
            p[2] = 0.0; // no viscous term: the yield branch alone
            m.simulate(&p, &inputs)
        };
        let (fluid, seal) = (force(0.0), force(1.0));
        // The first sample moving down after the top at 0.2 s, and one 10 yield displacements later (the state
        // within 1e-4 of the new branch).
        let k = inputs.iter().position(|i| i.v_m_s < 0.0).expect("a reversal");
        let ratio = seal[k] / fluid[k];
        assert!(
            fluid[k] > 0.0 && (ratio - (1.0 - a) / (1.0 + a)).abs() < 0.01,
            "at the reversal {} vs {}: ratio {ratio}",
            seal[k],
            fluid[k]
        );
        let mid = k + 200;
        assert!(inputs[mid].v_m_s < 0.0);
        assert!(
            (seal[mid] - fluid[mid]).abs() < 1e-4 * fluid[mid].abs() && fluid[mid] < 0.0,
            "on the branch {} vs {}",
            seal[mid],
            fluid[mid]
        );
    }

    #[test]
    fn zero_fraction_is_the_symmetric_base_model() {
        let m = model("bingham+asymmetry");
        let base = model("bingham");
        let inputs = sine(0.01, 1.0, 5.0, 1e-3, 1.0);
        let p = params(&m, &[("asym_fraction", 0.0)]);
        assert_eq!(m.simulate(&p, &inputs), base.simulate(&BASE, &inputs));
    }
}
