//! The rig's URDF: the kinematic tree (for `rapier3d-urdf`), the loop-closing joints (`<loop_joint>`, an
//! mrfeel extension that standard URDF parsers ignore) and link visuals, with errors that name the line.
//!
//! `urdf-rs` reports no position, so the text is first read with every element's and attribute's line
//! (`scan_xml`, on quick-xml) and checked against what `urdf-rs` reads (`SCHEMA`).

use std::path::{Path, PathBuf};

use super::{InputError, Source};

/// A parsed rig description.
#[derive(Debug, Clone)]
pub struct UrdfModel {
    /// The URDF file read.
    pub path: PathBuf,
    /// The element tree with lines (for messages).
    xml: XmlElement,
    /// The kinematic tree (every `<joint>`), as `rapier3d-urdf` will load it.
    pub robot: urdf_rs::Robot,
    /// Loop-closing joints (`<loop_joint>`), each with the same fields as a URDF `<joint>`.
    pub loops: Vec<urdf_rs::Joint>,
}

impl UrdfModel {
    /// Read and parse a URDF file with its loop joints.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        Self::parse(&Source::read(path)?.text, path)
    }

    /// Parse URDF text; `path` is used for messages and to resolve nothing else.
    pub fn parse(text: &str, path: &Path) -> Result<Self, InputError> {
        let xml = scan_xml(text)
            .map_err(|(line, msg)| urdf_error(path, line, format!("not a valid URDF (XML): {msg}")))?;
        check_schema(&xml).map_err(|(line, field, msg)| urdf_error(path, line, format!("{field}: {msg}")))?;
        // What the checks above let through, `urdf-rs` reads; should it not, the line its XML reader names
        // (`Line: N`, e.g. for `--` inside a comment, which quick-xml lets pass), else the <robot> line.
        let robot = urdf_rs::read_from_string(text).map_err(|e| {
            let msg = e.to_string();
            urdf_error(
                path,
                line_in_message(&msg).unwrap_or(xml.line),
                format!("not a valid URDF: {msg}"),
            )
        })?;
        // The loop joints read as ordinary joints once their tag is renamed; those whose names are not
        // in the tree are the loop joints.
        let renamed = text
            .replace("<loop_joint", "<joint")
            .replace("</loop_joint>", "</joint>");
        let all = urdf_rs::read_from_string(&renamed).map_err(|e| {
            urdf_error(
                path,
                xml.children
                    .iter()
                    .find(|c| c.name == "loop_joint")
                    .map_or(xml.line, |c| c.line),
                format!("a <loop_joint> element is not a valid joint: {e}"),
            )
        })?;
        let loop_names: Vec<&str> = xml
            .children
            .iter()
            .filter(|c| c.name == "loop_joint")
            .map(XmlElement::name_attr)
            .collect();
        let loops: Vec<urdf_rs::Joint> = all
            .joints
            .into_iter()
            .filter(|j| loop_names.contains(&j.name.as_str()))
            .collect();
        let model = Self {
            path: path.to_path_buf(),
            xml,
            robot,
            loops,
        };
        model.check_tree()?;
        Ok(model)
    }

    /// 1-based line of `<element name="name"` (a child of `<robot>`), or 0 when there is none.
    pub(crate) fn line_of(&self, element: &str, name: &str) -> usize {
        self.element(element, name).map_or(0, |e| e.line)
    }

    /// 1-based line of the first nested element along `path` (`["inertial", "mass"]`) in `<element
    /// name="name">`, or of the element itself where the path stops.
    pub(crate) fn line_in(&self, element: &str, name: &str, path: &[&str]) -> usize {
        let Some(mut e) = self.element(element, name) else {
            return 0;
        };
        for step in path {
            match e.children.iter().find(|c| c.name == *step) {
                Some(c) => e = c,
                None => break,
            }
        }
        e.line
    }

    fn element(&self, element: &str, name: &str) -> Option<&XmlElement> {
        self.xml
            .children
            .iter()
            .find(|c| c.name == element && c.name_attr() == name)
    }

    /// An error about a field of a named element.
    pub(crate) fn field_error(
        &self,
        element: &str,
        name: &str,
        field: &str,
        msg: impl Into<String>,
    ) -> InputError {
        urdf_error(
            &self.path,
            self.line_of(element, name),
            format!("{element} `{name}`: {field}: {}", msg.into()),
        )
    }

    pub(crate) fn link(&self, name: &str) -> Result<&urdf_rs::Link, InputError> {
        self.named(&self.robot.links, name, "link", "links", |l| &l.name)
    }

    pub(crate) fn joint(&self, name: &str) -> Result<&urdf_rs::Joint, InputError> {
        self.named(&self.robot.joints, name, "joint", "joints", |j| &j.name)
    }

    pub(crate) fn loop_joint(&self, name: &str) -> Result<&urdf_rs::Joint, InputError> {
        self.named(&self.loops, name, "<loop_joint>", "loop joints", |j| &j.name)
    }

    /// The item of `items` named `name`, or an error listing the names there are.
    fn named<'a, T>(
        &self,
        items: &'a [T],
        name: &str,
        what: &str,
        plural: &str,
        name_of: impl Fn(&T) -> &String,
    ) -> Result<&'a T, InputError> {
        items.iter().find(|i| name_of(i) == name).ok_or_else(|| {
            let all: Vec<&str> = items.iter().map(|i| name_of(i).as_str()).collect();
            let msg = format!("no {what} named `{name}` ({plural}: {})", all.join(", "));
            urdf_error(&self.path, 0, msg)
        })
    }

    /// Every joint's parent and child exist, every link has at most one parent joint, and masses and
    /// inertias are physical.
    fn check_tree(&self) -> Result<(), InputError> {
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
                let msg = format!(
                    "{parents} joints have this link as child; close a kinematic loop with <loop_joint>"
                );
                return Err(self.field_error("link", &l.name, "parent", msg));
            }
            let m = l.inertial.mass.value;
            if !m.is_finite() || m < 0.0 {
                return Err(self.mass_error(&l.name, format!("mass {m} must be ≥ 0")));
            }
            let i = &l.inertial.inertia;
            for (name, v) in [("ixx", i.ixx), ("iyy", i.iyy), ("izz", i.izz)] {
                if !v.is_finite() || v < 0.0 {
                    let field = format!("inertial/inertia `{name}`");
                    return Err(self.inertial_error(&l.name, "inertia", &field, format!("{v} must be ≥ 0")));
                }
            }
            // Triangle inequality of principal moments (for the diagonal inertias used here).
            if i.ixy == 0.0 && i.ixz == 0.0 && i.iyz == 0.0 && m > 0.0 {
                let (a, b, c) = (i.ixx, i.iyy, i.izz);
                let tol = 1e-9 * (a + b + c);
                if a + b < c - tol || a + c < b - tol || b + c < a - tol {
                    let msg = format!(
                        "moments ixx={a}, iyy={b}, izz={c} violate the triangle inequality (not a physical body)"
                    );
                    return Err(self.inertial_error(&l.name, "inertia", "inertial/inertia", msg));
                }
            }
        }
        // A link that a joint moves is a body: it needs mass, alone or with the links fixed to it (a
        // massless body has no dynamics; the loader would give it an arbitrary one).
        for j in &self.robot.joints {
            if matches!(j.joint_type, urdf_rs::JointType::Fixed) {
                continue;
            }
            let group = self.fixed_group(&j.child.link);
            let mass: f64 = self
                .robot
                .links
                .iter()
                .filter(|l| group.contains(&l.name.as_str()))
                .map(|l| l.inertial.mass.value)
                .sum();
            if mass <= 0.0 {
                let fixed = if group.len() > 1 {
                    format!(" (with the links fixed to it: {})", group[1..].join(", "))
                } else {
                    String::new()
                };
                let kind = format!("{:?}", j.joint_type).to_lowercase();
                let msg = format!(
                    "mass {mass} kg{fixed}: the link moves on joint `{}` ({kind}) and must have a mass > 0",
                    j.name
                );
                return Err(self.mass_error(&j.child.link, msg));
            }
        }
        Ok(())
    }

    /// `link` and every link joined to it, below it, by fixed joints: one rigid body.
    pub(crate) fn fixed_group<'a>(&'a self, link: &'a str) -> Vec<&'a str> {
        let mut group = vec![link];
        let mut k = 0;
        while k < group.len() {
            for j in &self.robot.joints {
                let (parent, child) = (j.parent.link.as_str(), j.child.link.as_str());
                if matches!(j.joint_type, urdf_rs::JointType::Fixed)
                    && parent == group[k]
                    && !group.contains(&child)
                {
                    group.push(child);
                }
            }
            k += 1;
        }
        group
    }

    /// An error about the mass of a link, at the line of its `<mass>` (of the link without one).
    fn mass_error(&self, link: &str, msg: String) -> InputError {
        self.inertial_error(link, "mass", "inertial/mass", msg)
    }

    /// An error about `<inertial><child>` of a link, at the line of that element.
    fn inertial_error(&self, link: &str, child: &str, field: &str, msg: String) -> InputError {
        urdf_error(
            &self.path,
            self.line_in("link", link, &["inertial", child]),
            format!("link `{link}`: {field}: {msg}"),
        )
    }
}

