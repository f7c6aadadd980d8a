//! What the loop needs from the mechanical rig, as a trait: the rapier multibody ([`crate::rig::Rig`])
//! implements it; tests may plug in an independent reduced model.

/// A rigid body to draw: pose in the rig's world frame (m; rotation as a unit quaternion `[x, y, z, w]`)
/// and its shape.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyPose {
    pub name: String,
    pub translation_m: [f32; 3],
    pub rotation_xyzw: [f32; 4],
    pub shape: BodyShape,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum BodyShape {
    /// Box with half-extents, m.
    Box { half_extents_m: [f32; 3] },
    /// Cylinder along the body's local z axis (URDF convention), m.
    Cylinder { radius_m: f32, length_m: f32 },
    Sphere { radius_m: f32 },
}

/// The rig's true state after a step (the loop logs it; the controller never sees it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PlantState {
    pub t_s: f64,
    pub stick_angle_rad: f64,
    pub stick_rate_rad_s: f64,
    /// Grip position along its path (arc length from centre), m, and velocity, m/s.
    pub grip_x_m: f64,
    pub grip_v_m_s: f64,
    /// Piston displacement from mid-stroke, m, and velocity, m/s.
    pub piston_x_m: f64,
    pub piston_v_m_s: f64,
    /// True load-cell force along +x on the piston, N.
    pub load_cell_n: f64,
    /// Damper force along +x on the piston (the force needed to move it), N.
    pub damper_force_n: f64,
    /// Damper yield-force magnitude at this instant, N.
    pub yield_force_n: f64,
    /// Kinetic energy of the moving bodies, J.
    pub kinetic_energy_j: f64,
    /// Energy dissipated in the damper since the start, J.
    pub dissipated_j: f64,
}

pub trait Plant {
    /// Physics step, s.
    fn dt_s(&self) -> f64;
    /// Advance one physics step with the hand force at the grip (N, along the grip path) and the coil
    /// current command (A) held over the step.
    fn step(&mut self, hand_force_n: f64, current_cmd_a: f64);
    fn state(&self) -> PlantState;
    /// Half stroke of the piston, m.
    fn stroke_half_m(&self) -> f64;
    /// Grip path length per stick radian, m/rad (the grip's arm about the pivot).
    fn grip_arm_m(&self) -> f64;
    /// Bodies to draw; empty when the plant has no geometry.
    fn bodies(&self) -> Vec<BodyPose> {
        Vec::new()
    }
}
