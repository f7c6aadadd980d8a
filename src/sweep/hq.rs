//! Handling-qualities verdicts on one run's stick forces.
//!
//! Sources (pounds-force in the standards, converted once with [`LBF_TO_N`]):
//! - **14 CFR 23.143(c)** and **25.143(d)**: the largest pitch force for temporary (short-term) and for
//!   prolonged (long-term) application. The limits are the repository's ([`CertificationBasis`], stick:
//!   60 lbf temporary under Part 23, 50 lbf one hand under Part 25, 10 lbf prolonged under both).
//! - **MIL-F-8785C 3.2.2.2.1, Table V** (kept in **MIL-STD-1797A 4.2.8.2**): stick force per g for
//!   centre-stick controllers, Level 1/2/3 bounds from the limit load factor `n_L` and the acceleration
//!   sensitivity `n/α` (g/rad), in lbf/g:
//!   - Level 1: max `240/(n/α)`, not more than 28.0 nor less than `56/(n_L − 1)`; min `21/(n_L − 1)`, not
//!     less than 3.0;
//!   - Level 2: max `360/(n/α)`, not more than 42.5 nor less than `85/(n_L − 1)`; min `18/(n_L − 1)`, not
//!     less than 3.0;
//!   - Level 3: max 56.0; min `12/(n_L − 1)`, not less than 2.0.
//! - **14 CFR Part 60, Appendix A, Table A2A, test 2.a.1.a** (full flight simulator objective tests,
//!   "Pitch Controller Position vs. Force and Surface Position Calibration"): "±2 lb (0.9 daN) breakout,
//!   ±10% or ±5 lb (2.2 daN) force, ±2° elevator". The force tolerance is read as whichever of the two is
//!   larger. Here the reference is the feel target (the aircraft's stick force, or the law's), the
//!   simulator's force is the one the pilot feels at the grip.
//!
//! Reading used here: a force held for at least the prolonged window (mean |force| over a sliding window,
//! 5 s by default) is a prolonged application; the largest |force| anywhere is a temporary one.

use crate::aero::certification::{CertificationBasis, PerGBounds};
use crate::units::LBF_TO_N;

/// Handling-qualities Level of the stick force per g (MIL-F-8785C 1.5): 1 satisfactory, 2 acceptable,
/// 3 controllable; 4 here: outside the Level 3 bounds.
pub type Level = u8;

/// The best Level whose bounds hold `per_g_n` (N/g), 4 if none does.
pub(crate) fn per_g_level(per_g_n: f64, bounds: &[PerGBounds; 3]) -> Level {
    bounds
        .iter()
        .position(|b| (b.min_n_per_g..=b.max_n_per_g).contains(&per_g_n))
        .map_or(4, |k| k as Level + 1)
}

/// Temporary and prolonged force limits of a basis, N: (temporary, prolonged). A stick under Part 23
/// takes its one stick value (60 lbf); under Part 25 the one-hand value (a stick is flown one-handed).
pub(crate) fn force_limits(basis: &CertificationBasis) -> (f64, f64) {
    (basis.short_term_one_hand_n, basis.long_term_n)
}

/// Largest mean |force| over any window of `window_s` (the force held for a prolonged application), N;
/// `None` when the run is shorter than the window. `t` and `f` are samples at increasing times.
pub(crate) fn prolonged_force_n(t: &[f64], f: &[f64], window_s: f64) -> Option<f64> {
    let n = t.len().min(f.len());
    if n < 2 || t[n - 1] - t[0] < window_s {
        return None;
    }
    // Trapezoid integral of |f| so far, per sample.
    let mut cum = vec![0.0; n];
    for k in 1..n {
        cum[k] = cum[k - 1] + 0.5 * (f[k].abs() + f[k - 1].abs()) * (t[k] - t[k - 1]);
    }
    let mut best = f64::NEG_INFINITY;
    let mut a = 0;
    for b in 1..n {
        // The shortest window ending at `b` that spans at least `window_s`.
        while a + 1 < b && t[b] - t[a + 1] >= window_s {
            a += 1;
        }
        if t[b] - t[a] >= window_s {
            best = best.max((cum[b] - cum[a]) / (t[b] - t[a]));
        }
    }
    best.is_finite().then_some(best)
}

/// Part 60 force tolerance at a reference force, N: ±5 lbf or ±10 % of it, whichever is larger.
pub(crate) fn part60_force_tolerance_n(reference_n: f64) -> f64 {
    (5.0 * LBF_TO_N).max(0.1 * reference_n.abs())
}

/// Part 60 breakout tolerance, N: ±2 lbf.
pub(crate) const PART60_BREAKOUT_TOLERANCE_N: f64 = 2.0 * LBF_TO_N;