/// An error at `line` of a URDF (0: no line to name).
pub(crate) fn urdf_error(path: &Path, line: usize, msg: impl Into<String>) -> InputError {
    match line {
        0 => InputError::file(path, msg),
        _ => InputError::line(path, line, msg),
    }
}

/// An element of the file, with the 1-based line of its start tag.
#[derive(Debug, Clone, Default)]
struct XmlElement {
    name: String,
    line: usize,
    attrs: Vec<XmlAttr>,
    children: Vec<XmlElement>,
}

#[derive(Debug, Clone)]
struct XmlAttr {
    name: String,
    value: String,
    line: usize,
}

impl XmlElement {
    fn attr(&self, name: &str) -> Option<&XmlAttr> {
        self.attrs.iter().find(|a| a.name == name)
    }

    /// The `name` attribute's value, `""` without one.
    fn name_attr(&self) -> &str {
        self.attr("name").map_or("", |a| a.value.as_str())
    }
}

type XmlError = (usize, String);

/// The deepest nesting of elements read: the tree is walked by recursion (here and in `urdf-rs`), which a
/// file nesting tens of thousands of elements would take past the stack.
const MAX_DEPTH: usize = 256;

/// Read the XML text (with quick-xml, as urdf-rs does) into its element tree, every element and attribute
/// with its line, or the line and reason it is not XML.
fn scan_xml(text: &str) -> Result<XmlElement, XmlError> {
    use quick_xml::events::{BytesStart, Event};
    // 1-based line of a byte offset, by the offsets where lines start.
    let starts: Vec<usize> = std::iter::once(0)
        .chain(text.match_indices('\n').map(|(i, _)| i + 1))
        .collect();
    let line_of = |offset: usize| starts.partition_point(|&s| s <= offset);
    let mut reader = quick_xml::Reader::from_str(text);
    // End tags are matched here, to name the line the unmatched element was opened at.
    reader.config_mut().check_end_names = false;
    let mut stack: Vec<XmlElement> = Vec::new();
    let mut root: Option<XmlElement> = None;
    let at_error = |reader: &quick_xml::Reader<&[u8]>| line_of(reader.error_position() as usize);
    // An element from its start tag, which begins at byte `start` of the text.
    let element = |tag: &BytesStart<'_>, start: usize| -> Result<XmlElement, XmlError> {
        let name = String::from_utf8_lossy(tag.name().as_ref()).into_owned();
        let line = line_of(start);
        // The tag's text from its `<`: quick-xml's tag content (quotes may hold a `>`) and the `<`.
        let raw = text.get(start..start + 1 + tag.len()).unwrap_or(&text[start..]);
        let mut el = XmlElement {
            name,
            line,
            ..Default::default()
        };
        for attr in tag.attributes() {
            let attr = attr.map_err(|e| (line, format!("in tag `<{}>`: {e}", el.name)))?;
            let key = String::from_utf8_lossy(attr.key.as_ref()).into_owned();
            let value = attr
                .unescape_value()
                .map_err(|e| (line, format!("attribute `{key}` of `<{}>`: {e}", el.name)))?
                .into_owned();
            el.attrs.push(XmlAttr {
                line: line_of(start + attribute_offset(raw, &key)),
                name: key,
                value,
            });
        }
        Ok(el)
    };
    loop {
        let before = reader.buffer_position() as usize;
        let event = reader
            .read_event()
            .map_err(|e| (at_error(&reader), e.to_string()))?;
        // Where the event's markup begins: its `<` (text events begin where the last event ended).
        let start = before + text[before..].find('<').unwrap_or(0);
        let closed = match event {
            Event::Start(tag) => {
                if stack.len() >= MAX_DEPTH {
                    let name = String::from_utf8_lossy(tag.name().as_ref()).into_owned();
                    return Err((
                        line_of(start),
                        format!(
                            "`<{name}>` is nested {} elements deep, more than the {MAX_DEPTH} allowed (a URDF \
                             nests a few)",
                            stack.len() + 1
                        ),
                    ));
                }
                stack.push(element(&tag, start)?);
                None
            }
            Event::Empty(tag) => Some(element(&tag, start)?),
            Event::End(tag) => {
                let name = String::from_utf8_lossy(tag.name().as_ref()).into_owned();
                let line = line_of(start);
                let Some(open) = stack.pop() else {
                    return Err((line, format!("`</{name}>` closes no open element")));
                };
                if open.name != name {
                    let (open, at) = (&open.name, open.line);
                    let msg = format!("`</{name}>` does not close `<{open}>` opened at line {at}");
                    return Err((line, msg));
                }
                Some(open)
            }
            Event::Text(t) if stack.is_empty() && !<[u8]>::trim_ascii(&t).is_empty() => {
                let shown: String = String::from_utf8_lossy(&t).trim().chars().take(30).collect();
                let at = before + text[before..].find(|c: char| !c.is_whitespace()).unwrap_or(0);
                let where_ = if root.is_some() {
                    "after the root element"
                } else {
                    "before any element (not an XML file?)"
                };
                return Err((line_of(at), format!("text `{shown}` {where_}")));
            }
            Event::Eof => break,
            _ => None,
        };
        if let Some(el) = closed {
            match stack.last_mut() {
                Some(parent) => parent.children.push(el),
                None if root.is_some() => {
                    let msg = format!("a second root element `<{}>` after the first", el.name);
                    return Err((el.line, msg));
                }
                None => root = Some(el),
            }
        }
    }
    if let Some(open) = stack.last() {
        let name = &open.name;
        let msg = format!("`<{name}>` is never closed (the file ends inside it: truncated?)");
        return Err((open.line, msg));
    }
    root.ok_or((1, "no XML element at all (not a URDF file?)".to_string()))
}

