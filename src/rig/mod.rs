//! The stick rig: a rapier multibody built from `models/stick-rig.urdf` (stick on a revolute pivot, push
//! rod, load cell, piston on a ±2 in prismatic joint in the cylinder), with the seed paper's MR damper
//! as the piston joint's force element (see `rig::damper_joint`).
//!
//! # Loop closure
//! Stick, push rod and piston form a closed loop (a slider-crank), which a multibody tree cannot hold.
//! The tree is `base → stick → push_rod` and `base → cylinder → piston → load_cell` (reduced coordinates,
//! exact joint axes and limits from the URDF); the rod-end pin between push rod and load cell (the URDF's
//! `<loop_joint>`) is an impulse joint between two links of the same multibody, which rapier solves with
//! the relative Jacobian. Its constraint impulse is the force through the load cell: the load cell
//! reading is the true constraint force, not a model of it.
//!
//! # Sign conventions
//! World: x along the damper axis, + = aft (towards the pilot), z up. The stick angle is positive aft
//! (a pull). A positive hand force pushes the grip aft (tangentially, in the pitch plane), which moves the
//! piston towards +x (extension): hand force + ⇒ stick angle + ⇒ piston x +.
//! `load_cell_n` is the force the push rod applies to the piston assembly along +x (+ = pulling the
//! piston out); `damper_force_n` is the paper's `Fd` (Eq. 2): the force needed to move the piston against
//! the fluid, with the sign of the piston velocity — the measurement format's convention, so at steady
//! speed `load_cell_n ≈ damper_force_n`.

pub(crate) mod damper_joint;
pub(crate) mod frames;
pub(crate) mod fuse;
pub(crate) mod linkage;

use std::path::{Path, PathBuf};

use rapier3d::prelude::{
    GenericJoint, GenericJointBuilder, ImpulseJointHandle, JointAxesMask, MultibodyJointHandle, PhysicsWorld,
    RigidBodyBuilder, RigidBodyHandle, SpringCoefficients, Vector,
};
use rapier3d_urdf::{UrdfLoaderOptions, UrdfMultibodyOptions, UrdfRobot};
use serde::Deserialize;

use crate::device::{Damper, Inputs};
use crate::input::urdf::{self, UrdfModel};
use crate::units::G0_M_S2;
use damper_joint::DamperJoint;
use frames::{neutral_frames, Frame, V3Ext, V3};
pub use linkage::Linkage;

/// Errors building the rig: its URDF refused (file, line, element), or its configuration out of range.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// A bad URDF or rig section.
    #[error(transparent)]
    Input(#[from] crate::input::InputError),
    /// A rig setting out of its range.
    #[error("rig configuration: field `{field}`: {msg}")]
    Config {
        /// The setting.
        field: String,
        /// What is wrong with it.
        msg: String,
    },
}

/// How far the URDF's piston stops may lie from a device's half stroke, m: 0.1 mm, the rounding of a
/// length in metres written to four decimals (2 in = 0.0508 m exactly).
pub const STROKE_TOLERANCE_M: f64 = 1e-4;

/// Which URDF elements play which role in the rig.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RigRoles {
    /// Revolute joint of the stick (its child link is the stick).
    pub stick_joint: String,
    /// Prismatic joint of the piston in the cylinder (the damper acts on it).
    pub piston_joint: String,
    /// `<loop_joint>` closing the linkage at the load cell (parent: load cell side, child: push rod).
    pub load_cell_joint: String,
    /// Name of the stick's `<visual>` whose origin is the grip reference point.
    pub grip_visual: String,
}

impl Default for RigRoles {
    fn default() -> Self {
        Self {
            stick_joint: "stick_pivot".into(),
            piston_joint: "piston_slide".into(),
            load_cell_joint: "rod_end_pin".into(),
            grip_visual: "grip".into(),
        }
    }
}

/// Rig settings (a scenario's `[rig]` table).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigConfig {
    /// The rig's URDF (`models/stick-rig.urdf`).
    pub urdf: PathBuf,
    /// Physics rate, Hz (allowed 100 ..= 100000; 1000 is the design rate).
    #[serde(default = "default_physics_hz")]
    pub physics_hz: f64,
    /// Gravity on (−z, standard gravity) or off.
    #[serde(default = "default_true")]
    pub gravity: bool,
    /// Solver substeps per physics step (rapier's `num_solver_iterations`, allowed 1 ..= 64).
    #[serde(default = "default_solver_iterations")]
    pub solver_iterations: usize,
    /// Gauss-Seidel sweeps per substep (rapier's `num_internal_pgs_iterations`, allowed 1 ..= 64): they
    /// converge the yield constraint with the loop closure so the stick holds without chatter; 3 is the
    /// least that passes `tests/rig.rs`.
    #[serde(default = "default_pgs_iterations")]
    pub pgs_iterations: usize,
    /// Natural frequency of the stops' critically damped constraint regularisation, Hz (allowed 10 ..= 1e6):
    /// stiff elastomer bumpers; a rigid stop limit-cycles against the yield constraint.
    #[serde(default = "default_stop_natural_hz")]
    pub stop_natural_hz: f64,
    /// Fold links joined by fixed joints into one rigid body (same dynamics, fewer links; `rig::fuse`).
    /// Off only to compare.
    #[serde(default = "default_true")]
    pub fuse_fixed_links: bool,
    /// When the linkage is planar, constrain only the loop pin's two in-plane translations. Off only to
    /// compare.
    #[serde(default = "default_true")]
    pub planar_loop_rows: bool,
    /// Which URDF links and joints are the stick, the linkage and the damper.
    #[serde(default)]
    pub roles: RigRoles,
}

