//! A fly-by-wire aircraft flown without Python: tabulated longitudinal aerodynamics and the pitch channel
//! of its flight control system, as JSBSim's package writes them (the F-16's `f16.xml`), on the 3-DOF
//! equations of [`super::longitudinal`].
//!
//! Aerodynamics (coefficients on wing area and chord; `δ` the horizontal tail, `λ` the leading-edge flap,
//! `q̂ = q c / 2V`):
//!
//! ```text
//! CL = CL(α, δ) + CL_λ(α) λ + CL_q(α) q̂
//! CD = CD(α, δ) + CD_λ(α) λ + (CD_q(α) + CD_qλ(α) λ) q̂ + CD(M)
//! Cm = Cm(α, δ) + Cm_αM(M) α + Cm_q(α) q̂
//! ```
//!
//! The flap follows its schedule in steps of `α` (then Mach) without a lag, as JSBSim's switch does.
//! Pitch FCS, once per frame, `c` the stick's command (JSBSim's sign: + push), on sensor values one frame
//! old (a computational delay of one frame: JSBSim runs its FCS before it updates α, q and the
//! accelerations of the frame):
//!
//! ```text
//! s = clip(c + c_trim, c_min, c_max) G(α)                 scheduled command
//! e = s + K_q q − K_n (n_p − cos θ)                       n_p: the pilot station's z specific force, g
//! u = clip(s + K_α α + clip(K_p e, ±1), ±1)               surface command, normalised
//! δ = δ_max · rate_limited(u)                             full travel 2 in `T_full` s
//! ```
//!
//! `n_p = −n_z − (q̇ r_x + q² r_z)/g` with `(r_x, r_z)` the pilot's station from the centre of gravity in
//! body axes (JSBSim's `accelerations/n-pilot-z-norm`). The F-16's PID has an integral gain, but its
//! trigger holds the integrator at zero whenever the aircraft flies (above 5 kt), so the loop is
//! proportional. Trim: the airframe's steady state, then the trim command that makes `u` equal the trim
//! surface with `q = 0`.

use nalgebra::{Complex, SMatrix, SVector, Vector3};

use super::atmosphere::{isa, RHO0_KG_M3};
use super::longitudinal::{
    airspeed_and_alpha, lift_slope, n_per_alpha, newton3, rk4, Airframe, Eval, Loads, X,
};
use super::table::{Table1, Table2};
use super::{AeroError, AircraftState};
use crate::pilot::attitude::PilotLoop;
use crate::units::G0_M_S2;

/// Tabulated longitudinal aerodynamics (the module header's build-up).
#[derive(Debug, Clone, PartialEq)]
pub struct TableAero {
    /// CL(α, δ).
    pub cl: Table2,
    /// CD(α, δ).
    pub cd: Table2,
    /// Cm(α, δ).
    pub cm: Table2,
    /// CL per radian of leading-edge flap, by α.
    pub cl_lef: Table1,
    /// CD per radian of leading-edge flap, by α.
    pub cd_lef: Table1,
    /// CL per unit `q c / 2V`, by α.
    pub cl_q: Table1,
    /// CD per unit `q c / 2V`, by α.
    pub cd_q: Table1,
    /// CD per unit `q c / 2V` per radian of flap, by α.
    pub cd_q_lef: Table1,
    /// Cm per unit `q c / 2V`, by α.
    pub cm_q: Table1,
    /// CD increment by Mach.
    pub cd_mach: Table1,
    /// Cm per radian of α, by Mach.
    pub cm_alpha_mach: Table1,
    /// Flap steps: above each α (rad), the flap angle (rad); the highest step exceeded wins.
    pub lef_alpha_steps: Vec<(f64, f64)>,
    /// Below every α step: above this Mach, this flap angle (rad).
    pub lef_above_mach: Option<(f64, f64)>,
}

impl TableAero {
    /// The leading-edge flap's angle at `alpha` and `mach`, rad.
    pub fn lef_rad(&self, alpha: f64, mach: f64) -> f64 {
        let step = self.lef_alpha_steps.iter().rev().find(|(a, _)| alpha > *a);
        match (step, self.lef_above_mach) {
            (Some(&(_, lef)), _) => lef,
            (None, Some((m, lef))) if mach > m => lef,
            _ => 0.0,
        }
    }
}

/// The pitch channel of the FCS (the module header's law).
#[derive(Debug, Clone, PartialEq)]
pub struct PitchFcs {
    /// Limits of the stick command plus trim, `[c_min, c_max]`.
    pub command_limits: (f64, f64),
    /// `G(α)`: the command's gain by angle of attack (rad).
    pub alpha_gain: Table1,
    /// `K_α`, per rad.
    pub alpha_limiter_per_rad: f64,
    /// `K_q`, s.
    pub pitch_rate_gain_s: f64,
    /// `K_n`, per g.
    pub load_factor_gain_per_g: f64,
    /// `K_p`.
    pub proportional_gain: f64,
    /// `T_full`: time for the surface to travel from one stop to the other, s.
    pub full_travel_s: f64,
    /// `δ_max`: the surface's stop, rad (symmetric).
    pub elevator_max_rad: f64,
}