/// The line an XML reader's message names (`... Line: 169, Column: 21 ...`).
fn line_in_message(msg: &str) -> Option<usize> {
    let rest = &msg[msg.find("Line: ")? + "Line: ".len()..];
    rest[..rest.find(|c: char| !c.is_ascii_digit())?]
        .parse()
        .ok()
        .filter(|l| *l > 0)
}

/// Byte offset, in the tag text `raw` (from its `<`), of the attribute `key`: where `key` stands after
/// white space and before `=`; 0 (the tag's start) if not found.
fn attribute_offset(raw: &str, key: &str) -> usize {
    raw.match_indices(key)
        .find(|&(k, _)| {
            raw[..k].ends_with(|c: char| c.is_whitespace())
                && raw[k + key.len()..].trim_start().starts_with('=')
        })
        .map_or(0, |(k, _)| k)
}

/// The attributes and children `urdf-rs` reads from an element, by its parent (`*`: any) and its name.
/// Attributes are `name:kind` (`t` text, `n` a number, `+` a number ≥ 0 (a joint's loss: a negative one
/// would feed energy in), `3`/`4` a vector of 3/4 numbers, `j` a joint type); children are names, `*` after
/// one that may repeat; `!` marks what is required. Elements not listed are left to `urdf-rs`.
const SCHEMA: &[(&str, &str, &str, &str)] = &[
    ("robot", "link", "name:t!", "inertial visual* collision*"),
    ("robot", "joint", "name:t! type:j!", JOINT_CHILDREN),
    ("robot", "loop_joint", "name:t! type:j!", JOINT_CHILDREN),
    ("robot", "material", "name:t!", "color texture"),
    ("visual", "material", "name:t!", "color texture"),
    ("link", "inertial", "", "origin mass! inertia!"),
    ("link", "visual", "name:t", "origin geometry! material"),
    ("link", "collision", "name:t", "origin geometry!"),
    ("*", "origin", "xyz:3 rpy:3 quat_xyzw:4", ""),
    ("inertial", "mass", "value:n!", ""),
    (
        "inertial",
        "inertia",
        "ixx:n! ixy:n! ixz:n! iyy:n! iyz:n! izz:n!",
        "",
    ),
    ("*", "geometry", "", "box cylinder capsule sphere mesh"),
    ("geometry", "box", "size:3!", ""),
    ("geometry", "cylinder", "radius:n! length:n!", ""),
    ("geometry", "capsule", "radius:n! length:n!", ""),
    ("geometry", "sphere", "radius:n!", ""),
    ("geometry", "mesh", "filename:t! scale:3", ""),
    ("material", "color", "rgba:4!", ""),
    ("material", "texture", "filename:t!", ""),
    ("*", "parent", "link:t!", ""),
    ("*", "child", "link:t!", ""),
    ("*", "axis", "xyz:3!", ""),
    ("*", "limit", "lower:n upper:n effort:n velocity:n!", ""),
    ("*", "calibration", "rising:n falling:n", ""),
    ("*", "dynamics", "damping:+ friction:+", ""),
    ("*", "mimic", "joint:t! multiplier:n offset:n", ""),
    (
        "*",
        "safety_controller",
        "soft_lower_limit:n soft_upper_limit:n k_position:n k_velocity:n!",
        "",
    ),
];