fn default_physics_hz() -> f64 {
    1000.0
}
fn default_true() -> bool {
    true
}
fn default_solver_iterations() -> usize {
    1
}
fn default_pgs_iterations() -> usize {
    3
}
fn default_stop_natural_hz() -> f64 {
    300.0
}

impl RigConfig {
    /// Defaults for the given URDF: 1 kHz, gravity on.
    pub fn new(urdf: impl Into<PathBuf>) -> Self {
        Self {
            urdf: urdf.into(),
            physics_hz: default_physics_hz(),
            gravity: true,
            solver_iterations: default_solver_iterations(),
            pgs_iterations: default_pgs_iterations(),
            stop_natural_hz: default_stop_natural_hz(),
            fuse_fixed_links: true,
            planar_loop_rows: true,
            roles: RigRoles::default(),
        }
    }

    /// Defaults for the given URDF at the given physics rate, checked (rate range, file readable).
    pub fn load(urdf: &Path, physics_hz: f64) -> Result<Self, RigError> {
        let cfg = Self {
            physics_hz,
            ..Self::new(urdf)
        };
        cfg.check()?;
        std::fs::metadata(urdf).map_err(|e| crate::input::InputError::file(urdf, e.to_string()))?;
        Ok(cfg)
    }

    fn check(&self) -> Result<(), RigError> {
        if !(self.physics_hz.is_finite() && (100.0..=100_000.0).contains(&self.physics_hz)) {
            return Err(RigError::Config {
                field: "physics_hz".into(),
                msg: format!(
                    "{} Hz outside the allowed range [100, 100000] Hz",
                    self.physics_hz
                ),
            });
        }
        for (field, n) in [
            ("solver_iterations", self.solver_iterations),
            ("pgs_iterations", self.pgs_iterations),
        ] {
            if !(1..=64).contains(&n) {
                return Err(RigError::Config {
                    field: field.into(),
                    msg: format!("{n} outside the allowed range [1, 64]"),
                });
            }
        }
        Ok(())
    }
}

/// Shape of a link's visual, with dimensions from the URDF (cylinders and capsules along local z).
#[derive(Debug, Clone, PartialEq)]
pub enum VisualShape {
    /// A box.
    Box {
        /// Edge lengths along x, y, z, m.
        size_m: [f64; 3],
    },
    /// A cylinder along z.
    Cylinder {
        /// Radius, m.
        radius_m: f64,
        /// Length, m.
        length_m: f64,
    },
    /// A capsule along z.
    Capsule {
        /// Radius, m.
        radius_m: f64,
        /// Length of the straight part, m.
        length_m: f64,
    },
    /// A sphere.
    Sphere {
        /// Radius, m.
        radius_m: f64,
    },
    /// A mesh file (not drawn).
    Mesh {
        /// The mesh file as the URDF names it.
        filename: String,
    },
}

/// One `<visual>` of a link, posed in the link's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Visual {
    /// The visual's name in the URDF, if any.
    pub name: Option<String>,
    /// Its shape.
    pub shape: VisualShape,
    /// Offset in the link's frame, m.
    pub translation_m: [f64; 3],
    /// Unit quaternion `[x, y, z, w]`.
    pub rotation_xyzw: [f64; 4],
}

/// A link's name and visuals (static; poses come from [`Rig::poses`]).
#[derive(Debug, Clone, PartialEq)]
pub struct LinkVisuals {
    /// The link's name.
    pub name: String,
    /// Its visuals.
    pub visuals: Vec<Visual>,
}

/// World pose of a link's frame.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyPose {
    /// The link's name.
    pub name: String,
    /// Origin in the world, m.
    pub translation_m: [f64; 3],
    /// Unit quaternion `[x, y, z, w]`.
    pub rotation_xyzw: [f64; 4],
}

/// The rig's state after the last step (all SI; signs in the module doc).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RigState {
    /// Time, s.
    pub t_s: f64,
    /// Stick angle about the pivot, rad, + = aft (pull).
    pub stick_angle_rad: f64,
    /// Stick angle change over the last step divided by the step, rad/s.
    pub stick_rate_rad_s: f64,
    /// Grip reference point, world, m.
    pub grip_pos_m: [f64; 3],
    /// Piston displacement from mid-stroke, m, + = extension (= +x).
    pub piston_x_m: f64,
    /// Piston velocity, m/s, + = extension.
    pub piston_v_m_s: f64,
    /// Piston acceleration over the last step, m/s².
    pub piston_a_m_s2: f64,
    /// True force in the load cell: force of the push rod on the piston assembly along +x, N.
    pub load_cell_n: f64,
    /// Damper force, the paper's Fd (force to move the piston against the fluid; sign of velocity), N.
    pub damper_force_n: f64,
    /// Yield (Coulomb) force of the device this step, N.
    pub yield_n: f64,
    /// Post-yield viscous damping of the device this step, N·s/m.
    pub damping_n_s_per_m: f64,
    /// Coil current command as given, A.
    pub current_cmd_a: f64,
    /// Coil current (Eq. 3 state), A.
    pub coil_current_a: f64,
    /// Fluid excitation (Eq. 4 state), A.
    pub fluid_current_a: f64,
    /// Hand force at the grip (tangential, + = aft), N.
    pub hand_force_n: f64,
    /// External force elements on the piston (feel springs: explicit force + implicit spring at the end of
    /// the step), N along +x.
    pub external_force_n: f64,
    /// Work done by the hand since the start, J.
    pub hand_work_j: f64,
    /// Work done by the external force element since the start, J.
    pub external_work_j: f64,
    /// Kinetic energy of all moving links, J.
    pub kinetic_energy_j: f64,
    /// Gravitational potential energy of the moving links relative to neutral, J.
    pub potential_energy_j: f64,
    /// Energy dissipated in the damper since the start, J (−Σ F_fluid·v⁺·Δt).
    pub damper_dissipated_j: f64,
    /// Power of the fluid's force on the piston in the last step, W (≤ 0: the damper only takes energy).
    pub damper_power_w: f64,
}

