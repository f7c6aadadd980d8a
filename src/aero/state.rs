//! What the rig, the feel law and the outputs see of an aircraft after a step, whichever backend flies it.

#[cfg(doc)]
use super::HingeModel;

/// What the rig and the feel law see of the aircraft after a step.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct AircraftState {
    /// Time, s.
    pub t_s: f64,
    /// Body-axis velocity along x, m/s.
    pub u_m_s: f64,
    /// Body-axis velocity along z, m/s.
    pub w_m_s: f64,
    /// Pitch rate, rad/s.
    pub q_rad_s: f64,
    /// Pitch attitude, rad.
    pub theta_rad: f64,
    /// Altitude, m.
    pub altitude_m: f64,
    /// True airspeed, m/s.
    pub airspeed_m_s: f64,
    /// Angle of attack, rad.
    pub alpha_rad: f64,
    /// Rate of the angle of attack, rad/s.
    pub alphadot_rad_s: f64,
    /// Dynamic pressure, Pa.
    pub qbar_pa: f64,
    /// Dynamic pressure at the elevator (slipstream included where the model has one), Pa.
    pub qbar_elevator_pa: f64,
    /// Mach number.
    pub mach: f64,
    /// Normal load factor, g.
    pub nz_g: f64,
    /// Elevator deflection, rad, positive trailing edge down.
    pub elevator_rad: f64,
    /// Trim tab deflection, rad.
    pub tab_rad: f64,
    /// Throttle, 0..1.
    pub throttle: f64,
    /// Thrust, N.
    pub thrust_n: f64,
    /// Angle of attack at the tail (downwash and pitch rate included), rad.
    pub alpha_tail_rad: f64,
    /// Elevator hinge moment, N·m, positive trailing edge down.
    pub hinge_moment_nm: f64,
    /// Column neutral set by trimming, before the Mach trim shift (powered controls with a feel
    /// computer; 0 otherwise), stick rad positive aft.
    pub feel_trim_rad: f64,
    /// Stick force at the grip, N, positive = pull (aft): the hinge moment fed back (reversible
    /// controls) plus the feel computer's force (powered controls), [`HingeModel::stick_force_n`].
    pub stick_force_n: f64,
}
