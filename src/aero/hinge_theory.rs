//! Elevator hinge-moment derivatives from the elevator's geometry, so that no hinge coefficient is
//! typed into a model file.
//!
//! **Section (2-D): thin-aerofoil theory of a hinged flap** (Glauert, *Theoretical relationships for an
//! aerofoil with hinged flap*, ARC R&M 1095, 1927; the same Fourier solution as Glauert, *The Elements of
//! Aerofoil and Airscrew Theory*, ch. VII, and Abbott & von Doenhoff, *Theory of Wing Sections*, §4.3).
//! Chord 1, `x = (1 − cos θ)/2`. A camber-line slope `−δ` from `x_a = (1 − cos θ_a)/2` to the trailing edge
//! (a surface deflected trailing edge down by `δ`) and the angle of attack `α` load the section with
//!
//! ```text
//! Δp/q = 4 A0 (1 + cos θ)/sin θ + 4 Σ An sin nθ,   A0 = α + δ (π − θ_a)/π,   An = 2 δ sin(nθ_a)/(nπ)
//!      = 4 A0 (1 + cos θ)/sin θ + (4δ/π) ln|sin((θ + θ_a)/2) / sin((θ − θ_a)/2)|
//! c_l  = 2π α + 2 (π − θ_a + sin θ_a) δ                                  (flap effectiveness τ = c_l,δ / 2π)
//! ```
//!
//! The hinge moment about the hinge `x_h`, over the moving surface from the balance's leading edge
//! `x_b = x_h − c_b` to the trailing edge, positive trailing edge down, in coefficient form on the chord
//! aft of the hinge `c_e = 1 − x_h`:
//!
//! ```text
//! c_h = −(1/c_e²) ∫_{x_b}^{1} (Δp/q) (x − x_h) dx
//! ```
//!
//! An **overhang (nose) balance** `c_b` moves the surface's leading edge (where its slope starts) ahead of
//! the hinge; the load ahead of the hinge then pushes the trailing edge down and takes hinge moment away
//! (the balance correction of the same theory: the balance's load enters with a negative arm). A horn
//! balance is represented by the overhang of equal area (an estimate, stated in the model files). A
//! **tab** of chord `c_tab` at the trailing edge is a second slope segment; its `c_h` is the elevator's
//! hinge moment per radian of tab. `b1 = ∂c_h/∂α`, `b2 = ∂c_h/∂δ`, `b3 = ∂c_h/∂δ_tab`.
//!
//! **Tail (3-D): lifting-line correction.** The tail's lift slope is Helmbold's
//! `a_t = 2π A / (2 + √(A² + 4))` (DATCOM §4.1.3.2 form for an unswept surface). The sections work at the
//! effective angle that gives their share of the tail's lift, `2π (α_e + τ δ + τ_tab δ_tab) = a_t (α + τ δ +
//! τ_tab δ_tab)`, so
//!
//! ```text
//! C_h,α   = k_v b1 a_t/2π
//! C_h,δ   = k_v (b2 − b1 τ     (1 − a_t/2π))
//! C_h,tab = k_v (b3 − b1 τ_tab (1 − a_t/2π))
//! ```
//!
//! A tab over part of the span contributes in proportion to the span it covers (strip theory).
//! `k_v`, the ratio of measured to inviscid hinge-moment derivatives (boundary-layer thickening over the
//! surface, trailing-edge angle, gap), is an input: thin-aerofoil theory has no boundary layer.
//!
//! Signs: `α`, `δ`, `δ_tab` positive trailing edge down / nose up as in `aero::hinge`; restoring hinge
//! moments are negative.

use std::f64::consts::PI;

/// Geometry of an elevator (or any trailing-edge control) on its tail, as fractions of chords.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlGeometry {
    /// `c_e / c_t`: chord aft of the hinge line over the tail's chord.
    pub chord_ratio: f64,
    /// `c_b / c_e`: overhang balance ahead of the hinge line over the chord aft of it (0: no balance).
    pub balance_ratio: f64,
    /// `c_tab / c_e`: tab chord over the control's chord aft of the hinge (0: no tab).
    pub tab_chord_ratio: f64,
    /// Fraction of the control's span the tab covers (strip theory: its hinge moment scales with it).
    pub tab_span_ratio: f64,
    /// Aspect ratio of the tail, `b_t² / S_t`.
    pub tail_aspect_ratio: f64,
    /// `k_v`: measured over inviscid hinge-moment derivatives.
    pub viscous_factor: f64,
}

