//! Where a model fails: the residual (model − measured force) mapped over the operating space (|velocity| ×
//! current, time), the regions that carry most of the error in words, the residual signatures a missing
//! effect leaves (measured, not assumed), and the noise floor of the measurement.

use serde::Serialize;

use super::Test;
use crate::signal::{channel_noise_std_on, smooth_derivative};

/// A region of the operating space and its part of the squared error.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Region {
    /// The region, in words (|v| bin × current bin, or a part of each test's duration).
    pub region: String,
    /// Its share of the squared error, 0..1.
    pub share_of_error: f64,
    /// RMS force error in the region, N.
    pub rmse_n: f64,
}

/// How samples are binned by current: by the distinct command levels when there are few, else by ranges.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum CurrentBins {
    Levels(Vec<f64>),
    Ranges(Vec<f64>),
}

impl CurrentBins {
    /// Bins for the current commands (|i|) of these tests.
    pub fn of(tests: &[Test]) -> Self {
        let every = || tests.iter().flat_map(|t| &t.inputs);
        let imax = every().fold(0.0f64, |m, i| m.max(i.current_cmd_a.abs()));
        let q = (imax * 1e-3).max(1e-9);
        let mut levels: Vec<i64> = every()
            .map(|i| (i.current_cmd_a.abs() / q).round() as i64)
            .collect();
        levels.sort_unstable();
        levels.dedup();
        if levels.len() <= 8 {
            return CurrentBins::Levels(levels.iter().map(|&l| l as f64 * q).collect());
        }
        let mut all: Vec<f64> = every().map(|i| i.current_cmd_a.abs()).collect();
        all.sort_by(f64::total_cmp);
        let qt = |f: f64| all[((all.len() - 1) as f64 * f) as usize];
        let mut edges = vec![
            qt(0.0),
            qt(1.0 / 3.0),
            qt(2.0 / 3.0),
            qt(1.0) * (1.0 + 1e-12) + 1e-12,
        ];
        edges.dedup();
        CurrentBins::Ranges(edges)
    }

    pub fn len(&self) -> usize {
        match self {
            CurrentBins::Levels(l) => l.len(),
            CurrentBins::Ranges(e) => e.len().saturating_sub(1).max(1),
        }
    }

    pub fn index(&self, i_a: f64) -> usize {
        let i = i_a.abs();
        match self {
            CurrentBins::Levels(l) => {
                let mut best = 0;
                for (k, v) in l.iter().enumerate() {
                    if (v - i).abs() < (l[best] - i).abs() {
                        best = k;
                    }
                }
                best
            }
            CurrentBins::Ranges(e) => {
                let n = self.len();
                (0..n).find(|&k| i < e[k + 1]).unwrap_or(n - 1)
            }
        }
    }

    /// Representative current of a bin, A.
    pub fn centre(&self, k: usize) -> f64 {
        match self {
            CurrentBins::Levels(l) => l[k],
            CurrentBins::Ranges(e) => 0.5 * (e[k] + e[(k + 1).min(e.len() - 1)]),
        }
    }

    pub fn label(&self, k: usize) -> String {
        match self {
            CurrentBins::Levels(l) => format!("i = {} A", sig(l[k])),
            CurrentBins::Ranges(e) => {
                let n = self.len();
                if k == 0 {
                    format!("i < {} A", sig(e[1]))
                } else if k + 1 == n {
                    format!("i ≥ {} A", sig(e[k]))
                } else {
                    format!("{} A ≤ i < {} A", sig(e[k]), sig(e[k + 1]))
                }
            }
        }
    }
}

/// A number with two significant digits, for region labels.
pub(crate) fn sig(x: f64) -> String {
    if x == 0.0 || !x.is_finite() {
        return "0".into();
    }
    let d = (2 - 1 - x.abs().log10().floor() as i32).max(0) as usize;
    let s = format!("{:.*}", d, x);
    if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    }
}

/// Edges of |v| bins as fractions of the largest |v|: slow (near reversal) to fast.
pub(crate) const V_EDGES_FRAC: [f64; 5] = [0.0, 0.05, 0.2, 0.5, 1.0];

fn v_max(tests: &[Test]) -> f64 {
    tests
        .iter()
        .flat_map(|t| &t.inputs)
        .fold(0.0f64, |m, i| m.max(i.v_m_s.abs()))
        .max(1e-12)
}