/// A fly-by-wire aircraft's embedded model (`models/aircraft/<name>.toml` with `[airframe]`,
/// `[aero_tables]` and `[fcs]` beside its `[fly_by_wire]` stick).
#[derive(Debug, Clone, PartialEq)]
pub struct FbwModel {
    /// The aircraft's name.
    pub name: String,
    /// Wing reference area, m².
    pub wing_area_m2: f64,
    /// Mean aerodynamic chord, m.
    pub chord_m: f64,
    /// Mass, inertia and load points.
    pub(crate) airframe: Airframe,
    /// The pilot's station in the structural frame (x aft, z up): x, z, m.
    pub pilot_station_m: (f64, f64),
    /// Thrust at full throttle at sea level, N (`T = throttle T_max σ^k`).
    pub max_thrust_n: f64,
    /// `k` in the thrust's density lapse.
    pub density_exponent: f64,
    /// The aerodynamic tables.
    pub aero: TableAero,
    /// The pitch FCS.
    pub fcs: PitchFcs,
}

impl FbwModel {
    fn eval(&self, x: &X, elevator_rad: f64, lef_rad: f64, throttle: f64) -> Eval {
        let a = &self.aero;
        let [u, w, q, _, h] = *x;
        let (v, alpha) = airspeed_and_alpha(x);
        let air = isa(h);
        let qbar = 0.5 * air.density_kg_m3 * v * v;
        let mach = v / air.speed_of_sound_m_s;
        let qhat = q * self.chord_m / (2.0 * v);
        let cl = a.cl.eval(alpha, elevator_rad) + a.cl_lef.eval(alpha) * lef_rad + a.cl_q.eval(alpha) * qhat;
        let cd = a.cd.eval(alpha, elevator_rad)
            + a.cd_lef.eval(alpha) * lef_rad
            + (a.cd_q.eval(alpha) + a.cd_q_lef.eval(alpha) * lef_rad) * qhat
            + a.cd_mach.eval(mach);
        let cm =
            a.cm.eval(alpha, elevator_rad) + a.cm_alpha_mach.eval(mach) * alpha + a.cm_q.eval(alpha) * qhat;
        let sigma = air.density_kg_m3 / RHO0_KG_M3;
        let thrust = throttle * self.max_thrust_n * sigma.powf(self.density_exponent);
        let s = self.wing_area_m2;
        let loads = Loads {
            lift_n: qbar * s * cl,
            drag_n: qbar * s * cd,
            moment_nm: qbar * s * self.chord_m * cm,
            thrust_n: thrust,
        };
        let (dx, nz) = self.airframe.derivatives(x, alpha, &loads);
        Eval {
            dx,
            alpha,
            alphadot: (u * dx[1] - w * dx[0]) / (v * v),
            airspeed: v,
            qbar,
            qbar_e: qbar,
            mach,
            nz,
            thrust,
        }
    }

    /// Acceleration sensitivity `n/α = q̄ S C_Lα / W` at angle of attack `alpha` and tail `elevator_rad`,
    /// g/rad (`C_Lα` the lift table's slope there, over ±0.01 rad).
    pub fn n_per_alpha_g_per_rad(&self, alpha: f64, elevator_rad: f64, qbar_pa: f64) -> f64 {
        let cl_alpha = lift_slope(|a| self.aero.cl.eval(a, elevator_rad), alpha);
        n_per_alpha(qbar_pa, self.wing_area_m2, cl_alpha, self.airframe.mass_kg)
    }

    /// The pilot station's normal specific force, g (z body down: about −1 in level flight).
    fn pilot_nz(&self, x: &X, e: &Eval) -> f64 {
        let f = &self.airframe;
        let (rx, rz) = (
            -(self.pilot_station_m.0 - f.cg_x_m),
            -(self.pilot_station_m.1 - f.cg_z_m),
        );
        let (q, qdot) = (x[2], e.dx[2]);
        -e.nz - (qdot * rx + q * q * rz) / G0_M_S2
    }
}

/// A fly-by-wire aircraft flying its embedded model under its FCS.
#[derive(Debug, Clone)]
pub struct FbwAircraft {
    model: FbwModel,
    x: X,
    t_s: f64,
    throttle: f64,
    trim_command: f64,
    /// The FCS's normalised surface position after its rate limit.
    surface: f64,
    /// What the FCS senses (α, q, pilot's `n_p`), one frame old.
    sensed: Sensed,
    /// The sensors at the present state ([`Self::refresh`]): what the next frame's FCS reads a frame later.
    now: Sensed,
    state: AircraftState,
}

