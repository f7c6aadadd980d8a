//! The aircraft model file (`models/aircraft/<name>.toml`): its schema, read into an [`AircraftModel`]
//! with its hinge model derived from the elevator's geometry.

use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use super::{InputError, Source};
use crate::aero::fbw::{FlyByWire, BREAKOUT_RANGE_CLASS_IV_N};
use crate::aero::fcs::{FbwModel, PitchFcs, TableAero};
use crate::aero::hinge::{FeelComputer, HingeModel};
use crate::aero::hinge_theory::ControlGeometry;
use crate::aero::longitudinal::Airframe;
use crate::aero::model::{AircraftModel, CertificationPart, ControlType, Propulsion};
use crate::aero::Table1;
use crate::aero::Table2;

type S<T> = Spanned<T>;
/// A table as written: `[[x, y], ...]`, each row spanned so that a row with the wrong number of values is
/// named by its line (a fixed-size `[f64; 2]` would silently drop a third value).
type Rows = S<Vec<S<Vec<f64>>>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    geometry: Geometry,
    mass: Mass,
    propulsion: PropulsionFile,
    aero: Aero,
    elevator: Elevator,
    hinge: Hinge,
    stick: Stick,
    feel_computer: Option<FeelComputerFile>,
    certification: Certification,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FeelComputerFile {
    breakout_n: S<f64>,
    breakout_band_rad: S<f64>,
    centering_n_per_rad: S<f64>,
    q_feel_n_per_rad_pa: S<f64>,
    mach_trim_start: S<f64>,
    mach_trim_stick_rad_per_mach: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Geometry {
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
struct Mass {
    mass_kg: S<f64>,
    iyy_kg_m2: S<f64>,
    cg_x_m: S<f64>,
    cg_z_m: S<f64>,
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
enum PropulsionKind {
    Propeller,
    Jet,
}

/// A propeller's or a jet's values, named by `kind` (each kind requires its own).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PropulsionFile {
    kind: S<PropulsionKind>,
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
struct Aero {
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
struct Elevator {
    min_rad: S<f64>,
    max_rad: S<f64>,
    chord_ratio: S<f64>,
    balance_ratio: S<f64>,
    tab_chord_ratio: S<f64>,
    tab_span_ratio: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Hinge {
    ch0: S<f64>,
    viscous_factor: S<f64>,
    tab_min_rad: S<f64>,
    tab_max_rad: S<f64>,
    tail_dynamic_pressure_ratio: S<f64>,
    downwash_gradient: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Stick {
    elevator_per_stick_rad_per_rad: S<f64>,
    arm_m: S<f64>,
    force_feedback_ratio: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Certification {
    part: CertificationPart,
    control: ControlType,
    max_weight_kg: S<f64>,
    limit_load_factor: S<f64>,
}

/// A table of `[x, y]` rows: every row exactly two values (a row is named by its line and number).
fn table(src: &Source, v: &Rows, field: &str) -> Result<Table1, InputError> {
    let mut rows = Vec::with_capacity(v.get_ref().len());
    for (k, r) in v.get_ref().iter().enumerate() {
        match r.get_ref().as_slice() {
            &[x, y] => rows.push([x, y]),
            other => {
                let n = other.len();
                let s = if n == 1 { "" } else { "s" };
                let msg = format!("row {} has {n} value{s}, a table row is [x, y] (2 values)", k + 1);
                return Err(src.err(r, field, msg));
            }
        }
    }
    Table1::new(&rows).map_err(|m| src.err(v, field, m))
}

/// The `section.key` of every line whose comment carries the `[EST]` tag, in file order.
fn estimated_keys(text: &str) -> Vec<String> {
    let mut section = String::new();
    let mut keys = Vec::new();
    for line in text.lines() {
        let (code, comment) = line.split_once('#').unwrap_or((line, ""));
        let code = code.trim();
        if code.starts_with('[') && !code.starts_with("[[") {
            section = code.trim_matches(|c| c == '[' || c == ']').trim().to_string();
        } else if let Some((key, _)) = code.split_once('=').filter(|_| comment.contains("[EST]")) {
            let key = key.trim();
            keys.push(match section.as_str() {
                "" => key.to_string(),
                s => format!("{s}.{key}"),
            });
        }
    }
    keys
}

impl AircraftModel {
    /// Read and check an aircraft model file.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        Self::from_toml(&Source::read(path)?.text, path)
    }

    /// Check an aircraft model's text; `path` places its errors.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, InputError> {
        let src = Source::new(path, text);
        let f: File = src.toml()?;
        let p = &f.propulsion;
        let feel_computer = match &f.feel_computer {
            None => None,
            Some(feel_computer) => Some(FeelComputer {
                breakout_n: within!(src, feel_computer.breakout_n, 0.0..=500.0)?,
                breakout_band_rad: within!(src, feel_computer.breakout_band_rad, 1e-4..=0.2)?,
                centering_n_per_rad: within!(src, feel_computer.centering_n_per_rad, 0.0..=1e5)?,
                q_feel_n_per_rad_pa: within!(src, feel_computer.q_feel_n_per_rad_pa, 0.0..=10.0)?,
                mach_trim_start: within!(src, feel_computer.mach_trim_start, 0.0..=1.0)?,
                mach_trim_stick_rad_per_mach: within!(
                    src,
                    feel_computer.mach_trim_stick_rad_per_mach,
                    0.0..=5.0
                )?,
            }),
        };
        // A value the propulsion kind requires: a missing one is named at the `kind` line.
        let need = |v: &Option<S<f64>>, key: &str, lo: f64, hi: f64| {
            let field = format!("propulsion.{key}");
            match v {
                Some(v) => src.within(v, &field, lo..=hi, ""),
                None => {
                    let kind = match *p.kind.get_ref() {
                        PropulsionKind::Propeller => "propeller",
                        PropulsionKind::Jet => "jet",
                    };
                    let msg = format!("required for propulsion kind \"{kind}\" (allowed range [{lo}, {hi}])");
                    Err(src.err(&p.kind, &field, msg))
                }
            }
        };
        let propulsion = match p.kind.get_ref() {
            PropulsionKind::Propeller => Propulsion::Propeller {
                max_power_w: need(&p.max_power_w, "max_power_w", 1.0, 1e12)?,
                efficiency: need(&p.efficiency, "efficiency", 0.05, 1.0)?,
                min_airspeed_m_s: need(&p.min_airspeed_m_s, "min_airspeed_m_s", 0.1, 100.0)?,
                diameter_m: need(&p.diameter_m, "diameter_m", 0.1, 10.0)?,
            },
            PropulsionKind::Jet => Propulsion::Jet {
                max_thrust_n: need(&p.max_thrust_n, "max_thrust_n", 1.0, 1e12)?,
            },
        };
        let htail_area_m2 = within!(src, f.geometry.htail_area_m2, 0.01..=500.0)?;
        let htail_span_m = within!(src, f.geometry.htail_span_m, 0.1..=50.0)?;
        let elevator_geometry = ControlGeometry {
            chord_ratio: within!(src, f.elevator.chord_ratio, 0.05..=0.6)?,
            balance_ratio: within!(src, f.elevator.balance_ratio, 0.0..=0.6)?,
            tab_chord_ratio: within!(src, f.elevator.tab_chord_ratio, 0.0..=0.6)?,
            tab_span_ratio: within!(src, f.elevator.tab_span_ratio, 0.0..=1.0)?,
            tail_aspect_ratio: htail_span_m * htail_span_m / htail_area_m2,
            viscous_factor: within!(src, f.hinge.viscous_factor, 0.05..=1.0)?,
        };
        let derived = elevator_geometry
            .derivatives()
            .map_err(|msg| src.err(&f.geometry.htail_span_m, "geometry.htail_span_m", msg))?;
        let stick = &f.stick;
        let hinge = HingeModel {
            elevator_area_m2: elevator_geometry.chord_ratio * htail_area_m2,
            elevator_chord_m: elevator_geometry.chord_ratio * htail_area_m2 / htail_span_m,
            ch0: within!(src, f.hinge.ch0, -0.5..=0.5)?,
            ch_alpha_per_rad: derived.ch_alpha_per_rad,
            ch_elevator_per_rad: derived.ch_elevator_per_rad,
            ch_tab_per_rad: derived.ch_tab_per_rad,
            tab_min_rad: within!(src, f.hinge.tab_min_rad, -1.0..=0.0)?,
            tab_max_rad: within!(src, f.hinge.tab_max_rad, 0.0..=1.0)?,
            tail_dynamic_pressure_ratio: within!(src, f.hinge.tail_dynamic_pressure_ratio, 0.3..=1.5)?,
            downwash_gradient: within!(src, f.hinge.downwash_gradient, 0.0..=0.9)?,
            tail_arm_m: within!(src, f.geometry.htail_arm_m, 0.1..=100.0)?,
            elevator_per_stick_rad_per_rad: within!(src, stick.elevator_per_stick_rad_per_rad, 0.05..=20.0)?,
            stick_arm_m: within!(src, f.stick.arm_m, 0.05..=2.0)?,
            force_feedback_ratio: within!(src, f.stick.force_feedback_ratio, 0.0..=1.0)?,
            feel_computer,
            elevator_min_rad: within!(src, f.elevator.min_rad, -1.0..=0.0)?,
            elevator_max_rad: within!(src, f.elevator.max_rad, 0.0..=1.0)?,
        };
        if hinge.force_feedback_ratio < 1e-4 && hinge.feel_computer.is_none() {
            let msg = format!(
                "{} leaves the stick without feel: use a ratio in [1e-4, 1] (reversible or boosted controls) \
                 or add a [feel_computer] section (powered controls)",
                hinge.force_feedback_ratio
            );
            return Err(src.err(&f.stick.force_feedback_ratio, "stick.force_feedback_ratio", msg));
        }
        let mass_kg = within!(src, f.mass.mass_kg, 1.0..=1e6)?;
        let max_weight_kg = within!(src, f.certification.max_weight_kg, 1.0..=1e6)?;
        if mass_kg > max_weight_kg {
            let msg = format!(
                "{mass_kg} kg exceeds certification.max_weight_kg = {max_weight_kg} kg (allowed range [1, \
                 max_weight_kg])"
            );
            return Err(src.err(&f.mass.mass_kg, "mass.mass_kg", msg));
        }
        Ok(AircraftModel {
            name: f.name.clone(),
            path: path.to_path_buf(),
            wing_area_m2: within!(src, f.geometry.wing_area_m2, 0.1..=2000.0)?,
            chord_m: within!(src, f.geometry.chord_m, 0.05..=50.0)?,
            span_m: within!(src, f.geometry.span_m, 0.1..=100.0)?,
            htail_area_m2,
            htail_span_m,
            aero_ref_x_m: within!(src, f.geometry.aero_ref_x_m, -100.0..=100.0)?,
            aero_ref_z_m: within!(src, f.geometry.aero_ref_z_m, -100.0..=100.0)?,
            mass_kg,
            iyy_kg_m2: within!(src, f.mass.iyy_kg_m2, 0.01..=1e9)?,
            cg_x_m: within!(src, f.mass.cg_x_m, -100.0..=100.0)?,
            cg_z_m: within!(src, f.mass.cg_z_m, -100.0..=100.0)?,
            propulsion,
            thrust_x_m: within!(src, f.propulsion.thrust_x_m, -100.0..=100.0)?,
            thrust_z_m: within!(src, f.propulsion.thrust_z_m, -100.0..=100.0)?,
            density_exponent: within!(src, f.propulsion.density_exponent, 0.0..=2.0)?,
            cl_alpha: table(&src, &f.aero.cl_alpha, "aero.cl_alpha")?,
            cl_elevator_per_rad: within!(src, f.aero.cl_elevator_per_rad, -5.0..=5.0)?,
            cl_q_per_rad: within!(src, f.aero.cl_q_per_rad, -50.0..=50.0)?,
            cl_alphadot_per_rad: within!(src, f.aero.cl_alphadot_per_rad, -50.0..=50.0)?,
            cd0: within!(src, f.aero.cd0, 0.0..=1.0)?,
            cd_alpha: table(&src, &f.aero.cd_alpha, "aero.cd_alpha")?,
            cd_induced_per_cl2: within!(src, f.aero.cd_induced_per_cl2, 0.0..=1.0)?,
            cd_elevator_abs_per_rad: within!(src, f.aero.cd_elevator_abs_per_rad, 0.0..=1.0)?,
            cd_mach: match &f.aero.cd_mach {
                Some(t) => table(&src, t, "aero.cd_mach")?,
                None => Table1::constant(0.0),
            },
            cm0: within!(src, f.aero.cm0, -1.0..=1.0)?,
            cm_alpha_per_rad: within!(src, f.aero.cm_alpha_per_rad, -20.0..=20.0)?,
            cm_q_per_rad: within!(src, f.aero.cm_q_per_rad, -200.0..=0.0)?,
            cm_alphadot_per_rad: within!(src, f.aero.cm_alphadot_per_rad, -200.0..=50.0)?,
            cm_elevator_per_rad: table(&src, &f.aero.cm_elevator_per_rad, "aero.cm_elevator_per_rad")?,
            elevator_in_slipstream: f.aero.elevator_in_slipstream,
            elevator_geometry,
            hinge,
            part: f.certification.part,
            control: f.certification.control,
            max_weight_kg,
            limit_load_factor: within!(src, f.certification.limit_load_factor, 1.5..=10.0)?,
            estimates: estimated_keys(text),
        })
    }
}

/// A fly-by-wire aircraft's model file: its stick and the condition its feel is designed at
/// ([`crate::aero::fbw`]).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FbwFile {
    name: String,
    fly_by_wire: FbwStick,
    design: FbwDesign,
    airframe: Option<FbwAirframe>,
    aero_tables: Option<FbwAero>,
    fcs: Option<FbwFcs>,
}

/// The embedded model's airframe (structural frame: x aft, z up).
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FbwAirframe {
    wing_area_m2: S<f64>,
    chord_m: S<f64>,
    aero_ref_x_m: S<f64>,
    aero_ref_z_m: S<f64>,
    pilot_x_m: S<f64>,
    pilot_z_m: S<f64>,
    mass_kg: S<f64>,
    iyy_kg_m2: S<f64>,
    cg_x_m: S<f64>,
    cg_z_m: S<f64>,
    max_thrust_n: S<f64>,
    thrust_z_m: S<f64>,
    density_exponent: S<f64>,
}

/// Tables over `alpha_rad` (rows) and `elevator_rad` (columns); the one-dimensional ones by α give one
/// value per `alpha_rad` breakpoint.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FbwAero {
    alpha_rad: S<Vec<f64>>,
    elevator_rad: S<Vec<f64>>,
    cl: S<Vec<Vec<f64>>>,
    cd: S<Vec<Vec<f64>>>,
    cm: S<Vec<Vec<f64>>>,
    cl_lef_per_rad: S<Vec<f64>>,
    cd_lef_per_rad: S<Vec<f64>>,
    cl_q: S<Vec<f64>>,
    cd_q: S<Vec<f64>>,
    cd_q_lef_per_rad: S<Vec<f64>>,
    cm_q: S<Vec<f64>>,
    cd_mach: Rows,
    cm_alpha_mach: Rows,
    lef_alpha_steps: Rows,
    lef_above_mach: Option<S<Vec<f64>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FbwFcs {
    command_limits: S<Vec<f64>>,
    alpha_gain: Rows,
    alpha_limiter_per_rad: S<f64>,
    pitch_rate_gain_s: S<f64>,
    load_factor_gain_per_g: S<f64>,
    proportional_gain: S<f64>,
    full_travel_s: S<f64>,
    elevator_max_rad: S<f64>,
}

impl FbwModel {
    /// The embedded model of a fly-by-wire aircraft's file, `None` if it has none (no `[airframe]`,
    /// `[aero_tables]` and `[fcs]`; all three or none).
    pub fn load(path: &Path) -> Result<Option<Self>, InputError> {
        FlyByWireFile::read(path)?.model()
    }

    /// As [`FbwModel::load`], from text; `path` places its errors.
    pub fn from_toml(text: &str, path: &Path) -> Result<Option<Self>, InputError> {
        FlyByWireFile::parse(Source::new(path, text))?.model()
    }
}

/// A fly-by-wire aircraft's model file parsed once: its stick ([`FlyByWireFile::stick`]) and its embedded
/// model ([`FlyByWireFile::model`]) are built from the one parse.
pub struct FlyByWireFile {
    src: Source,
    file: FbwFile,
}

impl FlyByWireFile {
    /// Read and parse the file at `path`.
    pub fn read(path: &Path) -> Result<Self, InputError> {
        Self::parse(Source::read(path)?)
    }

    /// Parse a text already read: a syntax error, an unknown key or a value of the wrong type names its
    /// line and key.
    pub fn parse(src: Source) -> Result<Self, InputError> {
        let file = src.toml()?;
        Ok(Self { src, file })
    }

    /// The embedded model ([`FbwModel::load`]).
    pub fn model(&self) -> Result<Option<FbwModel>, InputError> {
        let (src, f, path) = (&self.src, &self.file, self.src.path.as_path());
        let (airframe, a, fcs) = match (&f.airframe, &f.aero_tables, &f.fcs) {
            (None, None, None) => return Ok(None),
            (Some(g), Some(a), Some(c)) => (g, a, c),
            _ => {
                let missing: Vec<&str> = [
                    ("[airframe]", f.airframe.is_none()),
                    ("[aero_tables]", f.aero_tables.is_none()),
                    ("[fcs]", f.fcs.is_none()),
                ]
                .iter()
                .filter(|(_, m)| *m)
                .map(|(s, _)| *s)
                .collect();
                let missing = missing.join(", ");
                let msg = format!(
                    "an embedded fly-by-wire model needs [airframe], [aero_tables] and [fcs] together: {missing} missing"
                );
                return Err(InputError::file(path, msg));
            }
        };
        let alpha = a.alpha_rad.get_ref();
        let by_alpha = |v: &S<Vec<f64>>, field: &str| -> Result<Table1, InputError> {
            if v.get_ref().len() != alpha.len() {
                let msg = format!(
                    "{} values for {} aero_tables.alpha_rad breakpoints",
                    v.get_ref().len(),
                    alpha.len()
                );
                return Err(src.err(v, field, msg));
            }
            let rows: Vec<[f64; 2]> = alpha.iter().zip(v.get_ref()).map(|(&x, &y)| [x, y]).collect();
            Table1::new(&rows).map_err(|m| src.err(v, field, m))
        };
        let table2 = |v: &S<Vec<Vec<f64>>>, field: &str| {
            Table2::new(alpha, a.elevator_rad.get_ref(), v.get_ref()).map_err(|m| src.err(v, field, m))
        };
        let pair = |v: &S<Vec<f64>>, field: &str| match v.get_ref().as_slice() {
            &[x, y] => Ok((x, y)),
            other => Err(src.err(v, field, format!("{} values, expected 2", other.len()))),
        };
        // rows of two values with increasing thresholds, as a table's
        table(src, &a.lef_alpha_steps, "aero_tables.lef_alpha_steps")?;
        let lef_alpha_steps = a
            .lef_alpha_steps
            .get_ref()
            .iter()
            .map(|r| (r.get_ref()[0], r.get_ref()[1]))
            .collect();
        let elevator_max_rad = within!(src, fcs.elevator_max_rad, 0.01..=1.0)?;
        let (cmin, cmax) = pair(&fcs.command_limits, "fcs.command_limits")?;
        if !(cmin < 0.0 && cmax > 0.0 && cmin >= -1.0 && cmax <= 1.0) {
            let msg = format!("[{cmin}, {cmax}]: needs -1 <= min < 0 < max <= 1");
            return Err(src.err(&fcs.command_limits, "fcs.command_limits", msg));
        }
        Ok(Some(FbwModel {
            name: f.name.clone(),
            wing_area_m2: within!(src, airframe.wing_area_m2, 0.1..=2000.0)?,
            chord_m: within!(src, airframe.chord_m, 0.05..=50.0)?,
            airframe: Airframe {
                mass_kg: within!(src, airframe.mass_kg, 1.0..=1e6)?,
                iyy_kg_m2: within!(src, airframe.iyy_kg_m2, 0.01..=1e9)?,
                cg_x_m: within!(src, airframe.cg_x_m, -100.0..=100.0)?,
                cg_z_m: within!(src, airframe.cg_z_m, -100.0..=100.0)?,
                aero_ref_x_m: within!(src, airframe.aero_ref_x_m, -100.0..=100.0)?,
                aero_ref_z_m: within!(src, airframe.aero_ref_z_m, -100.0..=100.0)?,
                thrust_z_m: within!(src, airframe.thrust_z_m, -100.0..=100.0)?,
            },
            pilot_station_m: (
                within!(src, airframe.pilot_x_m, -100.0..=100.0)?,
                within!(src, airframe.pilot_z_m, -100.0..=100.0)?,
            ),
            max_thrust_n: within!(src, airframe.max_thrust_n, 1.0..=1e12)?,
            density_exponent: within!(src, airframe.density_exponent, 0.0..=2.0)?,
            aero: TableAero {
                cl: table2(&a.cl, "aero_tables.cl")?,
                cd: table2(&a.cd, "aero_tables.cd")?,
                cm: table2(&a.cm, "aero_tables.cm")?,
                cl_lef: by_alpha(&a.cl_lef_per_rad, "aero_tables.cl_lef_per_rad")?,
                cd_lef: by_alpha(&a.cd_lef_per_rad, "aero_tables.cd_lef_per_rad")?,
                cl_q: by_alpha(&a.cl_q, "aero_tables.cl_q")?,
                cd_q: by_alpha(&a.cd_q, "aero_tables.cd_q")?,
                cd_q_lef: by_alpha(&a.cd_q_lef_per_rad, "aero_tables.cd_q_lef_per_rad")?,
                cm_q: by_alpha(&a.cm_q, "aero_tables.cm_q")?,
                cd_mach: table(src, &a.cd_mach, "aero_tables.cd_mach")?,
                cm_alpha_mach: table(src, &a.cm_alpha_mach, "aero_tables.cm_alpha_mach")?,
                lef_alpha_steps,
                lef_above_mach: match &a.lef_above_mach {
                    Some(v) => Some(pair(v, "aero_tables.lef_above_mach")?),
                    None => None,
                },
            },
            fcs: PitchFcs {
                command_limits: (cmin, cmax),
                alpha_gain: table(src, &fcs.alpha_gain, "fcs.alpha_gain")?,
                alpha_limiter_per_rad: within!(src, fcs.alpha_limiter_per_rad, 0.0..=20.0)?,
                pitch_rate_gain_s: within!(src, fcs.pitch_rate_gain_s, 0.0..=100.0)?,
                load_factor_gain_per_g: within!(src, fcs.load_factor_gain_per_g, 0.0..=10.0)?,
                proportional_gain: within!(src, fcs.proportional_gain, 0.0..=100.0)?,
                full_travel_s: within!(src, fcs.full_travel_s, 1e-3..=60.0)?,
                elevator_max_rad,
            },
        }))
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FbwStick {
    full_command_stick_rad: S<f64>,
    breakout_n: S<f64>,
    stick_force_per_g_n: S<f64>,
    max_pull_n: S<f64>,
    max_push_n: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FbwDesign {
    airspeed_m_s: S<f64>,
    altitude_m: S<f64>,
    g_per_command: S<f64>,
    n_alpha_per_rad: S<f64>,
    limit_load_factor: S<f64>,
}

/// Whether a model file's text is a fly-by-wire aircraft's (it has a `[fly_by_wire]` section).
pub fn is_fly_by_wire(text: &str) -> bool {
    #[derive(Deserialize)]
    struct Probe {
        fly_by_wire: Option<toml::Value>,
    }
    crate::input::text::parse_toml::<Probe>(text)
        .map(|p| p.fly_by_wire.is_some())
        .unwrap_or(false)
}

impl FlyByWire {
    /// Read and check a fly-by-wire aircraft's model file.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        FlyByWireFile::read(path)?.stick()
    }

    /// Check a fly-by-wire aircraft's model text; `path` places its errors.
    pub fn from_toml(text: &str, path: &Path) -> Result<Self, InputError> {
        FlyByWireFile::parse(Source::new(path, text))?.stick()
    }
}

impl FlyByWireFile {
    /// The stick and its design condition ([`FlyByWire::load`]).
    pub fn stick(&self) -> Result<FlyByWire, InputError> {
        let (src, f) = (&self.src, &self.file);
        let (fly_by_wire, design) = (&f.fly_by_wire, &f.design);
        let (lo, hi) = BREAKOUT_RANGE_CLASS_IV_N;
        Ok(FlyByWire {
            name: f.name.clone(),
            full_command_stick_rad: within!(src, fly_by_wire.full_command_stick_rad, 1e-4..=1.0, "rad")?,
            // the design basis: MIL-F-8785C Table XII, pitch stick, Class IV
            breakout_n: within!(src, fly_by_wire.breakout_n, lo..=hi, "N")?,
            stick_force_per_g_n: within!(src, fly_by_wire.stick_force_per_g_n, 0.1..=500.0, "N/g")?,
            max_pull_n: within!(src, fly_by_wire.max_pull_n, 1.0..=2000.0, "N")?,
            max_push_n: within!(src, fly_by_wire.max_push_n, 1.0..=2000.0, "N")?,
            airspeed_m_s: within!(src, design.airspeed_m_s, 1.0..=1000.0, "m/s")?,
            altitude_m: within!(src, design.altitude_m, -500.0..=30000.0, "m")?,
            g_per_command: within!(src, design.g_per_command, 0.1..=20.0, "g")?,
            n_alpha_per_rad: within!(src, design.n_alpha_per_rad, 0.5..=200.0, "g/rad")?,
            limit_load_factor: within!(src, design.limit_load_factor, 1.5..=15.0, "g")?,
            estimates: estimated_keys(&src.text),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

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

    /// A fly-by-wire file's embedded model: all three sections or none, and a table row with the wrong
    /// number of values is named by its table's line and field with the row's number.
    #[test]
    fn an_embedded_fly_by_wire_model_needs_its_three_sections_and_whole_table_rows() {
        let path = AircraftModel::builtin_path("f16");
        let text = crate::input::text::read_text(&path).unwrap();
        assert!(FbwModel::from_toml(&text, &path).unwrap().is_some());
        let cut = text.find("\n[airframe]").unwrap();
        assert!(FbwModel::from_toml(&text[..cut], &path).unwrap().is_none());
        let no_fcs = &text[..text.find("\n[fcs]").unwrap()];
        let e = FbwModel::from_toml(no_fcs, Path::new("f.toml"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("f.toml") && e.contains("[fcs] missing"), "{e}");
        let bad = text.replacen(
            "[-0.659, -0.709, -0.754, -0.792, -0.825]",
            "[-0.659, -0.709, -0.754]",
            1,
        );
        let e = FbwModel::from_toml(&bad, Path::new("f.toml"))
            .unwrap_err()
            .to_string();
        let line = line_with(&bad, "cl = [");
        assert!(
            e.contains(&format!(
                "f.toml:{line}: field `aero_tables.cl`: row 1 has 3 values for 5 column"
            )),
            "{e}"
        );
    }
}