/// The regions (|v| bin × current bin, and a part of each test's duration) that carry most of the squared
/// residual, largest first, until they cover most of it. Samples count with their [`direction_weights`], as
/// in the rest of the diagnosis: a sample whose direction of motion is unknown or whose force is clipped
/// does not place the error.
#[allow(clippy::needless_range_loop)] // several parallel per-sample arrays
pub(crate) fn where_regions(tests: &[Test], pred: &[Vec<f64>]) -> Vec<Region> {
    let cb = CurrentBins::of(tests);
    let vmax = v_max(tests);
    let edges: Vec<f64> = V_EDGES_FRAC.iter().map(|f| f * vmax).collect();
    let nv = edges.len() - 1;
    let mut sse = vec![vec![0.0; cb.len()]; nv];
    let mut cnt = vec![vec![0usize; cb.len()]; nv];
    let mut thirds = [(0.0, 0usize); 3];
    let mut total = 0.0;
    for (t, p) in tests.iter().zip(pred) {
        let n = t.len();
        let w = direction_weights(t);
        for k in 0..n {
            let r = p[k] - t.f_n[k];
            if w[k] == 0.0 || !r.is_finite() {
                continue;
            }
            let r2 = w[k] * r * r;
            let inp = &t.inputs[k];
            let vb = (0..nv)
                .find(|&b| inp.v_m_s.abs() < edges[b + 1])
                .unwrap_or(nv - 1);
            let ib = cb.index(inp.current_cmd_a);
            sse[vb][ib] += r2;
            cnt[vb][ib] += 1;
            let th = (3 * k / n.max(1)).min(2);
            thirds[th].0 += r2;
            thirds[th].1 += 1;
            total += r2;
        }
    }
    if total <= 0.0 {
        return Vec::new();
    }
    let mut cells: Vec<Region> = Vec::new();
    for (vb, row) in sse.iter().enumerate() {
        for (ib, &s) in row.iter().enumerate().filter(|&(ib, _)| cnt[vb][ib] > 0) {
            let vl = if vb == 0 {
                format!("|v| < {} m/s", sig(edges[1]))
            } else if vb + 1 == nv {
                format!("|v| ≥ {} m/s", sig(edges[vb]))
            } else {
                format!("{} ≤ |v| < {} m/s", sig(edges[vb]), sig(edges[vb + 1]))
            };
            cells.push(Region {
                region: format!("{vl}, {}", cb.label(ib)),
                share_of_error: s / total,
                rmse_n: (s / cnt[vb][ib] as f64).sqrt(),
            });
        }
    }
    cells.sort_by(|a, b| b.share_of_error.total_cmp(&a.share_of_error));
    let mut out = Vec::new();
    let mut covered = 0.0;
    for c in cells {
        if out.len() >= 4 || covered >= 0.6 || (c.share_of_error < 0.05 && !out.is_empty()) {
            break;
        }
        covered += c.share_of_error;
        out.push(c);
    }
    // A third of every test that carries far more than a third of the error: the error grows (or
    // shrinks) with time.
    let names = ["first third", "middle third", "last third"];
    for (k, (s, c)) in thirds.iter().enumerate() {
        if *c > 0 && s / total > 0.5 {
            out.push(Region {
                region: format!("{} of each test's duration", names[k]),
                share_of_error: s / total,
                rmse_n: (s / *c as f64).sqrt(),
            });
        }
    }
    out
}

/// RMS residual over |v| bins (columns, `nv` equal bins up to the largest |v|) × current bins (rows).
pub(crate) struct Heatmap {
    pub v_edges_m_s: Vec<f64>,
    pub current_labels: Vec<String>,
    /// `rms[current bin][v bin]`, N (NaN where there are no samples).
    pub rms_n: Vec<Vec<f64>>,
}

