//! Elevator hinge moment and the stick force it asks of the feel system.
//!
//! JSBSim's bundled aircraft carry no hinge moments, so this is our model (Etkin & Reid,
//! *Dynamics of Flight*, §2.6; Roskam, *Airplane Flight Dynamics* Part I, §4.4):
//!
//! ```text
//! alpha_t = alpha (1 - d(eps)/d(alpha)) + q l_t / V                    tail angle of attack (increment)
//! H       = eta_t qbar S_e c_e (Ch0 + Ch_alpha alpha_t + Ch_delta delta_e + Ch_tab delta_tab)
//! F       = H * G / l_s * k_fb  (+ F_feel for powered controls)        stick force at the grip
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
//!
//! **Powered (irreversible) elevators** (the 737) feel no air load (`k_fb = 0`): the force comes from
//! an elevator feel computer and a feel and centering unit, [`FeelComputer`]. As described for the
//! Boeing feel systems (737 FCOM, *Flight Controls — Elevator Feel System* and *Mach Trim System*; the
//! 747's feel computer: a pitot (impact-pressure) bellows sets the hydraulic feel pressure on the
//! feel unit's cam, a centring spring adds to it):
//!
//! ```text
//! F_feel = F_bo sat(Δ/δ_bo) + (K_c + K_q q_c) Δ,     Δ = θ_s − θ_n(M)
//! q_c    = p [(1 + 0.2 M²)^3.5 − 1]                  impact pressure the feel pitot senses
//! θ_n(M) = θ_trim + k_mt max(0, M − M_mt)            column neutral: trim, shifted aft by the Mach trim
//! ```
//!
//! `θ_trim` is where trimming (the stabilizer, in the real aircraft) puts the column's zero-force
//! position; the Mach trim actuator repositions the feel and centring unit above `M_mt` (0.615 on
//! the 737, FCOM), which moves the column neutral aft as the speed rises.

use super::state::AircraftState;

/// An aircraft's elevator hinge, tail and stick gearing (part of its [`super::AircraftModel`]).
#[derive(Debug, Clone, PartialEq)]
pub struct HingeModel {
    /// Elevator area aft of the hinge, m².
    pub elevator_area_m2: f64,
    /// Elevator chord aft of the hinge, m.
    pub elevator_chord_m: f64,
    /// Hinge moment coefficient at zero tail angle of attack and deflections.
    pub ch0: f64,
    /// Hinge moment coefficient per radian of tail angle of attack.
    pub ch_alpha_per_rad: f64,
    /// Hinge moment coefficient per radian of elevator.
    pub ch_elevator_per_rad: f64,
    /// Hinge moment coefficient per radian of trim tab.
    pub ch_tab_per_rad: f64,
    /// Trim tab travel: lowest deflection, rad.
    pub tab_min_rad: f64,
    /// Trim tab travel: highest deflection, rad.
    pub tab_max_rad: f64,
    /// Tail dynamic pressure over free-stream dynamic pressure.
    pub tail_dynamic_pressure_ratio: f64,
    /// Downwash gradient `d epsilon / d alpha` at the tail.
    pub downwash_gradient: f64,
    /// Centre of gravity to the tail's aerodynamic centre, m.
    pub tail_arm_m: f64,
    /// `G`: elevator radians per stick radian (positive; aft stick = trailing edge up).
    pub elevator_per_stick_rad_per_rad: f64,
    /// `l_s`: stick pivot to grip, m.
    pub stick_arm_m: f64,
    /// `k_fb`: fraction of the hinge moment felt at the stick (0 for irreversible powered controls).
    pub force_feedback_ratio: f64,
    /// Artificial feel of a powered elevator (`None` for reversible controls).
    pub feel_computer: Option<FeelComputer>,
    /// Elevator travel: lowest deflection, rad.
    pub elevator_min_rad: f64,
    /// Elevator travel: highest deflection, rad.
    pub elevator_max_rad: f64,
}

impl HingeModel {
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

    /// The part of the stick force fed back from the hinge moment `H`, N, **positive = pull (aft)**:
    /// `H G / l_s k_fb` (the whole force of a reversible control).
    pub fn hinge_feedback_force_n(&self, hinge_moment_nm: f64) -> f64 {
        hinge_moment_nm * self.elevator_per_stick_rad_per_rad / self.stick_arm_m * self.force_feedback_ratio
    }

