//! The seed paper's base model: Bingham plastic force (Eq. 2) whose yield force follows the coil current
//! through the coil's electrical lag (Eq. 3) and the fluid's lag (Eq. 4), i.e. Eq. (6), behind the current
//! driver's saturation.

use super::effect::{Inputs, Stage};
use super::lag::{advance_two_lags_in, DecayMemo};
use super::params::{DataStats, ParamSpec};

/// Index of each base parameter in the parameter vector.
pub(crate) const FC0: usize = 0;
pub(crate) const FC_GAIN: usize = 1;
/// Index of the viscous damping `C0`.
pub const C0: usize = 2;
pub(crate) const TE: usize = 3;
pub(crate) const TM: usize = 4;

/// The parameters Eq. (2) with Eq. (6)'s yield force is linear in: the zero-current yield force, the yield
/// force per ampere and the damping.
pub(crate) const LINEAR_GAINS: [usize; 3] = [FC0, FC_GAIN, C0];

/// Base parameters, in vector order.
///
/// Eq. (6) contains the product `bH kH` only, so the two gains are one parameter here, the yield force per
/// ampere of (lagged) coil current. `fc0_n` is the yield force at zero current: the seal and foam friction a
/// real damper shows with the coil off (Eq. 2's `Fc` at `H = 0`).
pub const PARAMS: [ParamSpec; 5] = [
    ParamSpec::non_negative(
        "fc0_n",
        "N",
        "yield (Coulomb) force at zero coil current, Eq. (2)",
    ),
    ParamSpec::non_negative(
        "fc_gain_n_per_a",
        "N/A",
        "yield force per ampere of lagged coil current, bH·kH of Eq. (6)",
    ),
    ParamSpec::non_negative("c0_n_s_per_m", "N·s/m", "post-yield viscous damping C0, Eq. (2)"),
    ParamSpec::new(
        "te_s",
        "s",
        0.0,
        1.0,
        "coil electrical time constant Te = L/R, Eq. (3)",
    ),
    ParamSpec::new(
        "tm_s",
        "s",
        0.0,
        1.0,
        "MR fluid response time constant Tm, Eq. (4)",
    ),
];

/// Number of base states: coil current (Eq. 3) and fluid excitation (Eq. 4), both in amperes.
pub(crate) const N_STATES: usize = 2;
/// The parameters [`advance`] reads: the lags' time constants (the states are the lagged currents).
pub(crate) const STATE_PARAMS: [usize; 2] = [TE, TM];

/// The driver's saturation: the coil current command is limited to ±`limit_a` (the paper's driver
/// saturates at 14 A; its supply could give 17 A). `limit_a` is positive ([`super::Model::new`] refuses any
/// other); this never panics on another (its magnitude is taken, and a NaN limit leaves the command as it is).
pub(crate) fn saturate(current_cmd_a: f64, limit_a: f64) -> f64 {
    let l = limit_a.abs();
    current_cmd_a.max(-l).min(l)
}

/// Lag states at rest for a command held since long before the first sample.
pub(crate) fn init_states(s: &mut [f64], current_cmd_a: f64, limit_a: f64) {
    s[..N_STATES].fill(saturate(current_cmd_a, limit_a));
}

/// Eq. (2) with Eq. (6)'s yield force: the stage before any effect.
///
/// The yield force depends on the field magnitude, so a bipolar driver's negative current gives the same
/// yield force as a positive one.
pub fn stage(p: &[f64], s: &[f64], inp: &Inputs) -> Stage {
    let h = s[1];
    Stage {
        current_a: h,
        yield_n: p[FC0] + p[FC_GAIN] * h.abs(),
        yield_field_n: p[FC_GAIN] * h.abs(),
        direction: sgn(inp.v_m_s),
        damping_n_s_per_m: p[C0],
        extra_n: 0.0,
    }
}

/// Advance the two lags (Eq. 3, Eq. 4) over one step with the saturated command held.
/// The lags' decays come from `memo`, an integration's ([`DecayMemo`]).
pub(crate) fn advance_in(
    p: &[f64],
    s: &mut [f64],
    current_cmd_a: f64,
    limit_a: f64,
    dt_s: f64,
    memo: &mut DecayMemo,
) {
    let u = saturate(current_cmd_a, limit_a);
    (s[0], s[1]) = advance_two_lags_in(s[0], s[1], u, p[TE], p[TM], dt_s, memo);
}

/// `sgn` of Eq. (2), zero at zero velocity.
pub(crate) fn sgn(v: f64) -> f64 {
    if v > 0.0 {
        1.0
    } else if v < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// Starting values from the data's linear Bingham estimate; the lags start at a few sample intervals.
pub fn initial_guess(stats: &DataStats) -> Vec<f64> {
    let lag = (5.0 * stats.dt_s).clamp(1e-4, 0.1);
    vec![
        stats.fc0_n.max(0.0),
        stats.fc_gain_n_per_a.max(0.0),
        stats.c0_n_s_per_m.max(0.0),
        lag,
        lag,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saturation_limits_the_command_to_the_drivers_14_a_either_way() {
        assert_eq!(saturate(20.0, 14.0), 14.0);
        assert_eq!(saturate(-20.0, 14.0), -14.0);
        assert_eq!(saturate(5.0, 14.0), 5.0);
    }

    /// A limit that `Model::new` would refuse never panics here.
    #[test]
    fn saturation_does_not_panic_on_a_limit_that_is_not_positive() {
        assert_eq!(saturate(20.0, -14.0), 14.0);
        assert_eq!(saturate(5.0, f64::NAN), 5.0);
        assert_eq!(saturate(5.0, 0.0), 0.0);
    }
}
