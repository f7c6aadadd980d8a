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
    // A top-level key in its range: its field is its name.
    macro_rules! w {
        ($key:ident, $lo:expr, $hi:expr, $unit:expr) => {
            src.within(&h.$key, stringify!($key), $lo..=$hi, $unit)
        };
    }
    Ok(HandConfig {
        mass_kg: w!(mass_kg, 0.05, 20.0, "kg")?,
        stiffness_n_per_m: w!(stiffness_n_per_m, 0.0, 1e5, "N/m")?,
        damping_n_s_per_m: w!(damping_n_s_per_m, 0.0, 1e4, "N·s/m")?,
        activation_tau_s: w!(activation_tau_s, 1e-3, 1.0, "s")?,
        grip_stiffness_n_per_m: w!(grip_stiffness_n_per_m, 10.0, 1e6, "N/m")?,
        grip_damping_n_s_per_m: w!(grip_damping_n_s_per_m, 0.0, 1e4, "N·s/m")?,
        tracking_gain_per_s: w!(tracking_gain_per_s, 0.0, 100.0, "1/s")?,
    })
}
