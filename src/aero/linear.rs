//! Small-perturbation longitudinal model about a flight state, and the stick-to-output frequency
//! responses the pilot adapts to (McRuer's crossover model, [`crate::pilot::attitude`]).
//!
//! ```text
//! x' = A x + B δe            x = [Δu, Δw, q, Δθ] (body axes; altitude frozen)
//! Δθ  = [0 0 0 1] x
//! Δn_z = C x + D δe          (g)
//! Y_δe(jω) = C (jωI − A)⁻¹ B + D
//! Y_stick(jω) = Y_δe(jω) · dδe/dθ_s,   dδe/dθ_s = −G  (aft stick raises the trailing edge)
//! ```
//!
//! `A`, `B`, `C`, `D` are central finite differences of the nonlinear model's right-hand side and
//! load factor (`Aircraft::derivatives_and_nz`) at the aircraft's present state and controls, so a
//! trimmed aircraft gives the classical linear model about trim. [`simulated_stick_response`]
//! measures the same response on the nonlinear model by a sinusoidal stick (a check of the
//! linearisation at the amplitude the pilot uses).

pub use nalgebra::Complex;
use nalgebra::{Matrix4, RowVector4, Vector4};

use super::longitudinal::Aircraft;
use crate::pilot::attitude::{CrossoverDesign, CrossoverDesignError, CrossoverPilotConfig, PilotLoop};

/// Linear longitudinal model about a flight state (see the module docs).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct LinearLongitudinal {
    /// State matrix over `[Δu, Δw, q, Δθ]`, SI (1/s and m/s² per rad).
    pub a: Matrix4<f64>,
    /// Input column per radian of elevator (positive trailing edge down).
    pub b: Vector4<f64>,
    /// Load factor per unit state, g per (m/s, m/s, rad/s, rad).
    pub c_nz: RowVector4<f64>,
    /// Load factor per radian of elevator (direct lift), g/rad.
    pub d_nz: f64,
    /// `dδe/dθ_s = −G`: elevator radians per stick radian (aft stick positive).
    pub elevator_per_stick: f64,
}

