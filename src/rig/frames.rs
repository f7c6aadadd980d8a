//! Small f64 vector and rigid-frame helpers for the URDF's geometry (rapier itself runs in f32).

/// A 3-vector, f64.
pub type V3 = nalgebra::Vector3<f64>;

/// What the rig's geometry needs beyond nalgebra's vector algebra.
pub trait V3Ext {
    /// Unit vector (zero stays zero).
    fn unit(self) -> V3;
    /// Rodrigues rotation about the unit axis `k` by `angle` (right-handed).
    fn rotated_about(self, k: V3, angle: f64) -> V3;
}

impl V3Ext for V3 {
    fn unit(self) -> V3 {
        let n = self.norm();
        if n > 0.0 {
            self * (1.0 / n)
        } else {
            self
        }
    }

    fn rotated_about(self, k: V3, angle: f64) -> V3 {
        let (s, c) = angle.sin_cos();
        self * c + k.cross(&self) * s + k * (k.dot(&self) * (1.0 - c))
    }
}

/// A rigid frame: rotation matrix (rows) and origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub r: [[f64; 3]; 3],
    pub p: V3,
}

impl Frame {
    pub const IDENTITY: Frame = Frame {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        p: V3::new(0.0, 0.0, 0.0),
    };

    /// A URDF `<origin xyz rpy>`: `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub fn from_urdf(pose: &urdf_rs::Pose) -> Self {
        let (sr, cr) = pose.rpy[0].sin_cos();
        let (sp, cp) = pose.rpy[1].sin_cos();
        let (sy, cy) = pose.rpy[2].sin_cos();
        let r = [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ];
        Self {
            r,
            p: V3::from(pose.xyz.0),
        }
    }

    pub fn rotate(&self, v: V3) -> V3 {
        let r = &self.r;
        V3::new(
            r[0][0] * v.x + r[0][1] * v.y + r[0][2] * v.z,
            r[1][0] * v.x + r[1][1] * v.y + r[1][2] * v.z,
            r[2][0] * v.x + r[2][1] * v.y + r[2][2] * v.z,
        )
    }

    pub fn apply(&self, v: V3) -> V3 {
        self.rotate(v) + self.p
    }

    /// `self ∘ o`.
    pub fn compose(&self, o: &Frame) -> Frame {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x = (0..3).map(|k| self.r[i][k] * o.r[k][j]).sum();
            }
        }
        Frame {
            r,
            p: self.apply(o.p),
        }
    }
}

/// World frames of every link at neutral (all joint coordinates zero), composed from the root along the
/// URDF tree. Links not reachable from the root keep the identity.
pub(crate) fn neutral_frames(robot: &urdf_rs::Robot) -> Vec<(String, Frame)> {
    let mut frames: Vec<(String, Frame)> = robot
        .links
        .iter()
        .map(|l| (l.name.clone(), Frame::IDENTITY))
        .collect();
    let mut done: Vec<bool> = robot
        .links
        .iter()
        .map(|l| !robot.joints.iter().any(|j| j.child.link == l.name))
        .collect();
    // Repeated relaxation: at most as many passes as links.
    for _ in 0..robot.links.len() {
        for j in &robot.joints {
            let (Some(pi), Some(ci)) = (
                robot.links.iter().position(|l| l.name == j.parent.link),
                robot.links.iter().position(|l| l.name == j.child.link),
            ) else {
                continue;
            };
            if done[pi] && !done[ci] {
                frames[ci].1 = frames[pi].1.compose(&Frame::from_urdf(&j.origin));
                done[ci] = true;
            }
        }
    }
    frames
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rodrigues_quarter_turn_about_y_takes_z_to_x() {
        let v = V3::new(0.0, 0.0, 1.0).rotated_about(V3::new(0.0, 1.0, 0.0), std::f64::consts::FRAC_PI_2);
        assert!((v - V3::new(1.0, 0.0, 0.0)).norm() < 1e-15);
    }

    #[test]
    fn urdf_pitch_matches_rodrigues() {
        let pose = urdf_rs::Pose {
            xyz: urdf_rs::Vec3([0.0; 3]),
            rpy: urdf_rs::Vec3([0.0, 0.3, 0.0]),
        };
        let f = Frame::from_urdf(&pose);
        let a = f.rotate(V3::new(0.2, -0.1, 0.7));
        let b = V3::new(0.2, -0.1, 0.7).rotated_about(V3::new(0.0, 1.0, 0.0), 0.3);
        assert!((a - b).norm() < 1e-15);
    }
}