#[allow(clippy::needless_range_loop)] // several parallel per-sample arrays
pub(crate) fn heatmap(tests: &[Test], pred: &[Vec<f64>], nv: usize) -> Heatmap {
    let cb = CurrentBins::of(tests);
    let vmax = v_max(tests);
    let mut s = vec![vec![0.0; nv]; cb.len()];
    let mut c = vec![vec![0usize; nv]; cb.len()];
    for (t, p) in tests.iter().zip(pred) {
        for k in 0..t.len() {
            let inp = &t.inputs[k];
            let vb = ((inp.v_m_s.abs() / vmax * nv as f64) as usize).min(nv - 1);
            let ib = cb.index(inp.current_cmd_a);
            let r = p[k] - t.f_n[k];
            s[ib][vb] += r * r;
            c[ib][vb] += 1;
        }
    }
    let rms_n = s
        .iter()
        .zip(&c)
        .map(|(sr, cr)| {
            sr.iter()
                .zip(cr)
                .map(|(s, &c)| if c > 0 { (s / c as f64).sqrt() } else { f64::NAN })
                .collect()
        })
        .collect();
    Heatmap {
        v_edges_m_s: (0..=nv).map(|k| vmax * k as f64 / nv as f64).collect(),
        current_labels: (0..cb.len()).map(|k| cb.label(k)).collect(),
        rms_n,
    }
}

/// Measured signatures of the residual, each dimensionless (forces divided by the rms measured force).
/// These are the shapes the effect vocabulary describes; a candidate effect's evidence is which of them it
/// removes from the held-out residual.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Signatures {
    /// Mean residual × sign of acceleration at low |v|: force lagging velocity reversals (loops near v = 0).
    pub loop_near_zero_velocity: f64,
    /// Even-in-v mean residual (mean over v > 0 and v < 0) at the highest current minus at the lowest.
    pub direction_offset_vs_current: f64,
    /// Curvature of the mean residual × sgn v versus current (quadratic coefficient × i_max²).
    pub curvature_vs_current: f64,
    /// Slope of the residual versus velocity at the highest current minus at the lowest (× rms v).
    pub velocity_slope_vs_current: f64,
    /// Correlation of the residual with displacement.
    pub correlation_with_x: f64,
    /// Correlation of the residual with acceleration.
    pub correlation_with_acceleration: f64,
    /// Correlation of the residual × sgn v with each test's cumulative dissipated energy.
    pub drift_with_energy: f64,
}

