//! The modified Bouc–Wen model of Spencer, Dyke, Sain and Carlson (J. Eng. Mech. 123(3), 1997), the
//! field's standard, as a second base model. Its force is assembled as a yield force `r α zₛ`, a direction
//! `z/zₛ`, a damping `r c0` and an additive force, so effects compose with it as with the Bingham base; the
//! stiff `z` equation is integrated by Runge–Kutta on substeps set from its Jacobian bound (deterministic on
//! any thread). Equations and choices: `docs/explanation/damper-models.md`.

use super::bingham::saturate;
use super::effect::{Inputs, Stage, Step};
use super::params::{DataStats, ParamSpec};

pub(crate) const ALPHA_A: usize = 0;
pub(crate) const ALPHA_B: usize = 1;
pub(crate) const C0A: usize = 2;
pub(crate) const C0B: usize = 3;
pub(crate) const C1A: usize = 4;
pub(crate) const C1B: usize = 5;
pub(crate) const K0: usize = 6;
pub(crate) const K1: usize = 7;
pub(crate) const X0: usize = 8;
pub(crate) const BETA: usize = 9;
pub(crate) const GAMMA: usize = 10;
/// Index of the Bouc–Wen `A`.
pub const A: usize = 11;
/// Index of the Bouc–Wen exponent `n`.
pub const N: usize = 12;
/// Index of the command filter's time constant `1/η`.
pub const TAU: usize = 13;

/// Parameters, in vector order (SI; the 1997 paper's are in cm and V).
pub const PARAMS: [ParamSpec; 14] = [
    ParamSpec::non_negative(
        "spencer_alpha_a_n_per_m",
        "N/m",
        "Bouc–Wen gain α at zero command (α = αa + αb u)",
    ),
    ParamSpec::non_negative(
        "spencer_alpha_b_n_per_m_a",
        "N/(m·A)",
        "Bouc–Wen gain α per ampere of filtered command",
    ),
    ParamSpec::non_negative(
        "spencer_c0a_n_s_per_m",
        "N·s/m",
        "viscous damping c0 at large velocity, zero command",
    ),
    ParamSpec::non_negative(
        "spencer_c0b_n_s_per_m_a",
        "N·s/(m·A)",
        "c0 per ampere of filtered command",
    ),
    ParamSpec::new(
        "spencer_c1a_n_s_per_m",
        "N·s/m",
        1e-6,
        f64::INFINITY,
        "dashpot c1 that gives the roll-off at low velocity, zero command",
    ),
    ParamSpec::non_negative(
        "spencer_c1b_n_s_per_m_a",
        "N·s/(m·A)",
        "c1 per ampere of filtered command",
    ),
    ParamSpec::non_negative(
        "spencer_k0_n_per_m",
        "N/m",
        "stiffness k0 at large velocity (in series with c1)",
    ),
    ParamSpec::non_negative("spencer_k1_n_per_m", "N/m", "accumulator stiffness k1"),
    ParamSpec::new(
        "spencer_x0_m",
        "m",
        -1.0,
        1.0,
        "initial displacement x0 of the accumulator spring k1",
    ),
    ParamSpec::non_negative("spencer_beta_per_m_n", "m^-n", "Bouc–Wen shape β"),
    ParamSpec::non_negative("spencer_gamma_per_m_n", "m^-n", "Bouc–Wen shape γ"),
    ParamSpec::non_negative("spencer_a", "1", "Bouc–Wen gain A"),
    ParamSpec::new("spencer_n", "1", 1.0, 8.0, "Bouc–Wen exponent n"),
    ParamSpec::new(
        "spencer_tau_s",
        "s",
        0.0,
        1.0,
        "time constant 1/η of the first-order filter on the command",
    ),
];

/// States: the filtered command `u` (A), the internal displacement `y` (m) and the evolutionary variable
/// `z` (m).
pub(crate) const N_STATES: usize = 3;

/// Parameters the states depend on: all but `k1` and `x0`, which only add a force.
pub(crate) const STATE_PARAMS: [usize; 12] =
    [ALPHA_A, ALPHA_B, C0A, C0B, C1A, C1B, K0, BETA, GAMMA, A, N, TAU];
/// The parameters the force is linear in with the states held: `k1` (and `k1 x0` with it).
pub(crate) const LINEAR_GAINS: [usize; 1] = [K1];
/// The command filter's time constant: it acts only where the command changes.
pub(crate) const LAG_PARAMS: [usize; 1] = [TAU];

/// Most RK4 substeps in one sample interval: a `z` transition 64 times shorter than a sample, which the
/// samples cannot tell from a faster one (the 1997 device needs 46 at 500 Hz), so a fit drifting towards an
/// ever thinner yield transition stops paying for a difference the data do not hold.
const MAX_SUBSTEPS: usize = 64;

