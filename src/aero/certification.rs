//! Certification limits on pitch control forces and where an aircraft's feel sits against them.
//!
//! Limits (pounds-force in the regulations, converted once with [`LBF_TO_N`]):
//! - 14 CFR 23.143(c) (pre-Amendment 23-64 text) and 25.143(d): maximum pitch force for short-term
//!   (temporary) application, one or two hands on the wheel (stick: 60 lbf, Part 23 only), and for
//!   prolonged / long-term application.
//! - 14 CFR 23.155(a): the force to reach the positive limit manoeuvring load factor may not be less
//!   than W/100 or 20 lbf for wheel controls (W/140 or 15 lbf for a stick), whichever is greater,
//!   but need not exceed 50 lbf (35 lbf for a stick).
//! - 14 CFR 25.173(c): the average stable stick-force-versus-speed gradient may not be less than
//!   1 lbf per 6 knots.
//! - MIL-F-8785C §3.2.2.2.1, Table V (centre stick): the stick force per g of Levels 1, 2 and 3
//!   ([`centre_stick_per_g_bounds`], the bounds quoted in `sweep::hq`); Level 1 at most `240/(n/α)`
//!   lbf/g but not more than 28.0 nor less than `56/(n_L − 1)`, and at least `21/(n_L − 1)` but not less
//!   than 3.0 lbf/g; `n/α` is the load factor per radian of angle of attack.
//!
//! Reading used here: the pull to the limit load factor from trim is a short-term force, so it must
//! stay within the short-term two-hand limit; the stick force per g must be positive; Part 23's
//! minimum applies at the limit load factor.

use super::longitudinal::{n_per_alpha, Aircraft};
use super::model::{AircraftModel, CertificationPart, ControlType};
use super::AeroError;
use crate::units::{G0_M_S2, LBF_TO_N};

/// Knot to m/s (exact: 1852 m per nautical mile).
pub(crate) const KT_TO_M_S: f64 = 1852.0 / 3600.0;

/// Pitch-force limits of one certification basis, N.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CertificationBasis {
    /// Part 23 or 25.
    pub part: CertificationPart,
    /// Wheel or stick.
    pub control: ControlType,
    /// Short-term (temporary) maximum, two hands (or a stick), N.
    pub short_term_two_hands_n: f64,
    /// Short-term maximum, one hand, N.
    pub short_term_one_hand_n: f64,
    /// Prolonged / long-term maximum, N.
    pub long_term_n: f64,
    /// Minimum force to reach the limit load factor (23.155), N; `None` under Part 25.
    pub min_force_at_limit_n: Option<f64>,
    /// Minimum stick-force-versus-speed gradient (25.173(c)), N per m/s; `None` under Part 23.
    pub min_speed_gradient_n_per_m_s: Option<f64>,
}

impl CertificationBasis {
    /// The limits for a part, control type and maximum weight.
    pub fn new(part: CertificationPart, control: ControlType, max_weight_kg: f64) -> Self {
        let w_lbf = max_weight_kg * G0_M_S2 / LBF_TO_N;
        // short term two hands, one hand, long term, the minimum at the limit load factor; lbf
        let (two, one, long, min_at_limit) = match (part, control) {
            // 23.143(c): wheel 75 (two hands) / 50 (one hand); 23.155(a)(1)
            (CertificationPart::Part23, ControlType::Wheel) => {
                (75.0, 50.0, 10.0, Some((w_lbf / 100.0).clamp(20.0, 50.0)))
            }
            // 23.143(c): stick 60; 23.155(a)(2)
            (CertificationPart::Part23, ControlType::Stick) => {
                (60.0, 60.0, 10.0, Some((w_lbf / 140.0).clamp(15.0, 35.0)))
            }
            // 25.143(d)
            (CertificationPart::Part25, _) => (75.0, 50.0, 10.0, None),
            // MIL-F-8785C bounds the gradient (per flight condition, FeelAssessment), not the force
            (CertificationPart::MilF8785C, _) => (f64::INFINITY, f64::INFINITY, f64::INFINITY, None),
        };
        Self {
            part,
            control,
            short_term_two_hands_n: two * LBF_TO_N,
            short_term_one_hand_n: one * LBF_TO_N,
            long_term_n: long * LBF_TO_N,
            min_force_at_limit_n: min_at_limit.map(|f| f * LBF_TO_N),
            // 25.173(c): 1 lbf per 6 kt
            min_speed_gradient_n_per_m_s: (part == CertificationPart::Part25)
                .then(|| LBF_TO_N / (6.0 * KT_TO_M_S)),
        }
    }

    pub(crate) fn for_model(m: &AircraftModel) -> Self {
        Self::new(m.part, m.control, m.max_weight_kg)
    }
}