/// A URDF link: the rigid body it belongs to (links joined by fixed joints share one, see `rig::fuse`) and its
/// frame in that body's frame.
struct LinkBody {
    name: String,
    body: RigidBodyHandle,
    offset: rapier3d::math::Pose,
}

/// A rigid body of the multibody and its mass (the sum of its fused links).
struct BodyMass {
    body: RigidBodyHandle,
    mass_kg: f64,
}

/// The stick rig. See the module documentation for the physics and conventions.
pub struct Rig {
    world: PhysicsWorld,
    links: Vec<LinkBody>,
    bodies: Vec<BodyMass>,
    visuals: Vec<LinkVisuals>,
    stick_body: RigidBodyHandle,
    piston_body: RigidBodyHandle,
    load_cell_body: RigidBodyHandle,
    stick_joint: MultibodyJointHandle,
    piston_joint: MultibodyJointHandle,
    loop_joint: ImpulseJointHandle,
    /// Rotation of the loop joint's frame in the load-cell body (to express its impulse in the world).
    loop_frame1_rot: rapier3d::math::Rotation,
    grip_local: Vector,
    grip_lever_m: f64,
    pivot_axis: V3,
    slide_axis: V3,
    piston_group_mass_kg: f64,
    piston_friction_n: f64,
    piston_damping_n_s_per_m: f64,
    gravity_m_s2: f64,
    linkage: Linkage,
    stick_limits_rad: (f64, f64),
    stroke_limits_m: (f64, f64),
    /// Where the piston's stops are written: the URDF, the line of the piston joint's `<limit>`, the joint.
    stroke_limits_at: (PathBuf, usize, String),
    damper: DamperJoint,
    dt_s: f64,
    substep_dt_s: f64,
    steps: u64,
    external_force_n: f64,
    spring_k_n_per_m: f64,
    spring_rest_m: f64,
    pe0_j: f64,
    state: RigState,
}

impl std::fmt::Debug for Rig {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Rig")
            .field("state", &self.state)
            .finish_non_exhaustive()
    }
}

impl Rig {
    /// Build the rig from its URDF and a damper (from `DeviceConfig::load(..).damper()`).
    pub fn new(cfg: &RigConfig, damper: Damper) -> Result<Rig, RigError> {
        cfg.check()?;
        let model = UrdfModel::load(&cfg.urdf)?;
        Self::from_model(cfg, &model, damper)
    }

