//! Signal processing on sampled records: sample intervals and the smoothing differentiator.

/// Median sample interval, s (1 with fewer than two samples).
pub fn median_interval(t: &[f64]) -> f64 {
    let mut d: Vec<f64> = t.windows(2).map(|w| w[1] - w[0]).collect();
    if d.is_empty() {
        return 1.0;
    }
    d.sort_by(f64::total_cmp);
    d[d.len() / 2]
}

/// The sample interval of an even time grid: the median interval when every interval is within 1 % of
/// it, `None` on an uneven grid (jittered clock, lost samples) or with fewer than two samples.
pub fn uniform_interval(t: &[f64]) -> Option<f64> {
    if t.len() < 2 {
        return None;
    }
    let dt = median_interval(t);
    let even = dt.is_finite() && dt > 0.0 && t.windows(2).all(|w| ((w[1] - w[0]) - dt).abs() <= 0.01 * dt);
    even.then_some(dt)
}

/// Smoothing differentiator: the slope of a local least-squares cubic over a 7-sample window (the
/// Savitzky–Golay derivative of order 3, generalised to uneven sampling), the window shifted inward at
/// the ends of the record. For a sine sampled 20 times per period its gain error is about 0.2 % (a
/// quadratic over the same window loses 11 %), and it amplifies white noise about 1.4× less than a
/// central difference.
pub fn smooth_derivative(t: &[f64], y: &[f64]) -> Vec<f64> {
    const WINDOW: usize = 7;
    let n = t.len();
    match n {
        0 => return Vec::new(),
        1 => return vec![0.0],
        _ => {}
    }
    let w = WINDOW.min(n);
    let degree = (w - 1).min(3);
    (0..n)
        .map(|k| {
            let lo = k.saturating_sub(w / 2).min(n - w);
            local_poly_slope(&t[lo..lo + w], &y[lo..lo + w], t[k], degree)
        })
        .collect()
}

/// Slope at `t0` of the least-squares polynomial of the given degree through the points.
fn local_poly_slope(t: &[f64], y: &[f64], t0: f64, degree: usize) -> f64 {
    let m = t.len();
    // Centred on t0 and scaled for conditioning: u = (t - t0) / s; the slope at u = 0 is c1 / s.
    let s = (t[m - 1] - t[0]).max(f64::MIN_POSITIVE);
    let a = nalgebra::DMatrix::from_fn(m, degree + 1, |r, c| ((t[r] - t0) / s).powi(c as i32));
    let b = nalgebra::DVector::from_column_slice(y);
    match (a.transpose() * &a).cholesky() {
        Some(ch) => ch.solve(&(a.transpose() * b))[1] / s,
        None => (y[m - 1] - y[0]) / (t[m - 1] - t[0]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derived_velocity_of_a_sine_is_accurate_on_uneven_sampling() {
        // x = A sin(wt) sampled ~20 times per period with jittered times.
        let (a, w) = (0.01, 2.0 * std::f64::consts::PI * 2.0);
        let mut t = Vec::new();
        let mut tk = 0.0;
        for k in 0..200 {
            t.push(tk);
            tk += 0.025 * (1.0 + 0.2 * ((k * 7 % 5) as f64 - 2.0) / 2.0);
        }
        let x: Vec<f64> = t.iter().map(|&t| a * (w * t).sin()).collect();
        let v = smooth_derivative(&t, &x);
        let vmax = a * w;
        for k in 0..t.len() {
            let exact = a * w * (w * t[k]).cos();
            // Interior: 1 % of the peak; the three samples at each end use a shifted window: 6 %.
            let tol = if k < 3 || k + 3 >= t.len() { 0.06 } else { 0.01 };
            assert!(
                (v[k] - exact).abs() < tol * vmax,
                "k={k} v={} exact={exact}",
                v[k]
            );
        }
    }
}
