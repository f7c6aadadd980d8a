//! Passive feel springs on the piston joint (N along +x), the alternatives to the MR element on the same
//! rig and linkage, and the feel system a scenario names ([`FeelKind`], [`FeelSystemConfig`]).
//!
//! * [`CentringSpring`]: Hanlon et al. (U.S. Patent 8,056,432): `F = −k x`.
//! * [`VariableGradientSpring`]: Griffith's feel unit (U.S. Patent 4,106,728): a spring through a nonlinear
//!   linkage, stroke `s(x) = x (1 + a x² / (3 x_ref²))`, potential `U = ½ k s²`, `F = −k s s'`.
//! * [`QFeelSpring`]: a q-feel unit, gradient `k0 + kq q̄` scheduled with dynamic pressure.
//!
//! All derive from a potential at a fixed flight condition: they store energy, never inject it.

use crate::device::{Damper, DeviceConfig};
use crate::rig::Rig;

/// A passive feel spring on the piston joint.
pub trait Spring {
    /// Force on the piston along +x, N, at displacement `x_m` from mid-stroke.
    fn force_on_piston_n(&self, x_m: f64) -> f64;
    /// Energy stored at `x_m`, J (`F = −dU/dx`).
    fn stored_energy_j(&self, x_m: f64) -> f64;
    /// Local gradient `−dF/dx`, N/m (the stiffness the pilot feels through the gearing).
    fn gradient_n_per_m(&self, x_m: f64) -> f64 {
        let h = 1e-7;
        -(self.force_on_piston_n(x_m + h) - self.force_on_piston_n(x_m - h)) / (2.0 * h)
    }
}

/// Hanlon et al.'s centring spring: `F = −k x`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentringSpring {
    /// Stiffness at the piston, N/m.
    pub k_n_per_m: f64,
}

impl Spring for CentringSpring {
    fn force_on_piston_n(&self, x_m: f64) -> f64 {
        -self.k_n_per_m * x_m
    }
    fn stored_energy_j(&self, x_m: f64) -> f64 {
        0.5 * self.k_n_per_m * x_m * x_m
    }
}

/// Griffith's variable-gradient spring through a nonlinear linkage.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct VariableGradientSpring {
    /// Spring stiffness, N/m (the gradient at the centre).
    pub k_n_per_m: f64,
    /// Linkage nonlinearity `a`: the ratio `s'` grows from 1 at the centre to `1 + a` at `x_ref_m`.
    pub nonlinearity: f64,
    /// Reference displacement, m (full stroke of the linkage).
    pub x_ref_m: f64,
}

impl VariableGradientSpring {
    /// Spring stroke through the linkage, m.
    pub(crate) fn spring_stroke_m(&self, x_m: f64) -> f64 {
        x_m * (1.0 + self.nonlinearity * x_m * x_m / (3.0 * self.x_ref_m * self.x_ref_m))
    }

    /// Linkage ratio `ds/dx`.
    pub fn ratio(&self, x_m: f64) -> f64 {
        1.0 + self.nonlinearity * (x_m / self.x_ref_m).powi(2)
    }
}

impl Spring for VariableGradientSpring {
    fn force_on_piston_n(&self, x_m: f64) -> f64 {
        -self.k_n_per_m * self.spring_stroke_m(x_m) * self.ratio(x_m)
    }
    fn stored_energy_j(&self, x_m: f64) -> f64 {
        0.5 * self.k_n_per_m * self.spring_stroke_m(x_m).powi(2)
    }
}

/// A q-feel spring: gradient `k0 + kq q̄`, with `q̄` set by the flight condition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct QFeelSpring {
    /// Gradient at zero airspeed, N/m.
    pub k0_n_per_m: f64,
    /// Gradient per pascal of dynamic pressure, N/m/Pa.
    pub kq_n_per_m_per_pa: f64,
    /// Present dynamic pressure, Pa (set from the flight condition).
    pub qbar_pa: f64,
}

impl QFeelSpring {
    /// Schedule the gradient with the dynamic pressure `½ ρ V²`, Pa.
    pub fn set_dynamic_pressure(&mut self, qbar_pa: f64) {
        self.qbar_pa = qbar_pa.max(0.0);
    }

    /// The present gradient, N/m.
    pub fn stiffness_n_per_m(&self) -> f64 {
        self.k0_n_per_m + self.kq_n_per_m_per_pa * self.qbar_pa
    }
}

impl Spring for QFeelSpring {
    fn force_on_piston_n(&self, x_m: f64) -> f64 {
        -self.stiffness_n_per_m() * x_m
    }
    fn stored_energy_j(&self, x_m: f64) -> f64 {
        0.5 * self.stiffness_n_per_m() * x_m * x_m
    }
}

/// The feel systems a scenario can put on the rig, in comparison-table order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Default)]
pub enum FeelKind {
    /// A passive centring spring.
    CentringSpring,
    /// A passive spring whose gradient rises with deflection.
    VariableGradientSpring,
    /// A spring whose force scales with dynamic pressure (q-feel).
    QFeel,
    /// The MR damper alone under the feel loop (the default).
    #[default]
    Mr,
    /// The MR damper with a centring spring on the same joint (the hybrid).
    MrSpring,
    /// A motor-driven stick rendering the law by impedance control: the upper bound on fidelity, and the
    /// one system that can drive the stick (back-drive hazard).
    Active,
}