    fn from_model(cfg: &RigConfig, model: &UrdfModel, damper: Damper) -> Result<Rig, RigError> {
        let fail = |element: &str, name: &str, field: &str, msg: &str| -> Result<Rig, RigError> {
            Err(model.field_error(element, name, field, msg).into())
        };
        let roles = &cfg.roles;
        let stick_j = model.joint(&roles.stick_joint)?;
        let piston_j = model.joint(&roles.piston_joint)?;
        let loop_j = model.loop_joint(&roles.load_cell_joint)?;
        if !matches!(stick_j.joint_type, urdf_rs::JointType::Revolute) {
            return fail(
                "joint",
                &stick_j.name,
                "type",
                "the stick joint must be `revolute` (with stops)",
            );
        }
        if !matches!(piston_j.joint_type, urdf_rs::JointType::Prismatic) {
            return fail(
                "joint",
                &piston_j.name,
                "type",
                "the piston joint must be `prismatic`",
            );
        }
        let stick_limits @ (lo, hi) = (stick_j.limit.lower, stick_j.limit.upper);
        if !(lo < 0.0 && hi > 0.0) {
            let msg = format!("stops [{lo}, {hi}] rad must bracket the neutral angle 0");
            return fail("joint", &stick_j.name, "limit", &msg);
        }
        let stroke_limits @ (lo, hi) = (piston_j.limit.lower, piston_j.limit.upper);
        if !(lo < 0.0 && hi > 0.0) {
            let msg = format!("stroke [{lo}, {hi}] m must bracket mid-stroke 0");
            return fail("joint", &piston_j.name, "limit", &msg);
        }
        for (j, element) in [(stick_j, "joint"), (piston_j, "joint"), (loop_j, "loop_joint")] {
            if V3::from(j.axis.xyz.0).norm() < 1e-9 {
                return fail(element, &j.name, "axis", "zero axis");
            }
        }

        // Neutral geometry in f64, and the linkage it implies.
        let frames = neutral_frames(&model.robot);
        let frame_of = |link: &str| {
            frames
                .iter()
                .find(|(n, _)| n == link)
                .map(|(_, f)| *f)
                .unwrap_or(Frame::IDENTITY)
        };
        let stick_link = stick_j.child.link.clone();
        let pivot = frame_of(&stick_j.parent.link).compose(&Frame::from_urdf(&stick_j.origin));
        let slide = frame_of(&piston_j.parent.link).compose(&Frame::from_urdf(&piston_j.origin));
        let rod_link = loop_j.child.link.clone();
        let rod_joint = model
            .robot
            .joints
            .iter()
            .find(|j| j.child.link == rod_link)
            .ok_or_else(|| {
                model.field_error(
                    "loop_joint",
                    &loop_j.name,
                    "child",
                    "the push rod has no parent joint",
                )
            })?;
        if rod_joint.parent.link != stick_link {
            let msg = format!(
                "`{rod_link}` must hang on the stick `{stick_link}` (it hangs on `{}`)",
                rod_joint.parent.link
            );
            return fail("loop_joint", &loop_j.name, "child", &msg);
        }
        let clevis = frame_of(&rod_link).p;
        let pin = frame_of(&loop_j.parent.link).apply(V3::from(loop_j.origin.xyz.0));
        let linkage = Linkage::new(
            &pivot,
            V3::from(stick_j.axis.xyz.0),
            clevis,
            pin,
            &slide,
            V3::from(piston_j.axis.xyz.0),
        );
        check_stops_agree(model, stick_j, piston_j, &linkage)?;

        // The damper force is recovered from the piston's momentum, which needs the cylinder fixed to the
        // world: every joint from the piston's parent up to the root must be fixed.
        let mut link = piston_j.parent.link.clone();
        for _ in 0..model.robot.joints.len() {
            let Some(j) = model.robot.joints.iter().find(|j| j.child.link == link) else {
                break;
            };
            if !matches!(j.joint_type, urdf_rs::JointType::Fixed) {
                let msg = format!("the cylinder must be fixed to the base; `{}` moves it", j.name);
                return fail("joint", &j.name, "type", &msg);
            }
            link = j.parent.link.clone();
        }

        // The piston group: the piston link and every link fixed to it (the load cell).
        let group = model.fixed_group(&piston_j.child.link);
        if !group.contains(&loop_j.parent.link.as_str()) {
            let msg = format!(
                "`{}` must be fixed to the piston `{}`",
                loop_j.parent.link, piston_j.child.link
            );
            return fail("loop_joint", &loop_j.name, "parent", &msg);
        }
        let piston_group_mass_kg: f64 = group
            .iter()
            .map(|n| model.link(n).map(|l| l.inertial.mass.value).unwrap_or(0.0))
            .sum();

        // Grip reference point.
        let stick_urdf = model.link(&stick_link)?;
        let grip = stick_urdf
            .visual
            .iter()
            .find(|v| v.name.as_deref() == Some(roles.grip_visual.as_str()))
            .ok_or_else(|| {
                model.field_error(
                    "link",
                    &stick_link,
                    "visual",
                    format!("no <visual name=\"{}\"> marking the grip", roles.grip_visual),
                )
            })?;
        let grip_local_f64 = V3::from(grip.origin.xyz.0);
        let stick_frame = frame_of(&stick_link);
        let r = stick_frame.apply(grip_local_f64) - linkage.pivot;
        let r_perp = r - linkage.pivot_axis * r.dot(&linkage.pivot_axis);
        let grip_lever_m = r_perp.norm();
        if grip_lever_m < 1e-6 {
            return fail(
                "link",
                &stick_link,
                "visual grip/origin",
                "the grip lies on the pivot axis",
            );
        }

        // Rapier world from the tree.
        let dt_s = 1.0 / cfg.physics_hz;
        let mut world = PhysicsWorld::new();
        world.integration_parameters.dt = dt_s as f32;
        world.integration_parameters.num_solver_iterations = cfg.solver_iterations;
        world.integration_parameters.warmstart_joints = true;
        world.integration_parameters.num_internal_pgs_iterations = cfg.pgs_iterations;
        // No colliders (the linkage's contacts are its joints and stops): continuous collision detection
        // has nothing to find; 0 switches it off for the world.
        world.integration_parameters.max_ccd_substeps = 0;
        let gravity_m_s2 = if cfg.gravity { G0_M_S2 } else { 0.0 };
        world.gravity = Vector::new(0.0, 0.0, -(gravity_m_s2 as f32));

        let options = UrdfLoaderOptions {
            create_colliders_from_collision_shapes: false,
            create_colliders_from_visual_shapes: false,
            make_roots_fixed: true,
            rigid_body_blueprint: RigidBodyBuilder::dynamic().can_sleep(false),
            ..Default::default()
        };
        let dir = cfg.urdf.parent().map(Path::to_path_buf).unwrap_or_default();
        // Fixed joints folded (cylinder into the base, load cell into the piston): the same dynamics with
        // fewer multibody links, see `fuse`.
        let fused = if cfg.fuse_fixed_links {
            fuse::fuse_fixed(&model.robot)
        } else {
            fuse::unfused(&model.robot)
        };
        let robot = UrdfRobot::from_robot(&fused.robot, options, &dir);
        let link_names: Vec<String> = robot
            .links
            .iter()
            .map(|l| fused.robot.links[l.urdf_link_index].name.clone())
            .collect();
        let joint_names: Vec<String> = robot
            .joints
            .iter()
            .map(|j| fused.robot.joints[j.urdf_joint_index].name.clone())
            .collect();
        let handles = robot.insert_using_multibody_joints(
            &mut world.bodies,
            &mut world.colliders,
            &mut world.multibody_joints,
            UrdfMultibodyOptions::DISABLE_SELF_CONTACTS,
        );
        // The rigid body of a URDF link and the link's frame in it (identity unless fused).
        let body_of = |name: &str| -> Result<(RigidBodyHandle, Frame), RigError> {
            let (body_link, offset) = fused.body_of(name).unwrap_or((name, Frame::IDENTITY));
            link_names
                .iter()
                .position(|n| n == body_link)
                .map(|k| (handles.links[k].body, offset))
                .ok_or_else(|| {
                    RigError::from(urdf::urdf_error(
                        &model.path,
                        model.line_of("link", name),
                        format!("link `{name}` was dropped by the loader (an empty link?)"),
                    ))
                })
        };
        let joint_of = |name: &str| -> Result<MultibodyJointHandle, RigError> {
            joint_names
                .iter()
                .position(|n| n == name)
                .and_then(|k| handles.joints[k].joint)
                .ok_or_else(|| {
                    RigError::from(urdf::urdf_error(
                        &model.path,
                        model.line_of("joint", name),
                        format!("joint `{name}` could not be inserted into the multibody"),
                    ))
                })
        };
        for name in &joint_names {
            joint_of(name)?;
        }
        let links: Vec<LinkBody> = model
            .robot
            .links
            .iter()
            .map(|l| {
                body_of(&l.name).map(|(body, offset)| LinkBody {
                    name: l.name.clone(),
                    body,
                    offset: pose_f32(&offset),
                })
            })
            .collect::<Result<_, _>>()?;
        let bodies: Vec<BodyMass> = link_names
            .iter()
            .zip(&handles.links)
            .map(|(n, h)| BodyMass {
                body: h.body,
                mass_kg: fused
                    .robot
                    .links
                    .iter()
                    .find(|l| &l.name == n)
                    .map(|l| l.inertial.mass.value)
                    .unwrap_or(0.0),
            })
            .collect();
        let (stick_body, stick_offset) = body_of(&stick_link)?;
        let (piston_body, _) = body_of(&piston_j.child.link)?;
        let (load_cell_body, load_cell_offset) = body_of(&loop_j.parent.link)?;
        let (rod_body, rod_offset) = body_of(&rod_link)?;
        if rod_offset != Frame::IDENTITY {
            let msg = format!("`{rod_link}` must be a moving link (it is fixed to its parent)");
            return fail("loop_joint", &loop_j.name, "child", &msg);
        }
        let stick_joint = joint_of(&stick_j.name)?;
        let piston_joint = joint_of(&piston_j.name)?;

        // Joint losses from <dynamics> (rapier3d-urdf ignores them; rapier's default angular damping is
        // replaced so that the only losses are the ones the URDF and the damper declare).
        for (name, handle) in joint_names
            .iter()
            .filter_map(|n| joint_of(n).ok().map(|h| (n, h)))
        {
            let j = model.joint(name)?;
            let dynamics = j.dynamics.clone().unwrap_or_default();
            let Some((mb, link_id)) = world.multibody_joints.get_mut(handle) else {
                continue;
            };
            let Some(link) = mb.link(link_id) else {
                continue;
            };
            let (start, n) = (link.assembly_id(), link.joint().ndofs());
            for k in start..start + n {
                mb.damping_mut()[k] = dynamics.damping as f32;
                mb.frictions_mut()[k] = dynamics.friction as f32;
            }
        }
        let piston_dyn = piston_j.dynamics.clone().unwrap_or_default();
        // Stick stops: critically damped at `stop_natural_hz`. Not on the piston: rapier softens its
        // dry-friction (yield) constraint too, and the stick would creep; its stops are never reached (checked).
        if let Some((mb, link_id)) = world.multibody_joints.get_mut(stick_joint) {
            if let Some(link) = mb.link_mut(link_id) {
                link.joint.data.softness = SpringCoefficients::new(cfg.stop_natural_hz as f32, 1.0);
            }
        }

        // The loop-closing pin as an impulse joint: frame 1 in the load cell at the URDF origin, frame 2
        // where that point sits in the push rod at neutral.
        let pose1 = *world.bodies[load_cell_body].position();
        let pose2 = *world.bodies[rod_body].position();
        let o = &loop_j.origin;
        let origin =
            rapier3d::math::Pose::from_parts(f32v(V3::from(o.xyz.0)), quat(urdf::rpy_to_quat_xyzw(o.rpy.0)));
        let axis = f32v(V3::from(loop_j.axis.xyz.0)).normalize();
        let basis = rapier3d::math::Pose::from_rotation(GenericJoint::complete_ang_frame(axis));
        let frame1 = pose_f32(&load_cell_offset) * origin * basis;
        let frame2 = pose2.inverse() * pose1 * frame1;
        // A planar linkage (pin, pivot and clevis axes parallel, slide across them, pivot and cylinder on
        // one grounded body) moves only in its plane: the pin's other three locked rows have identically zero
        // Jacobians, so only the two in-plane translations are constrained (the joint frame's x is the pin axis).
        let loop_axis_w = frame_of(&loop_j.parent.link)
            .compose(&Frame::from_urdf(&loop_j.origin))
            .rotate(V3::from(loop_j.axis.xyz.0))
            .unit();
        let rod_axis_w = frame_of(&rod_link).rotate(V3::from(rod_joint.axis.xyz.0)).unit();
        let parallel = |a: V3| a.unit().cross(&loop_axis_w).norm() < 1e-9;
        let grounded = |link: &str| fused.body_of(link).map(|(b, _)| b.to_string());
        let planar = cfg.planar_loop_rows
            && parallel(linkage.pivot_axis)
            && parallel(rod_axis_w)
            && matches!(
                rod_joint.joint_type,
                urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous
            )
            && linkage.slide_axis.unit().dot(&loop_axis_w).abs() < 1e-9
            && grounded(&stick_j.parent.link) == grounded(&piston_j.parent.link);
        let locked = match loop_j.joint_type {
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous if planar => {
                JointAxesMask::LIN_Y | JointAxesMask::LIN_Z
            }
            urdf_rs::JointType::Revolute | urdf_rs::JointType::Continuous => {
                JointAxesMask::LOCKED_REVOLUTE_AXES
            }
            urdf_rs::JointType::Spherical => JointAxesMask::LOCKED_SPHERICAL_AXES,
            urdf_rs::JointType::Fixed => JointAxesMask::LOCKED_FIXED_AXES,
            _ => {
                let msg = "a loop joint must be revolute, continuous, spherical or fixed";
                return fail("loop_joint", &loop_j.name, "type", msg);
            }
        };
        let joint = GenericJointBuilder::new(locked)
            .local_frame1(frame1)
            .local_frame2(frame2)
            .contacts_enabled(false)
            .build();
        let loop_joint = world.impulse_joints.insert(load_cell_body, rod_body, joint, true);

        let grip_in_body = stick_offset.apply(grip_local_f64);
        let grip_local = f32v(grip_in_body);
        let visuals = model
            .robot
            .links
            .iter()
            .map(|l| LinkVisuals {
                name: l.name.clone(),
                visuals: l.visual.iter().map(visual_of).collect(),
            })
            .collect();
        let substep_dt_s = dt_s / cfg.solver_iterations as f64;
        let mut rig = Rig {
            world,
            links,
            bodies,
            visuals,
            stick_body,
            piston_body,
            load_cell_body,
            stick_joint,
            piston_joint,
            loop_joint,
            loop_frame1_rot: frame1.rotation,
            grip_local,
            grip_lever_m,
            pivot_axis: linkage.pivot_axis,
            slide_axis: linkage.slide_axis,
            piston_group_mass_kg,
            piston_friction_n: piston_dyn.friction,
            piston_damping_n_s_per_m: piston_dyn.damping,
            gravity_m_s2,
            linkage,
            stick_limits_rad: stick_limits,
            stroke_limits_m: stroke_limits,
            stroke_limits_at: (
                model.path.clone(),
                model.line_in("joint", &piston_j.name, &["limit"]),
                piston_j.name.clone(),
            ),
            damper: DamperJoint::new(damper),
            dt_s,
            substep_dt_s,
            steps: 0,
            external_force_n: 0.0,
            spring_k_n_per_m: 0.0,
            spring_rest_m: 0.0,
            pe0_j: 0.0,
            state: RigState::default(),
        };
        // A step of zero length applies the pending changes (mass properties from the URDF, the fixed
        // root's reduced coordinates) without advancing time.
        rig.world.integration_parameters.dt = 0.0;
        rig.world.step();
        rig.world.integration_parameters.dt = dt_s as f32;
        rig.pe0_j = rig.potential_energy_abs_j();
        rig.state = rig.measure(RigState::default());
        Ok(rig)
    }

