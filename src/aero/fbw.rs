//! A fly-by-wire aircraft's stick: no hinge moment reaches it, so its feel is designed, and the pilot's
//! force on it commands the flight control system (FCS), as on the F-16's force-sensing sidestick.
//!
//! - **Command.** The stick's own force sensor (not the feel loop's load cell) gives the FCS
//!   `c = sgn(F) max(|F| − F_b, 0) / F_c` clipped to [-1, 1] (pull +), `F_c = (F/n) g_c`. A fault in the feel
//!   loop changes what the pilot feels, never what the FCS is told: the MR damper cannot move the stick.
//! - **Feel law.** `F(θ) = F_b sgn(θ) + K θ` at the grip (pull +), full command at the aft stop `θ_full`, from
//!   the breakout `F_b` (MIL-F-8785C §3.5.2.1, Table XII: pitch, stick, Class IV, 0.5 to 3 lbf) and the stick
//!   force per g `F/n` (MIL-F-8785C §3.2.2.2.1, Table V, Level 1): `K = (F/n) g_c / θ_full`, `g_c` the FCS's
//!   steady load factor per unit command, so a steady pull to `n` asks `F_b + (F/n)(n − 1)`.
//! - **Level 1 band.** Table V's centre-stick limits ([`super::certification`]); the sidestick limits of
//!   MIL-STD-1797A §4.2.8.2 could not be consulted, so the centre-stick band is the design band.

use super::certification::PerGBounds;
use crate::device::bingham::sgn;
use crate::units::LBF_TO_N;

/// MIL-F-8785C §3.5.2.1, Table XII: pitch breakout of a stick, Class IV aircraft, N (0.5 to 3 lbf).
pub const BREAKOUT_RANGE_CLASS_IV_N: (f64, f64) = (0.5 * LBF_TO_N, 3.0 * LBF_TO_N);

/// A fly-by-wire aircraft's stick and the flight condition its feel is designed at
/// (`models/aircraft/<name>.toml` with a `[fly_by_wire]` section).
#[derive(Debug, Clone, PartialEq)]
pub struct FlyByWire {
    /// JSBSim's name of the aircraft (`f16`).
    pub name: String,
    /// Stick angle of full aft command, rad (the sidestick's aft stop).
    pub full_command_stick_rad: f64,
    /// Designed breakout at the grip, N.
    pub breakout_n: f64,
    /// Designed stick force per g at the design condition, N/g.
    pub stick_force_per_g_n: f64,
    /// Largest pull the pilot's hand puts on the grip, N.
    pub max_pull_n: f64,
    /// Largest push the pilot's hand puts on the grip, N.
    pub max_push_n: f64,
    /// The design condition: true airspeed, m/s.
    pub airspeed_m_s: f64,
    /// The design condition: altitude, m.
    pub altitude_m: f64,
    /// The FCS's steady load factor per unit command at the design condition, g.
    pub g_per_command: f64,
    /// Load factor per radian of angle of attack at the design condition, g/rad.
    pub n_alpha_per_rad: f64,
    /// Symmetric limit load factor, g.
    pub limit_load_factor: f64,
    /// The model file's parameters marked `[EST]` (`section.key`).
    pub estimates: Vec<String>,
}

impl FlyByWire {
    /// The designed gradient at the grip, N per rad of stick: `(F/n) g_c / θ_full`.
    pub fn gradient_n_per_rad(&self) -> f64 {
        self.stick_force_per_g_n * self.g_per_command / self.full_command_stick_rad
    }

    /// The designed stick force at the grip at stick angle `stick_rad` from neutral (pull +), N.
    pub fn stick_force_n(&self, stick_rad: f64) -> f64 {
        self.breakout_n * sgn(stick_rad) + self.gradient_n_per_rad() * stick_rad
    }

    /// The force of full command at the grip beyond the breakout, N: `(F/n) g_c`.
    pub fn full_command_force_n(&self) -> f64 {
        self.stick_force_per_g_n * self.g_per_command
    }

    /// The FCS's normalised pitch command for the hand's force `grip_force_n` on the grip (pull +), in
    /// [-1, 1]: nothing inside the breakout.
    pub fn command(&self, grip_force_n: f64) -> f64 {
        let beyond = (grip_force_n.abs() - self.breakout_n).max(0.0);
        (grip_force_n.signum() * beyond / self.full_command_force_n()).clamp(-1.0, 1.0)
    }

    /// The designed steady stick force to hold `nz_g` at the design condition, N.
    pub fn designed_force_n(&self, nz_g: f64) -> f64 {
        let dn = nz_g - 1.0;
        self.breakout_n * sgn(dn) + self.stick_force_per_g_n * dn
    }

    /// MIL-F-8785C Table V Level 1 stick force per g at the design condition: [min, max] N/g.
    pub fn level1_per_g_n(&self) -> (f64, f64) {
        PerGBounds::level1(self.limit_load_factor, self.n_alpha_per_rad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f16() -> FlyByWire {
        FlyByWire {
            name: "f16".into(),
            full_command_stick_rad: 0.05,
            breakout_n: 6.0,
            stick_force_per_g_n: 20.0,
            max_pull_n: 100.0,
            max_push_n: 50.0,
            airspeed_m_s: 200.0,
            altitude_m: 3000.0,
            g_per_command: 6.0,
            n_alpha_per_rad: 20.0,
            limit_load_factor: 9.0,
            estimates: Vec::new(),
        }
    }

    /// The stick held where the FCS gives `n` g (command `(n − 1)/g_c`) asks the designed force:
    /// breakout plus the force per g times the load factor gained, and that force commands `n` g; a force
    /// inside the breakout commands nothing. Table V's worked corner: n/α 20 g/rad,
    /// n_L 9 gives [3.0, 12.0] lbf/g.
    #[test]
    fn the_stick_where_the_fcs_gives_n_g_asks_the_designed_force_per_g() {
        let f = f16();
        for n in [1.5, 2.0, 3.0, 4.0] {
            let stick = (n - 1.0) / f.g_per_command * f.full_command_stick_rad;
            let force = f.stick_force_n(stick);
            assert!((force - (6.0 + 20.0 * (n - 1.0))).abs() < 1e-9);
            assert!((f.command(force) * f.g_per_command - (n - 1.0)).abs() < 1e-12);
            assert!((f.designed_force_n(n) - force).abs() < 1e-9);
        }
        assert_eq!(f.command(5.9), 0.0);
        assert_eq!(f.command(-5.9), 0.0);
        assert_eq!(f.command(1000.0), 1.0);
        assert_eq!(f.command(-1000.0), -1.0);
        let (lo, hi) = f.level1_per_g_n();
        assert!((lo / LBF_TO_N - 3.0).abs() < 1e-9 && (hi / LBF_TO_N - 12.0).abs() < 1e-9);
    }
}
