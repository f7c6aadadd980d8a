//! Elevator hinge moment and the stick force it asks of the feel system.
//!
//! JSBSim's bundled aircraft carry no hinge moments, so this is our model (Etkin & Reid,
//! *Dynamics of Flight*, §2.6; Roskam, *Airplane Flight Dynamics* Part I, §4.4):
//!
//! ```text
//! alpha_t = alpha (1 - d(eps)/d(alpha)) + q l_t / V                    tail angle of attack (increment)
//! H       = eta_t qbar S_e c_e (Ch0 + Ch_alpha alpha_t + Ch_delta delta_e + Ch_tab delta_tab)
//! F       = H * G / l_s * k_fb                                         stick force at the grip
//! ```
//!
//! Signs: `H` is positive when the air pushes the elevator's trailing edge **down** (the same sign
//! as a trailing-edge-down elevator, `delta_e > 0`). The stick angle `theta_s` is positive **aft**
//! (pull) and moves the elevator trailing edge up: `delta_e = -G theta_s`. Virtual work at
//! equilibrium, `F l_s d(theta_s) + H d(delta_e) = 0`, gives `F = H G / l_s`: a trailing-edge-down
//! hinge moment must be held by a **pull**, so `F > 0` is a pull (aft force on the grip) and a
//! trailing-edge-down elevator (restoring `Ch_delta < 0`, `H < 0`) needs a push. `k_fb` is the
//! fraction of the hinge moment fed back to the pilot: 1 for reversible (cable) controls, the
//! equivalent of the artificial-feel unit for powered controls.
//!
//! Constant terms (`Ch0`, tail incidence, zero-lift downwash) only move the trim-tab setting: the
//! tab is set in trim so that the stick force there is zero, as a pilot trims.

use super::model::AircraftModel;

/// Per-aircraft hinge, tail and stick-gearing parameters (from the model TOML).
#[derive(Debug, Clone, PartialEq)]
pub struct HingeModel {
    pub elevator_area_m2: f64,
    pub elevator_chord_m: f64,
    pub ch0: f64,
    pub ch_alpha_per_rad: f64,
    pub ch_elevator_per_rad: f64,
    pub ch_tab_per_rad: f64,
    pub tab_min_rad: f64,
    pub tab_max_rad: f64,
    pub tail_dynamic_pressure_ratio: f64,
    pub downwash_gradient: f64,
    pub tail_arm_m: f64,
    /// `G`: elevator radians per stick radian (positive; aft stick = trailing edge up).
    pub elevator_per_stick_rad_per_rad: f64,
    /// `l_s`: stick pivot to grip, m.
    pub stick_arm_m: f64,
    /// `k_fb`: fraction of the hinge moment felt at the stick.
    pub force_feedback_ratio: f64,
    pub elevator_min_rad: f64,
    pub elevator_max_rad: f64,
}

impl HingeModel {
    pub fn from_model(m: &AircraftModel) -> Self {
        Self {
            elevator_area_m2: m.elevator_area_m2,
            elevator_chord_m: m.elevator_chord_m,
            ch0: m.ch0,
            ch_alpha_per_rad: m.ch_alpha_per_rad,
            ch_elevator_per_rad: m.ch_elevator_per_rad,
            ch_tab_per_rad: m.ch_tab_per_rad,
            tab_min_rad: m.tab_min_rad,
            tab_max_rad: m.tab_max_rad,
            tail_dynamic_pressure_ratio: m.tail_dynamic_pressure_ratio,
            downwash_gradient: m.downwash_gradient,
            tail_arm_m: m.htail_arm_m,
            elevator_per_stick_rad_per_rad: m.elevator_per_stick_rad_per_rad,
            stick_arm_m: m.stick_arm_m,
            force_feedback_ratio: m.force_feedback_ratio,
            elevator_min_rad: m.elevator_min_rad,
            elevator_max_rad: m.elevator_max_rad,
        }
    }

    /// Tail angle-of-attack increment: wing alpha less downwash, plus the pitch-rate term `q l_t / V`.
    pub fn alpha_tail_rad(&self, alpha_rad: f64, q_rad_s: f64, airspeed_m_s: f64) -> f64 {
        alpha_rad * (1.0 - self.downwash_gradient) + q_rad_s * self.tail_arm_m / airspeed_m_s.max(1.0)
    }

    /// Hinge-moment coefficient.
    pub fn ch(&self, alpha_tail_rad: f64, elevator_rad: f64, tab_rad: f64) -> f64 {
        self.ch0
            + self.ch_alpha_per_rad * alpha_tail_rad
            + self.ch_elevator_per_rad * elevator_rad
            + self.ch_tab_per_rad * tab_rad
    }

