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
        let (v, q) = (&f.variable_gradient, &f.q_feel);
        Ok(Self {
            centring: CentringSpring {
                k_n_per_m: src.within(&f.centring.k_n_per_m, "centring.k_n_per_m", 0.0..=1e6, "N/m")?,
            },
            variable_gradient: VariableGradientSpring {
                k_n_per_m: src.within(&v.k_n_per_m, "variable_gradient.k_n_per_m", 0.0..=1e6, "N/m")?,
                nonlinearity: src.within(
                    &v.nonlinearity,
                    "variable_gradient.nonlinearity",
                    0.0..=100.0,
                    "",
                )?,
                x_ref_m: src.within(&v.x_ref_m, "variable_gradient.x_ref_m", 1e-4..=1.0, "m")?,
            },
            q_feel: QFeelSpring {
                k0_n_per_m: src.within(&q.k0_n_per_m, "q_feel.k0_n_per_m", 0.0..=1e6, "N/m")?,
                kq_n_per_m_per_pa: src.within(
                    &q.kq_n_per_m_per_pa,
                    "q_feel.kq_n_per_m_per_pa",
                    0.0..=1e3,
                    "N/m/Pa",
                )?,
                qbar_pa: match &q.qbar_pa {
                    Some(p) => src.within(p, "q_feel.qbar_pa", 0.0..=1e6, "Pa")?,
                    None => 0.0,
                },
            },
        })
    }
}