impl Signatures {
    /// Names and values, in a fixed order.
    pub fn named(&self) -> [(&'static str, f64); 7] {
        const NAMES: [&str; 7] = [
            "loop near v = 0 (residual × sgn a at low |v|, of rms force)",
            "direction offset growing with current (of rms force)",
            "curvature of the residual vs current (of rms force)",
            "residual slope vs velocity changing with current (of rms force)",
            "correlation of the residual with displacement",
            "correlation of the residual with acceleration",
            "drift of the residual with dissipated energy (correlation)",
        ];
        let values = [
            self.loop_near_zero_velocity,
            self.direction_offset_vs_current,
            self.curvature_vs_current,
            self.velocity_slope_vs_current,
            self.correlation_with_x,
            self.correlation_with_acceleration,
            self.drift_with_energy,
        ];
        std::array::from_fn(|k| (NAMES[k], values[k]))
    }

    #[allow(clippy::needless_range_loop)] // several parallel per-sample arrays
    pub fn of(tests: &[Test], pred: &[Vec<f64>]) -> Self {
        let cb = CurrentBins::of(tests);
        let nb = cb.len();
        let vmax = v_max(tests);
        let mut f2 = 0.0;
        let mut n = 0usize;
        let mut near_zero = (0.0, 0usize);
        let mut pos = vec![(0.0, 0usize); nb];
        let mut neg = vec![(0.0, 0usize); nb];
        let mut odd = vec![(0.0, 0usize); nb];
        // Per current bin: the residual against the velocity, for its slope.
        let mut sl: Vec<Corr> = (0..nb).map(|_| Corr::default()).collect();
        let (mut cx, mut ca, mut ce) = (Corr::default(), Corr::default(), Corr::default());
        let mut v2 = 0.0;
        // A sum and its count, for a mean.
        let add = |acc: &mut (f64, usize), x: f64| {
            acc.0 += x;
            acc.1 += 1;
        };
        for (t, p) in tests.iter().zip(pred) {
            let mut energy = 0.0;
            for k in 0..t.len() {
                let inp = &t.inputs[k];
                let f = t.f_n[k];
                let r = p[k] - f;
                f2 += f * f;
                v2 += inp.v_m_s * inp.v_m_s;
                n += 1;
                let sv = inp.v_m_s.signum() * (inp.v_m_s != 0.0) as i32 as f64;
                if inp.v_m_s.abs() < 0.1 * vmax && inp.a_m_s2 != 0.0 {
                    add(&mut near_zero, r * inp.a_m_s2.signum());
                }
                let b = cb.index(inp.current_cmd_a);
                if inp.v_m_s > 0.0 {
                    add(&mut pos[b], r);
                } else if inp.v_m_s < 0.0 {
                    add(&mut neg[b], r);
                }
                add(&mut odd[b], r * sv);
                sl[b].add(inp.v_m_s, r);
                cx.add(r, inp.x_m);
                ca.add(r, inp.a_m_s2);
                if k > 0 {
                    energy += (f * (inp.x_m - t.inputs[k - 1].x_m)).abs();
                }
                ce.add(r * sv, energy);
            }
        }
        let frms = (f2 / n.max(1) as f64).sqrt().max(1e-300);
        let vrms = (v2 / n.max(1) as f64).sqrt();
        let mean = |(s, c): (f64, usize)| if c > 0 { s / c as f64 } else { 0.0 };
        let mut sig = Signatures {
            loop_near_zero_velocity: mean(near_zero) / frms,
            correlation_with_x: cx.value(),
            correlation_with_acceleration: ca.value(),
            drift_with_energy: ce.value(),
            ..Default::default()
        };
        // Bins with samples, in order of current.
        let mut order: Vec<usize> = (0..nb).filter(|&b| odd[b].1 > 0).collect();
        order.sort_by(|&a, &b| cb.centre(a).total_cmp(&cb.centre(b)));
        if order.len() >= 2 {
            let (lo, hi) = (order[0], order[order.len() - 1]);
            let off = |b: usize| 0.5 * (mean(pos[b]) + mean(neg[b]));
            sig.direction_offset_vs_current = (off(hi) - off(lo)) / frms;
            sig.velocity_slope_vs_current = (sl[hi].slope() - sl[lo].slope()) * vrms / frms;
        }
        if order.len() >= 3 {
            let xs: Vec<f64> = order.iter().map(|&b| cb.centre(b)).collect();
            let ys: Vec<f64> = order.iter().map(|&b| mean(odd[b])).collect();
            let imax = xs.iter().fold(0.0f64, |m, x| m.max(x.abs())).max(1e-12);
            if let Some(c2) = quadratic_coefficient(&xs, &ys) {
                sig.curvature_vs_current = c2 * imax * imax / frms;
            }
        }
        sig
    }
}

/// Leading coefficient of the least-squares quadratic through the points.
fn quadratic_coefficient(x: &[f64], y: &[f64]) -> Option<f64> {
    let mut a = nalgebra::Matrix3::<f64>::zeros();
    let mut b = nalgebra::Vector3::<f64>::zeros();
    for (xi, yi) in x.iter().zip(y) {
        let row = [1.0, *xi, xi * xi];
        for r in 0..3 {
            b[r] += row[r] * yi;
            for c in 0..3 {
                a[(r, c)] += row[r] * row[c];
            }
        }
    }
    a.lu().solve(&b).map(|s| s[2])
}

/// Running Pearson correlation of `y` with `x`, and the least-squares slope of `y` on `x`.
#[derive(Default)]
struct Corr {
    n: f64,
    sx: f64,
    sy: f64,
    sxx: f64,
    syy: f64,
    sxy: f64,
}

impl Corr {
    fn add(&mut self, x: f64, y: f64) {
        self.n += 1.0;
        self.sx += x;
        self.sy += y;
        self.sxx += x * x;
        self.syy += y * y;
        self.sxy += x * y;
    }

    fn value(&self) -> f64 {
        let vx = self.n * self.sxx - self.sx * self.sx;
        let vy = self.n * self.syy - self.sy * self.sy;
        if vx <= 0.0 || vy <= 0.0 {
            return 0.0;
        }
        (self.n * self.sxy - self.sx * self.sy) / (vx * vy).sqrt()
    }

