//! Aircraft model files (`models/aircraft/<name>.toml`): what a user edits without recompiling.
//!
//! Every number in the shipped files carries its source in a comment (JSBSim 1.3.3's bundled
//! aircraft XML, JSBSim's computed mass properties, or an estimate and how it was made). Loading
//! rejects unknown fields and out-of-range values with the file, line and field.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use super::hinge::FeelComputer;
use super::hinge_theory::ControlGeometry;
use super::table::Table1;
use super::AeroError;
use crate::input::text::line_of;

/// Which certification basis the aircraft's control forces are checked against.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
pub enum CertificationPart {
    /// 14 CFR Part 23 (normal, utility, acrobatic, commuter), pre-Amendment 23-64 text.
    #[serde(rename = "23")]
    Part23,
    /// 14 CFR Part 25 (transport category).
    #[serde(rename = "25")]
    Part25,
    /// MIL-F-8785C (military airplanes' flying qualities), Level 1 stick force per g (Table V).
    #[serde(rename = "MIL-F-8785C")]
    MilF8785C,
}

impl CertificationPart {
    /// The basis as printed in reports and plots.
    pub fn label(self) -> &'static str {
        match self {
            Self::Part23 => "14 CFR 23",
            Self::Part25 => "14 CFR 25",
            Self::MilF8785C => "MIL-F-8785C Level 1",
        }
    }
}

/// The pilot's control.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ControlType {
    Wheel,
    Stick,
}

/// Propulsion: enough to trim and to hold throttle in a manoeuvre.
#[derive(Debug, Clone, PartialEq)]
pub enum Propulsion {
    /// Constant power: `T = throttle * eta * P_max * sigma^k / max(V, V_min)`.
    Propeller {
        max_power_w: f64,
        efficiency: f64,
        min_airspeed_m_s: f64,
        /// Disc diameter for the slipstream (momentum theory), m.
        diameter_m: f64,
    },
    /// Constant thrust: `T = throttle * T_max * sigma^k`.
    Jet { max_thrust_n: f64 },
}

/// A loaded, validated aircraft model in SI units.
#[derive(Debug, Clone)]
pub struct AircraftModel {
    pub name: String,
    pub path: PathBuf,
    // geometry
    pub wing_area_m2: f64,
    pub chord_m: f64,
    pub span_m: f64,
    pub htail_arm_m: f64,
    /// Horizontal tail area and span, m², m.
    pub htail_area_m2: f64,
    pub htail_span_m: f64,
    /// Aerodynamic reference point in JSBSim's structural frame (x aft, z up), m.
    pub aero_ref_x_m: f64,
    pub aero_ref_z_m: f64,
    // mass
    pub mass_kg: f64,
    pub iyy_kg_m2: f64,
    pub cg_x_m: f64,
    pub cg_z_m: f64,
    // propulsion
    pub propulsion: Propulsion,
    pub thrust_x_m: f64,
    pub thrust_z_m: f64,
    pub density_exponent: f64,
    // aerodynamics (coefficients on wing area and chord)
    pub cl_alpha: Table1,
    pub cl_elevator_per_rad: f64,
    pub cl_q_per_rad: f64,
    pub cl_alphadot_per_rad: f64,
    pub cd0: f64,
    pub cd_alpha: Table1,
    pub cd_induced_per_cl2: f64,
    pub cd_elevator_abs_per_rad: f64,
    pub cd_mach: Table1,
    pub cm0: f64,
    pub cm_alpha_per_rad: f64,
    pub cm_q_per_rad: f64,
    pub cm_alphadot_per_rad: f64,
    /// Cm per radian of elevator, by Mach number.
    pub cm_elevator_per_rad: Table1,
    /// JSBSim's c172p scales the elevator's pitching moment with the propeller slipstream's qbar.
    pub elevator_in_slipstream: bool,
    // elevator, hinge and stick
    pub elevator_min_rad: f64,
    pub elevator_max_rad: f64,
    /// Elevator area and mean chord aft of the hinge line (chord ratio × tail area, × tail chord).
    pub elevator_area_m2: f64,
    pub elevator_chord_m: f64,
    /// The elevator's geometry the hinge derivatives are computed from ([`ControlGeometry`]).
    pub elevator_geometry: ControlGeometry,
    pub ch0: f64,
    pub ch_alpha_per_rad: f64,
    pub ch_elevator_per_rad: f64,
    pub ch_tab_per_rad: f64,
    pub tab_min_rad: f64,
    pub tab_max_rad: f64,
    pub tail_dynamic_pressure_ratio: f64,
    pub downwash_gradient: f64,
    pub elevator_per_stick_rad_per_rad: f64,
    pub stick_arm_m: f64,
    pub force_feedback_ratio: f64,
    /// Artificial feel of a powered elevator (`[feel_computer]`), `None` for reversible controls.
    pub feel_computer: Option<FeelComputer>,
    // certification
    pub part: CertificationPart,
    pub control: ControlType,
    pub max_weight_kg: f64,
    pub limit_load_factor: f64,
    /// Keys (`section.key`) whose value the file marks `[EST]`: estimates without a source.
    pub estimates: Vec<String>,
}

