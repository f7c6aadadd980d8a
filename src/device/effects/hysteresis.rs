//! Pre-yield hysteresis: the direction function `sgn v` of Eq. (2) becomes an internal state `z` that
//! follows the displacement with a Dahl / Bouc–Wen law.
//!
//! Physics: below its yield stress the MR fluid (and the seals) behave as an elastic-plastic solid, so after
//! a reversal the force does not jump from `-Fy` to `+Fy` as Eq. (2) says: it travels back along a steep
//! pre-yield branch over a small displacement before it yields again. In a force–velocity plot this is the
//! familiar loop around `v = 0`; the force lags the velocity reversal.
//!
//! Equation (Dahl 1968, "A solid friction model", Aerospace Corp. TOR-0158(3107-18)-1; the Bouc–Wen form
//! used for MR dampers by Spencer, Dyke, Sain & Carlson 1997, J. Eng. Mech. 123(3), with exponent `n = 1`,
//! `γ = 0`, `β = A = 1/x_y`):
//!
//! `dz/dx = (sgn(dx) − z) / x_y`,  force `F = Fy · z + C0 v + …`
//!
//! where `x_y` = `hyst_x_yield_m` is the characteristic yield displacement: after a reversal the force
//! crosses zero `x_y ln 2` later and reaches 90 % of the yield force after `x_y ln 20 ≈ 3 x_y`. The
//! pre-yield stiffness is `Fy / x_y` at the reversal. The hysteretic force scale is the base's yield force
//! (no second gain), and the raw Bouc–Wen `A, β, γ, n`, whose products are not identifiable from force data,
//! collapse into the one displacement.
//!
//! Integration: the law is rate-independent, so for a monotone displacement increment `dx` over a step it
//! has the exact solution `z₁ = s − (s − z₀) e^{−|dx|/x_y}`, `s = sgn dx`: a convex combination of `z₀` and
//! `±1`, so `|z| ≤ 1` holds at any step size and any `x_y`, and as `x_y → 0` it becomes `sgn(dx)`, the
//! Bingham model.

use crate::device::effect::{Effect, EffectStage, Inputs, Stage, Step};
use crate::device::params::{DataStats, ParamSpec};

use super::Scales;

/// Pre-yield hysteresis (Dahl / Bouc–Wen `n = 1`), see the module documentation.
#[derive(Debug, Clone, Copy, Default)]
pub struct Hysteresis;

/// Index of the parameter in the effect's slice.
pub const X_YIELD: usize = 0;

const PARAMS: [ParamSpec; 1] = [ParamSpec::new(
    "hyst_x_yield_m",
    "m",
    // 0.1 µm: below any displacement sensor's resolution, i.e. the Bingham limit; 10 mm: beyond any pre-yield
    // deformation of a fluid gap or seal (estimates: pre-yield displacements of MR dampers are 0.01–1 mm).
    1e-7,
    0.01,
    "characteristic pre-yield displacement: the force crosses zero x_y·ln2 after a reversal (Dahl 1968)",
)];

/// One exact step of `dz/dx = (sgn dx − z)/x_y` over a monotone increment `dx`.
pub fn dahl_step(z: f64, dx_m: f64, x_yield_m: f64) -> f64 {
    if dx_m == 0.0 {
        return z;
    }
    let s = dx_m.signum();
    let decay = if x_yield_m > 0.0 {
        (-dx_m.abs() / x_yield_m).exp()
    } else {
        0.0
    };
    (s - (s - z) * decay).clamp(-1.0, 1.0)
}