    fn slope(&self) -> f64 {
        let d = self.n * self.sxx - self.sx * self.sx;
        if d.abs() < 1e-300 {
            0.0
        } else {
            (self.n * self.sxy - self.sx * self.sy) / d
        }
    }
}

/// The measurement noise of the force as logged, N (standard deviation over all samples), estimated from
/// third differences of the measured force: `Δ³f` of white noise has variance 20σ², while a smooth force
/// contributes little and the jumps at velocity reversals are rare enough that a median ignores them. A test
/// logged through a moving average (its [`Test::drive`]) holds the load cell's white noise through the
/// filter: its third differences are scaled by [`raw_noise_gain`] to read the load cell's own noise, pooled
/// over all tests, and each test then counts the share `1/window` of its variance the filter passes.
pub(crate) fn noise_floor_n(tests: &[Test]) -> f64 {
    let window = |t: &Test| t.drive.as_ref().map_or(1, |d| d.window());
    let forces: Vec<std::borrow::Cow<[f64]>> = tests
        .iter()
        .map(|t| match window(t) {
            1 => std::borrow::Cow::Borrowed(t.f_n.as_slice()),
            w => {
                let gain = raw_noise_gain(w);
                t.f_n.iter().map(|f| f * gain).collect()
            }
        })
        .collect();
    let records: Vec<(Vec<f64>, &[f64])> = tests
        .iter()
        .zip(&forces)
        .map(|(t, f)| (t.inputs.iter().map(|i| i.t_s).collect(), &**f))
        .collect();
    let raw = crate::signal::pooled_white_noise_std(&records);
    if tests.iter().all(|t| window(t) == 1) {
        return raw;
    }
    let (passed, n) = tests.iter().fold((0.0, 0.0), |(p, n), t| {
        (p + t.len() as f64 / window(t) as f64, n + t.len() as f64)
    });
    raw * (passed / n).sqrt()
}

/// What the third-difference estimate read from white noise through a moving average of `window` samples
/// must be multiplied by to give the noise's spread before the filter: the filter `h` (`1/window` over
/// `window` taps) leaves third differences of variance `σ² Σ(Δ³h)²`, against `20σ²` unfiltered.
pub(crate) fn raw_noise_gain(window: usize) -> f64 {
    let h = 1.0 / window as f64;
    let d3 = [1.0, -3.0, 3.0, -1.0];
    let g2: f64 = (0..window + 3)
        .map(|n| {
            let g: f64 = (0..4)
                .filter(|&j| j <= n && n - j < window)
                .map(|j| d3[j] * h)
                .sum();
            g * g
        })
        .sum();
    (20.0 / g2).sqrt()
}

/// How many noise standard deviations a velocity must be from zero for its sign to be known: a Gaussian
/// error exceeds 4σ in one direction with probability 3·10⁻⁵.
pub(crate) const DIRECTION_SIGMAS: f64 = 4.0;

/// Weight of each sample of a test in a fit's loss and a held-out score: 0 where the velocity the model is
/// given is within `DIRECTION_SIGMAS` noise standard deviations of zero, or the force is stuck at a rail
/// (`ident::clipping`), 1 elsewhere. Why: the models take the yield force's direction from the sign of the
/// velocity; where that sign is a coin toss, a residual of `2 Fy` no effect explains would dominate the
/// residual of a correct model, and any effect that softens the reversal would look significant.
pub fn direction_weights(t: &Test) -> Vec<f64> {
    let weight = |v: f64, sd: f64| if v.abs() < DIRECTION_SIGMAS * sd { 0.0 } else { 1.0 };
    let mut w: Vec<f64> = match &t.velocity_noise_m_s {
        // A velocity derived here: its noise at each sample (larger at the ends of the test).
        Some(sd) if sd.len() == t.inputs.len() => t
            .inputs
            .iter()
            .zip(sd)
            .map(|(i, sd)| weight(i.v_m_s, *sd))
            .collect(),
        _ => {
            let sd = velocity_noise_std(t);
            t.inputs.iter().map(|i| weight(i.v_m_s, sd)).collect()
        }
    };
    for (w, c) in w.iter_mut().zip(super::clipping::unclipped(&t.f_n)) {
        *w *= c;
    }
    w
}

/// Standard deviation of the noise in the velocity a test's model is given: [`Test::velocity_noise_m_s`]
/// when known; a measured velocity's noise ([`channel_noise_std_on`]); or, for one derived by
/// [`smooth_derivative`] (whose differences hide its noise), the displacement's noise times the
/// differentiator's noise gain.
pub(crate) fn velocity_noise_std(t: &Test) -> f64 {
    if let Some(sd) = t.velocity_noise_m_s.as_ref().filter(|sd| !sd.is_empty()) {
        // Inside the test, where the centred window is used.
        return sd[sd.len() / 2];
    }
    let ts: Vec<f64> = t.inputs.iter().map(|i| i.t_s).collect();
    if t.velocity_measured {
        let v: Vec<f64> = t.inputs.iter().map(|i| i.v_m_s).collect();
        return channel_noise_std_on(&ts, &v);
    }
    let x: Vec<f64> = t.inputs.iter().map(|i| i.x_m).collect();
    let n = t.inputs.len();
    if n < 3 {
        return 0.0;
    }
    // An impulse in the middle of a stretch of the test's time grid, wide enough for the differentiator.
    let w = n.min(31);
    let lo = (n - w) / 2;
    let mut pulse = vec![0.0; w];
    pulse[w / 2] = 1.0;
    let gain = smooth_derivative(&ts[lo..lo + w], &pulse)
        .iter()
        .map(|d| d * d)
        .sum::<f64>()
        .sqrt();
    channel_noise_std_on(&ts, &x) * gain
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Inputs;
    use crate::ident::noise;

    /// White noise through a moving average: the third-difference estimate, scaled by the gain, reads the
    /// spread of the noise before the filter (without it, a small fraction of it: 0.8 % at 100 samples), and
    /// the filter passes `1/window` of its variance.
    #[test]
    fn the_raw_noise_gain_recovers_the_spread_of_white_noise_before_a_moving_average() {
        let e = noise(200_000, 1.0, 3);
        for window in [1, 2, 5, 100] {
            let f = crate::signal::moving_average(&e, window);
            let f = &f[window..];
            let est = crate::signal::white_noise_std(f) * raw_noise_gain(window);
            assert!((est - 1.0).abs() < 0.03, "window {window}: {est}");
            let sd = (f.iter().map(|v| v * v).sum::<f64>() / f.len() as f64).sqrt();
            let before = sd * (window as f64).sqrt();
            assert!((before - 1.0).abs() < 0.03, "window {window}: {sd}");
        }
    }

    fn test_of(f: Vec<f64>, v: Vec<f64>, i: Vec<f64>) -> Test {
        let inputs = v
            .iter()
            .zip(&i)
            .enumerate()
            .map(|(k, (v, i))| Inputs {
                t_s: k as f64 * 1e-3,
                v_m_s: *v,
                current_cmd_a: *i,
                ..Default::default()
            })
            .collect();
        Test::synthetic("t.csv", "t", inputs, f)
    }

    #[test]
    fn noise_floor_recovers_white_noise_on_a_square_wave_force() {
        // A Bingham-like force (jumps at reversals, slow sine part) plus white noise of 0.7 N.
        let n = 20_000;
        let nd = noise(n, 0.7, 3);
        let f: Vec<f64> = (0..n)
            .map(|k| {
                let ph = 2.0 * std::f64::consts::PI * 2.0 * k as f64 * 1e-3;
                40.0 * ph.cos().signum() + 10.0 * ph.cos() + nd[k]
            })
            .collect();
        let t = test_of(f, vec![0.0; n], vec![0.0; n]);
        let s = noise_floor_n(&[t]);
        assert!((s - 0.7).abs() < 0.07, "estimated {s} N for 0.7 N");
    }

    #[test]
    fn where_names_the_slow_high_current_region_that_holds_the_error() {
        // Error only where |v| is small and the current is high.
        let n = 4000;
        let v: Vec<f64> = (0..n)
            .map(|k| (2.0 * std::f64::consts::PI * k as f64 / 1000.0).sin())
            .collect();
        let i: Vec<f64> = (0..n).map(|k| if k < n / 2 { 1.0 } else { 10.0 }).collect();
        let f = vec![0.0; n];
        let pred: Vec<f64> = (0..n)
            .map(|k| if v[k].abs() < 0.04 && i[k] > 5.0 { 5.0 } else { 0.1 })
            .collect();
        let t = test_of(f, v, i);
        let w = where_regions(&[t], &[pred]);
        assert!(
            w[0].region.contains("|v| < 0.05 m/s") && w[0].region.contains("i = 10 A"),
            "{w:?}"
        );
        assert!(w[0].share_of_error > 0.8, "{w:?}");
    }

    #[test]
    fn sig_rounds_to_two_significant_digits() {
        assert_eq!(sig(0.0234), "0.023");
        assert_eq!(sig(14.0), "14");
        assert_eq!(sig(0.5), "0.5");
        assert_eq!(sig(1234.0), "1234");
    }
}
