//! MR damper physics: the seed paper's base model (Eq. 2–6), the modified Bouc–Wen model of Spencer et al.
//! (1997) as a second base, and the effect library.
//!
//! One home for the damper force: the virtual MTS machine, the stick rig and the fitter all call
//! [`Model::eval`] / [`Damper`].

pub(crate) mod bingham;
pub(crate) mod config;
pub(crate) mod effect;
pub mod effects;
pub mod formula;
pub(crate) mod inverse;
pub(crate) mod lag;
pub mod model;
pub(crate) mod params;
pub mod spencer;

pub use config::{DeviceConfig, Geometry, ParamsFile};
pub use effect::{Effect, EffectStage, Inputs, Stage, Step};
pub use inverse::ForceInverse;
pub use model::{Base, Damper, Model, ModelSpec, Registry, PAPER_CURRENT_LIMIT_A};
pub use params::{DataStats, ParamSpec, ParamValue};

/// Errors from building or loading a device model.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    /// A model spec names a base model that does not exist.
    #[error("model `{spec}`: unknown base model `{base}` (base models: `bingham`, `spencer`)")]
    UnknownBase {
        /// The spec as given.
        spec: String,
        /// The base it names.
        base: String,
    },
    /// An effect name not in the registry.
    #[error("unknown effect `{name}` (known effects: {known}; an effect saved by `diagnose --save-effect` is given with `--effects FILE.toml`)")]
    UnknownEffect {
        /// The name given.
        name: String,
        /// The names known, for the message.
        known: String,
    },
    /// A model spec that cannot be built.
    #[error("model `{spec}`: {why}")]
    BadSpec {
        /// The spec as given.
        spec: String,
        /// Why not.
        why: String,
    },
    /// A device, parameter or effect file refused.
    #[error(transparent)]
    Input(#[from] crate::input::InputError),
}

impl DeviceError {
    /// [`DeviceError::BadSpec`] of `spec` for the reason `why`.
    pub(crate) fn bad_spec(spec: impl ToString, why: impl Into<String>) -> Self {
        Self::BadSpec {
            spec: spec.to_string(),
            why: why.into(),
        }
    }
}