    /// Total stick force at the grip, N, **positive = pull (aft)**, at a flight state: the hinge
    /// feedback of `s.hinge_moment_nm` plus, for powered controls, the feel computer's force at the
    /// stick angle that commands `s.elevator_rad`, about the feel trim `s.feel_trim_rad`, at the
    /// free-stream `s.qbar_pa` and `s.mach`.
    pub fn stick_force_n(&self, s: &AircraftState) -> f64 {
        let hinge = self.hinge_feedback_force_n(s.hinge_moment_nm);
        match &self.feel_computer {
            None => hinge,
            Some(fc) => {
                let stick = self.stick_from_elevator_rad(s.elevator_rad);
                hinge + fc.force_n(stick, s.feel_trim_rad, s.qbar_pa, s.mach)
            }
        }
    }

    /// The state `s` with its hinge fields filled from this model (for backends without hinge moments):
    /// tail angle of attack, hinge moment at the elevator's dynamic pressure and the stick force (with the
    /// feel trim `s.feel_trim_rad` for a feel computer).
    pub fn fill(&self, mut s: AircraftState) -> AircraftState {
        s.alpha_tail_rad = self.alpha_tail_rad(s.alpha_rad, s.q_rad_s, s.airspeed_m_s);
        s.hinge_moment_nm =
            self.hinge_moment_nm(s.qbar_elevator_pa, s.alpha_tail_rad, s.elevator_rad, s.tab_rad);
        s.stick_force_n = self.stick_force_n(&s);
        s
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

    /// The column neutral that zeroes the feel computer's force with the elevator at `elevator_rad` at
    /// `mach`; 0 without a feel computer.
    pub fn feel_trim_rad(&self, elevator_rad: f64, mach: f64) -> f64 {
        self.feel_computer.map_or(0.0, |fc| {
            fc.trim_rad(self.stick_from_elevator_rad(elevator_rad), mach)
        })
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

/// Elevator feel computer and feel-and-centring unit of a powered elevator (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FeelComputer {
    /// `F_bo`: breakout (centring preload) force, N, reached `breakout_band_rad` from the neutral.
    pub breakout_n: f64,
    /// `δ_bo`: stick angle over which the breakout force builds up (the centring detent), rad.
    pub breakout_band_rad: f64,
    /// `K_c`: centring-spring gradient, N per rad of stick (acts with no airspeed).
    pub centering_n_per_rad: f64,
    /// `K_q`: feel gradient per impact pressure, N per rad of stick per Pa.
    pub q_feel_n_per_rad_pa: f64,
    /// `M_mt`: Mach number above which the Mach trim moves the column neutral.
    pub mach_trim_start: f64,
    /// `k_mt`: aft shift of the column neutral per Mach number above `M_mt`, rad of stick.
    pub mach_trim_stick_rad_per_mach: f64,
}

impl FeelComputer {
    /// Impact pressure `q_c = p [(1 + 0.2 M²)^3.5 − 1]` from the dynamic pressure and Mach number
    /// (isentropic, subsonic; `q̄ = 0.7 p M²`), Pa. Tends to `q̄` at low Mach.
    pub fn impact_pressure_pa(qbar_pa: f64, mach: f64) -> f64 {
        let m2 = mach * mach;
        if m2 < 1e-8 {
            return qbar_pa;
        }
        qbar_pa * ((1.0 + 0.2 * m2).powf(3.5) - 1.0) / (0.7 * m2)
    }

    /// Feel gradient `K_c + K_q q_c`, N per rad of stick.
    pub fn gradient_n_per_rad(&self, qbar_pa: f64, mach: f64) -> f64 {
        self.centering_n_per_rad + self.q_feel_n_per_rad_pa * Self::impact_pressure_pa(qbar_pa, mach)
    }

    /// Aft shift of the column neutral by the Mach trim, rad of stick.
    pub fn mach_trim_shift_rad(&self, mach: f64) -> f64 {
        self.mach_trim_stick_rad_per_mach * (mach - self.mach_trim_start).max(0.0)
    }

    /// Feel force, N (pull positive), at stick angle `stick_rad` (positive aft), with the column's
    /// trimmed neutral `feel_trim_rad` (before the Mach trim shift), at `qbar_pa` and `mach`.
    pub fn force_n(&self, stick_rad: f64, feel_trim_rad: f64, qbar_pa: f64, mach: f64) -> f64 {
        let d = stick_rad - (feel_trim_rad + self.mach_trim_shift_rad(mach));
        self.breakout_n * (d / self.breakout_band_rad).clamp(-1.0, 1.0)
            + self.gradient_n_per_rad(qbar_pa, mach) * d
    }

    /// The trimmed neutral `feel_trim_rad` that zeroes the force at `stick_rad` and `mach`.
    pub fn trim_rad(&self, stick_rad: f64, mach: f64) -> f64 {
        stick_rad - self.mach_trim_shift_rad(mach)
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
            feel_computer: None,
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
        assert!(h.hinge_feedback_force_n(hm) < 0.0);
        assert!(h.stick_from_elevator_rad(0.1) < 0.0);
        let pull = h.hinge_feedback_force_n(h.hinge_moment_nm(2000.0, 0.0, -0.1, 0.0));
        assert!(pull > 0.0);
        // Magnitude: 0.9 * 2000 * 1.0 * 0.3 * 0.04 = 21.6 N·m at the hinge, x 2 / 0.5 m = 86.4 N.
        assert!((pull - 86.4).abs() < 1e-9, "{pull}");
    }

    fn feel() -> FeelComputer {
        FeelComputer {
            breakout_n: 5.0,
            breakout_band_rad: 0.01,
            centering_n_per_rad: 0.0,
            q_feel_n_per_rad_pa: 0.1,
            mach_trim_start: 0.6,
            mach_trim_stick_rad_per_mach: 0.2,
        }
    }

    /// Low-speed check of the isentropic impact pressure: `q_c/q̄ = 1 + M²/4 + M⁴/40 + …`
    /// (1.0641 at M = 0.5), and `q_c → q̄` as M → 0.
    #[test]
    fn impact_pressure_follows_the_compressible_pitot_series() {
        let r = FeelComputer::impact_pressure_pa(1000.0, 0.5) / 1000.0;
        assert!((r - 1.0641).abs() < 2e-4, "{r}");
        let r0 = FeelComputer::impact_pressure_pa(1000.0, 0.01) / 1000.0;
        assert!((r0 - 1.0).abs() < 1e-4, "{r0}");
    }

    /// Breakout inside the detent, then breakout plus q-feel gradient times displacement; the force
    /// doubles its gradient part when the impact pressure doubles; above the Mach-trim start the
    /// neutral moves aft, so the same column position needs less pull.
    #[test]
    fn feel_computer_force_is_breakout_plus_q_gradient_about_the_mach_shifted_neutral() {
        let fc = feel();
        let q1 = 5000.0;
        let (m_low, q1c) = (0.3, FeelComputer::impact_pressure_pa(q1, 0.3));
        assert_eq!(fc.force_n(0.1, 0.1, q1, m_low), 0.0);
        assert!((fc.force_n(0.105, 0.1, q1, m_low) - (2.5 + 0.1 * q1c * 0.005)).abs() < 1e-9);
        let f1 = fc.force_n(0.15, 0.1, q1, m_low) - 5.0;
        assert!((f1 - 0.1 * q1c * 0.05).abs() < 1e-9, "{f1}");
        assert!(
            fc.force_n(0.05, 0.1, q1, m_low) < -5.0,
            "forward of neutral: push"
        );
        // same Mach (same q_c/q̄), twice the dynamic pressure: twice the gradient force
        let f2 = fc.force_n(0.15, 0.1, 2.0 * q1, m_low) - 5.0;
        assert!((f2 / f1 - 2.0).abs() < 1e-12);
        // Mach trim: 0.2 rad/Mach above 0.6 -> at M 0.7 the neutral is 0.02 rad aft
        assert_eq!(fc.mach_trim_shift_rad(0.55), 0.0);
        assert!((fc.mach_trim_shift_rad(0.7) - 0.02).abs() < 1e-12);
        assert!(fc.force_n(0.12, 0.1, q1, 0.7).abs() < 1e-9);
        assert!((fc.trim_rad(0.12, 0.7) - 0.1).abs() < 1e-12);
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