const JOINT_CHILDREN: &str = "origin parent! child! axis limit calibration dynamics mimic safety_controller";

/// The joint types, as a message lists them.
const JOINT_TYPES: &str = "revolute, continuous, prismatic, fixed, floating, planar, spherical";

/// An element's attributes (name, kind, required) and children (name, repeatable, required) by
/// [`SCHEMA`], `None` for an element not listed.
#[allow(clippy::type_complexity)]
fn schema(
    parent: &str,
    name: &str,
) -> Option<(Vec<(&'static str, char, bool)>, Vec<(&'static str, bool, bool)>)> {
    let &(_, _, attrs, children) = SCHEMA
        .iter()
        .find(|s| (s.0 == parent || s.0 == "*") && s.1 == name)?;
    let attrs = attrs.split_whitespace().map(|a| {
        let (name, kind) = a.split_once(':').expect("name:kind");
        (name, kind.chars().next().expect("a kind"), kind.ends_with('!'))
    });
    let children = children.split_whitespace().map(|c| {
        let name = c.trim_end_matches(['!', '*']);
        (name, c.contains('*'), c.ends_with('!'))
    });
    Some((attrs.collect(), children.collect()))
}

/// A finding of the checker: line, the element (`link `stick`: inertial/mass`), the message.
type SchemaError = (usize, String, String);