impl FeelKind {
    /// Every kind, in comparison-table order.
    pub const ALL: [FeelKind; 6] = [
        FeelKind::CentringSpring,
        FeelKind::VariableGradientSpring,
        FeelKind::QFeel,
        FeelKind::Mr,
        FeelKind::MrSpring,
        FeelKind::Active,
    ];

    /// The name in scenario files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            FeelKind::CentringSpring => "centring_spring",
            FeelKind::VariableGradientSpring => "variable_gradient_spring",
            FeelKind::QFeel => "q_feel",
            FeelKind::Mr => "mr",
            FeelKind::MrSpring => "mr_spring",
            FeelKind::Active => "active",
        }
    }

    /// The kind of a name.
    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == s)
    }

    /// Whether the system has the MR damper and its electrical loop.
    pub fn has_coil(self) -> bool {
        matches!(self, FeelKind::Mr | FeelKind::MrSpring)
    }

    /// Whether the system has a driver and sensors a fault can act on (not the spring units).
    pub fn has_electrical_path(self) -> bool {
        self.has_coil() || self == FeelKind::Active
    }

    /// The names, for error messages.
    pub fn names() -> String {
        Self::ALL.map(Self::name).join(", ")
    }
}

/// One of the spring elements, as a value (scenarios are cloned and compared).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SpringElement {
    /// A centring spring.
    Centring(CentringSpring),
    /// A variable-gradient spring.
    VariableGradient(VariableGradientSpring),
    /// A q-feel spring.
    QFeel(QFeelSpring),
}

impl SpringElement {
    fn inner(&self) -> &dyn Spring {
        match self {
            SpringElement::Centring(s) => s,
            SpringElement::VariableGradient(s) => s,
            SpringElement::QFeel(s) => s,
        }
    }

    /// Schedule a q-feel spring with the flight's dynamic pressure (other springs ignore it).
    pub fn set_dynamic_pressure(&mut self, qbar_pa: f64) {
        if let SpringElement::QFeel(q) = self {
            q.set_dynamic_pressure(qbar_pa);
        }
    }
}

impl Spring for SpringElement {
    fn force_on_piston_n(&self, x_m: f64) -> f64 {
        self.inner().force_on_piston_n(x_m)
    }
    fn stored_energy_j(&self, x_m: f64) -> f64 {
        self.inner().stored_energy_j(x_m)
    }
    fn gradient_n_per_m(&self, x_m: f64) -> f64 {
        self.inner().gradient_n_per_m(x_m)
    }
}

/// The feel system of a scenario (`[feel_system]`; the MR damper alone when absent, the default).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FeelSystemConfig {
    /// Which feel system.
    pub kind: FeelKind,
    /// The spring on the piston joint (spring units and the hybrid).
    pub spring: Option<SpringElement>,
    /// A spring unit's (or the active stick's) own viscous damping, N·s/m: it replaces the MR damper.
    pub unit_damping_n_s_per_m: f64,
    /// Hybrid: the virtual viscous damping the MR damper gives at rest and on the way back, N·s/m.
    pub return_damping_n_s_per_m: f64,
    /// Whether a q-feel spring follows the flight's dynamic pressure (with an `[aircraft]`).
    pub q_from_aircraft: bool,
    /// Active stick: the motor's force limit on the piston, N.
    pub motor_max_force_n: f64,
    /// Active stick: its motor, driver, sensor and admittance loop; `None`: an ideal clamped force source.
    pub active_stick: Option<super::active::ActiveStickConfig>,
}

impl FeelSystemConfig {
    /// The passive or MR system `kind` with the springs of a feel-spring file: `qbar_pa` sets the q-feel
    /// spring's dynamic pressure, `hybrid` the hybrid's centring spring.
    pub fn from_springs(
        kind: FeelKind,
        springs: &FeelSprings,
        qbar_pa: f64,
        hybrid: CentringSpring,
        unit_damping_n_s_per_m: f64,
        return_damping_n_s_per_m: f64,
    ) -> Self {
        let spring = match kind {
            FeelKind::CentringSpring => Some(SpringElement::Centring(springs.centring)),
            FeelKind::VariableGradientSpring => {
                Some(SpringElement::VariableGradient(springs.variable_gradient))
            }
            FeelKind::QFeel => {
                let mut q = springs.q_feel;
                q.set_dynamic_pressure(qbar_pa);
                Some(SpringElement::QFeel(q))
            }
            FeelKind::Mr | FeelKind::Active => None,
            FeelKind::MrSpring => Some(SpringElement::Centring(hybrid)),
        };
        Self {
            kind,
            spring,
            unit_damping_n_s_per_m,
            return_damping_n_s_per_m,
            ..Self::default()
        }
    }