/// Where an aircraft's stick forces sit at one flight condition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeelAssessment {
    /// True airspeed, m/s.
    pub airspeed_m_s: f64,
    /// Altitude, m.
    pub altitude_m: f64,
    /// The force limits applied.
    pub basis: CertificationBasis,
    /// Positive limit load factor, g.
    pub limit_load_factor: f64,
    /// Secant stick force per g between 1 g and `per_g_at_nz` (2 g, or less where the limit load
    /// factor or the stall come first), N/g.
    pub stick_force_per_g_n: f64,
    /// The load factor the stick force per g is taken at, g.
    pub per_g_at_nz: f64,
    /// Pull from trim to the limit load factor, N (from the model's steady pull-up; extrapolated
    /// with the stick force per g when the wing stalls before the limit).
    pub force_at_limit_n: f64,
    /// Whether `force_at_limit_n` is extrapolated (the wing stalls first).
    pub force_at_limit_extrapolated: bool,
    /// Stick-force-versus-speed gradient around the trim speed, N per m/s, positive when stable (a
    /// pull below the trim speed): the mean of the slopes from 5 % to 10 % below and above the trim
    /// speed (the "stable slope" of 25.173(c); a breakout step at trim does not count).
    pub speed_gradient_n_per_m_s: f64,
    /// Allowed stick force per g band implied by the limits: [min, max] N/g.
    pub allowed_per_g_n: (f64, f64),
}

impl FeelAssessment {
    /// Assess `aircraft` trimmed at `airspeed_m_s`, `altitude_m`.
    pub fn assess(aircraft: &Aircraft, airspeed_m_s: f64, altitude_m: f64) -> Result<Self, AeroError> {
        let m = aircraft.model();
        let basis = CertificationBasis::for_model(m);
        let n_lim = m.limit_load_factor;
        let n_ref = per_g_load_factor(m, airspeed_m_s, altitude_m)?;
        let per_g = aircraft.stick_force_per_g(airspeed_m_s, altitude_m, n_ref)?;
        let (force_at_limit_n, extrapolated) =
            match aircraft.pull_up_stick_force_n(airspeed_m_s, altitude_m, n_lim) {
                Ok(f) => (f, false),
                Err(AeroError::Trim { .. }) => (per_g * (n_lim - 1.0), true),
                Err(e) => return Err(e),
            };
        // the stable slope on each side of the trim speed (5 % to 10 % off trim), averaged: a
        // breakout force (the step of a feel unit's centring detent at trim) is not a gradient
        let dv = 0.1 * airspeed_m_s;
        let f = |v: f64| aircraft.off_trim_stick_force_n(airspeed_m_s, v, altitude_m);
        let slow = f(airspeed_m_s - dv)? - f(airspeed_m_s - 0.5 * dv)?;
        let fast = f(airspeed_m_s + 0.5 * dv)? - f(airspeed_m_s + dv)?;
        let speed_gradient = (slow + fast) / dv;
        let (min_per_g, max_per_g) = match m.part {
            CertificationPart::MilF8785C => {
                // n/α at the trim: the lift slope there times the dynamic pressure over the weight
                let trim = aircraft.steady_state(airspeed_m_s, altitude_m, 1.0)?;
                let cl_alpha = m.cl_alpha.slope(trim.alpha_rad);
                let n_alpha = n_per_alpha(trim.qbar_pa, m.wing_area_m2, cl_alpha, m.mass_kg);
                PerGBounds::level1(n_lim, n_alpha)
            }
            _ => (
                basis
                    .min_force_at_limit_n
                    .map(|f| f / (n_lim - 1.0))
                    .unwrap_or(0.0),
                basis.short_term_two_hands_n / (n_lim - 1.0),
            ),
        };
        Ok(Self {
            airspeed_m_s,
            altitude_m,
            basis,
            limit_load_factor: n_lim,
            stick_force_per_g_n: per_g,
            per_g_at_nz: n_ref,
            force_at_limit_n,
            force_at_limit_extrapolated: extrapolated,
            speed_gradient_n_per_m_s: speed_gradient,
            allowed_per_g_n: (min_per_g, max_per_g),
        })
    }

    /// Every limit met: positive stick force per g inside the band, the pull to the limit load
    /// factor within the short-term force, a stable speed gradient (and the Part 25 minimum).
    pub fn complies(&self) -> bool {
        let (lo, hi) = self.allowed_per_g_n;
        self.stick_force_per_g_n > 0.0
            && self.stick_force_per_g_n >= lo
            && self.stick_force_per_g_n <= hi
            && self.force_at_limit_n <= self.basis.short_term_two_hands_n
            && self
                .basis
                .min_force_at_limit_n
                .is_none_or(|f| self.force_at_limit_n >= f)
            && self.speed_gradient_n_per_m_s > 0.0
            && self
                .basis
                .min_speed_gradient_n_per_m_s
                .is_none_or(|g| self.speed_gradient_n_per_m_s >= g)
    }

    /// Position of the stick force per g in the allowed band: 0 at the minimum, 1 at the maximum.
    pub(crate) fn band_position(&self) -> f64 {
        let (lo, hi) = self.allowed_per_g_n;
        (self.stick_force_per_g_n - lo) / (hi - lo)
    }