/// Check the robot's links, joints and loop joints against [`schema`], and that link names and joint names
/// (`<joint>` and `<loop_joint>` together) are unique.
fn check_schema(root: &XmlElement) -> Result<(), SchemaError> {
    if root.name != "robot" {
        return Err((
            root.line,
            format!("<{}>", root.name),
            "the root element must be <robot> (not a URDF file?)".into(),
        ));
    }
    let mut links: Vec<(&str, usize)> = Vec::new();
    let mut joints: Vec<(&str, &str, usize)> = Vec::new();
    for el in &root.children {
        if schema("robot", &el.name).is_none() {
            continue; // <gazebo>, <transmission>, ...: not read
        }
        let owner = match el.attr("name") {
            Some(a) => format!("{} `{}`", el.name, a.value),
            None => format!("<{}>", el.name),
        };
        check_element("robot", el, &owner, "")?;
        let name = el.name_attr();
        match el.name.as_str() {
            "link" => {
                if let Some((_, first)) = links.iter().find(|(n, _)| *n == name) {
                    let msg = format!("name: a second link named `{name}` (the first is at line {first})");
                    return Err((el.line, owner, msg));
                }
                links.push((name, el.line));
            }
            "joint" | "loop_joint" => {
                if let Some((_, kind, first)) = joints.iter().find(|(n, _, _)| *n == name) {
                    let msg = format!(
                        "name: a second joint named `{name}` (the first, a <{kind}>, is at line {first})"
                    );
                    return Err((el.line, owner, msg));
                }
                joints.push((name, &el.name, el.line));
            }
            _ => {}
        }
    }
    Ok(())
}

