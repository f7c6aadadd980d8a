//! Nonlinear 3-DOF longitudinal flight dynamics (surge, heave, pitch) over a flat, non-rotating
//! earth in the ISA troposphere, with JSBSim's coefficient build-up for the bundled aircraft:
//!
//! ```text
//! CL = CL(alpha) + CL_de de + (CL_q q + CL_adot adot) c/(2V)
//! CD = CD0 + CD(alpha) + k CL^2 + CD_de |de| + CD(M)
//! Cm = Cm0 + Cm_alpha alpha + (Cm_q q + Cm_adot adot) c/(2V) + (qbar_e/qbar) Cm_de(M) de
//! ```
//!
//! Lift and drag act at the aerodynamic reference point and thrust along the body x axis at the
//! thruster; both are carried to the centre of gravity. Body axes (x forward, z down):
//!
//! ```text
//! du/dt = (X_a + T)/m - g sin(theta) - q w      dq/dt = M / Iyy
//! dw/dt = Z_a/m + g cos(theta) + q u            dtheta/dt = q
//! dh/dt = u sin(theta) - w cos(theta)           nz = -Z_a / (m g)
//! ```
//!
//! The alpha-dot terms make the right-hand side implicit; it is solved exactly at every
//! evaluation (the forces are affine in alpha-dot). Integration: classical Runge–Kutta 4.

use std::sync::Arc;

use nalgebra::{Matrix3, Vector3};

use super::atmosphere::{isa, RHO0_KG_M3};
use super::hinge::HingeModel;
use super::model::{AircraftModel, Propulsion};
use super::state::AircraftState;
use super::AeroError;
use crate::units::G0_M_S2;

/// Inputs held over one integration step.
#[derive(Debug, Clone, Copy)]
struct Controls {
    elevator_rad: f64,
    throttle: f64,
}

/// State vector `[u, w, q, theta, h]`.
pub(crate) type X = [f64; 5];

/// Mass, pitch inertia and where the loads act, in JSBSim's structural frame (x aft, z up), m.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Airframe {
    pub mass_kg: f64,
    pub iyy_kg_m2: f64,
    pub cg_x_m: f64,
    pub cg_z_m: f64,
    pub aero_ref_x_m: f64,
    pub aero_ref_z_m: f64,
    /// Height of the thrust line (thrust acts along body x).
    pub thrust_z_m: f64,
}

/// The loads of one evaluation: lift and drag (wind axes) at the aerodynamic reference point, the
/// aerodynamic pitching moment about that point, and thrust along body x.
pub(crate) struct Loads {
    pub lift_n: f64,
    pub drag_n: f64,
    pub moment_nm: f64,
    pub thrust_n: f64,
}

impl Airframe {
    /// Derivatives of `[u, w, q, theta, h]` at `x` (angle of attack `alpha`) under `loads`, and the normal
    /// load factor: the equations of the module header, with lift and drag carried from the reference
    /// point to the centre of gravity.
    pub(crate) fn derivatives(&self, x: &X, alpha: f64, loads: &Loads) -> (X, f64) {
        let [u, w, q, theta, _] = *x;
        let (sa, ca) = alpha.sin_cos();
        let xa = -loads.drag_n * ca + loads.lift_n * sa;
        let za = -loads.drag_n * sa - loads.lift_n * ca;
        // arms from the CG in body axes: the structural frame is x aft, z up
        let (rx_a, rz_a) = (
            -(self.aero_ref_x_m - self.cg_x_m),
            -(self.aero_ref_z_m - self.cg_z_m),
        );
        // thrust along body x: only the thruster's vertical offset from the CG makes a moment
        let rz_t = -(self.thrust_z_m - self.cg_z_m);
        let moment = loads.moment_nm + (rz_a * xa - rx_a * za) + rz_t * loads.thrust_n;
        let (st, ct) = theta.sin_cos();
        let g = G0_M_S2;
        let du = (xa + loads.thrust_n) / self.mass_kg - g * st - q * w;
        let dw = za / self.mass_kg + g * ct + q * u;
        let dq = moment / self.iyy_kg_m2;
        let dh = u * st - w * ct;
        ([du, dw, dq, q, dh], -za / (self.mass_kg * g))
    }
}

/// Airspeed, m/s (at least 1 mm/s), and angle of attack, rad, of the body velocity `(u, w)` of `x`.
pub(crate) fn airspeed_and_alpha(x: &X) -> (f64, f64) {
    let [u, w, ..] = *x;
    ((u * u + w * w).sqrt().max(1e-3), w.atan2(u))
}