/// Section (2-D, inviscid) derivatives of thin-aerofoil theory, per radian.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SectionDerivatives {
    /// `b1 = ∂c_h/∂α`.
    pub b1: f64,
    /// `b2 = ∂c_h/∂δ`.
    pub b2: f64,
    /// `b3 = ∂c_h/∂δ_tab`.
    pub b3: f64,
    /// `τ = c_l,δ / c_l,α`: lift effectiveness of the control (balance included).
    pub tau: f64,
    /// `τ_tab = c_l,δtab / c_l,α`.
    pub tau_tab: f64,
}

/// Tail (3-D) hinge-moment derivatives per radian, with the tail's lift slope they assume.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HingeDerivatives {
    /// Per radian of tail angle of attack.
    pub ch_alpha_per_rad: f64,
    /// Per radian of elevator.
    pub ch_elevator_per_rad: f64,
    /// Per radian of trim tab.
    pub ch_tab_per_rad: f64,
    /// `a_t`, per radian of tail angle of attack.
    pub tail_lift_slope_per_rad: f64,
    /// The 2-D section derivatives they come from.
    pub section: SectionDerivatives,
}

impl ControlGeometry {
    /// Inputs inside the theory's reach; the message names the field.
    pub fn check(&self) -> Result<(), String> {
        let bad = |f: &str, v: f64, lo: &str, hi: &str| Err(format!("{f} = {v} is outside ({lo}, {hi}]"));
        if !(self.chord_ratio > 0.0 && self.chord_ratio <= 1.0) {
            return bad("chord_ratio", self.chord_ratio, "0", "1");
        }
        if !(0.0..=0.6).contains(&self.balance_ratio)
            || self.balance_ratio * self.chord_ratio > 1.0 - self.chord_ratio
        {
            return Err(format!(
                "balance_ratio = {} must lie in [0, 0.6] and end behind the tail's leading edge",
                self.balance_ratio
            ));
        }
        if !(0.0..=0.6).contains(&self.tab_chord_ratio) {
            return Err(format!(
                "tab_chord_ratio = {} is outside [0, 0.6]",
                self.tab_chord_ratio
            ));
        }
        if !(0.0..=1.0).contains(&self.tab_span_ratio) {
            return Err(format!(
                "tab_span_ratio = {} is outside [0, 1]",
                self.tab_span_ratio
            ));
        }
        if !(self.tail_aspect_ratio > 0.5 && self.tail_aspect_ratio <= 20.0) {
            return bad("tail_aspect_ratio", self.tail_aspect_ratio, "0.5", "20");
        }
        if !(self.viscous_factor > 0.0 && self.viscous_factor <= 1.0) {
            return bad("viscous_factor", self.viscous_factor, "0", "1");
        }
        Ok(())
    }

    /// Section derivatives (thin-aerofoil theory, see the module docs).
    pub fn section(&self) -> SectionDerivatives {
        let e = self.chord_ratio;
        let x_h = 1.0 - e;
        let x_b = (x_h - self.balance_ratio * e).max(0.0);
        let x_t = 1.0 - self.tab_chord_ratio * e;
        let theta = |x: f64| (1.0 - 2.0 * x).clamp(-1.0, 1.0).acos();
        let (th_b, th_t) = (theta(x_b), theta(x_t));
        let norm = -1.0 / (e * e);
        let b1 = norm * moment_of_alpha(th_b, x_h);
        let b2 = norm * moment_of_slope(th_b, th_b, x_h);
        let b3 = if self.tab_chord_ratio > 0.0 {
            norm * moment_of_slope(th_t, th_b, x_h)
        } else {
            0.0
        };
        let lift_of_slope = |th: f64| 2.0 * (PI - th + th.sin());
        SectionDerivatives {
            b1,
            b2,
            b3,
            tau: lift_of_slope(th_b) / (2.0 * PI),
            tau_tab: if self.tab_chord_ratio > 0.0 {
                lift_of_slope(th_t) / (2.0 * PI)
            } else {
                0.0
            },
        }
    }

    /// Tail derivatives: the section's, corrected for the tail's aspect ratio (lifting line) and
    /// scaled by the viscous factor.
    pub fn derivatives(&self) -> Result<HingeDerivatives, String> {
        self.check()?;
        let s = self.section();
        let a = self.tail_aspect_ratio;
        let a_t = 2.0 * PI * a / (2.0 + (a * a + 4.0).sqrt());
        let r = a_t / (2.0 * PI);
        let k = self.viscous_factor;
        Ok(HingeDerivatives {
            ch_alpha_per_rad: k * s.b1 * r,
            ch_elevator_per_rad: k * (s.b2 - s.b1 * s.tau * (1.0 - r)),
            ch_tab_per_rad: k * self.tab_span_ratio * (s.b3 - s.b1 * s.tau_tab * (1.0 - r)),
            tail_lift_slope_per_rad: a_t,
            section: s,
        })
    }
}

