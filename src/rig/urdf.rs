//! Reading the rig's URDF: the kinematic tree (for `rapier3d-urdf`), the loop-closing joints
//! (`<loop_joint>`, an mrfeel extension that standard URDF parsers ignore), link visuals for Rerun, and
//! errors that name the file, the line and the element.

use std::path::{Path, PathBuf};

use super::RigError;

/// A parsed rig description.
#[derive(Debug, Clone)]
pub struct UrdfModel {
    pub path: PathBuf,
    text: String,
    /// The kinematic tree (every `<joint>`), as `rapier3d-urdf` will load it.
    pub robot: urdf_rs::Robot,
    /// Loop-closing joints (`<loop_joint>`), each with the same fields as a URDF `<joint>`.
    pub loops: Vec<urdf_rs::Joint>,
}

impl UrdfModel {
    /// Read and parse a URDF file with its loop joints.
    pub fn load(path: &Path) -> Result<Self, RigError> {
        let text = std::fs::read_to_string(path).map_err(|e| RigError::Io {
            path: path.to_path_buf(),
            msg: e.to_string(),
        })?;
        Self::parse(&text, path)
    }

    /// Parse URDF text; `path` is used for messages and to resolve nothing else.
    pub fn parse(text: &str, path: &Path) -> Result<Self, RigError> {
        let robot = urdf_rs::read_from_string(text).map_err(|e| RigError::Urdf {
            path: path.to_path_buf(),
            line: 0,
            msg: format!("not a valid URDF: {e}"),
        })?;
        // The loop joints read as ordinary joints once their tag is renamed; those whose names are not
        // in the tree are the loop joints.
        let renamed = text
            .replace("<loop_joint", "<joint")
            .replace("</loop_joint>", "</joint>");
        let all = urdf_rs::read_from_string(&renamed).map_err(|e| RigError::Urdf {
            path: path.to_path_buf(),
            line: 0,
            msg: format!("a <loop_joint> element is not a valid joint: {e}"),
        })?;
        let loops: Vec<urdf_rs::Joint> = all
            .joints
            .into_iter()
            .filter(|j| text_has_element(text, "loop_joint", &j.name))
            .collect();
        let model = Self {
            path: path.to_path_buf(),
            text: text.to_string(),
            robot,
            loops,
        };
        model.check_tree()?;
        Ok(model)
    }

    /// 1-based line of `<element name="name"`, or 0 when not found.
    pub fn line_of(&self, element: &str, name: &str) -> usize {
        find_element(&self.text, element, name)
            .map(|off| {
                self.text.as_bytes()[..off]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
                    + 1
            })
            .unwrap_or(0)
    }

    /// An error about a field of a named element.
    pub fn field_error(&self, element: &str, name: &str, field: &str, msg: impl Into<String>) -> RigError {
        RigError::Field {
            path: self.path.clone(),
            line: self.line_of(element, name),
            field: format!("{element} `{name}`: {field}"),
            msg: msg.into(),
        }
    }