/// Acceleration sensitivity `n/α = q̄ S C_Lα / W`, g/rad, for the lift-curve slope `cl_alpha_per_rad`.
pub(crate) fn n_per_alpha(qbar_pa: f64, wing_area_m2: f64, cl_alpha_per_rad: f64, mass_kg: f64) -> f64 {
    qbar_pa * wing_area_m2 * cl_alpha_per_rad / (mass_kg * G0_M_S2)
}

/// The slope of `cl` at `alpha` by central differences over ±0.01 rad, per rad.
pub(crate) fn lift_slope(cl: impl Fn(f64) -> f64, alpha: f64) -> f64 {
    let d = 0.01;
    (cl(alpha + d) - cl(alpha - d)) / (2.0 * d)
}

/// One classical Runge–Kutta 4 step of `dx/dt = f(x)` over `dt_s`.
pub(crate) fn rk4(x: &X, dt_s: f64, f: impl Fn(&X) -> X) -> X {
    let add = |k: &X, h: f64| -> X { std::array::from_fn(|i| x[i] + h * k[i]) };
    let k1 = f(x);
    let k2 = f(&add(&k1, 0.5 * dt_s));
    let k3 = f(&add(&k2, 0.5 * dt_s));
    let k4 = f(&add(&k3, dt_s));
    std::array::from_fn(|i| x[i] + dt_s / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]))
}

/// What one evaluation of a model's right-hand side gives besides the derivatives `dx`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Eval {
    pub dx: X,
    pub alpha: f64,
    pub alphadot: f64,
    pub airspeed: f64,
    pub qbar: f64,
    /// Dynamic pressure at the elevator, Pa.
    pub qbar_e: f64,
    pub mach: f64,
    pub nz: f64,
    pub thrust: f64,
}

impl AircraftState {
    /// The state at `x` evaluated as `e` with the elevator and throttle held (no tab, hinge or feel).
    pub(crate) fn at(t_s: f64, x: &X, e: &Eval, elevator_rad: f64, throttle: f64) -> Self {
        let [u_m_s, w_m_s, q_rad_s, theta_rad, altitude_m] = *x;
        Self {
            t_s,
            u_m_s,
            w_m_s,
            q_rad_s,
            theta_rad,
            altitude_m,
            airspeed_m_s: e.airspeed,
            alpha_rad: e.alpha,
            alphadot_rad_s: e.alphadot,
            qbar_pa: e.qbar,
            qbar_elevator_pa: e.qbar_e,
            mach: e.mach,
            nz_g: e.nz,
            elevator_rad,
            throttle,
            thrust_n: e.thrust,
            ..Self::default()
        }
    }
}

/// An aircraft flying its longitudinal model, with its elevator hinge and stick.
#[derive(Debug, Clone)]
pub struct Aircraft {
    model: Arc<AircraftModel>,
    x: X,
    t_s: f64,
    controls: Controls,
    tab_rad: f64,
    feel_trim_rad: f64,
    state: AircraftState,
}

impl Aircraft {
    /// The aircraft of `model`, its state refreshed at the initial condition (not trimmed).
    pub fn new(model: Arc<AircraftModel>) -> Self {
        let mut a = Self {
            model,
            x: [50.0, 0.0, 0.0, 0.0, 1000.0],
            t_s: 0.0,
            controls: Controls {
                elevator_rad: 0.0,
                throttle: 0.0,
            },
            tab_rad: 0.0,
            feel_trim_rad: 0.0,
            state: AircraftState::default(),
        };
        a.refresh();
        a
    }

    /// Load `models/aircraft/<name>.toml` from a path.
    pub fn load(path: &std::path::Path) -> Result<Self, AeroError> {
        Ok(Self::new(Arc::new(AircraftModel::load(path)?)))
    }

    /// The aircraft's model.
    pub fn model(&self) -> &AircraftModel {
        &self.model
    }

    /// The elevator hinge, tail and stick gearing.
    pub fn hinge(&self) -> &HingeModel {
        &self.model.hinge
    }

    /// The state after the last step.
    pub fn state(&self) -> &AircraftState {
        &self.state
    }