fn check_element(parent: &str, el: &XmlElement, owner: &str, path: &str) -> Result<(), SchemaError> {
    let Some((attrs, children)) = schema(parent, &el.name) else {
        return Ok(());
    };
    let here = match path {
        "" => owner.to_string(),
        _ => format!("{owner}: {path}"),
    };
    let allowed = |names: Vec<String>| match names.is_empty() {
        true => "none".to_string(),
        false => names.join(", "),
    };
    for a in &el.attrs {
        let Some(&(_, kind, _)) = attrs.iter().find(|(n, _, _)| *n == a.name) else {
            let known = allowed(attrs.iter().map(|(n, _, _)| n.to_string()).collect());
            let msg = format!("unknown attribute `{}` (allowed: {known})", a.name);
            return Err((a.line, here, msg));
        };
        check_value(kind, &a.value).map_err(|m| (a.line, here.clone(), format!("`{}`: {m}", a.name)))?;
    }
    if let Some((name, _, _)) = attrs
        .iter()
        .find(|(n, _, required)| *required && el.attr(n).is_none())
    {
        return Err((el.line, here, format!("missing attribute `{name}`")));
    }
    for c in &el.children {
        let Some(&(_, repeats, _)) = children.iter().find(|(n, _, _)| *n == c.name) else {
            let known = allowed(children.iter().map(|(n, _, _)| format!("<{n}>")).collect());
            let msg = format!("unknown element <{}> (allowed here: {known})", c.name);
            return Err((c.line, here, msg));
        };
        let first = el.children.iter().find(|d| d.name == c.name).expect("c itself");
        if !repeats && !std::ptr::eq(first, c) {
            let (name, at) = (&c.name, first.line);
            let msg = format!("a second <{name}> (one allowed; the first is at line {at})");
            return Err((c.line, here, msg));
        }
        let sub = match path {
            "" => c.name.clone(),
            _ => format!("{path}/{}", c.name),
        };
        check_element(&el.name, c, owner, &sub)?;
    }
    if let Some((name, _, _)) = children
        .iter()
        .find(|(n, _, required)| *required && !el.children.iter().any(|c| c.name == *n))
    {
        return Err((el.line, here, format!("missing element <{name}>")));
    }
    if el.name == "geometry" && el.children.len() != 1 {
        let msg = "needs exactly one shape: <box>, <cylinder>, <capsule>, <sphere> or <mesh>";
        return Err((el.line, here, msg.into()));
    }
    Ok(())
}

/// Whether `v` is an attribute value of `kind` (see [`SCHEMA`]).
fn check_value(kind: char, v: &str) -> Result<(), String> {
    let num = |s: &str| -> Result<f64, String> {
        match s.trim().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            Ok(_) => Err(format!("`{s}` is not a finite number")),
            Err(_) => Err(format!("`{s}` is not a number")),
        }
    };
    let vector = |n: usize| -> Result<(), String> {
        let parts: Vec<&str> = v.split_whitespace().collect();
        if parts.len() != n {
            let s = if parts.len() == 1 { "" } else { "s" };
            let msg = format!(
                "`{v}` has {} value{s}, {n} expected (numbers separated by spaces)",
                parts.len()
            );
            return Err(msg);
        }
        parts.iter().try_for_each(|p| num(p).map(|_| ()))
    };
    match kind {
        'n' => num(v).map(|_| ()),
        '+' => match num(v)? {
            x if x >= 0.0 => Ok(()),
            x => Err(format!(
                "{x} must be ≥ 0 (a joint's loss: a negative one feeds energy into the rig)"
            )),
        },
        '3' => vector(3),
        '4' => vector(4),
        'j' if !JOINT_TYPES.split(", ").any(|t| t == v) => Err(format!("`{v}` is not one of: {JOINT_TYPES}")),
        _ => Ok(()),
    }
}