impl LinearLongitudinal {
    /// Linearise `aircraft` about its present state and controls.
    pub fn about(aircraft: &Aircraft) -> Self {
        let (x0, de0) = aircraft.body_state_and_elevator();
        let f = |x: [f64; 4], de: f64| aircraft.derivatives_and_nz(x, de);
        let mut a = Matrix4::zeros();
        let mut c_nz = RowVector4::zeros();
        for j in 0..4 {
            // steps: 1e-5 of a speed (m/s) or 1e-5 rad (rad/s) — small against the state, large
            // against round-off; central differences, so the error is O(h²)
            let h = 1e-5 * x0[j].abs().max(1.0);
            let (mut xp, mut xm) = (x0, x0);
            xp[j] += h;
            xm[j] -= h;
            let ((fp, np), (fm, nm)) = (f(xp, de0), f(xm, de0));
            for i in 0..4 {
                a[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
            }
            c_nz[j] = (np - nm) / (2.0 * h);
        }
        let h = 1e-5;
        let ((fp, np), (fm, nm)) = (f(x0, de0 + h), f(x0, de0 - h));
        let b = Vector4::from_fn(|i, _| (fp[i] - fm[i]) / (2.0 * h));
        Self {
            a,
            b,
            c_nz,
            d_nz: (np - nm) / (2.0 * h),
            elevator_per_stick: -aircraft.hinge().elevator_per_stick_rad_per_rad,
        }
    }

    /// Frequency response from the stick (rad, aft positive) to the output at `omega_rad_s`: the controlled
    /// element `Y_c(jω)` of the pilot's loop, pitch in rad per stick rad, load factor in g per stick rad.
    pub(crate) fn stick_response(&self, output: PilotLoop, omega_rad_s: f64) -> Complex<f64> {
        let jw = Complex::new(0.0, omega_rad_s);
        let m = Matrix4::<Complex<f64>>::identity() * jw - self.a.map(|v| Complex::new(v, 0.0));
        let b = self.b.map(|v| Complex::new(v, 0.0));
        // (jωI − A) is singular only at an eigenvalue on the imaginary axis (neutral mode)
        let Some(x) = m.lu().solve(&b) else {
            return Complex::new(f64::INFINITY, 0.0) * self.elevator_per_stick;
        };
        let per_elevator = match output {
            PilotLoop::Pitch => x[3],
            PilotLoop::LoadFactor => (self.c_nz.map(|v| Complex::new(v, 0.0)) * x)[0] + self.d_nz,
        };
        per_elevator * self.elevator_per_stick
    }
}

/// McRuer's crossover pilot adapted to `aircraft` about its present (trimmed) state for the loop
/// `output`: the controlled element is the linearised stick response behind a first-order lag
/// `1/(stick_lag_s s + 1)` from the pilot's stick command to the stick: the hand's activation lag
/// (0.1 s, `models/pilot-hand.toml`), or the lag measured on the rig (≈ 1 s for the c172p pitch task with
/// the paper's MR brake, docs/explanation/aero.md §4), or 0.
pub fn adapted_pilot(
    aircraft: &Aircraft,
    output: PilotLoop,
    design: &CrossoverDesign,
    stick_lag_s: f64,
) -> Result<CrossoverPilotConfig, CrossoverDesignError> {
    let lin = aircraft.linearise();
    adapted_behind_lag(|w| lin.stick_response(output, w), design, stick_lag_s)
}

/// The crossover pilot for the controlled element `yc` behind the stick's lag `stick_lag_s` (finite, ≥ 0).
fn adapted_behind_lag(
    yc: impl Fn(f64) -> Complex<f64>,
    design: &CrossoverDesign,
    stick_lag_s: f64,
) -> Result<CrossoverPilotConfig, CrossoverDesignError> {
    if !(stick_lag_s.is_finite() && stick_lag_s >= 0.0) {
        return Err(CrossoverDesignError(format!(
            "stick lag {stick_lag_s} s must be finite and >= 0"
        )));
    }
    CrossoverPilotConfig::adapted_with(|w| yc(w) / Complex::new(1.0, w * stick_lag_s), design)
}

/// McRuer's adapted pilot for a fly-by-wire aircraft's embedded model, trimmed: the controlled element is
/// the FCS and airframe from the stick's normalised command, `command_per_output` command per unit of
/// the pilot's output (per newton on the grip for a force task, per radian of stick otherwise), behind the
/// stick's lag.
pub fn adapted_fly_by_wire_pilot(
    aircraft: &super::FbwAircraft,
    output: PilotLoop,
    design: &CrossoverDesign,
    stick_lag_s: f64,
    command_per_output: f64,
    dt_s: f64,
) -> Result<CrossoverPilotConfig, CrossoverDesignError> {
    adapted_behind_lag(
        |w| aircraft.command_response(output, w, dt_s) * command_per_output,
        design,
        stick_lag_s,
    )
}

/// The stick-to-output response (rad/rad or g/rad) of the **nonlinear** aircraft at `omega_rad_s`, measured
/// from its present (trimmed) state with a stick sinusoid of `stick_amplitude_rad` ([`simulated_response`]).
pub fn simulated_stick_response(
    aircraft: &Aircraft,
    output: PilotLoop,
    omega_rad_s: f64,
    stick_amplitude_rad: f64,
    dt_s: f64,
) -> Complex<f64> {
    let mut ac = aircraft.clone();
    let s0 = *ac.state();
    let g = -ac.hinge().elevator_per_stick_rad_per_rad;
    simulated_response(
        |stick| *ac.step(s0.elevator_rad + g * stick, s0.throttle, dt_s),
        &s0,
        output,
        omega_rad_s,
        stick_amplitude_rad,
        dt_s,
    )
}

/// The complex ratio output/input at `omega_rad_s` measured by simulation: `step` flies one step of `dt_s`
/// with the input (relative to trim) held; `s0` is the start. The sinusoid fades in over two periods (raised
/// cosine, so the phugoid is barely excited), then eight periods are fitted by least squares with
/// `a sin ωt + b cos ωt` plus a quadratic trend (what is left of the phugoid).
pub fn simulated_response(
    mut step: impl FnMut(f64) -> super::AircraftState,
    s0: &super::AircraftState,
    output: PilotLoop,
    omega_rad_s: f64,
    amplitude: f64,
    dt_s: f64,
) -> Complex<f64> {
    let period = 2.0 * std::f64::consts::PI / omega_rad_s;
    let (fade, measure) = (2.0 * period, 8.0 * period);
    let n = ((fade + measure) / dt_s).round() as usize;
    let y_of = |s: &super::AircraftState| match output {
        PilotLoop::Pitch => s.theta_rad - s0.theta_rad,
        PilotLoop::LoadFactor => s.nz_g - s0.nz_g,
    };
    // normal equations of the fit y = a sin + b cos + c0 + c1 τ + c2 τ²  (τ from the window's middle)
    let mut ata = nalgebra::SMatrix::<f64, 5, 5>::zeros();
    let mut aty = nalgebra::SVector::<f64, 5>::zeros();
    let t_mid = fade + 0.5 * measure;
    for k in 0..n {
        let t = k as f64 * dt_s;
        // input over the step [t, t + dt]: evaluated at the step's middle
        let tm = t + 0.5 * dt_s;
        let env = if tm < fade {
            0.5 * (1.0 - (std::f64::consts::PI * tm / fade).cos())
        } else {
            1.0
        };
        let s = step(amplitude * env * (omega_rad_s * tm).sin());
        let t1 = t + dt_s;
        if t1 >= fade {
            let tau = (t1 - t_mid) / measure;
            let row = nalgebra::SVector::<f64, 5>::from([
                (omega_rad_s * t1).sin(),
                (omega_rad_s * t1).cos(),
                1.0,
                tau,
                tau * tau,
            ]);
            ata += row * row.transpose();
            aty += row * y_of(&s);
        }
    }
    let coef = ata.lu().solve(&aty).unwrap_or_else(nalgebra::SVector::zeros);
    // y = a sin ωt + b cos ωt = Im[(a + j b) e^{jωt}], input = A Im[e^{jωt}]
    Complex::new(coef[0], coef[1]) / amplitude
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::aero::AircraftModel;

    fn c172p() -> Aircraft {
        let m = AircraftModel::load(&AircraftModel::builtin_path("c172p")).unwrap();
        let mut a = Aircraft::new(Arc::new(m));
        a.trim(50.0, 1000.0).unwrap();
        a
    }

    /// Pitch follows q exactly in the linear model (θ' = q), and a steady pull (aft stick) pitches
    /// the nose up: the short-period band response to aft stick is positive in pitch rate.
    #[test]
    fn linear_model_has_theta_dot_equal_q_and_aft_stick_pitches_up() {
        let lin = c172p().linearise();
        for j in 0..4 {
            let expect = if j == 2 { 1.0 } else { 0.0 };
            assert!((lin.a[(3, j)] - expect).abs() < 1e-6, "{:?}", lin.a);
        }
        // pitch rate per stick rad at 3 rad/s: jω Y_θ; positive real part = in phase with the pull
        let q = lin.stick_response(PilotLoop::Pitch, 3.0) * Complex::new(0.0, 3.0);
        assert!(q.re > 0.0, "{q}");
        let nz = lin.stick_response(PilotLoop::LoadFactor, 1.0);
        assert!(nz.re > 0.0, "aft stick loads the wing: {nz}");
    }

    /// The linearisation against the nonlinear model flown with a small sinusoidal stick: the complex
    /// responses agree within 2 % at the pilot's crossover frequencies.
    #[test]
    fn linear_response_matches_the_nonlinear_model_flown_with_a_sinusoidal_stick() {
        let a = c172p();
        let lin = a.linearise();
        for (output, w) in [
            (PilotLoop::Pitch, 2.5),
            (PilotLoop::LoadFactor, 2.5),
            (PilotLoop::Pitch, 1.0),
        ] {
            let y_lin = lin.stick_response(output, w);
            let y_sim = simulated_stick_response(&a, output, w, 0.002, 1.0 / 240.0);
            let rel = (y_sim - y_lin).norm() / y_lin.norm();
            assert!(
                rel < 0.02,
                "{output:?} at {w} rad/s: linear {y_lin}, simulated {y_sim} ({rel})"
            );
        }
    }
}