/// The bound of `|z|`, `(A/(β+γ))^(1/n)`, or 1 m where `β + γ = 0` (no bound; the direction is then `z`).
pub(crate) fn z_scale(p: &[f64]) -> f64 {
    let bg = p[BETA] + p[GAMMA];
    if bg > 0.0 && p[A] > 0.0 {
        let s = (p[A] / bg).powf(1.0 / p[N]);
        if s.is_finite() && s > 0.0 {
            return s;
        }
    }
    1.0
}

/// `a^n` for `a ≥ 0`, exact and fast for the usual `n = 2` and `n = 1`.
fn pow_n(a: f64, n: f64) -> f64 {
    if n == 2.0 {
        a * a
    } else if n == 1.0 {
        a
    } else {
        a.powf(n)
    }
}

/// `(α, c0, c1)` at the filtered command `u`.
fn gains(p: &[f64], u: f64) -> (f64, f64, f64) {
    let a = u.abs();
    (
        p[ALPHA_A] + p[ALPHA_B] * a,
        p[C0A] + p[C0B] * a,
        p[C1A] + p[C1B] * a,
    )
}

/// States at the first sample: the filter settled at the first command, `y = x` (the k0 spring relaxed),
/// and `z` at its bound in the direction of motion (0 at rest), as after a long stroke that way.
pub(crate) fn init_states(p: &[f64], s: &mut [f64], first: &Inputs, limit_a: f64) {
    s[0] = saturate(first.current_cmd_a, limit_a);
    s[1] = first.x_m;
    s[2] = super::bingham::sgn(first.v_m_s) * z_scale(p);
}

/// The force assembly at one sample (see the module's comment).
pub fn stage(p: &[f64], s: &[f64], inp: &Inputs) -> Stage {
    let (u, y, z) = (s[0], s[1], s[2]);
    let (alpha, c0, c1) = gains(p, u);
    let r = c1 / (c0 + c1);
    let zs = z_scale(p);
    Stage {
        current_a: u,
        yield_n: r * alpha * zs,
        yield_field_n: r * p[ALPHA_B] * u.abs() * zs,
        direction: z / zs,
        damping_n_s_per_m: r * c0,
        extra_n: r * p[K0] * (inp.x_m - y) + p[K1] * (inp.x_m - p[X0]),
    }
}

/// `(ẏ, ż)` at displacement `x`, velocity `xd` and filtered command `u`.
fn rates(p: &[f64], x: f64, xd: f64, u: f64, y: f64, z: f64) -> (f64, f64) {
    let (alpha, c0, c1) = gains(p, u);
    let yd = (alpha * z + c0 * xd + p[K0] * (x - y)) / (c0 + c1);
    let d = xd - yd;
    let az = z.abs();
    let zn = pow_n(az, p[N]);
    // −γ |d| z |z|^(n−1) = −γ |d| sgn(z) |z|^n
    let zd = -p[GAMMA] * d.abs() * z.signum() * zn - p[BETA] * d * zn + p[A] * d;
    (yd, if z == 0.0 { p[A] * d } else { zd })
}

/// RK4 substeps for a step of `h_s` from state `s` towards the command `cmd` at piston speed `xd`:
/// `ceil(h λ)`, `λ` a bound of the `(y, z)` equations' stiffness at the start of the step (the `z`
/// equation's own Jacobian with `|z|` at least at its bound, plus the coupling through `ẏ`), at most
/// [`MAX_SUBSTEPS`].
fn substeps(p: &[f64], s: &[f64], inp: &Inputs, cmd: f64, xd: f64, h_s: f64) -> usize {
    let (u0, y, z) = (s[0], s[1], s[2]);
    let (alpha, c0, c1) = gains(p, u0.abs().max(cmd.abs()));
    let den = c0 + c1;
    let (yd0, _) = rates(p, inp.x_m, xd, u0, y, z);
    let dmax = xd.abs() + yd0.abs() + alpha * z_scale(p).max(z.abs()) / den;
    let zb = z_scale(p).max(z.abs());
    let bg = p[BETA] + p[GAMMA];
    let lambda =
        p[N] * bg * dmax * pow_n(zb, p[N] - 1.0) + (p[A] + bg * pow_n(zb, p[N])) * alpha / den + p[K0] / den;
    if lambda.is_finite() {
        ((h_s * lambda).ceil() as usize).clamp(1, MAX_SUBSTEPS)
    } else {
        MAX_SUBSTEPS
    }
}