    /// A one-paragraph report in SI with pounds in brackets.
    pub fn report(&self) -> String {
        let lbf = |n: f64| n / LBF_TO_N;
        let (lo, hi) = self.allowed_per_g_n;
        let part = self.basis.part.label();
        format!(
            "{:.1} m/s at {:.0} m ({part}): stick force per g {:.1} N/g ({:.1} lbf/g, 1 to {:.2} g), allowed [{:.1}, {:.1}] N/g \
             ([{:.1}, {:.1}] lbf/g), band position {:.2}; pull to n = {:.1}: {:.0} N ({:.1} lbf{}); \
             speed gradient {:.2} N per m/s ({:.2} lbf per 6 kt); complies: {}",
            self.airspeed_m_s,
            self.altitude_m,
            self.stick_force_per_g_n,
            lbf(self.stick_force_per_g_n),
            self.per_g_at_nz,
            lo,
            hi,
            lbf(lo),
            lbf(hi),
            self.band_position(),
            self.limit_load_factor,
            self.force_at_limit_n,
            lbf(self.force_at_limit_n),
            if self.force_at_limit_extrapolated { ", extrapolated: stall or elevator stop first" } else { "" },
            self.speed_gradient_n_per_m_s,
            lbf(self.speed_gradient_n_per_m_s * 6.0 * KT_TO_M_S),
            self.complies()
        )
    }
}

/// The load factor of the pull-up that measures stick force per g: 2 g, or 80 % of the way to the stall
/// load factor when the wing cannot reach 2 g at this speed (never beyond the limit load factor); refused
/// too close to the stall.
pub(crate) fn per_g_load_factor(
    m: &AircraftModel,
    airspeed_m_s: f64,
    altitude_m: f64,
) -> Result<f64, AeroError> {
    let air = super::atmosphere::isa(altitude_m);
    let cl_1g = m.mass_kg * G0_M_S2 / (0.5 * air.density_kg_m3 * airspeed_m_s.powi(2) * m.wing_area_m2);
    let n_stall = m.cl_alpha.max_value() / cl_1g;
    let n_ref = 2.0_f64.min(m.limit_load_factor).min(1.0 + 0.8 * (n_stall - 1.0));
    if n_ref <= 1.05 {
        return Err(AeroError::Refused {
            what: format!("{} at {airspeed_m_s} m/s, {altitude_m} m", m.name),
            why: format!("too close to the stall for a pull-up (stall load factor {n_stall:.2})"),
        });
    }
    Ok(n_ref)
}

/// Stick-force-per-g bounds of one Level, N/g.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PerGBounds {
    pub min_n_per_g: f64,
    pub max_n_per_g: f64,
}

impl PerGBounds {
    /// Table V's Level 1 band for a centre stick ([`centre_stick_per_g_bounds`]) as (min, max), N/g.
    pub(crate) fn level1(n_limit: f64, n_per_alpha: f64) -> (f64, f64) {
        let b = centre_stick_per_g_bounds(n_limit, n_per_alpha)[0];
        (b.min_n_per_g, b.max_n_per_g)
    }
}

/// MIL-F-8785C Table V for a centre stick: the bounds of Levels 1, 2 and 3, N/g, for limit load factor
/// `n_limit` (g) and acceleration sensitivity `n_per_alpha` (g/rad).
pub(crate) fn centre_stick_per_g_bounds(n_limit: f64, n_per_alpha: f64) -> [PerGBounds; 3] {
    let dn = n_limit - 1.0;
    let b = |min_lbf: f64, max_lbf: f64| PerGBounds {
        min_n_per_g: min_lbf * LBF_TO_N,
        max_n_per_g: max_lbf * LBF_TO_N,
    };
    [
        b(
            (21.0 / dn).max(3.0),
            (240.0 / n_per_alpha).min(28.0).max(56.0 / dn),
        ),
        b(
            (18.0 / dn).max(3.0),
            (360.0 / n_per_alpha).min(42.5).max(85.0 / dn),
        ),
        b((12.0 / dn).max(2.0), 56.0),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_23_wheel_limits_follow_the_regulation_table() {
        // 2400 lbf maximum weight: W/100 = 24 lbf > 20 lbf.
        let b = CertificationBasis::new(
            CertificationPart::Part23,
            ControlType::Wheel,
            2400.0 * LBF_TO_N / G0_M_S2,
        );
        assert!((b.short_term_two_hands_n / LBF_TO_N - 75.0).abs() < 1e-9);
        assert!((b.min_force_at_limit_n.unwrap() / LBF_TO_N - 24.0).abs() < 1e-9);
        // a heavy Part 23 aircraft: the minimum need not exceed 50 lbf
        let heavy = CertificationBasis::new(CertificationPart::Part23, ControlType::Wheel, 19_000.0);
        assert!((heavy.min_force_at_limit_n.unwrap() / LBF_TO_N - 50.0).abs() < 1e-9);
    }

    #[test]
    fn part_25_speed_gradient_is_one_pound_per_six_knots() {
        let b = CertificationBasis::new(CertificationPart::Part25, ControlType::Wheel, 60_000.0);
        // 4.448 N per 3.087 m/s = 1.441 N per m/s
        assert!((b.min_speed_gradient_n_per_m_s.unwrap() - 1.4410).abs() < 1e-3);
        assert!((b.short_term_one_hand_n - 222.41).abs() < 0.01);
    }
}