    /// Hinge moment `H`, N·m, positive trailing edge down. `qbar_pa` is the dynamic pressure the
    /// elevator sees before the tail efficiency (free stream, or the slipstream where modelled).
    pub fn hinge_moment_nm(&self, qbar_pa: f64, alpha_tail_rad: f64, elevator_rad: f64, tab_rad: f64) -> f64 {
        self.tail_dynamic_pressure_ratio
            * qbar_pa
            * self.elevator_area_m2
            * self.elevator_chord_m
            * self.ch(alpha_tail_rad, elevator_rad, tab_rad)
    }

    /// Stick force at the grip, N, **positive = pull (aft)**, that holds hinge moment `H`.
    pub fn stick_force_n(&self, hinge_moment_nm: f64) -> f64 {
        hinge_moment_nm * self.elevator_per_stick_rad_per_rad / self.stick_arm_m * self.force_feedback_ratio
    }

    /// Elevator angle (positive trailing edge down) commanded by a stick angle (positive aft),
    /// held at the elevator stops.
    pub fn elevator_from_stick_rad(&self, stick_angle_rad: f64) -> f64 {
        (-self.elevator_per_stick_rad_per_rad * stick_angle_rad)
            .clamp(self.elevator_min_rad, self.elevator_max_rad)
    }

    /// Stick angle (positive aft) that puts the elevator at `elevator_rad`.
    pub fn stick_from_elevator_rad(&self, elevator_rad: f64) -> f64 {
        -elevator_rad / self.elevator_per_stick_rad_per_rad
    }

    /// Tab angle that zeroes the hinge moment (and so the stick force) at a flight condition.
    /// `None` when that angle lies outside the tab's travel.
    pub fn trim_tab_rad(&self, alpha_tail_rad: f64, elevator_rad: f64) -> Option<f64> {
        let tab =
            -(self.ch0 + self.ch_alpha_per_rad * alpha_tail_rad + self.ch_elevator_per_rad * elevator_rad)
                / self.ch_tab_per_rad;
        (self.tab_min_rad..=self.tab_max_rad)
            .contains(&tab)
            .then_some(tab)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plain() -> HingeModel {
        HingeModel {
            elevator_area_m2: 1.0,
            elevator_chord_m: 0.3,
            ch0: 0.0,
            ch_alpha_per_rad: -0.1,
            ch_elevator_per_rad: -0.4,
            ch_tab_per_rad: -0.5,
            tab_min_rad: -0.4,
            tab_max_rad: 0.4,
            tail_dynamic_pressure_ratio: 0.9,
            downwash_gradient: 0.4,
            tail_arm_m: 5.0,
            elevator_per_stick_rad_per_rad: 2.0,
            stick_arm_m: 0.5,
            force_feedback_ratio: 1.0,
            elevator_min_rad: -0.5,
            elevator_max_rad: 0.4,
        }
    }

    #[test]
    fn trailing_edge_down_elevator_needs_a_push_and_trailing_edge_up_a_pull() {
        let h = plain();
        // 0.1 rad trailing edge down at 2 kPa: the air pushes it back up (H < 0)...
        let hm = h.hinge_moment_nm(2000.0, 0.0, 0.1, 0.0);
        assert!(hm < 0.0);
        // ... so the pilot must push (negative force); and the stick sits forward of neutral.
        assert!(h.stick_force_n(hm) < 0.0);
        assert!(h.stick_from_elevator_rad(0.1) < 0.0);
        let pull = h.stick_force_n(h.hinge_moment_nm(2000.0, 0.0, -0.1, 0.0));
        assert!(pull > 0.0);
        // Magnitude: 0.9 * 2000 * 1.0 * 0.3 * 0.04 = 21.6 N·m at the hinge, x 2 / 0.5 m = 86.4 N.
        assert!((pull - 86.4).abs() < 1e-9, "{pull}");
    }

    #[test]
    fn gearing_round_trips_and_respects_the_elevator_stops() {
        let h = plain();
        assert!((h.elevator_from_stick_rad(h.stick_from_elevator_rad(0.2)) - 0.2).abs() < 1e-12);
        assert_eq!(h.elevator_from_stick_rad(1.0), -0.5); // full aft: trailing-edge-up stop
        assert_eq!(h.elevator_from_stick_rad(-1.0), 0.4);
    }

    #[test]
    fn trim_tab_zeroes_the_hinge_moment() {
        let h = plain();
        let tab = h.trim_tab_rad(0.05, 0.1).unwrap();
        assert!(h.hinge_moment_nm(3000.0, 0.05, 0.1, tab).abs() < 1e-9);
        assert!(h.trim_tab_rad(0.0, 1.0).is_none()); // would need 0.8 rad of tab
    }
}