/// Advance `(u, y, z)` from this sample to the next: the command held over the step, the displacement
/// moving linearly by `step.dx_m` (its mean velocity), `u` exact, `(y, z)` by RK4 on substeps.
pub fn advance(p: &[f64], s: &mut [f64], inp: &Inputs, limit_a: f64, step: Step) {
    let h_all = step.dt_s;
    if h_all.is_nan() || h_all <= 0.0 {
        return;
    }
    let cmd = saturate(inp.current_cmd_a, limit_a);
    let u0 = s[0];
    let tau = p[TAU];
    let u_at = |t: f64| {
        if tau <= 0.0 {
            cmd
        } else {
            cmd + (u0 - cmd) * (-t / tau).exp()
        }
    };
    let xd = step.dx_m / h_all;
    let x_at = |t: f64| inp.x_m + xd * t;
    let (mut y, mut z) = (s[1], s[2]);
    let n_sub = substeps(p, s, inp, cmd, xd, h_all);
    let h = h_all / n_sub as f64;
    for j in 0..n_sub {
        let t = j as f64 * h;
        let (um, u1, u2) = (u_at(t), u_at(t + 0.5 * h), u_at(t + h));
        let (xm, x1, x2) = (x_at(t), x_at(t + 0.5 * h), x_at(t + h));
        let (k1y, k1z) = rates(p, xm, xd, um, y, z);
        let (k2y, k2z) = rates(p, x1, xd, u1, y + 0.5 * h * k1y, z + 0.5 * h * k1z);
        let (k3y, k3z) = rates(p, x1, xd, u1, y + 0.5 * h * k2y, z + 0.5 * h * k2z);
        let (k4y, k4z) = rates(p, x2, xd, u2, y + h * k3y, z + h * k3z);
        y += h / 6.0 * (k1y + 2.0 * k2y + 2.0 * k3y + k4y);
        z += h / 6.0 * (k1z + 2.0 * k2z + 2.0 * k3z + k4z);
    }
    s[0] = u_at(h_all);
    s[1] = y;
    s[2] = z;
}

/// Starting values from the data's linear Bingham estimate: `A = 1`, `n = 2`, `β = γ` with `z`'s bound at a
/// fiftieth of the largest displacement, `α zₛ` the yield force, `c1` ten times the yield force over the rms
/// velocity, the springs and current gains at small fractions of their scales, the filter at a few samples.
/// No parameter starts on its bound of 0: the fit searches a logarithm of each (`ident::fit`), where a start
/// on the bound would stay there.
pub fn initial_guess(stats: &DataStats) -> Vec<f64> {
    let d = (0.02 * stats.x_max_m).max(1e-6);
    let bg = 1.0 / (d * d);
    let c0 = stats.c0_n_s_per_m.max(1e-3);
    let (fy0, gain) = (stats.fc0_n.max(0.0), stats.fc_gain_n_per_a.max(0.0));
    let i_ref = stats.i_max_a.max(1e-3);
    let fy = (fy0 + gain * stats.i_mean_a).max(1e-3);
    let v = stats.v_rms_m_s.max(1e-6);
    // c1 = 10 (fy0 + gain i) / v, at least ten times c0 at every command.
    let (c1a, c1b) = ((10.0 * fy0 / v).max(10.0 * c0).max(1.0), 10.0 * gain / v);
    let r = c1a / (c0 + c1a);
    let x = stats.x_max_m.max(1e-6);
    let lag = (5.0 * stats.dt_s).clamp(1e-4, 0.1);
    vec![
        fy0.max(0.01 * fy) / (r * d),
        gain.max(0.01 * fy / i_ref) / (r * d),
        c0 / r,
        0.1 * c0 / i_ref,
        c1a,
        c1b.max(0.01 * c1a / i_ref),
        0.1 * fy / x,
        0.01 * stats.f_rms_n.max(fy) / x,
        0.0,
        0.5 * bg,
        0.5 * bg,
        1.0,
        2.0,
        lag,
    ]
}

