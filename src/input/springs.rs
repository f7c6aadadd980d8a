//! Feel-spring files (`models/feel-springs.toml`): the three passive springs a scenario or a comparison
//! can put on the rig.

use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use super::{InputError, Source};
use crate::control::feel::{CentringSpring, FeelSprings, QFeelSpring, VariableGradientSpring};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    centring: Centring,
    variable_gradient: VariableGradient,
    q_feel: QFeel,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Centring {
    k_n_per_m: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct VariableGradient {
    k_n_per_m: Spanned<f64>,
    nonlinearity: Spanned<f64>,
    x_ref_m: Spanned<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct QFeel {
    k0_n_per_m: Spanned<f64>,
    kq_n_per_m_per_pa: Spanned<f64>,
    qbar_pa: Option<Spanned<f64>>,
}

impl FeelSprings {
    /// Read and check a feel-spring file: a value out of range names its line and field.
    pub fn load(path: &Path) -> Result<Self, InputError> {
        let src = Source::read(path)?;
        let f: File = src.toml()?;
        Ok(Self {
            centring: CentringSpring {
                k_n_per_m: within!(src, f.centring.k_n_per_m, 0.0..=1e6, "N/m")?,
            },
            variable_gradient: VariableGradientSpring {
                k_n_per_m: within!(src, f.variable_gradient.k_n_per_m, 0.0..=1e6, "N/m")?,
                nonlinearity: within!(src, f.variable_gradient.nonlinearity, 0.0..=100.0)?,
                x_ref_m: within!(src, f.variable_gradient.x_ref_m, 1e-4..=1.0, "m")?,
            },
            q_feel: QFeelSpring {
                k0_n_per_m: within!(src, f.q_feel.k0_n_per_m, 0.0..=1e6, "N/m")?,
                kq_n_per_m_per_pa: within!(src, f.q_feel.kq_n_per_m_per_pa, 0.0..=1e3, "N/m/Pa")?,
                qbar_pa: match &f.q_feel.qbar_pa {
                    Some(p) => src.within(p, "q_feel.qbar_pa", 0.0..=1e6, "Pa")?,
                    None => 0.0,
                },
            },
        })
    }
}