/// The FCS's sensor values: angle of attack, rad; pitch rate, rad/s; the pilot station's specific force, g.
#[derive(Debug, Clone, Copy, Default)]
struct Sensed {
    alpha: f64,
    q: f64,
    pilot_nz: f64,
}

impl FbwAircraft {
    /// The aircraft of `model`, not trimmed.
    pub fn new(model: FbwModel) -> Self {
        Self {
            model,
            x: [100.0, 0.0, 0.0, 0.0, 1000.0],
            t_s: 0.0,
            throttle: 0.0,
            trim_command: 0.0,
            surface: 0.0,
            sensed: Sensed::default(),
            now: Sensed::default(),
            state: AircraftState::default(),
        }
    }

    /// The model.
    pub fn model(&self) -> &FbwModel {
        &self.model
    }

    /// The state after the last step.
    pub fn state(&self) -> &AircraftState {
        &self.state
    }

    fn elevator_rad(&self) -> f64 {
        self.surface * self.model.fcs.elevator_max_rad
    }

    fn lef_rad(&self) -> f64 {
        let (v, alpha) = airspeed_and_alpha(&self.x);
        self.model
            .aero
            .lef_rad(alpha, v / isa(self.x[4]).speed_of_sound_m_s)
    }

    fn refresh(&mut self) {
        let e = self
            .model
            .eval(&self.x, self.elevator_rad(), self.lef_rad(), self.throttle);
        self.now = Sensed {
            alpha: e.alpha,
            q: self.x[2],
            pilot_nz: self.model.pilot_nz(&self.x, &e),
        };
        self.state = AircraftState::at(self.t_s, &self.x, &e, self.elevator_rad(), self.throttle);
    }

    /// Trim in wings-level, unaccelerated level flight at a true airspeed and altitude: the airframe's
    /// angle of attack, surface and throttle, then the FCS's trim command that holds that surface.
    /// Time restarts at 0.
    pub fn trim(&mut self, airspeed_m_s: f64, altitude_m: f64) -> Result<AircraftState, AeroError> {
        let m = &self.model;
        let fail = |why: String| AeroError::Trim {
            aircraft: m.name.clone(),
            airspeed_m_s,
            altitude_m,
            nz_g: 1.0,
            why,
        };
        if !(airspeed_m_s.is_finite() && airspeed_m_s > 1.0 && altitude_m.is_finite()) {
            return Err(fail("airspeed must exceed 1 m/s and all inputs be finite".into()));
        }
        let state = |p: &Vector3<f64>| -> X {
            let alpha = p[0];
            [
                airspeed_m_s * alpha.cos(),
                airspeed_m_s * alpha.sin(),
                0.0,
                alpha,
                altitude_m,
            ]
        };
        let mach = airspeed_m_s / isa(altitude_m).speed_of_sound_m_s;
        let residual = |p: &Vector3<f64>| -> Vector3<f64> {
            let x = state(p);
            let lef = m.aero.lef_rad(p[0], mach);
            let e = m.eval(&x, p[1], lef, p[2]);
            Vector3::new(e.dx[0] / G0_M_S2, e.dx[1] / G0_M_S2, e.dx[2])
        };
        let p = newton3(Vector3::new(0.05, 0.0, 0.5), residual).map_err(fail)?;
        let f = &m.fcs;
        if p[1].abs() > f.elevator_max_rad || !(0.0..=1.0).contains(&p[2]) {
            return Err(fail(format!(
                "surface {:.4} rad (stops ±{}) or throttle {:.3} (0 to 1) out of range",
                p[1], f.elevator_max_rad, p[2]
            )));
        }
        self.x = state(&p);
        self.throttle = p[2];
        self.surface = p[1] / f.elevator_max_rad;
        self.t_s = 0.0;
        // the command whose scheduled value s holds the surface: u = s (1 + K_p) + K_α α − K_p K_n (n_p − cos θ)
        let e = m.eval(&self.x, p[1], self.lef_rad(), self.throttle);
        let g_corr = m.pilot_nz(&self.x, &e) - self.x[3].cos();
        let s = (self.surface - f.alpha_limiter_per_rad * p[0]
            + f.proportional_gain * f.load_factor_gain_per_g * g_corr)
            / (1.0 + f.proportional_gain);
        let gain = f.alpha_gain.eval(p[0]);
        let c = s / gain;
        if gain <= 0.0 || c < f.command_limits.0 || c > f.command_limits.1 {
            return Err(fail(format!(
                "the FCS cannot hold the trim surface (trim command {c:.3})"
            )));
        }
        self.trim_command = c;
        self.refresh();
        self.sensed = self.now;
        Ok(self.state)
    }

