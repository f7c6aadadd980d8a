//! International Standard Atmosphere, troposphere (0–11 km), as JSBSim uses by default.
//! Constants from ISO 2533:1975 / U.S. Standard Atmosphere 1976.

/// Sea-level temperature, K.
pub const T0_K: f64 = 288.15;
/// Sea-level density, kg/m³.
pub const RHO0_KG_M3: f64 = 1.225;
/// Troposphere lapse rate, K/m.
pub const LAPSE_K_M: f64 = 0.0065;
/// Specific gas constant of dry air, J/(kg K).
pub const R_AIR_J_KG_K: f64 = 287.052_87;
/// Ratio of specific heats of air.
pub const GAMMA_AIR: f64 = 1.4;
/// Tropopause altitude, m: above it this model holds the tropopause values.
pub const TROPOPAUSE_M: f64 = 11_000.0;

/// Air properties at an altitude.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Air {
    /// Temperature, K.
    pub temperature_k: f64,
    /// Density, kg/m³.
    pub density_kg_m3: f64,
    /// Speed of sound, m/s.
    pub speed_of_sound_m_s: f64,
}

/// ISA air at geopotential altitude `altitude_m` (clamped to the troposphere, 0–11 km).
pub fn isa(altitude_m: f64) -> Air {
    let h = altitude_m.clamp(-500.0, TROPOPAUSE_M);
    let t = T0_K - LAPSE_K_M * h;
    let g0 = crate::units::G0_M_S2;
    let exponent = g0 / (LAPSE_K_M * R_AIR_J_KG_K) - 1.0;
    Air {
        temperature_k: t,
        density_kg_m3: RHO0_KG_M3 * (t / T0_K).powf(exponent),
        speed_of_sound_m_s: (GAMMA_AIR * R_AIR_J_KG_K * t).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn isa_density_at_3000_m_matches_standard_table() {
        // U.S. Standard Atmosphere 1976 tables: 0.90925 kg/m³ and 328.58 m/s at 3000 m.
        let a = isa(3000.0);
        assert!((a.density_kg_m3 - 0.90925).abs() < 5e-4, "{}", a.density_kg_m3);
        assert!(
            (a.speed_of_sound_m_s - 328.58).abs() < 0.1,
            "{}",
            a.speed_of_sound_m_s
        );
    }
}