impl Effect for Hysteresis {
    fn name(&self) -> &'static str {
        "hysteresis"
    }

    fn describe(&self) -> &'static str {
        "Pre-yield visco-elastic hysteresis: sgn(v) of Eq. (2) is replaced by a state z in [-1, 1] obeying \
         the Dahl law dz/dx = (sgn dx - z)/x_y (Dahl 1968; Bouc-Wen with n = 1 as in Spencer et al. 1997), so \
         the force ramps from -Fy to +Fy over a few yield displacements x_y after each reversal."
    }

    fn stage(&self) -> EffectStage {
        EffectStage::Direction
    }

    fn params(&self) -> &'static [ParamSpec] {
        &PARAMS
    }

    /// 2 % of the largest displacement: a loop the data can see, so the gradient is informative.
    fn initial_guess(&self, stats: &DataStats) -> Vec<f64> {
        vec![0.02 * Scales::of(stats).x_m]
    }

    /// 6 % of the largest displacement: the force reaches 90 % of yield 18 % of an amplitude after a reversal.
    fn typical_params(&self, stats: &DataStats) -> Vec<f64> {
        vec![0.06 * Scales::of(stats).x_m]
    }

    fn n_states(&self) -> usize {
        1
    }

    /// A test starts on the yield branch of its first motion (`z = sgn v`), at rest with `z = 0`.
    fn init_states(&self, _p: &[f64], s: &mut [f64], inp: &Inputs, _stage: &Stage) {
        s[0] = crate::device::bingham::sgn(inp.v_m_s);
    }

    fn apply(&self, _p: &[f64], s: &[f64], _inp: &Inputs, stage: &mut Stage) {
        stage.direction = s[0];
    }

    fn advance(&self, p: &[f64], s: &mut [f64], _inp: &Inputs, _stage: &Stage, _force_n: f64, step: Step) {
        s[0] = dahl_step(s[0], step.dx_m, p[X_YIELD]);
    }

    fn residual_signature(&self) -> &'static str {
        "loops in force-velocity near v = 0: after each velocity reversal the measured force is still on the old \
         branch for a small displacement (a few x_y), so the residual of a model without it is a spike of \
         about 2·Fy that decays over ~3 x_y of travel after every reversal, largest at high current"
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::effects::testkit::*;

    /// Force at the sample nearest to `x` on the rising branch (v > 0) of the last cycle.
    fn loop_force(inputs: &[Inputs], f: &[f64], x: f64, rising: bool) -> f64 {
        let last = &inputs[inputs.len() / 2..];
        let k = last
            .iter()
            .enumerate()
            .filter(|(_, i)| (i.v_m_s > 0.0) == rising)
            .min_by(|a, b| (a.1.x_m - x).abs().total_cmp(&(b.1.x_m - x).abs()))
            .map(|(k, _)| k + inputs.len() / 2)
            .expect("samples");
        f[k]
    }

    #[test]
    fn force_lags_the_reversal_by_about_the_yield_displacement() {
        // Triangle at constant speed, no viscosity: after the reversal at x = -A the force is
        // Fy (1 - 2 e^{-(x + A)/x_y}), crossing zero x_y ln 2 after the reversal.
        let m = model("bingham+hysteresis");
        let xy = 2e-4;
        let mut p = params(&m, &[("hyst_x_yield_m", xy)]);
        p[2] = 0.0;
        let (amp, i) = (0.005, 4.0);
        let inputs = triangle(amp, 0.02, i, 1e-4, 2.0);
        let f = m.simulate(&p, &inputs);
        let fy = BASE[0] + BASE[1] * i;
        let f_zero = loop_force(&inputs, &f, -amp + xy * 2f64.ln(), true);
        assert!(
            f_zero.abs() < 0.02 * fy,
            "force {f_zero} N at x_y ln 2 after reversal, yield {fy}"
        );
        let f_3 = loop_force(&inputs, &f, -amp + 3.0 * xy, true);
        let expect = fy * (1.0 - 2.0 * (-3.0f64).exp());
        assert!((f_3 - expect).abs() < 0.02 * fy, "at 3 x_y: {f_3} vs {expect}");
        // Far from the reversal the force is the yield force, as in Bingham.
        let f_mid = loop_force(&inputs, &f, 0.0, true);
        assert!((f_mid - fy).abs() < 1e-6 * fy);
    }

    #[test]
    fn loop_in_force_velocity_dissipates_positive_energy_near_zero_velocity() {
        let m = model("bingham+hysteresis");
        let p = params(&m, &[("hyst_x_yield_m", 5e-4)]);
        let inputs = sine(0.005, 2.0, 5.0, 1e-4, 1.5);
        let f = m.simulate(&p, &inputs);
        // At v ≈ 0 after a rise (x at +A, about to go down) the force is still positive: it lags the reversal.
        let at_top = loop_force(&inputs, &f, 0.005, false);
        let at_bottom = loop_force(&inputs, &f, -0.005, true);
        assert!(
            at_top > 0.5 * (BASE[0] + 5.0 * BASE[1]),
            "force at the top {at_top}"
        );
        assert!(
            at_bottom < -0.5 * (BASE[0] + 5.0 * BASE[1]),
            "force at the bottom {at_bottom}"
        );
        // Energy dissipated over the last full cycle (∮F dx) is positive.
        let period = 0.5;
        let start = inputs.iter().position(|i| i.t_s >= 1.0).expect("samples");
        let end = inputs
            .iter()
            .position(|i| i.t_s >= 1.0 + period)
            .expect("samples");
        let w: f64 = (start..end)
            .map(|k| 0.5 * (f[k] + f[k + 1]) * (inputs[k + 1].x_m - inputs[k].x_m))
            .sum();
        assert!(w > 0.0, "cycle work {w} J");
    }

    #[test]
    fn reduces_to_bingham_as_the_yield_displacement_vanishes() {
        let hyst = model("bingham+hysteresis");
        let base = model("bingham");
        let inputs = sine(0.01, 1.0, 6.0, 1e-3, 2.0);
        let fb = base.simulate(&BASE, &inputs);
        let p = params(&hyst, &[("hyst_x_yield_m", 1e-7)]);
        let fh = hyst.simulate(&p, &inputs);
        // Identical except within a few samples of each reversal, where z follows the sign of the last
        // displacement step and sgn v the sign of the present velocity.
        let (amp, w, dt) = (0.01, 2.0 * std::f64::consts::PI, 1e-3);
        let near_reversal = 3.0 * dt * amp * w * w; // |v| within three samples of a reversal
        let mut differ = 0;
        for ((b, h), i) in fb.iter().zip(&fh).zip(&inputs) {
            if (b - h).abs() > 1e-6 {
                differ += 1;
                assert!(
                    i.v_m_s.abs() < near_reversal,
                    "differs at t = {} far from a reversal",
                    i.t_s
                );
            }
        }
        assert!(differ <= 12, "{differ} samples differ from Bingham (4 reversals)");
    }

    #[test]
    fn state_stays_in_unit_interval_at_any_step_size() {
        for dt in [1e-5, 1e-4, 1e-3, 5e-3, 2e-2] {
            for xy in [1e-7, 1e-5, 1e-3, 1e-2] {
                let inputs = sine(0.02, 3.0, 10.0, dt, 1.0);
                let mut z = 0.0;
                for w in inputs.windows(2) {
                    z = dahl_step(z, w[1].x_m - w[0].x_m, xy);
                    assert!((-1.0..=1.0).contains(&z), "z = {z} at dt {dt}, x_y {xy}");
                }
            }
        }
    }

    #[test]
    fn one_big_step_equals_many_small_ones_along_a_monotone_path() {
        // Rate independence and exactness: the state depends only on the path travelled.
        let xy = 3e-4;
        let mut z_fine = -1.0;
        for _ in 0..1000 {
            z_fine = dahl_step(z_fine, 1e-6, xy);
        }
        let z_coarse = dahl_step(-1.0, 1e-3, xy);
        assert!((z_fine - z_coarse).abs() < 1e-12);
        // And matches the closed form z = 1 - 2 e^{-x/x_y}.
        assert!((z_coarse - (1.0 - 2.0 * (-1e-3f64 / xy).exp())).abs() < 1e-12);
    }
}