    /// One physics step: the hand pushes at the grip with `hand_force_n` (tangential to the stick's arc,
    /// + = aft/pull, which drives the piston towards +x), the coil is commanded `current_cmd_a`.
    pub fn step(&mut self, hand_force_n: f64, current_cmd_a: f64) {
        let before = self.state;
        let (x0, v0) = (before.piston_x_m, before.piston_v_m_s);
        let theta0 = before.stick_angle_rad;
        let inp = Inputs {
            t_s: before.t_s,
            x_m: x0,
            v_m_s: v0,
            a_m_s2: before.piston_a_m_s2,
            current_cmd_a,
        };
        let jf = self.damper.begin_step(inp);

        // The damper on the piston DoF: implicit yield (dry friction) and viscous damping.
        // The feel-system spring on the same DoF, implicit: −k (x⁺ − rest).
        if let Some((mb, link_id)) = self.world.multibody_joints.get_mut(self.piston_joint) {
            if let Some(k) = mb.link(link_id).map(|l| l.assembly_id()) {
                mb.frictions_mut()[k] = (jf.friction_n + self.piston_friction_n) as f32;
                mb.damping_mut()[k] = (jf.damping_n_s_per_m + self.piston_damping_n_s_per_m) as f32;
            }
            if let Some(link) = mb.link_mut(link_id) {
                link.joint
                    .set_spring(0, self.spring_k_n_per_m as f32, self.spring_rest_m as f32);
            }
        }
        // Explicit forces (forces persist in rapier until reset).
        let u = self.slide_axis;
        let explicit_n = jf.explicit_on_piston_n + self.external_force_n;
        {
            let rb = &mut self.world.bodies[self.piston_body];
            rb.reset_forces(false);
            rb.reset_torques(false);
            rb.add_force(f32v(u * explicit_n), false);
        }
        {
            let rb = &mut self.world.bodies[self.stick_body];
            rb.reset_forces(false);
            rb.reset_torques(false);
            let grip = rb.position().transform_point(self.grip_local);
            let tangent = f32v(self.pivot_axis)
                .cross(grip - f32v(self.linkage.pivot))
                .normalize_or_zero();
            rb.add_force_at_point(tangent * hand_force_n as f32, grip, false);
        }

        self.world.step();
        self.steps += 1;

        let mut s = RigState {
            t_s: self.steps as f64 * self.dt_s,
            current_cmd_a,
            hand_force_n,
            external_force_n: self.external_force_n,
            yield_n: self.damper.stage().yield_n,
            damping_n_s_per_m: self.damper.stage().damping_n_s_per_m,
            ..before
        };
        s = self.measure(s);
        let dx = s.piston_x_m - x0;
        let dv = s.piston_v_m_s - v0;
        s.piston_a_m_s2 = dv / self.dt_s;
        // The stick's rate as its motion over the step (an encoder's view): the solver's generalized velocity
        // holds a spurious value while the soft stop is loaded.
        s.stick_rate_rad_s = (s.stick_angle_rad - theta0) / self.dt_s;
        // The fluid's force on the piston from the piston group's momentum balance along the slide:
        // m Δv/Δt = F_load_cell + F_fluid + F_external + m g·u.
        let g_along = -self.gravity_m_s2 * u.z;
        let spring_n = -self.spring_k_n_per_m * (s.piston_x_m - self.spring_rest_m);
        let fluid_on_piston = self.piston_group_mass_kg * s.piston_a_m_s2
            - s.load_cell_n
            - self.external_force_n
            - spring_n
            - self.piston_group_mass_kg * g_along;
        s.damper_force_n = -fluid_on_piston;
        // Power at the end-of-step velocity, the one the implicit yield and damping act on (positions may
        // also move by the solver's constraint stabilisation at an impact on a stop).
        s.damper_power_w = fluid_on_piston * s.piston_v_m_s;
        s.damper_dissipated_j = before.damper_dissipated_j - s.damper_power_w * self.dt_s;
        s.hand_work_j = before.hand_work_j + hand_force_n * self.grip_lever_m * (s.stick_angle_rad - theta0);
        s.external_force_n = self.external_force_n + spring_n;
        s.external_work_j = before.external_work_j + (self.external_force_n + spring_n) * dx;
        self.damper.end_step(self.dt_s, dx);
        let d = self.damper.damper();
        (s.coil_current_a, s.fluid_current_a) = (d.coil_current_a(), d.fluid_excitation_a());
        self.state = s;
    }

