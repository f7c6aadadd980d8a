//! Aircraft backends behind one trait: the embedded Rust models ([`Embedded`], the default, no Python)
//! and the live JSBSim co-simulation (`super::jsbsim_bridge::JsbsimBridge`, a Python subprocess).
//!
//! A scenario names its backend with one string: `"c172p"` (embedded, `models/aircraft/c172p.toml`; a
//! fly-by-wire aircraft's embedded model and FCS, [`super::fcs`], for `"f16"`),
//! `"jsbsim:c172p"` (live JSBSim 1.3.3). Both report the same [`AircraftState`]; the hinge moment and
//! stick force come from the same [`HingeModel`] in both cases (JSBSim has no hinge moments), with the
//! trim tab set at trim so the stick force is zero there.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::fbw::FlyByWire;
use super::fcs::FbwAircraft;
use super::jsbsim_bridge::JsbsimBridge;
use super::{AeroError, Aircraft, AircraftModel, AircraftState, HingeModel};
use crate::input::aircraft::{is_fly_by_wire, FlyByWireFile};
use crate::input::Source;

/// What the flight loop needs from an aircraft.
pub trait AircraftBackend {
    /// The scenario string that selected it (`"c172p"`, `"jsbsim:c172p"`).
    fn label(&self) -> &str;
    /// The hinge and stick gearing used for the stick force; `None` for a fly-by-wire aircraft.
    fn hinge(&self) -> Option<&HingeModel>;
    /// A fly-by-wire aircraft's stick (its designed feel and FCS command); `None` for the others.
    fn fly_by_wire(&self) -> Option<&FlyByWire> {
        None
    }
    /// The model file's parameters marked `[EST]` (`section.key`): estimates without a source.
    fn estimates(&self) -> &[String];
    /// Level 1-g trim at a true airspeed and altitude; time restarts at 0. Sets the trim tab.
    fn trim(&mut self, airspeed_m_s: f64, altitude_m: f64, dt_s: f64) -> Result<AircraftState, AeroError>;
    /// One step of `dt_s` (the `dt_s` given to [`AircraftBackend::trim`]) with the elevator (rad,
    /// positive trailing edge down) and the throttle as a ratio of the trim throttle held over it.
    fn step(&mut self, elevator_rad: f64, throttle_ratio: f64) -> Result<AircraftState, AeroError>;
    /// One step of a fly-by-wire aircraft with its stick's normalised FCS command (pull +, in [-1, 1]).
    fn step_command(&mut self, command: f64, throttle_ratio: f64) -> Result<AircraftState, AeroError>;
    /// Round trips of the `step` requests for a co-simulation: (count, mean µs, max µs).
    fn round_trip_us(&self) -> Option<(u64, f64, f64)> {
        None
    }
}

/// The mrfeel model beside a JSBSim aircraft folder: the elevator's hinge moments, the tail and the stick
/// gearing, which JSBSim's XML does not have, with the flight-dynamics sections the adapted pilot is
/// designed on, in the format of `models/aircraft/*.toml`.
pub const FOLDER_MODEL: &str = "mrfeel.toml";

/// The JSBSim aircraft folder a live backend's name gives, if it is a path (it has a path separator):
/// `jsbsim:path/to/f16` flies `path/to/f16/f16.xml`.
pub fn jsbsim_folder(name: &str) -> Option<&Path> {
    (name.contains('/') || name.contains(std::path::MAIN_SEPARATOR)).then(|| Path::new(name))
}

/// The mrfeel aircraft model file for the aircraft `name` of a spec: `<folder>/mrfeel.toml` for a JSBSim
/// aircraft folder ([`jsbsim_folder`]), checked to hold the JSBSim model too; else the model of that name
/// ([`AircraftModel::builtin`]).
pub fn model_file(name: &str) -> Result<PathBuf, AeroError> {
    let Some(dir) = jsbsim_folder(name) else {
        return AircraftModel::builtin(name);
    };
    let fail = |why: String| AeroError::Refused {
        what: format!("JSBSim aircraft folder `{}`", dir.display()),
        why,
    };
    if name.chars().any(char::is_whitespace) {
        return Err(fail(
            "a folder path without spaces, please (the bridge's requests are space separated)".into(),
        ));
    }
    let stem = dir
        .file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    if !dir.join(format!("{stem}.xml")).is_file() {
        return Err(fail(format!(
            "no `{stem}.xml` in it (a JSBSim aircraft folder holds the model named as the folder)"
        )));
    }
    let model = dir.join(FOLDER_MODEL);
    if !model.is_file() {
        return Err(fail(format!(
            "no `{FOLDER_MODEL}` beside `{stem}.xml`: JSBSim's XML has no hinge moments or stick gearing; write \
             them there in the format of the built-in models (`mrfeel` docs: docs/howto/fly-an-aircraft.md)"
        )));
    }
    Ok(model)
}

