//! What one run of a sweep gives: its figures (tracking, forces) and its handling-qualities verdicts, or
//! the error that stopped it.

use serde::{Deserialize, Serialize};

use super::hq;
use super::steady::{steady_per_g, Lever};
use crate::aero::certification::{centre_stick_per_g_bounds, CertificationBasis};
use crate::aero::model::{AircraftModel, CertificationPart, ControlType};
use crate::aero::Aircraft;
use crate::control::law::FeelLaw;
use crate::input::aircraft::FlyByWireFile;
use crate::scenario::Scenario;
use crate::sim::Results;

/// A cell of a results column. `None`: not applicable to this run (no aircraft, a run that failed).
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// A number.
    F(Option<f64>),
    /// A verdict.
    B(Option<bool>),
    /// A small count (a Level).
    U(Option<u8>),
    /// Text.
    S(Option<String>),
}

/// Declares [`Outcome`] and its results columns from one list, so that the two keep one order.
macro_rules! outcome {
    ($($(#[doc = $doc:literal])* $name:ident: $cell:ident($ty:ty),)*) => {
        /// One run's figures and verdicts. Non-finite figures are `None`.
        #[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
        #[serde(deny_unknown_fields)]
        pub struct Outcome {
            $($(#[doc = $doc])* pub $name: Option<$ty>,)*
        }

        impl Outcome {
            /// The columns, in the results' order.
            pub fn columns(&self) -> Vec<(&'static str, Cell)> {
                vec![$((stringify!($name), Cell::$cell(self.$name.to_owned())),)*]
            }
        }
    };
}

outcome! {
    /// RMS of (load cell − desired force) where the loop resists the motion, N (the feel loop's tracking).
    force_tracking_rmse_n: F(f64),
    /// `force_tracking_rmse_n` over the RMS desired force there.
    force_tracking_nrmse: F(f64),
    /// RMS of the pilot's task error (pitch, rad; load factor, g) with an outer loop.
    task_tracking_rms: F(f64),
    /// RMS of (true load cell − desired) where the damper can follow, N (flight runs).
    follow_rms_n: F(f64),
    /// Largest |pilot force at the grip|, N.
    grip_force_peak_n: F(f64),
    /// The largest grip force held over the prolonged window, N.
    grip_force_prolonged_n: F(f64),
    /// Largest |aircraft stick force| asked for at the grip, N.
    stick_force_peak_n: F(f64),
    /// Largest coil current command, A.
    current_max_a: F(f64),
    /// Largest |force through the load cell|, N (the true force, not the clipped reading).
    load_cell_peak_n: F(f64),
    /// Stick deflection per g of the aircraft's steady pull-up (1 g to `nz`: 2 g, or less near the stall),
    /// rad.
    stick_per_g_rad: F(f64),
    /// Stick force per g the feel system holds in that steady pull-up, N/g (breakout excluded): the
    /// MIL-F-8785C quantity, from the feel system's design (`sweep::steady`).
    stick_force_per_g_n: F(f64),
    /// The same deflection per g times the force–deflection gradient the feel rendered in the run (the
    /// outward samples' least-squares line), N/g.
    stick_force_per_g_rendered_n: F(f64),
    /// Span of the load factor flown, g.
    nz_span_g: F(f64),
    /// The felt pull force per g over the load factor flown (least squares over the task, a dynamic figure, not the verdict's), N/g.
    stick_force_per_g_flown_n: F(f64),
    /// Acceleration sensitivity at trim, g/rad.
    n_per_alpha_g_per_rad: F(f64),
    /// Largest |felt − aircraft stick force| as a ratio of the Part 60 tolerance.
    part60_force_ratio: F(f64),
    /// Breakout the pilot felt (the intercept at centre of the force–deflection line rendered moving out), N at the grip.
    breakout_n: F(f64),
    /// Breakout of the feel target (the aircraft's feel unit, or the law's), N at the grip.
    breakout_ref_n: F(f64),
    /// 14 CFR 23.143 / 25.143: peak within the temporary limit.
    far_temporary_ok: B(bool),
    /// 14 CFR 23.143 / 25.143: prolonged force within the prolonged limit.
    far_prolonged_ok: B(bool),
    /// MIL-F-8785C Table V Level of the stick force per g (4: outside Level 3): of the steady pull-up's, or
    /// for a fly-by-wire aircraft of the force per g flown.
    per_g_level: U(u8),
    /// 14 CFR Part 60 force tolerance met throughout.
    part60_force_ok: B(bool),
    /// 14 CFR Part 60 breakout tolerance (±2 lbf of the target's breakout) met.
    part60_breakout_ok: B(bool),
    /// The force through the load cell stayed within its rated range (`load_cell.range_n`) all run.
    load_cell_ok: B(bool),
    /// Why the run stopped, if it did (its figures are then empty).
    error: S(String),
}

/// A load-factor span below this gives no flown stick force per g (the slope would be noise), g.
const MIN_NZ_SPAN_G: f64 = 0.2;

fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}

impl Outcome {
    /// A run that stopped with `msg`: no figures.
    pub fn failed(msg: String) -> Self {
        Self {
            error: Some(msg),
            ..Self::default()
        }
    }

    /// The figures and verdicts of a finished run of `scn`.
    pub fn of(res: &Results, scn: &Scenario, prolonged_window_s: f64) -> Self {
        let s = res.summary();
        let flight = crate::sim::metrics::FlightMetrics::of(res, scn);
        let t: Vec<f64> = res.rows.iter().map(|r| r.t_s).collect();
        let grip: Vec<f64> = res.rows.iter().map(|r| r.pilot_force_n).collect();
        let peak = grip.iter().fold(0.0_f64, |m, f| m.max(f.abs()));
        let prolonged = hq::prolonged_force_n(&t, &grip, prolonged_window_s);
        let name = scn
            .aircraft
            .as_ref()
            .map(|a| a.model.strip_prefix("jsbsim:").unwrap_or(&a.model));
        let model = name.and_then(|n| AircraftModel::load_builtin(n).ok());
        // A fly-by-wire aircraft: its stick's design and, where its file has one, its embedded model.
        let fbw = match (&model, name.and_then(|n| AircraftModel::builtin(n).ok())) {
            (None, Some(path)) => FlyByWireFile::read(&path)
                .ok()
                .and_then(|f| Some((f.stick().ok()?, f.model().ok().flatten()))),
            _ => None,
        };
        let basis = match (&model, &fbw) {
            (Some(m), _) => CertificationBasis::for_model(m),
            // MIL-F-8785C, Class IV: the designed feel's basis (`aero::fbw`).
            (None, Some(_)) => CertificationBasis::new(CertificationPart::MilF8785C, ControlType::Stick, 0.0),
            // The rig alone: a stick under Part 23 (the paper's light-aircraft stick).
            (None, None) => CertificationBasis::new(CertificationPart::Part23, ControlType::Stick, 0.0),
        };
        let (temporary, prolonged_limit) = hq::force_limits(&basis);
        let lever = Lever {
            grip_arm_m: res.grip_arm_m,
            gearing_m_per_rad: res.gearing_at_centre_m_per_rad,
            mr_ceiling_n: res.feel_ceiling_n,
        };
        let to_grip = lever.gearing_m_per_rad / lever.grip_arm_m;
        let theta: Vec<f64> = res.rows.iter().map(|r| r.stick_angle_rad).collect();
        let rate: Vec<f64> = res.rows.iter().map(|r| r.stick_rate_rad_s).collect();
        let line = hq::force_line(
            &theta,
            &rate,
            &grip,
            scn.controller.rest_speed_m_s / lever.gearing_m_per_rad,
        );
        let breakout_ref = match (&scn.feel, &model, &fbw) {
            (FeelLaw::Target { .. }, Some(m), _) => {
                Some(m.hinge.feel_computer.map_or(0.0, |fc| fc.breakout_n))
            }
            // a fly-by-wire stick's designed law (`aero::fbw`)
            (FeelLaw::Target { .. }, None, Some((stick, _))) => Some(stick.breakout_n),
            (FeelLaw::Spring { breakout_n, .. }, ..) => Some(breakout_n * to_grip),
            _ => None,
        };
        let breakout = line.and_then(|l| finite(l.breakout_n));
        let mut o = Outcome {
            force_tracking_rmse_n: s.tracking_rmse_n.and_then(finite),
            force_tracking_nrmse: s.tracking_nrmse.and_then(finite),
            task_tracking_rms: flight.and_then(|f| finite(f.tracking_rms)),
            follow_rms_n: flight.and_then(|f| finite(f.follow_rms_n)),
            grip_force_peak_n: finite(peak),
            grip_force_prolonged_n: prolonged,
            stick_force_peak_n: flight.and_then(|f| finite(f.stick_force_peak_n)),
            current_max_a: finite(s.current_max_a),
            load_cell_peak_n: finite(
                res.rows
                    .iter()
                    .fold(0.0_f64, |m, r| m.max(r.load_cell_true_n.abs())),
            ),
            load_cell_ok: Some(
                res.rows
                    .iter()
                    .all(|r| r.load_cell_true_n.abs() <= scn.sensors.load_cell.range_n),
            ),
            far_temporary_ok: Some(peak <= temporary),
            far_prolonged_ok: prolonged.map(|p| p <= prolonged_limit),
            breakout_n: breakout,
            breakout_ref_n: breakout_ref,
            part60_breakout_ok: breakout
                .zip(breakout_ref)
                .map(|(b, r)| (b - r).abs() <= hq::PART60_BREAKOUT_TOLERANCE_N),
            ..Self::default()
        };
        if let (Some(m), Some(a)) = (&model, &scn.aircraft) {
            let ac = Aircraft::new(std::sync::Arc::new(m.clone()));
            if let Ok(st) = steady_per_g(
                &scn.feel_system,
                &scn.feel,
                &lever,
                &ac,
                a.airspeed_m_s,
                a.altitude_m,
            ) {
                o.stick_per_g_rad = finite(st.stick_per_g_rad);
                o.stick_force_per_g_n = finite(st.per_g_n);
                o.stick_force_per_g_rendered_n =
                    line.and_then(|l| finite(l.gradient_n_per_rad * st.stick_per_g_rad.abs()));
            }
        }
        let aero: Vec<(f64, crate::sim::AeroRow)> = res
            .rows
            .iter()
            .filter_map(|r| r.aero.map(|a| (r.pilot_force_n, a)))
            .collect();
        // The limit load factor, and whether the aircraft is fly-by-wire.
        let verdict_of = model
            .as_ref()
            .map(|m| (m.limit_load_factor, false))
            .or(fbw.as_ref().map(|(f, _)| (f.limit_load_factor, true)));
        if let (Some((n_limit, fly_by_wire)), Some(first)) = (verdict_of, aero.first()) {
            // The felt force's sign as the aircraft's (pull +): the pilot's force on the grip follows it.
            let dot: f64 = aero.iter().map(|(f, a)| f * a.stick_force_n).sum();
            let sign = if dot < 0.0 { -1.0 } else { 1.0 };
            let felt: Vec<f64> = aero.iter().map(|(f, _)| sign * f).collect();
            let target: Vec<f64> = aero.iter().map(|(_, a)| a.stick_force_n).collect();
            let nz_lo = aero.iter().map(|(_, a)| a.nz_g).fold(f64::INFINITY, f64::min);
            let nz_hi = aero.iter().map(|(_, a)| a.nz_g).fold(f64::NEG_INFINITY, f64::max);
            o.nz_span_g = finite(nz_hi - nz_lo);
            // n/α at the trim's angle of attack from the model's lift table; a fly-by-wire aircraft without
            // an embedded model: its design condition's.
            let (alpha, qbar) = (first.1.alpha_rad, first.1.qbar_pa);
            let n_alpha = match (&model, &fbw) {
                (Some(m), _) => m.n_per_alpha_g_per_rad(alpha, qbar),
                (None, Some((_, Some(e)))) => e.n_per_alpha_g_per_rad(alpha, first.1.elevator_rad, qbar),
                (None, Some((f, None))) => f.n_alpha_per_rad,
                (None, None) => f64::NAN,
            };
            o.n_per_alpha_g_per_rad = finite(n_alpha);
            if nz_hi - nz_lo >= MIN_NZ_SPAN_G {
                let per_g = crate::signal::slope(aero.iter().zip(&felt).map(|((_, a), f)| (a.nz_g, *f)));
                o.stick_force_per_g_flown_n = finite(per_g);
            }
            // The verdict's force per g: the feel's steady pull-up, or for a fly-by-wire aircraft (no steady
            // hinge moment to hold; its FCS sets the load factor a force gives) the force per g flown.
            let per_g = if fly_by_wire {
                o.stick_force_per_g_flown_n
            } else {
                o.stick_force_per_g_n
            };
            if let (Some(g), Some(na)) = (per_g, o.n_per_alpha_g_per_rad) {
                let bounds = centre_stick_per_g_bounds(n_limit, na);
                o.per_g_level = Some(hq::per_g_level(g, &bounds));
            }
            o.part60_force_ratio = hq::part60_force_ratio(&felt, &target).and_then(finite);
            o.part60_force_ok = o.part60_force_ratio.map(|r| r <= 1.0);
        }
        o
    }

    /// The stick force per g that `per_g_level` judges, N/g: the steady pull-up's, or for a fly-by-wire
    /// aircraft the force per g flown.
    pub fn per_g_judged_n(&self) -> Option<f64> {
        self.per_g_level
            .and(self.stick_force_per_g_n.or(self.stick_force_per_g_flown_n))
    }
}