    /// Positions, velocities, load cell and energies read from the bodies; accumulators kept from `s`.
    fn measure(&self, mut s: RigState) -> RigState {
        let b = &self.world.bodies;
        if let Some((mb, link_id)) = self.world.multibody_joints.get(self.stick_joint) {
            if let Some(link) = mb.link(link_id) {
                s.stick_angle_rad = link.joint().coords()[3] as f64;
                s.stick_rate_rad_s = mb.generalized_velocity()[link.assembly_id()] as f64;
            }
        }
        if let Some((mb, link_id)) = self.world.multibody_joints.get(self.piston_joint) {
            if let Some(link) = mb.link(link_id) {
                s.piston_x_m = link.joint().coords()[0] as f64;
                s.piston_v_m_s = mb.generalized_velocity()[link.assembly_id()] as f64;
            }
        }
        let grip = b[self.stick_body].position().transform_point(self.grip_local);
        s.grip_pos_m = [grip.x as f64, grip.y as f64, grip.z as f64];
        if let Some(j) = self.world.impulse_joints.get(self.loop_joint) {
            let rot = b[self.load_cell_body].rotation() * self.loop_frame1_rot;
            let imp = rot * Vector::new(j.impulses[0], j.impulses[1], j.impulses[2]);
            let u = self.slide_axis;
            let along = imp.x as f64 * u.x + imp.y as f64 * u.y + imp.z as f64 * u.z;
            s.load_cell_n = along / self.substep_dt_s;
        }
        s.kinetic_energy_j = self
            .bodies
            .iter()
            .map(|l| b[l.body].kinetic_energy() as f64)
            .sum();
        s.potential_energy_j = self.potential_energy_abs_j() - self.pe0_j;
        let d = self.damper.damper();
        (s.coil_current_a, s.fluid_current_a) = (d.coil_current_a(), d.fluid_excitation_a());
        s
    }