/// Rotation of a URDF `rpy` (fixed-axis roll, pitch, yaw: `Rz(yaw) Ry(pitch) Rx(roll)`) as a unit
/// quaternion `[x, y, z, w]`.
pub(crate) fn rpy_to_quat_xyzw(rpy: [f64; 3]) -> [f64; 4] {
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

    fn parse_err(text: &str) -> String {
        UrdfModel::parse(text, Path::new("bad.urdf"))
            .expect_err("must be rejected")
            .to_string()
    }

    /// `text` is refused with a message holding both `at` (file and line) and `what`.
    fn refused(text: &str, at: &str, what: &str) {
        let e = parse_err(text);
        assert!(e.contains(at) && e.contains(what), "{e}");
    }

    #[test]
    fn a_link_with_two_parents_is_an_error_naming_the_line() {
        let bad = MINI
            .replace("<loop_joint", "<joint")
            .replace("</loop_joint>", "</joint>");
        refused(&bad, "bad.urdf:4", "link `b`");
    }

    #[test]
    fn unphysical_inertia_is_rejected() {
        let bad = MINI.replacen(
            r#"ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1""#,
            r#"ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="3""#,
            1,
        );
        refused(&bad, "bad.urdf:3", "triangle inequality");
    }

    #[test]
    fn the_shipped_rig_passes_the_checks() {
        let path = crate::builtin::by_file_name("stick-rig.urdf").unwrap();
        let m = UrdfModel::load(&path).unwrap();
        assert_eq!(m.loops.len(), 1);
        // Lines come from elements, not from mentions in comments.
        assert_eq!(m.line_of("loop_joint", "rod_end_pin"), 207);
        assert_eq!(m.line_in("link", "stick", &["inertial", "mass"]), 75);
    }

    #[test]
    fn bad_values_name_the_line_element_and_attribute() {
        // An attribute on the next line of its tag, after a quoted `>`, is still found at its own line.
        let split = "<joint name=\"a>c\"\n    type=\"prismatik\">";
        refused(
            &MINI.replace(r#"<joint name="ac" type="prismatic">"#, split),
            "bad.urdf:9:",
            "`prismatik`",
        );
        // A value that urdf-rs would silently drop from a vector.
        let bad_axis = MINI.replacen(r#"<axis xyz="0 1 0"/>"#, r#"<axis xyz="0 one 0"/>"#, 1);
        refused(&bad_axis, "bad.urdf:6:", "`one` is not a number");
        let no_mass = MINI.replacen(r#"<mass value="1"/>"#, r#"<mass/>"#, 1);
        refused(&no_mass, "bad.urdf:3:", "missing attribute `value`");
        let limits = MINI.replacen("<limit ", "<limits ", 1);
        refused(&limits, "bad.urdf:7:", "unknown element <limits>");
    }

    #[test]
    fn malformed_xml_names_the_line() {
        refused(
            &MINI[..MINI.find("<origin").unwrap() + 12],
            "bad.urdf:10:",
            "not closed",
        );
        assert!(parse_err("").contains("bad.urdf:1:"));
        assert!(parse_err("hello").contains("bad.urdf:1:"));
        refused(
            "<?xml version=\"1.0\"?>\n<link name=\"a\"/>\n",
            "bad.urdf:2:",
            "must be <robot>",
        );
        // `--` inside a comment: quick-xml lets it pass, urdf-rs's reader refuses it at its line.
        let comment = MINI.replace("  <joint name=\"ac\"", "  <!-- a -- b -->\n  <joint name=\"ac\"");
        refused(&comment, "bad.urdf:8:", "not a valid URDF");
    }

    #[test]
    fn a_loop_joint_may_not_repeat_a_joint_name() {
        let e = parse_err(&MINI.replace(r#"<loop_joint name="cb""#, r#"<loop_joint name="ab""#));
        assert!(
            e.contains("bad.urdf:10:") && e.contains("a second joint named `ab`") && e.contains("line 6"),
            "{e}"
        );
    }

    /// The root is fixed to the world: it needs no mass (a moving massless link is refused:
    /// `tests/bad_input_files.rs`).
    #[test]
    fn a_massless_root_link_is_accepted() {
        let massless = MINI.replacen(r#"<mass value="1"/>"#, r#"<mass value="0"/>"#, 1);
        UrdfModel::parse(&massless, Path::new("ok.urdf")).unwrap();
    }

    #[test]
    fn rpy_quaternion_turns_z_into_x_for_a_quarter_pitch() {
        let q = rpy_to_quat_xyzw([0.0, std::f64::consts::FRAC_PI_2, 0.0]);
        // Rotate z = (0,0,1) by q.
        let q = nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[3], q[0], q[1], q[2]));
        let r = q * nalgebra::Vector3::z();
        assert!(
            (r[0] - 1.0).abs() < 1e-12 && r[1].abs() < 1e-12 && r[2].abs() < 1e-12,
            "{r:?}"
        );
    }
}