/// Open the backend a scenario names: `"<name>"` (embedded model `models/aircraft/<name>.toml`),
/// `"jsbsim:<name>"` (live JSBSim through `python/jsbsim_bridge.py`) or `"jsbsim:<folder>"` (a JSBSim
/// aircraft folder with its [`FOLDER_MODEL`]). An embedded `<name>` is a model name, never a path
/// ([`AircraftModel::builtin`]).
pub fn open(spec: &str) -> Result<Box<dyn AircraftBackend>, AeroError> {
    match spec.split_once(':') {
        Some(("jsbsim", name)) => {
            let path = model_file(name)?;
            let src = Source::read(&path)?;
            if is_fly_by_wire(&src.text) {
                let fbw = FlyByWireFile::parse(src)?.stick()?;
                return Ok(Box::new(JsbsimBridge::spawn_fly_by_wire(name, fbw)?));
            }
            let model = Arc::new(AircraftModel::from_toml(&src.text, &path)?);
            Ok(Box::new(JsbsimBridge::spawn(name, model)?))
        }
        Some((other, _)) => Err(AeroError::Refused {
            what: format!("aircraft `{spec}`"),
            why: format!("unknown backend `{other}` (use `<name>` or `jsbsim:<name>`)"),
        }),
        None => {
            let path = AircraftModel::builtin(spec)?;
            let src = Source::read(&path)?;
            if is_fly_by_wire(&src.text) {
                let file = FlyByWireFile::parse(src)?;
                let Some(model) = file.model()? else {
                    return Err(AeroError::Refused {
                        what: format!("aircraft `{spec}`"),
                        why: format!(
                            "a fly-by-wire aircraft without an embedded model ([airframe], [aero_tables], [fcs]) \
                             is flown live through its flight control system: `jsbsim:{spec}`"
                        ),
                    });
                };
                let flown = Flown::FlyByWire(Box::new(FbwAircraft::new(model)), file.stick()?);
                return Ok(Box::new(Embedded::new(spec, flown)));
            }
            let model = Arc::new(AircraftModel::from_toml(&src.text, &path)?);
            Ok(Box::new(Embedded::new(spec, Flown::Linked(Aircraft::new(model)))))
        }
    }
}

/// An embedded model flown without Python.
pub enum Flown {
    /// The nonlinear 3-DOF model ([`Aircraft`]), its stick linked to the elevator.
    Linked(Aircraft),
    /// A fly-by-wire aircraft ([`FbwAircraft`]) behind its designed stick.
    FlyByWire(Box<FbwAircraft>, FlyByWire),
}

/// The embedded backend: a [`Flown`] model with the throttle of its trim.
pub struct Embedded {
    label: String,
    aircraft: Flown,
    trim_throttle: f64,
    dt_s: f64,
}

impl Embedded {
    /// The embedded model `aircraft`, named `label` in outputs.
    pub fn new(label: &str, aircraft: Flown) -> Self {
        Self {
            label: label.to_string(),
            aircraft,
            trim_throttle: 0.0,
            dt_s: 1.0 / 120.0,
        }
    }

    fn refused(&self, why: &str) -> AeroError {
        AeroError::Refused {
            what: format!("aircraft `{}`", self.label),
            why: why.into(),
        }
    }
}

impl AircraftBackend for Embedded {
    fn label(&self) -> &str {
        &self.label
    }

    fn hinge(&self) -> Option<&HingeModel> {
        match &self.aircraft {
            Flown::Linked(a) => Some(a.hinge()),
            Flown::FlyByWire(..) => None,
        }
    }

    fn fly_by_wire(&self) -> Option<&FlyByWire> {
        match &self.aircraft {
            Flown::Linked(_) => None,
            Flown::FlyByWire(_, stick) => Some(stick),
        }
    }

    fn estimates(&self) -> &[String] {
        match &self.aircraft {
            Flown::Linked(a) => &a.model().estimates,
            Flown::FlyByWire(_, stick) => &stick.estimates,
        }
    }

    fn trim(&mut self, airspeed_m_s: f64, altitude_m: f64, dt_s: f64) -> Result<AircraftState, AeroError> {
        let s = match &mut self.aircraft {
            Flown::Linked(a) => a.trim(airspeed_m_s, altitude_m)?,
            Flown::FlyByWire(a, _) => a.trim(airspeed_m_s, altitude_m)?,
        };
        self.trim_throttle = s.throttle;
        self.dt_s = dt_s;
        Ok(s)
    }

    fn step(&mut self, elevator_rad: f64, throttle_ratio: f64) -> Result<AircraftState, AeroError> {
        match &mut self.aircraft {
            Flown::Linked(a) => Ok(*a.step(elevator_rad, self.trim_throttle * throttle_ratio, self.dt_s)),
            Flown::FlyByWire(..) => {
                Err(self
                    .refused("fly-by-wire: its stick commands the flight control system, not the elevator"))
            }
        }
    }

    fn step_command(&mut self, command: f64, throttle_ratio: f64) -> Result<AircraftState, AeroError> {
        match &mut self.aircraft {
            // the stick's command is pull +, JSBSim's elevator command push +
            Flown::FlyByWire(a, _) => Ok(*a.step(-command, self.trim_throttle * throttle_ratio, self.dt_s)),
            Flown::Linked(_) => Err(self.refused("not fly-by-wire: its stick drives the elevator")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The embedded c172p held at 0.08 rad of up elevator at 50 m/s needs more than 10 N on the stick: the
    /// hinge model is fed the embedded state (the same formula a JSBSim state goes through).
    #[test]
    fn a_held_up_elevator_needs_a_stick_force() {
        let mut b = open("c172p").unwrap_or_else(|e| panic!("{e}"));
        b.trim(50.0, 1000.0, 1.0 / 120.0).unwrap();
        let mut s = b.step(-0.08, 1.0).unwrap();
        for _ in 0..60 {
            s = b.step(-0.08, 1.0).unwrap();
        }
        assert!(
            s.stick_force_n.abs() > 10.0,
            "a pulled elevator needs a pull: {}",
            s.stick_force_n
        );
    }

    #[test]
    fn unknown_backend_is_an_error_naming_the_choices() {
        let e = open("xplane:c172p").err().unwrap().to_string();
        assert!(e.contains("jsbsim:<name>"), "{e}");
    }
}