    /// Trim in wings-level, unaccelerated level flight at a true airspeed and altitude: solves
    /// alpha, elevator and throttle, sets the trim tab (and the feel computer's column neutral) so
    /// the stick force is zero, and resets time.
    pub fn trim(&mut self, airspeed_m_s: f64, altitude_m: f64) -> Result<AircraftState, AeroError> {
        let (x, c) = self.solve_trim(airspeed_m_s, altitude_m, 1.0, Throttle::Trimmed)?;
        self.x = x;
        self.controls = c;
        self.t_s = 0.0;
        let alpha_t = self
            .model
            .hinge
            .alpha_tail_rad(airspeed_and_alpha(&x).1, x[2], airspeed_m_s);
        self.tab_rad = self
            .model
            .hinge
            .trim_tab_rad(alpha_t, c.elevator_rad)
            .ok_or_else(|| AeroError::Trim {
                aircraft: self.model.name.clone(),
                airspeed_m_s,
                altitude_m,
                nz_g: 1.0,
                why: format!(
                    "the tab cannot zero the stick force (travel [{}, {}] rad)",
                    self.model.hinge.tab_min_rad, self.model.hinge.tab_max_rad
                ),
            })?;
        self.feel_trim_rad = 0.0;
        self.refresh();
        if self.model.hinge.feel_computer.is_some() {
            self.feel_trim_rad = self.model.hinge.feel_trim_rad(c.elevator_rad, self.state.mach);
            self.refresh();
        }
        Ok(self.state)
    }

    /// Advance by `dt_s` with the elevator (rad, positive trailing edge down; held at the stops)
    /// and throttle (0–1) held over the step. Returns the new state.
    pub fn step(&mut self, elevator_rad: f64, throttle: f64, dt_s: f64) -> &AircraftState {
        self.controls = Controls {
            elevator_rad: elevator_rad.clamp(
                self.model.hinge.elevator_min_rad,
                self.model.hinge.elevator_max_rad,
            ),
            throttle: throttle.clamp(0.0, 1.0),
        };
        let c = self.controls;
        self.x = rk4(&self.x, dt_s, |x| self.eval(x, c).dx);
        self.t_s += dt_s;
        self.refresh();
        &self.state
    }

    /// Stick force, N (pull positive), to hold a steady symmetric pull-up at load factor `nz_g`
    /// through the bottom of the manoeuvre at the given speed and altitude, with the tab and throttle
    /// left where the 1-g trim put them (the manoeuvre of 14 CFR 23.155 and stick force per g).
    pub(crate) fn pull_up_stick_force_n(
        &self,
        airspeed_m_s: f64,
        altitude_m: f64,
        nz_g: f64,
    ) -> Result<f64, AeroError> {
        Ok(self.pull_up(airspeed_m_s, altitude_m, nz_g)?[1].stick_force_n)
    }

    /// The 1-g trim and the steady pull-up at `nz_g` from it, tab and throttle left at that trim.
    fn pull_up(
        &self,
        airspeed_m_s: f64,
        altitude_m: f64,
        nz_g: f64,
    ) -> Result<[AircraftState; 2], AeroError> {
        let mut a = self.clone();
        let s1 = a.trim(airspeed_m_s, altitude_m)?;
        (a.x, a.controls) = a.solve_trim(airspeed_m_s, altitude_m, nz_g, Throttle::Held(s1.throttle))?;
        a.refresh();
        Ok([s1, a.state])
    }

    /// The symmetric steady state at a true airspeed, altitude and load factor with the throttle trimmed
    /// too, as JSBSim's own trims (`do_trim(1)`, `do_trim(3)`) solve it: the throttle balances the drag even
    /// beyond the stand-in engine's maximum (JSBSim's engines give more). Tab and feel trim are kept.
    pub fn steady_state(
        &self,
        airspeed_m_s: f64,
        altitude_m: f64,
        nz_g: f64,
    ) -> Result<AircraftState, AeroError> {
        let mut a = self.clone();
        (a.x, a.controls) = a.solve_trim(airspeed_m_s, altitude_m, nz_g, Throttle::Unbounded)?;
        a.refresh();
        Ok(a.state)
    }

    /// Stick displacement per g, rad of stick (aft positive) per g: the secant between the 1-g trim and
    /// a steady pull-up at `nz_g`, "so much column for so much g" (the pursuit pilot's feedforward).
    pub fn stick_per_g_rad(&self, airspeed_m_s: f64, altitude_m: f64, nz_g: f64) -> Result<f64, AeroError> {
        let [s1, s] = self.pull_up(airspeed_m_s, altitude_m, nz_g)?;
        let h = &self.model.hinge;
        Ok(
            (h.stick_from_elevator_rad(s.elevator_rad) - h.stick_from_elevator_rad(s1.elevator_rad))
                / (nz_g - 1.0),
        )
    }