/// `∫_{θ_b}^{π} (Δp/q per unit α) (x − x_h) dx`: the flat plate's load `4 (1 + cos θ)/sin θ`, with
/// `dx = sin θ dθ / 2` (closed form).
fn moment_of_alpha(th_b: f64, x_h: f64) -> f64 {
    // ∫ 2 (1 + cos θ) ((1 − cos θ)/2 − x_h) dθ = ∫ (sin²θ − 2 x_h − 2 x_h cos θ) dθ
    let d = PI - th_b;
    (d / 2.0 + (2.0 * th_b).sin() / 4.0) - 2.0 * x_h * d + 2.0 * x_h * th_b.sin()
}

/// `∫_{θ_b}^{π} (Δp/q per unit δ) (x − x_h) dx` for a camber slope `−δ` aft of `θ_a`.
fn moment_of_slope(th_a: f64, th_b: f64, x_h: f64) -> f64 {
    let a0 = (PI - th_a) / PI * moment_of_alpha(th_b, x_h);
    // the logarithmic part, integrable at θ = θ_a: split there and cluster the nodes at both ends
    let f = |th: f64| {
        let l = ((0.5 * (th + th_a)).sin() / (0.5 * (th - th_a)).sin()).abs().ln();
        4.0 / PI * l * (0.5 * (1.0 - th.cos()) - x_h) * 0.5 * th.sin()
    };
    let mut log_part = 0.0;
    if th_a > th_b {
        log_part += clustered_simpson(&f, th_b, th_a);
    }
    log_part += clustered_simpson(&f, th_a, PI);
    a0 + log_part
}