/// The 1997 paper's fitted parameters (its Table 1, voltage read as the command), converted to SI.
pub const SPENCER_1997: [f64; 14] = [
    14_000.0,    // αa = 140 N/cm
    69_500.0,    // αb = 695 N/(cm·V)
    2_100.0,     // c0a = 21.0 N·s/cm
    3_500.0,     // c0b = 3.50 N·s/(cm·V)
    28_300.0,    // c1a = 283 N·s/cm
    295_000.0,   // c1b = 2950 N·s/(cm·V)
    4_690.0,     // k0 = 46.9 N/cm
    500.0,       // k1 = 5.00 N/cm
    0.143,       // x0 = 14.3 cm
    3.63e6,      // β = 363 cm⁻²
    3.63e6,      // γ = 363 cm⁻²
    301.0,       // A
    2.0,         // n
    1.0 / 190.0, // η = 190 s⁻¹
];

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(amp: f64, f_hz: f64, rate: f64, secs: f64, i: f64) -> Vec<Inputs> {
        let w = std::f64::consts::TAU * f_hz;
        (0..(secs * rate) as usize)
            .map(|k| {
                let t = k as f64 / rate;
                Inputs {
                    t_s: t,
                    x_m: amp * (w * t).sin(),
                    v_m_s: amp * w * (w * t).cos(),
                    a_m_s2: 0.0,
                    current_cmd_a: i,
                }
            })
            .collect()
    }

    /// Force at every sample of `inputs`, the base alone.
    fn run(p: &[f64], inputs: &[Inputs]) -> Vec<f64> {
        crate::device::effects::testkit::model("spencer").simulate(p, inputs)
    }

    /// The substep cap bounds only what a fit explores: the 1997 device on its Fig. 5 test (2.5 Hz, 1.5
    /// cm) at its highest command, 2.25 V, is resolved below the cap at 500 Hz, the slowest rate of a
    /// feel-damper record, where a sample spans the most of its yield transition, and needs substeps there.
    #[test]
    fn the_papers_device_is_resolved_below_the_substep_cap() {
        let p = SPENCER_1997;
        let inputs = sine(0.015, 2.5, 500.0, 0.8, 2.25);
        let mut s = [0.0; N_STATES];
        init_states(&p, &mut s, &inputs[0], 14.0);
        let mut most = 0;
        for w in inputs.windows(2) {
            let st = Step {
                dt_s: w[1].t_s - w[0].t_s,
                dx_m: w[1].x_m - w[0].x_m,
            };
            most = most.max(substeps(&p, &s, &w[0], 2.25, st.dx_m / st.dt_s, st.dt_s));
            advance(&p, &mut s, &w[0], 14.0, st);
        }
        assert!(most < MAX_SUBSTEPS, "{most} substeps");
        assert!(most > 8, "a stiff model needs substeps at 500 Hz: {most}");
    }

    /// The paper's device at 2.5 Hz and 1.5 cm (its Fig. 5 test), at 0 and 1 V, logged at 3 kHz where the
    /// z equation's Jacobian is several times the sample rate: the substepped RK4 agrees with an
    /// independent explicit Euler integration of the same equations at 2 MHz (written here from the
    /// 1997 paper's equations, without the substep rule) within 0.5 % of the peak force at every sample.
    #[test]
    fn the_stiff_model_at_3_khz_matches_a_fine_euler_integration() {
        let p = SPENCER_1997;
        for u in [0.0, 1.0] {
            let inputs = sine(0.015, 2.5, 3000.0, 0.8, u);
            let f = run(&p, &inputs);
            // Euler at 2 MHz from the same start, the same piecewise-linear displacement.
            let sub = 666;
            let (mut y, mut z) = (inputs[0].x_m, z_scale(&p));
            let (alpha, c0, c1) = (
                p[ALPHA_A] + p[ALPHA_B] * u,
                p[C0A] + p[C0B] * u,
                p[C1A] + p[C1B] * u,
            );
            let mut worst = 0.0f64;
            let peak = f.iter().fold(0.0f64, |m, f| m.max(f.abs()));
            for k in 0..inputs.len() - 1 {
                let (a, b) = (inputs[k], inputs[k + 1]);
                let xd = (b.x_m - a.x_m) / (b.t_s - a.t_s);
                // The force at the sample, as the paper writes it: c1 ẏ + k1 (x − x0), with the sample's ẋ.
                let yd = (alpha * z + c0 * a.v_m_s + p[K0] * (a.x_m - y)) / (c0 + c1);
                let f_euler = c1 * yd + p[K1] * (a.x_m - p[X0]);
                worst = worst.max((f_euler - f[k]).abs());
                let h = (b.t_s - a.t_s) / sub as f64;
                for j in 0..sub {
                    let x = a.x_m + xd * j as f64 * h;
                    let yd = (alpha * z + c0 * xd + p[K0] * (x - y)) / (c0 + c1);
                    let d = xd - yd;
                    let zd = -p[GAMMA] * d.abs() * z * z.abs() - p[BETA] * d * z * z + p[A] * d;
                    y += h * yd;
                    z += h * zd;
                }
            }
            assert!(worst < 5e-3 * peak, "u {u}: worst {worst} N of {peak} N");
        }
    }

    /// The force dissipates: over whole cycles the work the rig does on the damper is positive, and more at
    /// 1 V than at 0 V (a stronger field).
    #[test]
    fn the_damper_dissipates_and_more_with_more_current() {
        let work = |u: f64| {
            let inputs = sine(0.015, 2.5, 3000.0, 0.8, u);
            let f = run(&SPENCER_1997, &inputs);
            (1..inputs.len())
                .map(|k| f[k] * (inputs[k].x_m - inputs[k - 1].x_m))
                .sum::<f64>()
        };
        let (w0, w1) = (work(0.0), work(1.0));
        assert!(w0 > 0.0 && w1 > 2.0 * w0, "{w0} J, {w1} J");
    }
}