    /// Stick force per g, N/g: the secant between 1 g and `nz_g` of [`Self::pull_up_stick_force_n`].
    pub(crate) fn stick_force_per_g(
        &self,
        airspeed_m_s: f64,
        altitude_m: f64,
        nz_g: f64,
    ) -> Result<f64, AeroError> {
        Ok(self.pull_up_stick_force_n(airspeed_m_s, altitude_m, nz_g)? / (nz_g - 1.0))
    }

    /// Stick force, N (pull positive), to hold level flight at `airspeed_m_s` with the tab left at
    /// its trim for `trim_airspeed_m_s` (static longitudinal stability, 14 CFR 25.173).
    pub fn off_trim_stick_force_n(
        &self,
        trim_airspeed_m_s: f64,
        airspeed_m_s: f64,
        altitude_m: f64,
    ) -> Result<f64, AeroError> {
        let mut a = self.clone();
        a.trim(trim_airspeed_m_s, altitude_m)?;
        let (tab, feel_trim) = (a.tab_rad, a.feel_trim_rad);
        a.trim(airspeed_m_s, altitude_m)?;
        a.tab_rad = tab;
        a.feel_trim_rad = feel_trim;
        a.refresh();
        Ok(a.state.stick_force_n)
    }

    /// Eigenvalues of the longitudinal dynamics linearised about the current state with the
    /// controls held (finite differences over `[u, w, q, theta]`; altitude frozen).
    pub fn linear_modes(&self) -> Vec<(f64, f64)> {
        self.linearise()
            .a
            .complex_eigenvalues()
            .iter()
            .map(|z| (z.re, z.im))
            .collect()
    }

    /// Small-perturbation model about the current state and controls (see [`super::linear`]).
    pub(crate) fn linearise(&self) -> super::linear::LinearLongitudinal {
        super::linear::LinearLongitudinal::about(self)
    }

    /// Time derivatives of `[u, w, q, theta]` and the load factor at body state `x4` (altitude held
    /// at the current one) with the elevator `elevator_rad` and the current throttle. For
    /// linearisation: the elevator is not held at its stops here.
    pub(crate) fn derivatives_and_nz(&self, x4: [f64; 4], elevator_rad: f64) -> ([f64; 4], f64) {
        let x = [x4[0], x4[1], x4[2], x4[3], self.x[4]];
        let c = Controls {
            elevator_rad,
            throttle: self.controls.throttle,
        };
        let e = self.eval(&x, c);
        ([e.dx[0], e.dx[1], e.dx[2], e.dx[3]], e.nz)
    }

    /// Body state `[u, w, q, theta]` and the elevator held over the last step.
    pub(crate) fn body_state_and_elevator(&self) -> ([f64; 4], f64) {
        (
            [self.x[0], self.x[1], self.x[2], self.x[3]],
            self.controls.elevator_rad,
        )
    }

    // ---------------------------------------------------------------------------------------

    fn refresh(&mut self) {
        let (c, e) = (self.controls, self.eval(&self.x, self.controls));
        let s = AircraftState::at(self.t_s, &self.x, &e, c.elevator_rad, c.throttle);
        let (tab_rad, feel_trim_rad) = (self.tab_rad, self.feel_trim_rad);
        self.state = self.model.hinge.fill(AircraftState {
            tab_rad,
            feel_trim_rad,
            ..s
        });
    }

    fn thrust_n(&self, throttle: f64, airspeed: f64, rho: f64) -> f64 {
        let sigma = (rho / RHO0_KG_M3).powf(self.model.density_exponent);
        match self.model.propulsion {
            Propulsion::Propeller {
                max_power_w,
                efficiency,
                min_airspeed_m_s,
                ..
            } => throttle * efficiency * max_power_w * sigma / airspeed.max(min_airspeed_m_s),
            Propulsion::Jet { max_thrust_n } => throttle * max_thrust_n * sigma,
        }
    }

