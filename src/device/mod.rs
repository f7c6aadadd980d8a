//! MR damper physics: the seed paper's base model (Eq. 2–6), the modified Bouc–Wen model of Spencer et al.
//! (1997) as a second base, and the effect library.
//!
//! One home for the damper force: the virtual MTS machine, the stick rig and the fitter all call
//! [`Model::eval`] / [`Damper`].

pub mod bingham;
pub mod config;
pub mod effect;
pub mod effects;
pub mod formula;
pub mod inverse;
pub mod lag;
pub mod model;
pub mod params;
pub mod spencer;

pub use config::{DeviceConfig, Geometry, ParamsFile};
pub use effect::{Effect, EffectStage, Inputs, Stage, Step};
pub use inverse::ForceInverse;
pub use model::{Base, Damper, Model, ModelSpec, Registry, PAPER_CURRENT_LIMIT_A};
pub use params::{DataStats, ParamSpec, ParamValue};

/// Errors from building or loading a device model.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    #[error("model `{spec}`: unknown base model `{base}` (base models: `bingham`, `spencer`)")]
    UnknownBase { spec: String, base: String },
    #[error("unknown effect `{name}` (known effects: {known}; an effect saved by `diagnose --save-effect` is given with `--effects FILE.toml`)")]
    UnknownEffect { name: String, known: String },
    #[error("model `{spec}`: {why}")]
    BadSpec { spec: String, why: String },
    /// A device, parameter or effect file refused.
    #[error(transparent)]
    Input(#[from] crate::input::InputError),
}