    pub fn link(&self, name: &str) -> Result<&urdf_rs::Link, RigError> {
        self.robot
            .links
            .iter()
            .find(|l| l.name == name)
            .ok_or_else(|| RigError::Urdf {
                path: self.path.clone(),
                line: 0,
                msg: format!(
                    "no link named `{name}` (links: {})",
                    self.robot
                        .links
                        .iter()
                        .map(|l| l.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            })
    }

    pub fn joint(&self, name: &str) -> Result<&urdf_rs::Joint, RigError> {
        self.robot
            .joints
            .iter()
            .find(|j| j.name == name)
            .ok_or_else(|| RigError::Urdf {
                path: self.path.clone(),
                line: 0,
                msg: format!(
                    "no joint named `{name}` (joints: {})",
                    self.robot
                        .joints
                        .iter()
                        .map(|j| j.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            })
    }

    pub fn loop_joint(&self, name: &str) -> Result<&urdf_rs::Joint, RigError> {
        self.loops
            .iter()
            .find(|j| j.name == name)
            .ok_or_else(|| RigError::Urdf {
                path: self.path.clone(),
                line: 0,
                msg: format!(
                    "no <loop_joint> named `{name}` (loop joints: {})",
                    self.loops
                        .iter()
                        .map(|j| j.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            })
    }

    /// Every joint's parent and child exist, every link has at most one parent joint, and masses and
    /// inertias are physical.
    fn check_tree(&self) -> Result<(), RigError> {
        for j in self.robot.joints.iter().chain(&self.loops) {
            let element = if self.loops.iter().any(|l| l.name == j.name) {
                "loop_joint"
            } else {
                "joint"
            };
            for (field, link) in [("parent", &j.parent.link), ("child", &j.child.link)] {
                if !self.robot.links.iter().any(|l| &l.name == link) {
                    return Err(self.field_error(element, &j.name, field, format!("no link named `{link}`")));
                }
            }
        }
        for l in &self.robot.links {
            let parents = self
                .robot
                .joints
                .iter()
                .filter(|j| j.child.link == l.name)
                .count();
            if parents > 1 {
                return Err(self.field_error(
                    "link",
                    &l.name,
                    "parent",
                    format!(
                        "{parents} joints have this link as child; close a kinematic loop with <loop_joint>"
                    ),
                ));
            }
            let m = l.inertial.mass.value;
            if !m.is_finite() || m < 0.0 {
                return Err(self.field_error(
                    "link",
                    &l.name,
                    "inertial/mass",
                    format!("mass {m} must be ≥ 0"),
                ));
            }
            let i = &l.inertial.inertia;
            for (name, v) in [("ixx", i.ixx), ("iyy", i.iyy), ("izz", i.izz)] {
                if !v.is_finite() || v < 0.0 {
                    return Err(self.field_error(
                        "link",
                        &l.name,
                        &format!("inertia/{name}"),
                        format!("{v} must be ≥ 0"),
                    ));
                }
            }
            // Triangle inequality of principal moments (for the diagonal inertias used here).
            if i.ixy == 0.0 && i.ixz == 0.0 && i.iyz == 0.0 && m > 0.0 {
                let (a, b, c) = (i.ixx, i.iyy, i.izz);
                let tol = 1e-9 * (a + b + c);
                if a + b < c - tol || a + c < b - tol || b + c < a - tol {
                    return Err(self.field_error(
                        "link",
                        &l.name,
                        "inertia",
                        format!("moments ixx={a}, iyy={b}, izz={c} violate the triangle inequality (not a physical body)"),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Byte offset of `<element` whose `name="name"` attribute matches.
fn find_element(text: &str, element: &str, name: &str) -> Option<usize> {
    let open = format!("<{element}");
    let mut from = 0;
    while let Some(rel) = text[from..].find(&open) {
        let start = from + rel;
        let after = start + open.len();
        // The tag name must end here (`<joint` must not match `<jointx`).
        let next = text[after..].chars().next();
        if matches!(next, Some(c) if c.is_whitespace() || c == '>' || c == '/') {
            let end = text[after..].find('>').map(|e| after + e).unwrap_or(text.len());
            let tag = &text[after..end];
            if tag_name_is(tag, name) {
                return Some(start);
            }
        }
        from = after;
    }
    None
}

fn tag_name_is(tag: &str, name: &str) -> bool {
    for quote in ['"', '\''] {
        let pat = format!("name={quote}{name}{quote}");
        if tag.contains(&pat) {
            return true;
        }
    }
    false
}

fn text_has_element(text: &str, element: &str, name: &str) -> bool {
    find_element(text, element, name).is_some()
}

/// Rotation of a URDF `rpy` (fixed-axis roll, pitch, yaw: `Rz(yaw) Ry(pitch) Rx(roll)`) as a unit
/// quaternion `[x, y, z, w]`.
pub fn rpy_to_quat_xyzw(rpy: [f64; 3]) -> [f64; 4] {
    let (sr, cr) = (rpy[0] / 2.0).sin_cos();
    let (sp, cp) = (rpy[1] / 2.0).sin_cos();
    let (sy, cy) = (rpy[2] / 2.0).sin_cos();
    [
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINI: &str = r#"<?xml version="1.0"?>
<robot name="t">
  <link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <link name="c"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="ab" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="ac" type="prismatic"><parent link="a"/><child link="c"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <loop_joint name="cb" type="revolute"><parent link="c"/><child link="b"/><origin xyz="0.5 0 0"/>
    <axis xyz="0 1 0"/></loop_joint>
</robot>"#;

    #[test]
    fn loop_joints_are_read_apart_from_the_tree() {
        let m = UrdfModel::parse(MINI, Path::new("mini.urdf")).unwrap();
        assert_eq!(m.robot.joints.len(), 2);
        assert_eq!(m.loops.len(), 1);
        assert_eq!(m.loops[0].name, "cb");
        assert_eq!(m.loops[0].origin.xyz[0], 0.5);
        assert_eq!(m.line_of("loop_joint", "cb"), 10);
    }

    #[test]
    fn a_link_with_two_parents_is_an_error_naming_the_line() {
        let bad = MINI
            .replace("<loop_joint", "<joint")
            .replace("</loop_joint>", "</joint>");
        let e = UrdfModel::parse(&bad, Path::new("bad.urdf"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.urdf:4") && e.contains("link `b`"), "{e}");
    }

    #[test]
    fn unphysical_inertia_is_rejected() {
        let bad = MINI.replacen(
            r#"ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1""#,
            r#"ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="3""#,
            1,
        );
        let e = UrdfModel::parse(&bad, Path::new("bad.urdf"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("triangle inequality") && e.contains("bad.urdf:3"),
            "{e}"
        );
    }

    #[test]
    fn rpy_quaternion_turns_z_into_x_for_a_quarter_pitch() {
        let q = rpy_to_quat_xyzw([0.0, std::f64::consts::FRAC_PI_2, 0.0]);
        // Rotate z = (0,0,1) by q: v' = v + 2w(u×v) + 2u×(u×v)
        let (u, w) = ([q[0], q[1], q[2]], q[3]);
        let v = [0.0, 0.0, 1.0];
        let c = |a: [f64; 3], b: [f64; 3]| {
            [
                a[1] * b[2] - a[2] * b[1],
                a[2] * b[0] - a[0] * b[2],
                a[0] * b[1] - a[1] * b[0],
            ]
        };
        let uv = c(u, v);
        let uuv = c(u, uv);
        let r: Vec<f64> = (0..3).map(|k| v[k] + 2.0 * w * uv[k] + 2.0 * uuv[k]).collect();
        assert!(
            (r[0] - 1.0).abs() < 1e-12 && r[1].abs() < 1e-12 && r[2].abs() < 1e-12,
            "{r:?}"
        );
    }
}