    fn potential_energy_abs_j(&self) -> f64 {
        let b = &self.world.bodies;
        self.bodies
            .iter()
            .filter(|l| b[l.body].is_dynamic())
            .map(|l| l.mass_kg * self.gravity_m_s2 * b[l.body].center_of_mass().z as f64)
            .sum()
    }

    /// Benchmark baseline only: one bare rapier step of the rig's world, without the device model and the
    /// rig's bookkeeping (the state is not updated).
    #[doc(hidden)]
    pub fn step_rapier_only(&mut self) {
        self.world.step();
    }

    /// The state after the last step.
    pub fn state(&self) -> RigState {
        self.state
    }

    /// Physics step, s.
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }

    /// Stick stops (lower, upper), rad, from the URDF.
    pub fn stick_limits_rad(&self) -> (f64, f64) {
        self.stick_limits_rad
    }

    /// Half stroke of the piston, m (the smaller of the URDF's two limits).
    pub fn stroke_limit_m(&self) -> f64 {
        self.stroke_limits_m.1.min(-self.stroke_limits_m.0)
    }

    /// The piston's stops are the device's stroke ±`stroke_half_m` within [`STROKE_TOLERANCE_M`]; else an
    /// error naming both (`device` says where the device gives it, `file:line`).
    pub(crate) fn check_device_stroke(
        &self,
        stroke_half_m: f64,
        device: impl FnOnce() -> String,
    ) -> Result<(), RigError> {
        let (lo, hi) = self.stroke_limits_m;
        if (hi - stroke_half_m).abs() <= STROKE_TOLERANCE_M
            && (-lo - stroke_half_m).abs() <= STROKE_TOLERANCE_M
        {
            return Ok(());
        }
        let (path, line, joint) = &self.stroke_limits_at;
        let device = device();
        Err(RigError::from(urdf::urdf_error(path, *line, format!(
                "joint `{joint}`: limit: the piston's stops [{lo}, {hi}] m are not the device's stroke ±{stroke_half_m} m \
                 (±{} in, {device}): the rig's piston is the device's damper; make the two agree (within \
                 {} mm)",
                stroke_half_m / crate::units::IN_TO_M,
                STROKE_TOLERANCE_M * 1e3
            ))))
    }

    /// Piston x per stick angle at neutral, m/rad.
    pub fn gearing_m_per_rad(&self) -> f64 {
        self.linkage.gearing_m_per_rad(0.0).unwrap_or(f64::NAN)
    }

    /// Distance from the pivot axis to the grip reference point, m.
    pub fn grip_lever_m(&self) -> f64 {
        self.grip_lever_m
    }

    /// Mass moving with the piston DoF (piston and the links fixed to it), kg.
    pub fn piston_group_mass_kg(&self) -> f64 {
        self.piston_group_mass_kg
    }

    /// The linkage's closed-form kinematics (f64), from the URDF's neutral geometry.
    pub fn linkage(&self) -> &Linkage {
        &self.linkage
    }

    /// The damper element (device model and its state).
    pub fn damper(&self) -> &DamperJoint {
        &self.damper
    }

    /// For passive feel systems: an extra force on the piston along +x, N, computed by the
    /// caller (e.g. from [`Rig::state`]) and held for the following steps until set again.
    pub(crate) fn set_external_force_n(&mut self, force_n: f64) {
        self.external_force_n = force_n;
    }

    /// For spring feel systems: a linear spring `F = −k (x − rest)` on the piston joint, integrated implicitly
    /// (it never injects energy). Held until set again; `k = 0` removes it.
    pub(crate) fn set_external_spring(&mut self, stiffness_n_per_m: f64, rest_x_m: f64) {
        self.spring_k_n_per_m = stiffness_n_per_m.max(0.0);
        self.spring_rest_m = rest_x_m;
    }

    /// Link names and visual shapes (static), in URDF order.
    pub fn visuals(&self) -> &[LinkVisuals] {
        &self.visuals
    }

    /// World pose of every link's frame, in URDF order.
    pub fn poses(&self) -> Vec<BodyPose> {
        self.links
            .iter()
            .map(|l| {
                let p = *self.world.bodies[l.body].position() * l.offset;
                let (t, q) = (p.translation, p.rotation);
                BodyPose {
                    name: l.name.clone(),
                    translation_m: [t.x as f64, t.y as f64, t.z as f64],
                    rotation_xyzw: [q.x as f64, q.y as f64, q.z as f64, q.w as f64],
                }
            })
            .collect()
    }
}