/// The force–deflection line a run's feel renders, read as Part 60's control sweep reads it: on the samples
/// where the stick moves away from centre (the half of each cycle every feel system renders, a passive damper
/// included), the felt force `F = breakout · sgn(θ) + gradient · θ` by least squares.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct ForceLine {
    /// Force to leave centre, N (the intercept at centre).
    pub breakout_n: f64,
    /// Force per rad of stick, N/rad.
    pub gradient_n_per_rad: f64,
}

/// The [`ForceLine`] of samples (stick angle from neutral θ, rad; its rate, rad/s; the pilot's force at
/// the grip, N, either sign convention): the samples moving outward faster than `rest_rad_s`. `None` with
/// fewer than 20 such samples or deflections all alike.
pub(crate) fn force_line(theta: &[f64], rate: &[f64], force: &[f64], rest_rad_s: f64) -> Option<ForceLine> {
    let out: Vec<(f64, f64)> = theta
        .iter()
        .zip(rate)
        .zip(force)
        .filter(|((t, r), _)| *t * *r > 0.0 && r.abs() > rest_rad_s)
        .map(|((t, _), f)| (*t, *f))
        .collect();
    if out.len() < 20 {
        return None;
    }
    // The pilot pushes the way the stick goes out: the sign that makes the felt force resist.
    let dot: f64 = out.iter().map(|(t, f)| t * f).sum();
    let sign = if dot < 0.0 { -1.0 } else { 1.0 };
    // Normal equations of F = b s + k θ, s = sgn θ (s² = 1).
    let (mut ss, mut st, mut tt, mut sf, mut tf) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for &(t, f) in &out {
        let (sg, f) = (t.signum(), sign * f);
        ss += 1.0;
        st += sg * t;
        tt += t * t;
        sf += sg * f;
        tf += t * f;
    }
    let det = ss * tt - st * st;
    if det <= 1e-12 * ss * tt {
        return None;
    }
    Some(ForceLine {
        breakout_n: (sf * tt - tf * st) / det,
        gradient_n_per_rad: (ss * tf - st * sf) / det,
    })
}

