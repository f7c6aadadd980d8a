//! What the loop needs from the mechanical rig, as a trait: the rapier multibody [`Rig`] implements it;
//! tests may plug in an independent reduced model.

use crate::control::feel::{self, Spring};
use crate::rig::{BodyPose, LinkVisuals, Rig};

/// The rig's true state after a step (the loop logs it; the controller never sees it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlantState {
    /// Time, s.
    pub t_s: f64,
    /// Stick angle about the pivot, rad, + = aft.
    pub stick_angle_rad: f64,
    /// Stick rate, rad/s.
    pub stick_rate_rad_s: f64,
    /// Grip position along its path (arc length from neutral), m.
    pub grip_x_m: f64,
    /// Grip velocity along its path, m/s.
    pub grip_v_m_s: f64,
    /// Piston displacement from mid-stroke, m.
    pub piston_x_m: f64,
    /// Piston velocity, m/s.
    pub piston_v_m_s: f64,
    /// True load-cell force along +x on the piston, N.
    pub load_cell_n: f64,
    /// Damper force along +x on the piston (the force needed to move it, Eq. 2's `Fd`), N.
    pub damper_force_n: f64,
    /// Damper yield-force magnitude at this instant, N.
    pub yield_force_n: f64,
    /// Coil current (Eq. 3's state), A.
    pub coil_current_a: f64,
    /// Kinetic energy of the moving bodies, J.
    pub kinetic_energy_j: f64,
    /// Gravitational potential energy relative to the start, J.
    pub potential_energy_j: f64,
    /// Energy dissipated in the damper since the start, J.
    pub dissipated_j: f64,
}

/// What the feel loop drives: the stick rig, stepped with the hand force and the coil current.
pub trait Plant {
    /// Physics step, s.
    fn dt_s(&self) -> f64;
    /// Advance one physics step with the hand force at the grip (N, along the grip path) and the coil
    /// current command (A) held over the step.
    fn step(&mut self, hand_force_n: f64, current_cmd_a: f64);
    /// The true state after the last step.
    fn state(&self) -> PlantState;
    /// Half stroke of the piston, m.
    fn stroke_half_m(&self) -> f64;
    /// Grip path length per stick radian, m/rad (the grip's lever about the pivot).
    fn grip_arm_m(&self) -> f64;
    /// Piston travel per stick radian at a stick angle, m/rad (the linkage's local gearing; converts a grip
    /// force to the piston by virtual work: `F_piston = F_grip · grip_arm / gearing`).
    fn gearing_m_per_rad(&self, stick_angle_rad: f64) -> f64;
    /// Stick travel stops, rad (min, max).
    fn stick_limits_rad(&self) -> (f64, f64);
    /// Put a spring feel element on the piston joint for the next step (`None`: none).
    fn set_feel_spring(&mut self, spring: Option<&dyn Spring>);
    /// An actuator's force on the piston along +x for the next step, N (the active stick's motor; call
    /// after [`Plant::set_feel_spring`], which clears it).
    fn set_actuator_force_n(&mut self, force_n: f64);
    /// Link names and visual shapes (static); empty when the plant has no geometry.
    fn visuals(&self) -> Vec<LinkVisuals> {
        Vec::new()
    }
    /// World pose of every link now.
    fn poses(&self) -> Vec<BodyPose> {
        Vec::new()
    }
}

impl Plant for Rig {
    fn dt_s(&self) -> f64 {
        Rig::dt_s(self)
    }

    fn step(&mut self, hand_force_n: f64, current_cmd_a: f64) {
        Rig::step(self, hand_force_n, current_cmd_a);
    }

    fn state(&self) -> PlantState {
        let s = Rig::state(self);
        let lever = self.grip_lever_m();
        PlantState {
            t_s: s.t_s,
            stick_angle_rad: s.stick_angle_rad,
            stick_rate_rad_s: s.stick_rate_rad_s,
            grip_x_m: lever * s.stick_angle_rad,
            grip_v_m_s: lever * s.stick_rate_rad_s,
            piston_x_m: s.piston_x_m,
            piston_v_m_s: s.piston_v_m_s,
            load_cell_n: s.load_cell_n,
            damper_force_n: s.damper_force_n,
            yield_force_n: s.yield_n,
            coil_current_a: s.coil_current_a,
            kinetic_energy_j: s.kinetic_energy_j,
            potential_energy_j: s.potential_energy_j,
            dissipated_j: s.damper_dissipated_j,
        }
    }

    fn stroke_half_m(&self) -> f64 {
        self.stroke_limit_m()
    }

    fn grip_arm_m(&self) -> f64 {
        self.grip_lever_m()
    }

    fn gearing_m_per_rad(&self, stick_angle_rad: f64) -> f64 {
        self.linkage()
            .gearing_m_per_rad(stick_angle_rad)
            .unwrap_or(Rig::gearing_m_per_rad(self))
    }

    fn stick_limits_rad(&self) -> (f64, f64) {
        Rig::stick_limits_rad(self)
    }

    fn set_actuator_force_n(&mut self, force_n: f64) {
        self.set_external_force_n(force_n);
    }

    fn set_feel_spring(&mut self, spring: Option<&dyn Spring>) {
        match spring {
            Some(f) => feel::apply(f, self),
            None => {
                self.set_external_spring(0.0, 0.0);
                self.set_external_force_n(0.0);
            }
        }
    }

    fn visuals(&self) -> Vec<LinkVisuals> {
        Rig::visuals(self).to_vec()
    }

    fn poses(&self) -> Vec<BodyPose> {
        Rig::poses(self)
    }
}