    /// The active stick: a motor with force limit `motor_max_force_n` on the piston and the actuator's own
    /// viscous friction (back-EMF, gearbox).
    pub fn active(motor_max_force_n: f64, damping_n_s_per_m: f64) -> Self {
        Self {
            kind: FeelKind::Active,
            unit_damping_n_s_per_m: damping_n_s_per_m,
            motor_max_force_n,
            ..Self::default()
        }
    }

    /// The active stick `stick` models: its force limit and its rotor's friction at the push rod.
    pub fn active_stick(stick: super::active::ActiveStickConfig) -> Self {
        Self {
            active_stick: Some(stick),
            ..Self::active(stick.max_force_n(), stick.rod_damping_n_s_per_m())
        }
    }

    /// The damper this system puts on the rig: the device's MR damper where the system drives its coil,
    /// else the same body with no yield force and the unit's own viscous damping.
    pub fn damper(&self, device: &DeviceConfig) -> Damper {
        if self.kind.has_coil() {
            device.damper()
        } else {
            device.viscous_damper(self.unit_damping_n_s_per_m)
        }
    }
}

/// Put a spring on the rig's piston joint for the next step (call before each [`Rig::step`]).
///
/// The spring goes in as the rig's implicit joint spring, linearised at the present `x`: stiffness
/// `k = −dF/dx(x)`, rest point `x + F(x)/k`. An explicit force held over the step would inject `½ k Δx²`
/// per step; the implicit tangent dissipates as much instead. A non-positive gradient is applied as an
/// explicit force.
pub fn apply(feel: &dyn Spring, rig: &mut Rig) {
    let x = rig.state().piston_x_m;
    let f = feel.force_on_piston_n(x);
    let k = feel.gradient_n_per_m(x);
    if k > 0.0 {
        rig.set_external_spring(k, x + f / k);
        rig.set_external_force_n(0.0);
    } else {
        rig.set_external_spring(0.0, 0.0);
        rig.set_external_force_n(f);
    }
}

/// The three springs of a feel-spring file (`models/feel-springs.toml`, read by
/// `input::springs`).
#[derive(Debug, Clone, PartialEq)]
pub struct FeelSprings {
    /// The centring spring.
    pub centring: CentringSpring,
    /// The variable-gradient spring.
    pub variable_gradient: VariableGradientSpring,
    /// The q-feel spring.
    pub q_feel: QFeelSpring,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn variable_gradient_force_is_minus_the_slope_of_its_energy_and_stiffens_outwards() {
        let s = VariableGradientSpring {
            k_n_per_m: 1000.0,
            nonlinearity: 2.0,
            x_ref_m: 0.045,
        };
        for x in [-0.04, -0.01, 0.0, 0.02, 0.045] {
            let h = 1e-6;
            let dudx = (s.stored_energy_j(x + h) - s.stored_energy_j(x - h)) / (2.0 * h);
            assert!((s.force_on_piston_n(x) + dudx).abs() < 1e-6, "x {x}");
        }
        assert!((s.gradient_n_per_m(0.0) - 1000.0).abs() < 1e-3);
        // Gradient at x_ref: k (s'² + s s''), s' = 1 + a, s'' = 2a/x_ref, s = x_ref (1 + a/3).
        let (a, xr) = (2.0, 0.045);
        let expect = 1000.0 * ((1.0 + a) * (1.0 + a) + xr * (1.0 + a / 3.0) * 2.0 * a / xr);
        assert!((s.gradient_n_per_m(xr) - expect).abs() < 1e-3 * expect);
        assert!(s.gradient_n_per_m(0.03) > s.gradient_n_per_m(0.01));
    }

    #[test]
    fn q_feel_gradient_scales_with_dynamic_pressure() {
        let mut q = QFeelSpring {
            k0_n_per_m: 200.0,
            kq_n_per_m_per_pa: 0.1,
            qbar_pa: 0.0,
        };
        assert!((q.gradient_n_per_m(0.01) - 200.0).abs() < 1e-6);
        q.set_dynamic_pressure(10_000.0); // ~ 130 m/s at sea level: ½·1.225·128²
        assert!((q.gradient_n_per_m(0.01) - 1200.0).abs() < 1e-6);
        q.set_dynamic_pressure(20_000.0);
        assert!((q.gradient_n_per_m(-0.02) - 2200.0).abs() < 1e-6);
    }

    #[test]
    fn feel_file_loads_and_bad_values_name_the_field() {
        let path = crate::builtin::by_file_name("feel-springs.toml").unwrap();
        let f = FeelSprings::load(&path).unwrap();
        assert!(f.centring.k_n_per_m > 0.0);
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.toml");
        let text = crate::input::text::read_text(&path)
            .unwrap()
            .replace("nonlinearity = ", "nonlinearity = -");
        std::fs::write(&bad, text).unwrap();
        let e = FeelSprings::load(&bad).unwrap_err().to_string();
        let line = std::fs::read_to_string(&bad)
            .unwrap()
            .lines()
            .position(|l| l.starts_with("nonlinearity"))
            .unwrap()
            + 1;
        assert!(
            e.contains(&format!(
                "bad.toml:{line}: field `variable_gradient.nonlinearity`"
            )) && e.contains("[0, 100]"),
            "{e}"
        );
    }
}