    /// One frame of `dt_s`: the FCS takes the stick's command `command` (JSBSim's sign, + push, in
    /// [-1, 1]) with its sensors of one frame before and moves the surface, then the airframe flies the
    /// frame with surface, flap and throttle (0–1) held.
    pub fn step(&mut self, command: f64, throttle: f64, dt_s: f64) -> &AircraftState {
        let Sensed { alpha, q, pilot_nz } = std::mem::replace(&mut self.sensed, self.now);
        let m = &self.model;
        let f = &m.fcs;
        let s = (command.clamp(-1.0, 1.0) + self.trim_command).clamp(f.command_limits.0, f.command_limits.1)
            * f.alpha_gain.eval(alpha);
        let err = s + f.pitch_rate_gain_s * q - f.load_factor_gain_per_g * (pilot_nz - self.x[3].cos());
        let u = (s + f.alpha_limiter_per_rad * alpha + (f.proportional_gain * err).clamp(-1.0, 1.0))
            .clamp(-1.0, 1.0);
        let max_move = 2.0 / f.full_travel_s * dt_s;
        self.surface += (u - self.surface).clamp(-max_move, max_move);
        self.throttle = throttle.clamp(0.0, 1.0);
        let (de, lef, thr) = (self.elevator_rad(), self.lef_rad(), self.throttle);
        self.x = rk4(&self.x, dt_s, |x| m.eval(x, de, lef, thr).dx);
        self.t_s += dt_s;
        self.refresh();
        &self.state
    }
}

/// The frame map's state: airframe `[u, w, q, θ, h]`, the surface, and the FCS's sensors of one frame ago.
type Z = [f64; 9];

impl FbwAircraft {
    fn z(&self) -> Z {
        let [u, w, q, th, h] = self.x;
        let s = self.sensed;
        [u, w, q, th, h, self.surface, s.alpha, s.q, s.pilot_nz]
    }

    fn with_z(&self, z: &Z) -> Self {
        let mut a = self.clone();
        a.x = [z[0], z[1], z[2], z[3], z[4]];
        a.surface = z[5];
        a.sensed = Sensed {
            alpha: z[6],
            q: z[7],
            pilot_nz: z[8],
        };
        a.refresh();
        a
    }

    fn output(&self, output: PilotLoop) -> f64 {
        match output {
            PilotLoop::Pitch => self.state.theta_rad,
            PilotLoop::LoadFactor => self.state.nz_g,
        }
    }

    /// The response of `output` (pitch, rad; load factor, g) to the stick's normalised command (pull +)
    /// at `omega_rad_s`, about the present state with the throttle held: the frame map of [`Self::step`]
    /// over `dt_s`, linearised by central differences over its state (airframe, surface, the FCS's
    /// sensors), `Y(jω) = C (e^{jωT} I − A)⁻¹ B` with `T = dt_s`.
    pub fn command_response(&self, output: PilotLoop, omega_rad_s: f64, dt_s: f64) -> Complex<f64> {
        let z0 = self.z();
        let throttle = self.throttle;
        let frame = |z: &Z, pull: f64| -> Z {
            let mut a = self.with_z(z);
            a.step(-pull, throttle, dt_s);
            a.z()
        };
        let h = |v: f64| 1e-6 * v.abs().max(1.0);
        let mut am = SMatrix::<Complex<f64>, 9, 9>::zeros();
        let mut c = SMatrix::<Complex<f64>, 1, 9>::zeros();
        for j in 0..9 {
            let (mut zp, mut zm) = (z0, z0);
            zp[j] += h(z0[j]);
            zm[j] -= h(z0[j]);
            let (fp, fm) = (frame(&zp, 0.0), frame(&zm, 0.0));
            for i in 0..9 {
                am[(i, j)] = Complex::from((fp[i] - fm[i]) / (2.0 * h(z0[j])));
            }
            let d = self.with_z(&zp).output(output) - self.with_z(&zm).output(output);
            c[j] = Complex::from(d / (2.0 * h(z0[j])));
        }
        let du = 1e-4;
        let (fp, fm) = (frame(&z0, du), frame(&z0, -du));
        let b = SVector::<Complex<f64>, 9>::from_fn(|i, _| Complex::from((fp[i] - fm[i]) / (2.0 * du)));
        let zc = Complex::from_polar(1.0, omega_rad_s * dt_s);
        let m = SMatrix::<Complex<f64>, 9, 9>::identity() * zc - am;
        m.lu()
            .solve(&b)
            .map_or(Complex::new(f64::NAN, f64::NAN), |x| (c * x)[0])
    }
}