    /// Derivatives and outputs at `x`, with the alpha-dot terms solved.
    fn eval(&self, x: &X, c: Controls) -> Eval {
        // forces are affine in alpha-dot: two evaluations give the fixed point exactly
        // (up to the CL^2 drag term, which the secant handles to second order).
        let g0 = self.eval_with_alphadot(x, c, 0.0);
        let g1 = self.eval_with_alphadot(x, c, g0.alphadot_out);
        let slope = if g0.alphadot_out.abs() > 1e-14 {
            (g1.alphadot_out - g0.alphadot_out) / g0.alphadot_out
        } else {
            0.0
        };
        let ad = if (1.0 - slope).abs() > 1e-6 {
            g0.alphadot_out / (1.0 - slope)
        } else {
            g1.alphadot_out
        };
        self.eval_with_alphadot(x, c, ad).eval
    }

    fn eval_with_alphadot(&self, x: &X, c: Controls, alphadot: f64) -> EvalAd {
        let m = &*self.model;
        let [u, w, q, _, h] = *x;
        let (v, alpha) = airspeed_and_alpha(x);
        let air = isa(h);
        let rho = air.density_kg_m3;
        let qbar = 0.5 * rho * v * v;
        let mach = v / air.speed_of_sound_m_s;
        let ci2vel = m.chord_m / (2.0 * v);
        let de = c.elevator_rad;

        let cl = m.cl_alpha.eval(alpha)
            + m.cl_elevator_per_rad * de
            + (m.cl_q_per_rad * q + m.cl_alphadot_per_rad * alphadot) * ci2vel;
        let cd = m.cd0
            + m.cd_alpha.eval(alpha)
            + m.cd_induced_per_cl2 * cl * cl
            + m.cd_elevator_abs_per_rad * de.abs()
            + m.cd_mach.eval(mach);
        let thrust = self.thrust_n(c.throttle, v, rho);
        let qbar_e = match m.propulsion {
            Propulsion::Propeller { diameter_m, .. } if m.elevator_in_slipstream => {
                slipstream_qbar_pa(u, thrust, rho, diameter_m)
            }
            _ => qbar,
        };
        let cm = m.cm0
            + m.cm_alpha_per_rad * alpha
            + (m.cm_q_per_rad * q + m.cm_alphadot_per_rad * alphadot) * ci2vel;
        let cm_de = m.cm_elevator_per_rad.eval(mach) * de;

        let s = m.wing_area_m2;
        let loads = Loads {
            lift_n: qbar * s * cl,
            drag_n: qbar * s * cd,
            moment_nm: qbar * s * m.chord_m * cm + qbar_e * s * m.chord_m * cm_de,
            thrust_n: thrust,
        };
        let (dx, nz) = m.airframe().derivatives(x, alpha, &loads);
        let [du, dw, ..] = dx;
        let alphadot_out = (u * dw - w * du) / (v * v);
        EvalAd {
            alphadot_out,
            eval: Eval {
                dx,
                alpha,
                alphadot,
                airspeed: v,
                qbar,
                qbar_e,
                mach,
                nz,
                thrust,
            },
        }
    }