type S<T> = Spanned<T>;
/// A table as written: `[[x, y], ...]`, each row spanned so that a row with the wrong number of values is
/// named by its line (a fixed-size `[f64; 2]` would silently drop a third value).
type Rows = S<Vec<S<Vec<f64>>>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileModel {
    name: S<String>,
    geometry: FileGeometry,
    mass: FileMass,
    propulsion: FilePropulsion,
    aero: FileAero,
    elevator: FileElevator,
    hinge: FileHinge,
    stick: FileStick,
    feel_computer: Option<FileFeelComputer>,
    certification: FileCertification,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileFeelComputer {
    breakout_n: S<f64>,
    breakout_band_rad: S<f64>,
    centering_n_per_rad: S<f64>,
    q_feel_n_per_rad_pa: S<f64>,
    mach_trim_start: S<f64>,
    mach_trim_stick_rad_per_mach: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileGeometry {
    wing_area_m2: S<f64>,
    chord_m: S<f64>,
    span_m: S<f64>,
    htail_arm_m: S<f64>,
    htail_area_m2: S<f64>,
    htail_span_m: S<f64>,
    aero_ref_x_m: S<f64>,
    aero_ref_z_m: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileMass {
    mass_kg: S<f64>,
    iyy_kg_m2: S<f64>,
    cg_x_m: S<f64>,
    cg_z_m: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FilePropulsion {
    kind: S<String>,
    thrust_x_m: S<f64>,
    thrust_z_m: S<f64>,
    density_exponent: S<f64>,
    max_power_w: Option<S<f64>>,
    efficiency: Option<S<f64>>,
    min_airspeed_m_s: Option<S<f64>>,
    diameter_m: Option<S<f64>>,
    max_thrust_n: Option<S<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileAero {
    cl_alpha: Rows,
    cl_elevator_per_rad: S<f64>,
    cl_q_per_rad: S<f64>,
    cl_alphadot_per_rad: S<f64>,
    cd0: S<f64>,
    cd_alpha: Rows,
    cd_induced_per_cl2: S<f64>,
    cd_elevator_abs_per_rad: S<f64>,
    cd_mach: Option<Rows>,
    cm0: S<f64>,
    cm_alpha_per_rad: S<f64>,
    cm_q_per_rad: S<f64>,
    cm_alphadot_per_rad: S<f64>,
    cm_elevator_per_rad: Rows,
    elevator_in_slipstream: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileElevator {
    min_rad: S<f64>,
    max_rad: S<f64>,
    chord_ratio: S<f64>,
    balance_ratio: S<f64>,
    tab_chord_ratio: S<f64>,
    tab_span_ratio: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileHinge {
    ch0: S<f64>,
    viscous_factor: S<f64>,
    tab_min_rad: S<f64>,
    tab_max_rad: S<f64>,
    tail_dynamic_pressure_ratio: S<f64>,
    downwash_gradient: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileStick {
    elevator_per_stick_rad_per_rad: S<f64>,
    arm_m: S<f64>,
    force_feedback_ratio: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FileCertification {
    part: CertificationPart,
    control: ControlType,
    max_weight_kg: S<f64>,
    limit_load_factor: S<f64>,
}

struct Ctx<'a> {
    text: &'a str,
    path: &'a Path,
}

impl Ctx<'_> {
    fn err(&self, span: std::ops::Range<usize>, field: &str, msg: String) -> AeroError {
        AeroError::Field {
            path: self.path.to_path_buf(),
            line: line_of(self.text, span.start),
            field: field.to_string(),
            msg,
        }
    }

    /// The value, checked to lie in `[lo, hi]` (the allowed range is named in the message).
    fn num(&self, v: &S<f64>, field: &str, lo: f64, hi: f64) -> Result<f64, AeroError> {
        let x = *v.get_ref();
        if !x.is_finite() || x < lo || x > hi {
            return Err(self.err(
                v.span(),
                field,
                format!("{x} is outside the allowed range [{lo}, {hi}]"),
            ));
        }
        Ok(x)
    }

    /// A value the propulsion `kind` (its line is named when the value is missing) requires.
    fn opt(
        &self,
        v: &Option<S<f64>>,
        field: &str,
        lo: f64,
        hi: f64,
        kind: &S<String>,
    ) -> Result<f64, AeroError> {
        match v {
            Some(v) => self.num(v, field, lo, hi),
            None => Err(self.err(
                kind.span(),
                field,
                format!(
                    "required for propulsion kind \"{}\" (allowed range [{lo}, {hi}])",
                    kind.get_ref()
                ),
            )),
        }
    }

    /// A table of `[x, y]` rows: every row exactly two values (a row is named by its line and number).
    fn table(&self, v: &Rows, field: &str) -> Result<Table1, AeroError> {
        let mut rows = Vec::with_capacity(v.get_ref().len());
        for (k, r) in v.get_ref().iter().enumerate() {
            match r.get_ref().as_slice() {
                &[x, y] => rows.push([x, y]),
                other => {
                    return Err(self.err(
                        r.span(),
                        field,
                        format!(
                            "row {} has {} value{}, a table row is [x, y] (2 values)",
                            k + 1,
                            other.len(),
                            if other.len() == 1 { "" } else { "s" }
                        ),
                    ))
                }
            }
        }
        Table1::new(&rows).map_err(|m| self.err(v.span(), field, m))
    }
}

/// The `section.key` of every line whose comment carries the `[EST]` tag, in file order.
fn estimated_keys(text: &str) -> Vec<String> {
    let mut section = String::new();
    let mut keys = Vec::new();
    for line in text.lines() {
        let code = line.split('#').next().unwrap_or("").trim();
        if code.starts_with('[') && !code.starts_with("[[") {
            section = code.trim_matches(|c| c == '[' || c == ']').trim().to_string();
            continue;
        }
        let Some((key, _)) = code.split_once('=') else {
            continue;
        };
        let comment = line.find('#').map_or("", |i| &line[i..]);
        if comment.contains("[EST]") {
            let key = key.trim();
            keys.push(if section.is_empty() {
                key.to_string()
            } else {
                format!("{section}.{key}")
            });
        }
    }
    keys
}

impl AircraftModel {
    /// Load `models/aircraft/<name>.toml`.
    pub fn load(path: &Path) -> Result<Self, AeroError> {
        let text = crate::input::text::read_text(path).map_err(|msg| AeroError::Io {
            path: path.to_path_buf(),
            msg,
        })?;
        Self::from_toml(&text, path)
    }

    /// Parse and validate model TOML; `path` is used in error messages.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, AeroError> {
        let f: FileModel = crate::input::text::parse_toml(text).map_err(|e| AeroError::Parse {
            path: path.to_path_buf(),
            line: e.line,
            msg: e.message(),
        })?;
        let c = Ctx { text, path };
        let big = 1e12;
        let g = &f.geometry;
        let m = &f.mass;
        let p = &f.propulsion;
        let a = &f.aero;
        let e = &f.elevator;
        let h = &f.hinge;
        let s = &f.stick;
        let cert = &f.certification;
        let feel_computer = match &f.feel_computer {
            None => None,
            Some(fc) => Some(FeelComputer {
                breakout_n: c.num(&fc.breakout_n, "feel_computer.breakout_n", 0.0, 500.0)?,
                breakout_band_rad: c.num(
                    &fc.breakout_band_rad,
                    "feel_computer.breakout_band_rad",
                    1e-4,
                    0.2,
                )?,
                centering_n_per_rad: c.num(
                    &fc.centering_n_per_rad,
                    "feel_computer.centering_n_per_rad",
                    0.0,
                    1e5,
                )?,
                q_feel_n_per_rad_pa: c.num(
                    &fc.q_feel_n_per_rad_pa,
                    "feel_computer.q_feel_n_per_rad_pa",
                    0.0,
                    10.0,
                )?,
                mach_trim_start: c.num(&fc.mach_trim_start, "feel_computer.mach_trim_start", 0.0, 1.0)?,
                mach_trim_stick_rad_per_mach: c.num(
                    &fc.mach_trim_stick_rad_per_mach,
                    "feel_computer.mach_trim_stick_rad_per_mach",
                    0.0,
                    5.0,
                )?,
            }),
        };
        let kind = p.kind.get_ref().as_str();
        let propulsion = match kind {
            "propeller" => Propulsion::Propeller {
                max_power_w: c.opt(&p.max_power_w, "propulsion.max_power_w", 1.0, big, &p.kind)?,
                efficiency: c.opt(&p.efficiency, "propulsion.efficiency", 0.05, 1.0, &p.kind)?,
                min_airspeed_m_s: c.opt(
                    &p.min_airspeed_m_s,
                    "propulsion.min_airspeed_m_s",
                    0.1,
                    100.0,
                    &p.kind,
                )?,
                diameter_m: c.opt(&p.diameter_m, "propulsion.diameter_m", 0.1, 10.0, &p.kind)?,
            },
            "jet" => Propulsion::Jet {
                max_thrust_n: c.opt(&p.max_thrust_n, "propulsion.max_thrust_n", 1.0, big, &p.kind)?,
            },
            other => {
                return Err(c.err(
                    p.kind.span(),
                    "propulsion.kind",
                    format!("unknown kind \"{other}\" (allowed: \"propeller\", \"jet\")"),
                ))
            }
        };
        let htail_area_m2 = c.num(&g.htail_area_m2, "geometry.htail_area_m2", 0.01, 500.0)?;
        let htail_span_m = c.num(&g.htail_span_m, "geometry.htail_span_m", 0.1, 50.0)?;
        let elevator_geometry = ControlGeometry {
            chord_ratio: c.num(&e.chord_ratio, "elevator.chord_ratio", 0.05, 0.6)?,
            balance_ratio: c.num(&e.balance_ratio, "elevator.balance_ratio", 0.0, 0.6)?,
            tab_chord_ratio: c.num(&e.tab_chord_ratio, "elevator.tab_chord_ratio", 0.0, 0.6)?,
            tab_span_ratio: c.num(&e.tab_span_ratio, "elevator.tab_span_ratio", 0.0, 1.0)?,
            tail_aspect_ratio: htail_span_m * htail_span_m / htail_area_m2,
            viscous_factor: c.num(&h.viscous_factor, "hinge.viscous_factor", 0.05, 1.0)?,
        };
        let derived = elevator_geometry
            .derivatives()
            .map_err(|m| c.err(g.htail_span_m.span(), "geometry.htail_span_m", m))?;
        let model = AircraftModel {
            name: f.name.get_ref().clone(),
            path: path.to_path_buf(),
            wing_area_m2: c.num(&g.wing_area_m2, "geometry.wing_area_m2", 0.1, 2000.0)?,
            chord_m: c.num(&g.chord_m, "geometry.chord_m", 0.05, 50.0)?,
            span_m: c.num(&g.span_m, "geometry.span_m", 0.1, 100.0)?,
            htail_arm_m: c.num(&g.htail_arm_m, "geometry.htail_arm_m", 0.1, 100.0)?,
            htail_area_m2,
            htail_span_m,
            aero_ref_x_m: c.num(&g.aero_ref_x_m, "geometry.aero_ref_x_m", -100.0, 100.0)?,
            aero_ref_z_m: c.num(&g.aero_ref_z_m, "geometry.aero_ref_z_m", -100.0, 100.0)?,
            mass_kg: c.num(&m.mass_kg, "mass.mass_kg", 1.0, 1e6)?,
            iyy_kg_m2: c.num(&m.iyy_kg_m2, "mass.iyy_kg_m2", 0.01, 1e9)?,
            cg_x_m: c.num(&m.cg_x_m, "mass.cg_x_m", -100.0, 100.0)?,
            cg_z_m: c.num(&m.cg_z_m, "mass.cg_z_m", -100.0, 100.0)?,
            propulsion,
            thrust_x_m: c.num(&p.thrust_x_m, "propulsion.thrust_x_m", -100.0, 100.0)?,
            thrust_z_m: c.num(&p.thrust_z_m, "propulsion.thrust_z_m", -100.0, 100.0)?,
            density_exponent: c.num(&p.density_exponent, "propulsion.density_exponent", 0.0, 2.0)?,
            cl_alpha: c.table(&a.cl_alpha, "aero.cl_alpha")?,
            cl_elevator_per_rad: c.num(&a.cl_elevator_per_rad, "aero.cl_elevator_per_rad", -5.0, 5.0)?,
            cl_q_per_rad: c.num(&a.cl_q_per_rad, "aero.cl_q_per_rad", -50.0, 50.0)?,
            cl_alphadot_per_rad: c.num(&a.cl_alphadot_per_rad, "aero.cl_alphadot_per_rad", -50.0, 50.0)?,
            cd0: c.num(&a.cd0, "aero.cd0", 0.0, 1.0)?,
            cd_alpha: c.table(&a.cd_alpha, "aero.cd_alpha")?,
            cd_induced_per_cl2: c.num(&a.cd_induced_per_cl2, "aero.cd_induced_per_cl2", 0.0, 1.0)?,
            cd_elevator_abs_per_rad: c.num(
                &a.cd_elevator_abs_per_rad,
                "aero.cd_elevator_abs_per_rad",
                0.0,
                1.0,
            )?,
            cd_mach: match &a.cd_mach {
                Some(t) => c.table(t, "aero.cd_mach")?,
                None => Table1::constant(0.0),
            },
            cm0: c.num(&a.cm0, "aero.cm0", -1.0, 1.0)?,
            cm_alpha_per_rad: c.num(&a.cm_alpha_per_rad, "aero.cm_alpha_per_rad", -20.0, 20.0)?,
            cm_q_per_rad: c.num(&a.cm_q_per_rad, "aero.cm_q_per_rad", -200.0, 0.0)?,
            cm_alphadot_per_rad: c.num(&a.cm_alphadot_per_rad, "aero.cm_alphadot_per_rad", -200.0, 50.0)?,
            cm_elevator_per_rad: c.table(&a.cm_elevator_per_rad, "aero.cm_elevator_per_rad")?,
            elevator_in_slipstream: a.elevator_in_slipstream,
            elevator_min_rad: c.num(&e.min_rad, "elevator.min_rad", -1.0, 0.0)?,
            elevator_max_rad: c.num(&e.max_rad, "elevator.max_rad", 0.0, 1.0)?,
            elevator_area_m2: elevator_geometry.chord_ratio * htail_area_m2,
            elevator_chord_m: elevator_geometry.chord_ratio * htail_area_m2 / htail_span_m,
            elevator_geometry,
            ch0: c.num(&h.ch0, "hinge.ch0", -0.5, 0.5)?,
            ch_alpha_per_rad: derived.ch_alpha_per_rad,
            ch_elevator_per_rad: derived.ch_elevator_per_rad,
            ch_tab_per_rad: derived.ch_tab_per_rad,
            tab_min_rad: c.num(&h.tab_min_rad, "hinge.tab_min_rad", -1.0, 0.0)?,
            tab_max_rad: c.num(&h.tab_max_rad, "hinge.tab_max_rad", 0.0, 1.0)?,
            tail_dynamic_pressure_ratio: c.num(
                &h.tail_dynamic_pressure_ratio,
                "hinge.tail_dynamic_pressure_ratio",
                0.3,
                1.5,
            )?,
            downwash_gradient: c.num(&h.downwash_gradient, "hinge.downwash_gradient", 0.0, 0.9)?,
            elevator_per_stick_rad_per_rad: c.num(
                &s.elevator_per_stick_rad_per_rad,
                "stick.elevator_per_stick_rad_per_rad",
                0.05,
                20.0,
            )?,
            stick_arm_m: c.num(&s.arm_m, "stick.arm_m", 0.05, 2.0)?,
            force_feedback_ratio: c.num(&s.force_feedback_ratio, "stick.force_feedback_ratio", 0.0, 1.0)?,
            feel_computer,
            part: cert.part,
            control: cert.control,
            max_weight_kg: c.num(&cert.max_weight_kg, "certification.max_weight_kg", 1.0, 1e6)?,
            limit_load_factor: c.num(
                &cert.limit_load_factor,
                "certification.limit_load_factor",
                1.5,
                10.0,
            )?,
            estimates: estimated_keys(text),
        };
        if model.force_feedback_ratio < 1e-4 && model.feel_computer.is_none() {
            return Err(c.err(
                s.force_feedback_ratio.span(),
                "stick.force_feedback_ratio",
                format!(
                    "{} leaves the stick without feel: use a ratio in [1e-4, 1] (reversible or boosted \
                     controls) or add a [feel_computer] section (powered controls)",
                    model.force_feedback_ratio
                ),
            ));
        }
        if model.mass_kg > model.max_weight_kg {
            return Err(c.err(
                m.mass_kg.span(),
                "mass.mass_kg",
                format!(
                    "{} kg exceeds certification.max_weight_kg = {} kg (allowed range [1, max_weight_kg])",
                    model.mass_kg, model.max_weight_kg
                ),
            ));
        }
        Ok(model)
    }

    /// The file of the model `name` (`c172p`, `737`): the data directory's `models/aircraft/<name>.toml`
    /// or the built-in one ([`crate::builtin::aircraft`]). The name is not checked: see
    /// [`AircraftModel::builtin`] for a name a user gave.
    pub fn builtin_path(name: &str) -> PathBuf {
        crate::builtin::aircraft(name).unwrap_or_else(|| PathBuf::from(format!("{name}.toml")))
    }

    /// Names of the aircraft models there are ([`crate::builtin::aircraft_names`]).
    pub fn builtin_names() -> Vec<String> {
        crate::builtin::aircraft_names()
    }

    /// The file of a model a user names (`c172p`, `737`), never a path. A name with a path separator,
    /// `..`, a leading `.` or characters other than letters, digits, `_`, `-` and `.` is refused (it would
    /// reach files outside the models), as is a name with no model.
    pub fn builtin(name: &str) -> Result<PathBuf, AeroError> {
        let available = || Self::builtin_names().join(", ");
        let plain = !name.is_empty()
            && !name.starts_with('.')
            && !name.contains("..")
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if !plain {
            return Err(AeroError::Input {
                what: format!("aircraft `{name}`"),
                why: format!(
                    "not a model name: give the name of a model ({}), not a path (a JSBSim aircraft folder is \
                     flown live as `jsbsim:PATH`)",
                    available()
                ),
            });
        }
        crate::builtin::aircraft(name).ok_or_else(|| AeroError::Input {
            what: format!("aircraft `{name}`"),
            why: format!(
                "no model `{name}` (available: {}; more from the data directory's models/aircraft/<name>.toml, \
                 --data-dir or {})",
                available(),
                crate::builtin::DATA_ENV
            ),
        })
    }

    /// Load the model a user names ([`AircraftModel::builtin`]).
    pub fn load_builtin(name: &str) -> Result<Self, AeroError> {
        Self::load(&Self::builtin(name)?)
    }

    /// Maximum lift coefficient of the unstalled lift curve (largest value of `cl_alpha`).
    pub fn cl_max(&self) -> f64 {
        self.cl_alpha.max_value()
    }

    /// Aspect ratio b²/S.
    pub fn aspect_ratio(&self) -> f64 {
        self.span_m * self.span_m / self.wing_area_m2
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn c172p() -> (PathBuf, String) {
        let path = AircraftModel::builtin_path("c172p");
        let text = crate::input::text::read_text(&path).unwrap();
        (path, text)
    }

    fn line_with(text: &str, needle: &str) -> usize {
        text.lines().position(|l| l.contains(needle)).unwrap() + 1
    }

    #[test]
    fn a_table_row_with_a_value_too_many_or_too_few_is_an_error_naming_its_line() {
        let (path, text) = c172p();
        AircraftModel::from_toml(&text, &path).unwrap();
        for (row, n) in [("[0.0, 0.25, 1.0]", 3), ("[0.0]", 1)] {
            let bad = text.replacen("[0.0, 0.25]", row, 1);
            let e = AircraftModel::from_toml(&bad, Path::new("bad.toml"))
                .unwrap_err()
                .to_string();
            let line = line_with(&bad, row);
            assert!(
                e.contains(&format!(
                    "bad.toml:{line}: field `aero.cl_alpha`: row 2 has {n} value"
                )),
                "{e}"
            );
        }
    }

    #[test]
    fn a_missing_propulsion_value_names_the_kind_line() {
        let (_, text) = c172p();
        let bad: String = text
            .lines()
            .filter(|l| !l.starts_with("max_power_w"))
            .map(|l| format!("{l}\n"))
            .collect();
        let e = AircraftModel::from_toml(&bad, Path::new("bad.toml"))
            .unwrap_err()
            .to_string();
        let line = line_with(&bad, "kind = \"propeller\"");
        assert!(
            e.contains(&format!(
                "bad.toml:{line}: field `propulsion.max_power_w`: required"
            )),
            "{e}"
        );
    }

    #[test]
    fn a_model_name_is_never_a_path() {
        assert!(AircraftModel::builtin("c172p")
            .unwrap()
            .ends_with("models/aircraft/c172p.toml"));
        for name in [
            "../c172p",
            "../../etc/passwd",
            "/tmp/x",
            "a/b",
            "a\\b",
            ".hidden",
            "",
            "c172p/",
        ] {
            let e = AircraftModel::builtin(name).unwrap_err().to_string();
            assert!(
                e.contains("not a model name") && e.contains("c172p"),
                "{name}: {e}"
            );
        }
        let e = AircraftModel::builtin("c17").unwrap_err().to_string();
        assert!(
            e.contains("aircraft `c17`: no model") && e.contains("737, T37, c172p"),
            "{e}"
        );
    }
}
