//! The feel system held still in a steady pull-up: the stick force per g a pilot feels.
//!
//! MIL-F-8785C 3.2.2.2.1 bounds the gradient of stick force per unit normal acceleration in steady
//! manoeuvres (a pull-up, or a turn), so the verdict takes the steady value, not a slope over a tracking task:
//! the aircraft's stick deflection per g in the steady pull-up (`Aircraft::stick_per_g_rad`, the secant
//! between the 1-g trim and the pull-up's load factor) times the force the feel system holds at that
//! deflection, less its breakout (Table V bounds the gradient; breakout forces are bounded on their own in
//! 3.5.2.1). With the stick still, each feel system holds:
//! - a spring unit (centring, variable gradient, q-feel): its spring force;
//! - the hybrid: its spring only (at rest its coil gives no more than a speed-proportional force);
//! - the MR damper: the law's force (the aircraft's stick force for `feel.law = "aircraft"`), up to the
//!   largest yield force its controller can ask for;
//! - the active stick: the law's force, up to its motor's limit.
//!
//! Piston forces reach the grip through the linkage at centre: `F_grip = F_piston · gearing / grip arm`.

use crate::aero::{AeroError, Aircraft};
use crate::control::feel::{FeelKind, FeelSystemConfig, Spring};
use crate::control::law::FeelLaw;

/// The rig's lever between the piston and the grip, and the MR controller's ceiling.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Lever {
    /// The grip's arm about the pivot, m.
    pub grip_arm_m: f64,
    /// Piston travel per rad of stick at centre, m/rad.
    pub gearing_m_per_rad: f64,
    /// The largest yield force the MR controller can ask for, N on the piston.
    pub mr_ceiling_n: f64,
}

/// The steady pull-up of a run's aircraft and what its feel system holds there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SteadyPerG {
    /// The pull-up's load factor (2 g, or less near the stall), g.
    pub nz_g: f64,
    /// Stick deflection per g, rad (aft positive).
    pub stick_per_g_rad: f64,
    /// Stick force per g the feel system holds, N/g at the grip (breakout excluded).
    pub per_g_n: f64,
}

/// Force the feel system holds at the grip (magnitude, N) with the stick still at `stick_rad` from its
/// neutral; `aircraft_n` is the aircraft's stick force there (the target of `feel.law = "aircraft"`) and
/// `qbar_pa` the dynamic pressure a q-feel spring that follows the aircraft takes.
pub(crate) fn held_grip_force_n(
    fs: &FeelSystemConfig,
    law: &FeelLaw,
    lever: &Lever,
    qbar_pa: f64,
    stick_rad: f64,
    aircraft_n: f64,
) -> f64 {
    let x = lever.gearing_m_per_rad * stick_rad;
    let to_grip = lever.gearing_m_per_rad / lever.grip_arm_m;
    let spring = || {
        fs.spring.map_or(0.0, |mut s| {
            if fs.q_from_aircraft {
                s.set_dynamic_pressure(qbar_pa);
            }
            s.force_on_piston_n(x).abs()
        })
    };
    let law_n = || match law {
        FeelLaw::Target { .. } => aircraft_n.abs() / to_grip,
        _ => law.holding_force_n(0.0, x),
    };
    let piston = match fs.kind {
        FeelKind::CentringSpring
        | FeelKind::VariableGradientSpring
        | FeelKind::QFeel
        | FeelKind::MrSpring => spring(),
        FeelKind::Mr => law_n().min(lever.mr_ceiling_n),
        FeelKind::Active => law_n().min(fs.motor_max_force_n),
    };
    piston * to_grip
}

