//! An aircraft model (`models/aircraft/<name>.toml`, read by `input::aircraft`): geometry, mass,
//! propulsion and aerodynamic tables from JSBSim 1.3.3's bundled aircraft, with the elevator hinge and
//! stick gearing estimates; every number in the shipped files carries its source in a comment.

use std::path::PathBuf;

use serde::Deserialize;

use super::hinge::HingeModel;
use super::hinge_theory::ControlGeometry;
use super::longitudinal::{lift_slope, n_per_alpha};
use super::table::Table1;
use super::AeroError;

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
    /// A control wheel (yoke).
    Wheel,
    /// A stick.
    Stick,
}

/// Propulsion: enough to trim and to hold throttle in a manoeuvre.
#[derive(Debug, Clone, PartialEq)]
pub enum Propulsion {
    /// Constant power: `T = throttle * eta * P_max * sigma^k / max(V, V_min)`.
    Propeller {
        /// Shaft power at full throttle at sea level, W.
        max_power_w: f64,
        /// Propeller efficiency `eta`, 0..1.
        efficiency: f64,
        /// Airspeed below which the thrust stops rising, m/s.
        min_airspeed_m_s: f64,
        /// Disc diameter for the slipstream (momentum theory), m.
        diameter_m: f64,
    },
    /// Constant thrust: `T = throttle * T_max * sigma^k`.
    Jet {
        /// Thrust at full throttle at sea level, N.
        max_thrust_n: f64,
    },
}

/// A loaded, validated aircraft model in SI units.
#[derive(Debug, Clone)]
pub struct AircraftModel {
    /// The aircraft's name.
    pub name: String,
    /// The aircraft file.
    pub path: PathBuf,
    // geometry
    /// Wing reference area, m².
    pub wing_area_m2: f64,
    /// Mean aerodynamic chord, m.
    pub chord_m: f64,
    /// Wing span, m.
    pub span_m: f64,
    /// Horizontal tail area, m².
    pub htail_area_m2: f64,
    /// Horizontal tail span, m.
    pub htail_span_m: f64,
    /// Aerodynamic reference point in JSBSim's structural frame (x aft, z up): x, m.
    pub aero_ref_x_m: f64,
    /// Aerodynamic reference point: z, m.
    pub aero_ref_z_m: f64,
    // mass
    /// Mass, kg.
    pub mass_kg: f64,
    /// Pitch moment of inertia, kg·m².
    pub iyy_kg_m2: f64,
    /// Centre of gravity in the structural frame: x, m.
    pub cg_x_m: f64,
    /// Centre of gravity: z, m.
    pub cg_z_m: f64,
    // propulsion
    /// The engine's thrust law.
    pub propulsion: Propulsion,
    /// Thrust line in the structural frame: x, m.
    pub thrust_x_m: f64,
    /// Thrust line: z, m.
    pub thrust_z_m: f64,
    /// `k` in the thrust's density lapse `sigma^k`.
    pub density_exponent: f64,
    // aerodynamics (coefficients on wing area and chord)
    /// Lift coefficient by angle of attack (rad).
    pub cl_alpha: Table1,
    /// Lift coefficient per radian of elevator.
    pub cl_elevator_per_rad: f64,
    /// Lift coefficient per unit nondimensional pitch rate `q c / 2V`.
    pub cl_q_per_rad: f64,
    /// Lift coefficient per unit nondimensional `alpha-dot c / 2V`.
    pub cl_alphadot_per_rad: f64,
    /// Zero-lift drag coefficient.
    pub cd0: f64,
    /// Drag coefficient increment by angle of attack (rad).
    pub cd_alpha: Table1,
    /// Induced drag factor: drag coefficient per CL².
    pub cd_induced_per_cl2: f64,
    /// Drag coefficient per radian of |elevator|.
    pub cd_elevator_abs_per_rad: f64,
    /// Drag coefficient increment by Mach number.
    pub cd_mach: Table1,
    /// Pitching moment coefficient at zero angle of attack and elevator.
    pub cm0: f64,
    /// Pitching moment coefficient per radian of angle of attack.
    pub cm_alpha_per_rad: f64,
    /// Pitching moment coefficient per unit nondimensional pitch rate `q c / 2V`.
    pub cm_q_per_rad: f64,
    /// Pitching moment coefficient per unit nondimensional `alpha-dot c / 2V`.
    pub cm_alphadot_per_rad: f64,
    /// Cm per radian of elevator, by Mach number.
    pub cm_elevator_per_rad: Table1,
    /// JSBSim's c172p scales the elevator's pitching moment with the propeller slipstream's qbar.
    pub elevator_in_slipstream: bool,
    /// The elevator's geometry the hinge derivatives are computed from ([`ControlGeometry`]).
    pub elevator_geometry: ControlGeometry,
    /// Elevator hinge, tail and stick gearing.
    pub hinge: HingeModel,
    // certification
    /// Certification basis (14 CFR Part 23 or 25).
    pub part: CertificationPart,
    /// Wheel or stick, for the basis's force limits.
    pub control: ControlType,
    /// Maximum weight, kg.
    pub max_weight_kg: f64,
    /// Positive limit load factor, g.
    pub limit_load_factor: f64,
    /// Keys (`section.key`) whose value the file marks `[EST]`: estimates without a source.
    pub estimates: Vec<String>,
}

impl AircraftModel {
    /// The file of the model `name` (`c172p`, `737`), unchecked: [`AircraftModel::builtin`] checks a user's.
    pub fn builtin_path(name: &str) -> PathBuf {
        crate::builtin::aircraft(name).unwrap_or_else(|| PathBuf::from(format!("{name}.toml")))
    }

    /// The file of a model a user names (`c172p`, `737`), never a path: a name that could reach files outside
    /// the models (separators, `..`, a leading `.`, characters beyond `[A-Za-z0-9_.-]`) is refused.
    pub fn builtin(name: &str) -> Result<PathBuf, AeroError> {
        let available = || crate::builtin::aircraft_names().join(", ");
        let plain = !name.is_empty()
            && !name.starts_with('.')
            && !name.contains("..")
            && name
                .chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'));
        if !plain {
            return Err(AeroError::Refused {
                what: format!("aircraft `{name}`"),
                why: format!(
                    "not a model name: give the name of a model ({}), not a path (a JSBSim aircraft folder is \
                     flown live as `jsbsim:PATH`)",
                    available()
                ),
            });
        }
        crate::builtin::aircraft(name).ok_or_else(|| AeroError::Refused {
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
        Ok(Self::load(&Self::builtin(name)?)?)
    }

    /// Acceleration sensitivity `n/α = q̄ S C_Lα / W` at angle of attack `alpha`, g/rad (`C_Lα` the lift
    /// table's slope there, over ±0.01 rad).
    pub fn n_per_alpha_g_per_rad(&self, alpha: f64, qbar_pa: f64) -> f64 {
        let cl_alpha = lift_slope(|a| self.cl_alpha.eval(a), alpha);
        n_per_alpha(qbar_pa, self.wing_area_m2, cl_alpha, self.mass_kg)
    }

    /// Mass, inertia and load points for the equations of motion.
    pub(crate) fn airframe(&self) -> super::longitudinal::Airframe {
        super::longitudinal::Airframe {
            mass_kg: self.mass_kg,
            iyy_kg_m2: self.iyy_kg_m2,
            cg_x_m: self.cg_x_m,
            cg_z_m: self.cg_z_m,
            aero_ref_x_m: self.aero_ref_x_m,
            aero_ref_z_m: self.aero_ref_z_m,
            thrust_z_m: self.thrust_z_m,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