/// Simpson's rule on `[a, b]` after `θ = a + (b − a)(3t² − 2t³)`, which puts nodes densely at both ends
/// (where a logarithmic singularity sits) and makes the transformed integrand vanish there.
fn clustered_simpson(f: &dyn Fn(f64) -> f64, a: f64, b: f64) -> f64 {
    const N: usize = 4000;
    if b <= a {
        return 0.0;
    }
    let g = |t: f64| {
        let s = 3.0 * t * t - 2.0 * t * t * t;
        let ds = 6.0 * t * (1.0 - t);
        if ds == 0.0 {
            0.0
        } else {
            f(a + (b - a) * s) * (b - a) * ds
        }
    };
    let h = 1.0 / N as f64;
    let mut sum = g(0.0) + g(1.0);
    for i in 1..N {
        sum += g(i as f64 * h) * if i % 2 == 1 { 4.0 } else { 2.0 };
    }
    sum * h / 3.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{DMatrix, DVector};

    fn geometry(e: f64, balance: f64, tab: f64) -> ControlGeometry {
        ControlGeometry {
            chord_ratio: e,
            balance_ratio: balance,
            tab_chord_ratio: tab,
            tab_span_ratio: 1.0,
            tail_aspect_ratio: 6.0,
            viscous_factor: 1.0,
        }
    }

    /// An independent solution of the same flow: the lumped-vortex (discrete vortex) method, a vortex
    /// at each panel's quarter chord and the flow tangency at its three-quarter chord (Katz & Plotkin,
    /// *Low-Speed Aerodynamics*, §5.4), on `n` equal panels. Returns `(c_l, c_h)` for the camber-line
    /// slope `slope(x)` at `alpha`, the hinge moment taken about `x_h` over `x >= x_b`, on `c_e`.
    fn lumped_vortex(n: usize, alpha: f64, slope: impl Fn(f64) -> f64, x_h: f64, x_b: f64) -> (f64, f64) {
        let dx = 1.0 / n as f64;
        let xv: Vec<f64> = (0..n).map(|j| (j as f64 + 0.25) * dx).collect();
        let xc: Vec<f64> = (0..n).map(|i| (i as f64 + 0.75) * dx).collect();
        // downwash at x_i of a unit vortex (clockwise, lifting) at x_j: -1/(2π (x_i - x_j)); tangency
        // w_i = V (dz/dx - α) with V = 1
        let a = DMatrix::from_fn(n, n, |i, j| -1.0 / (2.0 * PI * (xc[i] - xv[j])));
        let rhs = DVector::from_fn(n, |i, _| slope(xc[i]) - alpha);
        let g = a.lu().solve(&rhs).unwrap();
        let cl = 2.0 * g.sum();
        let e = 1.0 - x_h;
        let ch = -(0..n)
            .filter(|&j| j as f64 * dx >= x_b - 1e-12)
            .map(|j| 2.0 * g[j] * (xv[j] - x_h))
            .sum::<f64>()
            / (e * e);
        (cl, ch)
    }

    #[test]
    fn thin_aerofoil_hinge_derivatives_agree_with_a_discrete_vortex_solution() {
        let n = 400;
        // edges of the flap, balance and tab on panel boundaries (multiples of 1/400)
        for (e, bal, tab) in [
            (0.3, 0.0, 0.0),
            (0.3, 0.2, 0.2),
            (0.45, 0.1, 0.2),
            (0.25, 0.3, 0.3),
        ] {
            let g = geometry(e, bal, tab);
            let s = g.section();
            let x_h = 1.0 - e;
            let x_b = x_h - bal * e;
            let x_t = 1.0 - tab * e;
            let (cl_a, b1) = lumped_vortex(n, 1.0, |_| 0.0, x_h, x_b);
            let (cl_d, b2) = lumped_vortex(n, 0.0, |x| if x > x_b { -1.0 } else { 0.0 }, x_h, x_b);
            let (cl_t, b3) = lumped_vortex(n, 0.0, |x| if x > x_t { -1.0 } else { 0.0 }, x_h, x_b);
            assert!(
                (cl_a / (2.0 * PI) - 1.0).abs() < 1e-3,
                "flat plate lift slope {cl_a}"
            );
            assert!(
                (s.tau - cl_d / cl_a).abs() < 0.01,
                "tau {} vs {}",
                s.tau,
                cl_d / cl_a
            );
            assert!((s.tau_tab - cl_t / cl_a).abs() < 0.01 || tab == 0.0);
            // within `rel` of the discrete vortex solution's value (of at least 0.1)
            let near = |name: &str, got: f64, want: f64, rel: f64| {
                assert!(
                    (got - want).abs() < rel * want.abs().max(0.1),
                    "{name} {got} vs {want}"
                )
            };
            near("b1", s.b1, b1, 0.02);
            near("b2", s.b2, b2, 0.03);
            if tab > 0.0 {
                near("b3", s.b3, b3, 0.02);
            }
        }
    }

    /// Glauert's closed-form flap effectiveness (the textbook `τ = 1 − (θ_h − sin θ_h)/π`) and the
    /// signs of restoring hinge moments; a balance lightens both derivatives.
    #[test]
    fn plain_flap_effectiveness_and_balance_lightening() {
        let s = geometry(0.25, 0.0, 0.0).section();
        // hinge at 75 % chord: θ_h = 120°, τ = 1 − (2π/3 − √3/2)/π = 0.6090
        assert!((s.tau - 0.6090).abs() < 1e-4, "{}", s.tau);
        assert!(s.b1 < 0.0 && s.b2 < 0.0 && s.b2 < s.b1, "{s:?}");
        let bal = geometry(0.25, 0.25, 0.0).section();
        assert!(
            bal.b1.abs() < 0.95 * s.b1.abs() && bal.b2.abs() < 0.95 * s.b2.abs(),
            "{bal:?}"
        );
        let tab = geometry(0.25, 0.0, 0.2).section();
        assert!(tab.b3 < 0.0 && tab.b3.abs() > 0.3 * s.b2.abs(), "{tab:?}");
    }

    /// The lifting-line correction: an infinite aspect ratio gives the section back; a low aspect ratio
    /// lightens C_h,α in proportion to the tail's lift slope.
    #[test]
    fn aspect_ratio_correction_tends_to_the_section() {
        let mut g = geometry(0.3, 0.1, 0.2);
        g.tail_aspect_ratio = 20.0;
        let hi = g.derivatives().unwrap();
        g.tail_aspect_ratio = 4.0;
        let lo = g.derivatives().unwrap();
        let s = g.section();
        // A = 4: a_t = 2π 4/(2 + √20) = 3.883 /rad
        assert!((lo.tail_lift_slope_per_rad - 3.883).abs() < 1e-3);
        assert!((lo.ch_alpha_per_rad / s.b1 - 3.883 / (2.0 * PI)).abs() < 1e-3);
        assert!((hi.ch_alpha_per_rad / s.b1 - 1.0).abs() < 0.15);
        assert!(lo.ch_elevator_per_rad < 0.0 && lo.ch_tab_per_rad < 0.0);
    }

    #[test]
    fn geometry_outside_the_theory_is_refused_by_name() {
        let mut g = geometry(0.3, 0.1, 0.2);
        g.chord_ratio = 0.0;
        assert!(g.derivatives().unwrap_err().contains("chord_ratio"));
        let mut g = geometry(0.3, 0.1, 0.2);
        g.viscous_factor = 1.5;
        assert!(g.derivatives().unwrap_err().contains("viscous_factor"));
    }
}
