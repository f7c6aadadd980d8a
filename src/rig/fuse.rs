//! Links joined by `fixed` joints are one rigid body: fold them into their parent before the tree goes to
//! rapier (MuJoCo's `fusestatic`, Drake's and PyBullet's "merge fixed links").
//!
//! A multibody link costs the solver the same whether its joint has one DoF or none; folding the rig's two
//! fixed links (cylinder into the base, load cell into the piston) keeps the dynamics: the fused link carries
//! the combined mass, centre of mass and inertia (parallel-axis theorem), and every original link keeps its
//! frame as a fixed offset in its body (for poses, the loop joint's anchor and the grip point).

use super::frames::{Frame, V3};

/// The tree after folding fixed joints.
#[derive(Debug, Clone)]
pub(crate) struct Fused {
    /// Body links (the root and every child of a moving joint) with the combined inertials of their fixed
    /// descendants; the non-fixed joints, re-parented to the body links with composed origins.
    pub robot: urdf_rs::Robot,
    /// For every link of the original URDF, in its order: the body link it belongs to and the link's frame
    /// in that body link's frame.
    pub link_in_body: Vec<(String, String, Frame)>,
}

impl Fused {
    /// Body link and offset of an original link.
    pub(crate) fn body_of(&self, link: &str) -> Option<(&str, Frame)> {
        self.link_in_body
            .iter()
            .find(|(n, _, _)| n == link)
            .map(|(_, b, f)| (b.as_str(), *f))
    }
}

/// Fold every `fixed` joint of `robot` (a tree; checked by the loader) into its parent link.
pub(crate) fn fuse_fixed(robot: &urdf_rs::Robot) -> Fused {
    let parent_joint = |link: &str| robot.joints.iter().find(|j| j.child.link == link);
    // Body of each link: climb fixed joints, composing their origins.
    let link_in_body: Vec<(String, String, Frame)> = robot
        .links
        .iter()
        .map(|l| {
            let mut name = l.name.clone();
            let mut offset = Frame::IDENTITY;
            for _ in 0..robot.joints.len() {
                match parent_joint(&name) {
                    Some(j) if matches!(j.joint_type, urdf_rs::JointType::Fixed) => {
                        offset = Frame::from_urdf(&j.origin).compose(&offset);
                        name = j.parent.link.clone();
                    }
                    _ => break,
                }
            }
            (l.name.clone(), name, offset)
        })
        .collect();
    let body = |link: &str| {
        link_in_body
            .iter()
            .find(|(n, _, _)| n == link)
            .map(|(_, b, f)| (b.clone(), *f))
            .unwrap_or((link.to_string(), Frame::IDENTITY))
    };
    let links = robot
        .links
        .iter()
        .filter(|l| body(&l.name).0 == l.name)
        .map(|l| {
            let members: Vec<(&urdf_rs::Link, Frame)> = robot
                .links
                .iter()
                .zip(&link_in_body)
                .filter(|(_, (_, b, _))| *b == l.name)
                .map(|(m, (_, _, f))| (m, *f))
                .collect();
            urdf_rs::Link {
                inertial: if members.len() == 1 {
                    l.inertial.clone()
                } else {
                    combined_inertial(&members)
                },
                ..l.clone()
            }
        })
        .collect();
    let joints = robot
        .joints
        .iter()
        .filter(|j| !matches!(j.joint_type, urdf_rs::JointType::Fixed))
        .map(|j| {
            let (parent, offset) = body(&j.parent.link);
            let mut j = j.clone();
            j.parent.link = parent;
            j.origin = pose_of(&offset.compose(&Frame::from_urdf(&j.origin)));
            j
        })
        .collect();
    Fused {
        robot: urdf_rs::Robot {
            name: robot.name.clone(),
            links,
            joints,
            materials: robot.materials.clone(),
        },
        link_in_body,
    }
}

/// The tree as it is, every link its own body (for comparisons).
pub fn unfused(robot: &urdf_rs::Robot) -> Fused {
    Fused {
        robot: robot.clone(),
        link_in_body: robot
            .links
            .iter()
            .map(|l| (l.name.clone(), l.name.clone(), Frame::IDENTITY))
            .collect(),
    }
}

type M3 = [[f64; 3]; 3];

/// Mass, centre of mass and inertia about it of several links, each posed by its frame in the body
/// frame; the result is expressed in the body frame (origin at the combined centre of mass, no rotation).
fn combined_inertial(members: &[(&urdf_rs::Link, Frame)]) -> urdf_rs::Inertial {
    let mass: f64 = members.iter().map(|(l, _)| l.inertial.mass.value).sum();
    // (mass, centre, inertia about the centre in the body frame) of each member.
    let parts: Vec<(f64, V3, M3)> = members
        .iter()
        .map(|(l, f)| {
            let i = &l.inertial;
            let fi = f.compose(&Frame::from_urdf(&i.origin));
            let t = &i.inertia;
            let local = [
                [t.ixx, t.ixy, t.ixz],
                [t.ixy, t.iyy, t.iyz],
                [t.ixz, t.iyz, t.izz],
            ];
            (i.mass.value, fi.p, rotate_tensor(&fi.r, &local))
        })
        .collect();
    let com = if mass > 0.0 {
        parts
            .iter()
            .fold(V3::zeros(), |acc, (m, c, _)| acc + *c * (*m / mass))
    } else {
        V3::zeros()
    };
    let mut inertia = [[0.0; 3]; 3];
    for (m, c, ic) in &parts {
        // Parallel-axis theorem: I_com + m (|d|² E − d dᵀ).
        let d: [f64; 3] = (*c - com).into();
        let d2: f64 = d.iter().map(|x| x * x).sum();
        for a in 0..3 {
            for b in 0..3 {
                let e = if a == b { 1.0 } else { 0.0 };
                inertia[a][b] += ic[a][b] + m * (d2 * e - d[a] * d[b]);
            }
        }
    }
    urdf_rs::Inertial {
        origin: urdf_rs::Pose {
            xyz: urdf_rs::Vec3(com.into()),
            rpy: urdf_rs::Vec3([0.0; 3]),
        },
        mass: urdf_rs::Mass { value: mass },
        inertia: urdf_rs::Inertia {
            ixx: inertia[0][0],
            ixy: inertia[0][1],
            ixz: inertia[0][2],
            iyy: inertia[1][1],
            iyz: inertia[1][2],
            izz: inertia[2][2],
        },
    }
}

