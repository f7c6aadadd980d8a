//! The pilot's hand model file (`models/pilot-hand.toml`): the arm's [`HandConfig`], each value in range.

use std::path::Path;

use serde::Deserialize;
use toml::Spanned;

use super::{InputError, Source};
use crate::pilot::HandConfig;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct HandFile {
    mass_kg: Spanned<f64>,
    stiffness_n_per_m: Spanned<f64>,
    damping_n_s_per_m: Spanned<f64>,
    activation_tau_s: Spanned<f64>,
    grip_stiffness_n_per_m: Spanned<f64>,
    grip_damping_n_s_per_m: Spanned<f64>,
    tracking_gain_per_s: Spanned<f64>,
}

/// Read and check a hand model file.
pub fn load(path: &Path) -> Result<HandConfig, InputError> {
    let src = Source::read(path)?;
    let h: HandFile = src.toml()?;
    let w = |v: &Spanned<f64>, field: &str, lo: f64, hi: f64, unit: &str| src.within(v, field, lo..=hi, unit);
    Ok(HandConfig {
        mass_kg: w(&h.mass_kg, "mass_kg", 0.05, 20.0, "kg")?,
        stiffness_n_per_m: w(&h.stiffness_n_per_m, "stiffness_n_per_m", 0.0, 1e5, "N/m")?,
        damping_n_s_per_m: w(&h.damping_n_s_per_m, "damping_n_s_per_m", 0.0, 1e4, "N·s/m")?,
        activation_tau_s: w(&h.activation_tau_s, "activation_tau_s", 1e-3, 1.0, "s")?,
        grip_stiffness_n_per_m: w(
            &h.grip_stiffness_n_per_m,
            "grip_stiffness_n_per_m",
            10.0,
            1e6,
            "N/m",
        )?,
        grip_damping_n_s_per_m: w(
            &h.grip_damping_n_s_per_m,
            "grip_damping_n_s_per_m",
            0.0,
            1e4,
            "N·s/m",
        )?,
        tracking_gain_per_s: w(&h.tracking_gain_per_s, "tracking_gain_per_s", 0.0, 100.0, "1/s")?,
    })
}