/// Stick stops and piston stops must agree: over the stick's travel the linkage must keep the piston
/// strictly inside its stroke, or the two sets of stops fight.
fn check_stops_agree(
    model: &UrdfModel,
    stick_j: &urdf_rs::Joint,
    piston_j: &urdf_rs::Joint,
    linkage: &Linkage,
) -> Result<(), RigError> {
    let (lo, hi) = (stick_j.limit.lower, stick_j.limit.upper);
    let n = 400;
    for k in 0..=n {
        let t = lo + (hi - lo) * k as f64 / n as f64;
        let Some(x) = linkage.piston_x_m(t) else {
            let msg = format!("at {t:.4} rad the push rod cannot reach the piston's line");
            return Err(model.field_error("joint", &stick_j.name, "limit", msg).into());
        };
        if x <= piston_j.limit.lower || x >= piston_j.limit.upper {
            let msg = format!(
                "stick stops [{lo}, {hi}] rad drive the piston to {x:.5} m at {t:.4} rad, outside its stroke [{}, {}] m \
                 (joint `{}`): the stops would fight",
                piston_j.limit.lower, piston_j.limit.upper, piston_j.name
            );
            return Err(model.field_error("joint", &stick_j.name, "limit", msg).into());
        }
    }
    Ok(())
}

/// A frame as a rapier pose (f32).
fn pose_f32(f: &Frame) -> rapier3d::math::Pose {
    let r = &f.r;
    let m = rapier3d::math::Matrix::from_cols(
        Vector::new(r[0][0] as f32, r[1][0] as f32, r[2][0] as f32),
        Vector::new(r[0][1] as f32, r[1][1] as f32, r[2][1] as f32),
        Vector::new(r[0][2] as f32, r[1][2] as f32, r[2][2] as f32),
    );
    rapier3d::math::Pose::from_parts(f32v(f.p), rapier3d::math::Rotation::from_mat3(&m).normalize())
}

/// A vector in rapier's f32.
fn f32v(v: V3) -> Vector {
    Vector::new(v.x as f32, v.y as f32, v.z as f32)
}

fn quat(q: [f64; 4]) -> rapier3d::math::Rotation {
    rapier3d::math::Rotation::from_xyzw(q[0] as f32, q[1] as f32, q[2] as f32, q[3] as f32).normalize()
}

fn visual_of(v: &urdf_rs::Visual) -> Visual {
    let shape = match &v.geometry {
        urdf_rs::Geometry::Box { size } => VisualShape::Box { size_m: size.0 },
        urdf_rs::Geometry::Cylinder { radius, length } => VisualShape::Cylinder {
            radius_m: *radius,
            length_m: *length,
        },
        urdf_rs::Geometry::Capsule { radius, length } => VisualShape::Capsule {
            radius_m: *radius,
            length_m: *length,
        },
        urdf_rs::Geometry::Sphere { radius } => VisualShape::Sphere { radius_m: *radius },
        urdf_rs::Geometry::Mesh { filename, .. } => VisualShape::Mesh {
            filename: filename.clone(),
        },
    };
    Visual {
        name: v.name.clone(),
        shape,
        translation_m: v.origin.xyz.0,
        rotation_xyzw: urdf::rpy_to_quat_xyzw(v.origin.rpy.0),
    }
}