/// `R I Rᵀ`.
fn rotate_tensor(r: &M3, i: &M3) -> M3 {
    let mut out = [[0.0; 3]; 3];
    for (a, row) in out.iter_mut().enumerate() {
        for (b, x) in row.iter_mut().enumerate() {
            *x = (0..3)
                .flat_map(|k| (0..3).map(move |l| (k, l)))
                .map(|(k, l)| r[a][k] * i[k][l] * r[b][l])
                .sum();
        }
    }
    out
}

/// A frame as a URDF `<origin xyz rpy>` (`R = Rz(yaw) Ry(pitch) Rx(roll)`).
fn pose_of(f: &Frame) -> urdf_rs::Pose {
    let r = &f.r;
    let pitch = (-r[2][0]).clamp(-1.0, 1.0).asin();
    let (roll, yaw) = if r[2][0].abs() < 1.0 - 1e-12 {
        (r[2][1].atan2(r[2][2]), r[1][0].atan2(r[0][0]))
    } else {
        // Gimbal lock: only roll − yaw (or roll + yaw) is defined; put it all in roll.
        ((-r[1][2]).atan2(r[1][1]), 0.0)
    };
    urdf_rs::Pose {
        xyz: urdf_rs::Vec3(f.p.into()),
        rpy: urdf_rs::Vec3([roll, pitch, yaw]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pose(xyz: [f64; 3], rpy: [f64; 3]) -> urdf_rs::Pose {
        urdf_rs::Pose {
            xyz: urdf_rs::Vec3(xyz),
            rpy: urdf_rs::Vec3(rpy),
        }
    }

    #[test]
    fn origin_round_trips_through_rpy() {
        for rpy in [
            [0.3, -0.7, 1.2],
            [0.0, std::f64::consts::FRAC_PI_2, 0.0],
            [-2.0, 0.1, -3.0],
        ] {
            let f = Frame::from_urdf(&pose([0.1, -0.2, 0.3], rpy));
            let g = Frame::from_urdf(&pose_of(&f));
            for a in 0..3 {
                for b in 0..3 {
                    assert!((f.r[a][b] - g.r[a][b]).abs() < 1e-9, "{rpy:?}");
                }
            }
            assert!((f.p - g.p).norm() < 1e-15);
        }
    }

    /// Two point-like unit masses 2 m apart along x, one rotated: the combined inertia about the middle
    /// is the parallel-axis sum, `2 · 1 kg · (1 m)²` about y and z plus the rotated own inertias.
    #[test]
    fn combined_inertia_follows_the_parallel_axis_theorem() {
        let text = r#"<?xml version="1.0"?>
<robot name="t">
  <link name="a"><inertial><origin xyz="-1 0 0"/><mass value="1"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/></inertial></link>
  <link name="b"><inertial><origin xyz="0 0 0" rpy="0 0 1.5707963267948966"/><mass value="1"/>
    <inertia ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"/></inertial></link>
  <link name="c"><inertial><mass value="2"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="ab" type="fixed"><parent link="a"/><child link="b"/><origin xyz="1 0 0"/></joint>
  <joint name="bc" type="revolute"><parent link="b"/><child link="c"/><origin xyz="0 0 0.5"/>
    <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"#;
        let robot = urdf_rs::read_from_string(text).unwrap();
        let f = fuse_fixed(&robot);
        assert_eq!(f.robot.links.len(), 2);
        assert_eq!(f.robot.joints.len(), 1);
        let a = &f.robot.links[0].inertial;
        assert!((a.mass.value - 2.0).abs() < 1e-12);
        assert!(a.origin.xyz.0.iter().all(|x| x.abs() < 1e-12));
        // b's own inertia turned a quarter about z: ixx and iyy swap.
        assert!((a.inertia.ixx - (0.1 + 0.2)).abs() < 1e-12, "{a:?}");
        assert!((a.inertia.iyy - (0.2 + 0.1 + 2.0)).abs() < 1e-12, "{a:?}");
        assert!((a.inertia.izz - (0.3 + 0.3 + 2.0)).abs() < 1e-12, "{a:?}");
        // The revolute joint now hangs on `a`, at b's frame composed with its own origin.
        let j = &f.robot.joints[0];
        assert_eq!(j.parent.link, "a");
        assert!((j.origin.xyz.0[0] - 1.0).abs() < 1e-12 && (j.origin.xyz.0[2] - 0.5).abs() < 1e-12);
        let (body, off) = f.body_of("b").unwrap();
        assert_eq!(body, "a");
        assert!((off.p.x - 1.0).abs() < 1e-12);
    }
}
