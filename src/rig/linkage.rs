//! Closed-form kinematics of the stick linkage, in f64, from the URDF's neutral geometry: a slider-crank
//! (stick pivot O, clevis S on the stick, push rod S–P of fixed length, rod-end pin P on the piston's line).
//!
//! Used to check that the stick stops and the piston stops agree, to report the gearing, and by tests as
//! an independent reference for the multibody.

use super::frames::{Frame, V3Ext, V3};

/// The slider-crank as it stands at neutral (all joint coordinates zero).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linkage {
    /// Stick pivot point (world).
    pub pivot: V3,
    /// The stick pivot's unit axis (world).
    pub pivot_axis: V3,
    /// Clevis pin on the stick at neutral (world).
    pub clevis: V3,
    /// Rod-end pin on the piston at neutral (world).
    pub pin: V3,
    /// Unit piston axis (world), + = piston +x.
    pub slide_axis: V3,
    /// Push rod length |P − S|, m.
    pub rod_m: f64,
}

impl Linkage {
    /// The linkage from the pivot's frame and local axis, the two pins and the slide's frame and local axis.
    pub fn new(
        pivot: &Frame,
        pivot_axis_local: V3,
        clevis: V3,
        pin: V3,
        slide: &Frame,
        slide_axis_local: V3,
    ) -> Self {
        let pivot_axis = pivot.rotate(pivot_axis_local).unit();
        let slide_axis = slide.rotate(slide_axis_local).unit();
        Self {
            pivot: pivot.p,
            pivot_axis,
            clevis,
            pin,
            slide_axis,
            rod_m: (pin - clevis).norm(),
        }
    }

    /// Clevis position at stick angle `theta_rad` (right-handed about the pivot axis).
    pub(crate) fn clevis_at(&self, theta_rad: f64) -> V3 {
        self.pivot + (self.clevis - self.pivot).rotated_about(self.pivot_axis, theta_rad)
    }

    /// Piston displacement from neutral at stick angle `theta_rad`: the root of `|P0 + x u − S(θ)| = ℓ`
    /// on the branch through `x = 0` at `θ = 0`. `None` if the push rod cannot reach the piston's line.
    pub fn piston_x_m(&self, theta_rad: f64) -> Option<f64> {
        let d = self.pin - self.clevis_at(theta_rad);
        let b = d.dot(&self.slide_axis);
        let disc = b * b - d.dot(&d) + self.rod_m * self.rod_m;
        if disc < 0.0 {
            return None;
        }
        let r = disc.sqrt();
        // Roots -b ± r; the neutral branch is the one with the smaller magnitude at θ = 0.
        let (x1, x2) = (-b + r, -b - r);
        Some(if x1.abs() <= x2.abs() { x1 } else { x2 })
    }

    /// Gearing dx/dθ at `theta_rad`, m/rad (central difference of [`Self::piston_x_m`]).
    pub fn gearing_m_per_rad(&self, theta_rad: f64) -> Option<f64> {
        let h = 1e-6;
        Some((self.piston_x_m(theta_rad + h)? - self.piston_x_m(theta_rad - h)?) / (2.0 * h))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn crank(a: f64, l: f64) -> Linkage {
        // Pivot at origin, axis +y, clevis a above, rod forward (−x) of length l, piston axis +x.
        let id = Frame::IDENTITY;
        Linkage::new(
            &id,
            V3::new(0.0, 1.0, 0.0),
            V3::new(0.0, 0.0, a),
            V3::new(-l, 0.0, a),
            &id,
            V3::new(1.0, 0.0, 0.0),
        )
    }

    #[test]
    fn slider_crank_matches_the_textbook_formula() {
        // The rod runs forward (−x) from the clevis to the pin: when the clevis drops by a(1 − cosθ) the
        // rod tilts and pulls the pin back towards it, x(θ) = a sinθ + l − sqrt(l² − a²(1 − cosθ)²).
        let (a, l) = (0.15, 0.20);
        let k = crank(a, l);
        for deg in [-18.0f64, -7.0, 0.0, 3.0, 18.0] {
            let t = deg.to_radians();
            let expect = a * t.sin() + l - (l * l - (a * (1.0 - t.cos())).powi(2)).sqrt();
            let got = k.piston_x_m(t).unwrap();
            assert!((got - expect).abs() < 1e-12, "{deg}°: {got} vs {expect}");
        }
    }

    #[test]
    fn gearing_at_centre_is_the_clevis_height() {
        let k = crank(0.15, 0.20);
        assert!((k.gearing_m_per_rad(0.0).unwrap() - 0.15).abs() < 1e-8);
    }
}