/// Largest |felt − reference| over the samples, as a ratio of the Part 60 tolerance at each sample: at most
/// 1 meets the test. `None` without samples.
pub(crate) fn part60_force_ratio(felt_n: &[f64], reference_n: &[f64]) -> Option<f64> {
    felt_n
        .iter()
        .zip(reference_n)
        .map(|(f, r)| (f - r).abs() / part60_force_tolerance_n(*r))
        .reduce(f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::aero::certification::centre_stick_per_g_bounds;
    use crate::aero::model::{CertificationPart, ControlType};

    const LB: f64 = LBF_TO_N;

    #[test]
    fn table_v_bounds_for_a_fighter_and_a_light_aircraft() {
        // Hand-computed from MIL-F-8785C Table V. A fighter: n_L = 7.33 g, n/α = 20 g/rad:
        // Level 1 max 240/20 = 12 (within [56/6.33 = 8.85, 28]); min 21/6.33 = 3.32.
        let b = centre_stick_per_g_bounds(7.33, 20.0);
        assert!((b[0].max_n_per_g / LB - 12.0).abs() < 1e-9);
        assert!((b[0].min_n_per_g / LB - 21.0 / 6.33).abs() < 1e-9);
        // Level 2 max 360/20 = 18; min 18/6.33 = 2.84 -> 3.0; Level 3 min 12/6.33 = 1.90 -> 2.0, max 56.
        assert!((b[1].max_n_per_g / LB - 18.0).abs() < 1e-9);
        assert!((b[1].min_n_per_g / LB - 3.0).abs() < 1e-9);
        assert!((b[2].min_n_per_g / LB - 2.0).abs() < 1e-9);
        assert!((b[2].max_n_per_g / LB - 56.0).abs() < 1e-9);
        // A light aircraft: n_L = 3.8 g, n/α = 5 g/rad: 240/5 = 48 -> capped at 28; min 21/2.8 = 7.5.
        let c = centre_stick_per_g_bounds(3.8, 5.0);
        assert!((c[0].max_n_per_g / LB - 28.0).abs() < 1e-9);
        assert!((c[0].min_n_per_g / LB - 7.5).abs() < 1e-9);
        // Level 2 max 360/5 = 72 -> capped at 42.5; a very sensitive aircraft (n/α = 60 g/rad): 240/60 = 4
        // -> raised to 56/2.8 = 20.
        assert!((c[1].max_n_per_g / LB - 42.5).abs() < 1e-9);
        let d = centre_stick_per_g_bounds(3.8, 60.0);
        assert!((d[0].max_n_per_g / LB - 20.0).abs() < 1e-9);
    }

    #[test]
    fn levels_follow_the_bounds() {
        let c = centre_stick_per_g_bounds(3.8, 5.0);
        // Level 1: 7.5..28 lbf/g; Level 2: 6.43..42.5; Level 3: 4.29..56.
        assert_eq!(per_g_level(10.0 * LB, &c), 1);
        assert_eq!(per_g_level(35.0 * LB, &c), 2);
        assert_eq!(per_g_level(7.0 * LB, &c), 2);
        assert_eq!(per_g_level(5.0 * LB, &c), 3);
        assert_eq!(per_g_level(50.0 * LB, &c), 3);
        assert_eq!(per_g_level(60.0 * LB, &c), 4);
        assert_eq!(per_g_level(1.0 * LB, &c), 4);
        assert_eq!(per_g_level(-10.0 * LB, &c), 4);
    }

    #[test]
    fn far_force_limits_of_a_stick() {
        // 23.143(c): stick, pitch, temporary 60 lbf, prolonged 10 lbf; 25.143(d): one hand 50 lbf, 10 lbf.
        let p23 = CertificationBasis::new(CertificationPart::Part23, ControlType::Stick, 1100.0);
        let (t, p) = force_limits(&p23);
        assert!((t - 266.89).abs() < 0.01 && (p - 44.48).abs() < 0.01, "{t} {p}");
        let p25 = CertificationBasis::new(CertificationPart::Part25, ControlType::Stick, 60_000.0);
        let (t, p) = force_limits(&p25);
        assert!((t - 222.41).abs() < 0.01 && (p - 44.48).abs() < 0.01, "{t} {p}");
    }

    #[test]
    fn prolonged_force_is_the_largest_held_mean() {
        // 1 kHz, 20 s: 0 N, then 60 N for 3 s (a temporary pull), then 40 N held for 8 s.
        let t: Vec<f64> = (0..20_000).map(|k| k as f64 * 1e-3).collect();
        let f: Vec<f64> = t
            .iter()
            .map(|&t| match t {
                t if (2.0..5.0).contains(&t) => 60.0,
                t if (8.0..16.0).contains(&t) => -40.0,
                _ => 0.0,
            })
            .collect();
        let p = prolonged_force_n(&t, &f, 5.0).unwrap();
        // Any 5 s window inside the hold has mean 40 N; the 60 N pull lasts 3 s: at most 36 N over 5 s.
        assert!((p - 40.0).abs() < 0.02, "{p}");
        assert!(prolonged_force_n(&t[..3000], &f[..3000], 5.0).is_none());
    }

    #[test]
    fn part60_tolerance_is_five_pounds_or_ten_percent() {
        // 100 N reference: 10 % = 10 N < 5 lbf = 22.24 N; 600 N: 60 N > 22.24 N.
        assert!((part60_force_tolerance_n(100.0) - 22.241).abs() < 1e-3);
        assert!((part60_force_tolerance_n(-600.0) - 60.0).abs() < 1e-9);
        // 20 N off at 100 N is within (0.899), 70 N off at 600 N is not (1.167).
        let r = part60_force_ratio(&[120.0, 530.0], &[100.0, 600.0]).unwrap();
        assert!((r - 70.0 / 60.0).abs() < 1e-9, "{r}");
        let r = part60_force_ratio(&[120.0], &[100.0]).unwrap();
        assert!((r - 20.0 / 22.241).abs() < 1e-3, "{r}");
    }

    #[test]
    fn breakout_is_the_intercept_of_the_outward_force_line() {
        // A stick swept ±0.2 rad at 0.5 Hz, sampled at 1 kHz; the pilot feels 6 N of breakout and 50 N/rad
        // on the way out (pushing the way the stick goes, here with the load cell's minus sign) and nothing
        // but 1 N of friction on the way back (a passive damper released). By hand: breakout 6 N, gradient
        // 50 N/rad; a fit over every sample would mix in the return and give neither.
        let w = std::f64::consts::PI;
        let (mut th, mut rt, mut f) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..4000 {
            let t = k as f64 * 1e-3;
            let (x, v) = (0.2 * (w * t).sin(), 0.2 * w * (w * t).cos());
            th.push(x);
            rt.push(v);
            f.push(if x * v > 0.0 {
                -(6.0 * x.signum() + 50.0 * x)
            } else {
                -v.signum()
            });
        }
        let l = force_line(&th, &rt, &f, 1e-3).unwrap();
        assert!((l.breakout_n - 6.0).abs() < 1e-9, "{l:?}");
        assert!((l.gradient_n_per_rad - 50.0).abs() < 1e-9, "{l:?}");
        // Part 60: 6 N against a reference of 0 (reversible controls, no detent) is within 2 lbf = 8.90 N.
        assert!((PART60_BREAKOUT_TOLERANCE_N - 8.896).abs() < 1e-3);
        assert!((l.breakout_n - 0.0).abs() <= PART60_BREAKOUT_TOLERANCE_N);
        // A stick at rest gives no line.
        assert!(force_line(&th, &vec![0.0; th.len()], &f, 1e-3).is_none());
    }
}