/// The steady stick force per g of feel system `fs` (law `law`) on `aircraft` trimmed at `airspeed_m_s`,
/// `altitude_m`.
pub(crate) fn steady_per_g(
    fs: &FeelSystemConfig,
    law: &FeelLaw,
    lever: &Lever,
    aircraft: &Aircraft,
    airspeed_m_s: f64,
    altitude_m: f64,
) -> Result<SteadyPerG, AeroError> {
    let nz_g = crate::aero::certification::per_g_load_factor(aircraft.model(), airspeed_m_s, altitude_m)?;
    let stick_per_g_rad = aircraft.stick_per_g_rad(airspeed_m_s, altitude_m, nz_g)?;
    let qbar_pa = aircraft.steady_state(airspeed_m_s, altitude_m, 1.0)?.qbar_pa;
    let pulled_n = match law {
        FeelLaw::Target { .. } => aircraft.pull_up_stick_force_n(airspeed_m_s, altitude_m, nz_g)?,
        _ => 0.0,
    };
    let deflection = stick_per_g_rad * (nz_g - 1.0);
    let held = held_grip_force_n(fs, law, lever, qbar_pa, deflection, pulled_n);
    // The force just off centre on the same side: the breakout, which the gradient does not count.
    let breakout = held_grip_force_n(fs, law, lever, qbar_pa, deflection * 1e-9, 0.0);
    Ok(SteadyPerG {
        nz_g,
        stick_per_g_rad,
        per_g_n: (held - breakout) / (nz_g - 1.0),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aero::AircraftModel;
    use crate::control::feel::{CentringSpring, SpringElement};
    use crate::units::G0_M_S2;
    use std::sync::Arc;

    fn c172p() -> Aircraft {
        Aircraft::new(Arc::new(AircraftModel::load_builtin("c172p").unwrap()))
    }

    /// The rig of models/stick-rig.urdf as models/feel-springs.toml states it: grip arm 0.40 m, gearing
    /// 0.15 m/rad at centre.
    const LEVER: Lever = Lever {
        grip_arm_m: 0.40,
        gearing_m_per_rad: 0.15,
        mr_ceiling_n: 1.0e6,
    };

    fn spring_law() -> FeelLaw {
        FeelLaw::Spring {
            breakout_n: 0.0,
            gradient_n_per_m: 0.0,
            damping_n_s_per_m: 0.0,
            max_force_n: 0.0,
        }
    }

    /// Elevator per g of the c172p in a steady pull-up, worked by hand from its trim and its derivatives
    /// (the small-perturbation balance of lift and pitching moment from 1 g to 2 g at constant speed and
    /// throttle, Etkin & Reid 6.4, with the lift's and the body-x force's arms about the centre of gravity).
    /// 55 m/s at 1000 m keeps the angle of attack from 1 g to 2 g on one segment of the lift table
    /// (0 to 0.09 rad, CL 0.25 to 0.73), so the lift slope there is exact: 0.48/0.09 rad.
    fn elevator_per_g_by_hand(ac: &Aircraft, v: f64, h: f64) -> f64 {
        let m = ac.model();
        let trim = ac.clone().trim(v, h).unwrap();
        let (qbar, s, c) = (trim.qbar_pa, m.wing_area_m2, m.chord_m);
        let cl_alpha = 0.48 / 0.09;
        assert!((0.0..0.09).contains(&trim.alpha_rad), "{}", trim.alpha_rad);
        let d_cl = m.mass_kg * G0_M_S2 / (qbar * s); // lift per g, as a coefficient
        let q_hat = G0_M_S2 / v * c / (2.0 * v); // pitch rate per g, nondimensional (q c / 2V)
                                                 // The elevator's moment in the slipstream (Cm_de scales with the elevator's qbar).
        let cm_de = m.cm_elevator_per_rad.eval(0.0) * trim.qbar_elevator_pa / qbar;
        let dx = m.aero_ref_x_m - m.cg_x_m; // lift acts this far aft of the CG
        let dz = m.aero_ref_z_m - m.cg_z_m; // the body-x force acts this far above it
                                            // Two passes: the body-x force's moment needs the angle of attack at 2 g from the first.
        let mut extra_cm = 0.0;
        let mut de = 0.0;
        for _ in 0..2 {
            // CL_a da + CL_de de = dCL - CL_q q;  Cm_a da + Cm_de de + Cm_q q - (dx/c) dCL + extra = 0
            let rhs = (dx / c) * d_cl
                - m.cm_q_per_rad * q_hat
                - m.cm_alpha_per_rad * (d_cl - m.cl_q_per_rad * q_hat) / cl_alpha
                - extra_cm;
            de = rhs / (cm_de - m.cm_alpha_per_rad * m.cl_elevator_per_rad / cl_alpha);
            let da = (d_cl - m.cl_q_per_rad * q_hat - m.cl_elevator_per_rad * de) / cl_alpha;
            // Body-x aerodynamic force X/(qbar S) = CL sin a - CD cos a at 1 g and at 2 g; its moment is
            // -dz/c times its change (a forward force above the CG pitches the nose down).
            let x_coef = |cl: f64, a: f64, el: f64| {
                let cd = m.cd0 + m.cd_alpha.eval(a) + m.cd_elevator_abs_per_rad * el.abs();
                cl * a.sin() - cd * a.cos()
            };
            let cl1 = d_cl; // 1 g
            let a1 = trim.alpha_rad;
            let e1 = trim.elevator_rad;
            extra_cm = -(dz / c) * (x_coef(2.0 * cl1, a1 + da, e1 + de) - x_coef(cl1, a1, e1));
        }
        de
    }

    #[test]
    fn steady_per_g_of_a_centring_spring_is_the_stick_per_g_times_its_gradient_at_the_grip() {
        let ac = c172p();
        let (v, h) = (55.0, 1000.0);
        // By hand: the elevator per g, through the stick gearing (2.5 rad of elevator per rad of stick,
        // trailing edge up aft), then the spring's 1130 N/m on the piston felt at the grip:
        // k · gearing² / grip arm = 1130 · 0.15² / 0.40 = 63.56 N per rad of stick.
        let de = elevator_per_g_by_hand(&ac, v, h);
        let stick_per_g = -de / 2.5;
        let per_g_hand = 1130.0 * 0.15 * 0.15 / 0.40 * stick_per_g;
        let fs = FeelSystemConfig {
            kind: FeelKind::CentringSpring,
            spring: Some(SpringElement::Centring(CentringSpring { k_n_per_m: 1130.0 })),
            ..FeelSystemConfig::default()
        };
        let s = steady_per_g(&fs, &spring_law(), &LEVER, &ac, v, h).unwrap();
        eprintln!(
            "elevator per g by hand {de:.5} rad; stick per g {:.5} rad (hand {stick_per_g:.5}); per g {:.3} N/g \
             (hand {per_g_hand:.3})",
            s.stick_per_g_rad, s.per_g_n
        );
        assert_eq!(s.nz_g, 2.0);
        // Within 2 %: the slipstream's qbar held at its trim value and the lift's small drag share are
        // left out by hand. A slope taken in piston metres, the gearing once, or the free-stream qbar on the
        // elevator would each be off by more than 20 %.
        assert!(
            (s.stick_per_g_rad / stick_per_g - 1.0).abs() < 0.02,
            "{} {stick_per_g}",
            s.stick_per_g_rad
        );
        assert!(
            (s.per_g_n / per_g_hand - 1.0).abs() < 0.02,
            "{} {per_g_hand}",
            s.per_g_n
        );
    }

    #[test]
    fn mr_holds_the_aircrafts_pull_up_force_up_to_its_ceiling_and_a_breakout_is_not_a_gradient() {
        let ac = c172p();
        let (v, h) = (55.0, 1000.0);
        let mr = FeelSystemConfig::default();
        let target = FeelLaw::Target { force_n: 0.0 };
        // Ample ceiling: the aircraft's own stick force per g, the hinge moment fed back.
        let s = steady_per_g(&mr, &target, &LEVER, &ac, v, h).unwrap();
        let own = ac.stick_force_per_g(v, h, 2.0).unwrap();
        assert!(own > 5.0, "{own}");
        assert!((s.per_g_n - own).abs() < 1e-9 * own, "{} {own}", s.per_g_n);
        // A 20 N ceiling on the piston is 20 · 0.15 / 0.40 = 7.5 N at the grip: 7.5 N/g from 1 g to 2 g.
        let low = Lever {
            mr_ceiling_n: 20.0,
            ..LEVER
        };
        let s = steady_per_g(&mr, &target, &low, &ac, v, h).unwrap();
        assert!((s.per_g_n - 7.5).abs() < 1e-9, "{}", s.per_g_n);
        // A spring law with a 10 N breakout and 2000 N/m: the breakout does not count, the gradient does:
        // 2000 · 0.15² / 0.40 = 112.5 N per rad of stick.
        let law = FeelLaw::Spring {
            breakout_n: 10.0,
            gradient_n_per_m: 2000.0,
            damping_n_s_per_m: 0.0,
            max_force_n: 1e4,
        };
        let s = steady_per_g(&mr, &law, &LEVER, &ac, v, h).unwrap();
        assert!(
            (s.per_g_n - 112.5 * s.stick_per_g_rad).abs() < 1e-6,
            "{}",
            s.per_g_n
        );
    }
}
