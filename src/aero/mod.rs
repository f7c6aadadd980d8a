//! Aircraft side of the feel system: longitudinal flight dynamics, elevator hinge moments and the
//! stick force they ask of the feel device, checked against the certification force limits.
//!
//! - [`AircraftModel`] (`models/aircraft/<name>.toml`): aerodynamic tables and mass properties read
//!   from JSBSim 1.3.3's bundled aircraft, plus the elevator hinge and stick gearing estimates.
//! - [`Aircraft`]: a nonlinear 3-DOF longitudinal model (surge, heave, pitch) to fly in the
//!   simulation loop without Python: [`Aircraft::trim`], [`Aircraft::step`], [`Aircraft::state`].
//! - [`HingeModel`]: `H = qbar_t S_e c_e (Ch0 + Ch_alpha alpha_t + Ch_delta delta_e + Ch_tab delta_tab)`
//!   and the stick force `F = H * gearing / arm * feedback` (pull = positive aft force).
//! - `certification`: 14 CFR 23/25 control-force limits and where an aircraft sits.
//! - [`FlyByWire`]: a fly-by-wire aircraft's stick: designed feel law and FCS command, flown live in JSBSim
//!   or embedded (`model = "f16"`, `fcs`).
//!
//! Axes: body x forward, z down; pitch rate, pitch angle and angle of attack positive nose-up;
//! elevator positive trailing edge down (JSBSim's convention: positive elevator pitches nose-down).

pub(crate) mod atmosphere;
pub(crate) mod backend;
pub(crate) mod certification;
pub(crate) mod fbw;
pub(crate) mod fcs;
pub(crate) mod hinge;
pub mod hinge_theory;
pub mod jsbsim_bridge;
pub mod linear;
pub(crate) mod longitudinal;
pub mod model;
pub(crate) mod state;
pub(crate) mod table;

pub use certification::{CertificationBasis, FeelAssessment};
pub use fbw::FlyByWire;
pub use fcs::{FbwAircraft, FbwModel};
pub use hinge::HingeModel;
pub use longitudinal::Aircraft;
pub use model::AircraftModel;
pub use state::AircraftState;
pub use table::{Table1, Table2};

/// An aircraft refused: its file, its name, or a flight condition it cannot trim at.
#[derive(Debug, thiserror::Error)]
pub enum AeroError {
    /// A bad aircraft file.
    #[error(transparent)]
    Input(#[from] crate::input::InputError),
    /// No trim at the flight condition.
    #[error("trim failed for {aircraft} at {airspeed_m_s} m/s, {altitude_m} m, {nz_g} g: {why}")]
    Trim {
        /// The aircraft's name.
        aircraft: String,
        /// True airspeed, m/s.
        airspeed_m_s: f64,
        /// Altitude, m.
        altitude_m: f64,
        /// Load factor, g.
        nz_g: f64,
        /// Why the trim failed.
        why: String,
    },
    /// A name, a JSBSim folder or the JSBSim bridge refused (`what`: which, `why`: the reason).
    #[error("{what}: {why}")]
    Refused {
        /// What was refused.
        what: String,
        /// Why.
        why: String,
    },
}