    /// Solve a symmetric steady state at airspeed, altitude and load factor (level flight for
    /// `nz_g = 1`; the bottom of a pull-up with `q = g (nz - 1) / V` otherwise). Unknowns: alpha,
    /// elevator and, unless given, throttle (then surge is not balanced: speed is momentarily held).
    fn solve_trim(
        &self,
        airspeed: f64,
        altitude: f64,
        nz_g: f64,
        throttle_mode: Throttle,
    ) -> Result<(X, Controls), AeroError> {
        let throttle = match throttle_mode {
            Throttle::Held(t) => Some(t),
            Throttle::Trimmed | Throttle::Unbounded => None,
        };
        let m = &*self.model;
        let fail = |why: String| AeroError::Trim {
            aircraft: m.name.clone(),
            airspeed_m_s: airspeed,
            altitude_m: altitude,
            nz_g,
            why,
        };
        if !(airspeed.is_finite() && airspeed > 1.0 && altitude.is_finite() && nz_g.is_finite()) {
            return Err(fail("airspeed must exceed 1 m/s and all inputs be finite".into()));
        }
        let q = G0_M_S2 * (nz_g - 1.0) / airspeed;
        let state = |p: &Vector3<f64>| -> (X, Controls) {
            let alpha = p[0];
            let x = [airspeed * alpha.cos(), airspeed * alpha.sin(), q, alpha, altitude];
            let c = Controls {
                elevator_rad: p[1],
                throttle: throttle.unwrap_or(p[2]),
            };
            (x, c)
        };
        let residual = |p: &Vector3<f64>| -> Vector3<f64> {
            let (x, c) = state(p);
            let e = self.eval_with_alphadot(&x, c, 0.0).eval;
            let r_u = if throttle.is_some() {
                p[2]
            } else {
                e.dx[0] / G0_M_S2
            };
            Vector3::new(r_u, e.dx[1] / G0_M_S2, e.dx[2])
        };
        // initial alpha from the lift needed, on the rising part of the lift curve
        let air = isa(altitude);
        let cl_need =
            nz_g * m.mass_kg * G0_M_S2 / (0.5 * air.density_kg_m3 * airspeed * airspeed * m.wing_area_m2);
        let (a_lo, a_hi) = m.cl_alpha.x_range();
        let mut alpha0 = 0.0;
        let mut best = f64::INFINITY;
        let mut a = a_lo;
        while a <= a_hi {
            if m.cl_alpha.slope(a) > 0.0 && (m.cl_alpha.eval(a) - cl_need).abs() < best {
                best = (m.cl_alpha.eval(a) - cl_need).abs();
                alpha0 = a;
            }
            a += 0.002;
        }
        let p0 = Vector3::new(alpha0, 0.0, throttle.map(|_| 0.0).unwrap_or(0.5));
        let p = newton3(p0, residual).map_err(fail)?;
        let (x, c) = state(&p);
        if c.elevator_rad < m.hinge.elevator_min_rad || c.elevator_rad > m.hinge.elevator_max_rad {
            return Err(fail(format!(
                "elevator {:.4} rad is beyond its stops [{}, {}]",
                c.elevator_rad, m.hinge.elevator_min_rad, m.hinge.elevator_max_rad
            )));
        }
        if !matches!(throttle_mode, Throttle::Unbounded) && !(0.0..=1.0).contains(&c.throttle) {
            return Err(fail(format!("throttle {:.3} is outside [0, 1]", c.throttle)));
        }
        if best > 0.05 || m.cl_alpha.slope(p[0]) <= 0.0 {
            return Err(fail(format!("needs CL = {cl_need:.3}: at or beyond the stall")));
        }
        Ok((x, c))
    }
}

/// The root of a trim's three residuals from `p`: Newton's method on a forward-difference Jacobian, each
/// step scaled so that no unknown moves more than 0.1; converged when the residual's norm is below 1e-11.
pub(crate) fn newton3(
    mut p: Vector3<f64>,
    residual: impl Fn(&Vector3<f64>) -> Vector3<f64>,
) -> Result<Vector3<f64>, String> {
    for _ in 0..60 {
        let r = residual(&p);
        if r.norm() < 1e-11 {
            return Ok(p);
        }
        let mut jac = Matrix3::<f64>::zeros();
        for j in 0..3 {
            let mut pp = p;
            let hstep = 1e-7;
            pp[j] += hstep;
            jac.set_column(j, &((residual(&pp) - r) / hstep));
        }
        let dp = jac.lu().solve(&(-r)).ok_or("singular trim Jacobian")?;
        p += dp * (0.1 / dp.amax()).min(1.0);
    }
    Err("no convergence in 60 Newton steps".into())
}

/// Dynamic pressure in a propeller's fully developed slipstream, Pa: momentum theory gives the
/// induced velocity at the disc `v_i = (-u + sqrt(u|u| + 2T/(rho A))) / 2` and the slipstream
/// `u + 2 v_i` (as JSBSim's FGPropeller and the c172p's `qbar-induced-psf`).
pub(crate) fn slipstream_qbar_pa(u_m_s: f64, thrust_n: f64, rho_kg_m3: f64, diameter_m: f64) -> f64 {
    let area = std::f64::consts::PI * diameter_m * diameter_m / 4.0;
    let s = u_m_s * u_m_s.abs() + 2.0 * thrust_n / (rho_kg_m3 * area);
    let vi = if s > 0.0 {
        0.5 * (-u_m_s + s.sqrt())
    } else {
        0.5 * (-u_m_s - (-s).sqrt())
    };
    0.5 * rho_kg_m3 * (u_m_s + 2.0 * vi).powi(2)
}

/// How a steady state treats the throttle.
#[derive(Debug, Clone, Copy)]
enum Throttle {
    /// Held at this value: surge is not balanced (speed momentarily held).
    Held(f64),
    /// Solved to balance surge, within [0, 1].
    Trimmed,
    /// Solved to balance surge, any value (the thrust the drag needs).
    Unbounded,
}

struct EvalAd {
    alphadot_out: f64,
    eval: Eval,
}
