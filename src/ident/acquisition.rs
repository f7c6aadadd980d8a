//! The acquisition chain: a moving average the data went through before it was logged, found from its comb
//! of zeros pooled over a protocol's tests in the motion and the force together (`detect_moving_average`,
//! thresholds below against white noise), undone on the motion by regularised least squares
//! (`deconvolve_moving_average`), and applied to the model's force before it is compared ([`Drive`]).
//! Why: `docs/explanation/diagnosis.md`, "Reading the data as it was logged".

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

use std::collections::{BTreeMap, BTreeSet};

use crate::device::Inputs;

/// Comb frequencies checked per candidate window (the first ones, up to the Nyquist frequency).
pub(crate) const NULLS: usize = 8;
/// The depth of one comb frequency on white noise (`null_depth`), measured: mean, decades.
const NOISE_MEAN: f64 = 0.04;
/// ... and its spread, decades.
const NOISE_SD: f64 = 0.64;
/// Both channels' combs together must lie this many noise spreads of a mean below white noise's over their
/// `M` values: `NOISE_MEAN − Z · NOISE_SD / √M` (the deepest comb of any window on white noise: 5.4).
pub(crate) const COMB_SIGMAS: f64 = 6.0;
/// ... and each channel on its own this many: the motion and the force went through one filter.
pub(crate) const CHANNEL_SIGMAS: f64 = 2.0;
/// ... with at least this share of each channel's comb frequencies below their band's noise level (white
/// noise: about 45 %).
pub(crate) const BELOW_SHARE: f64 = 2.0 / 3.0;
/// ... and at least this share of the comb frequencies tried left to count in it (not beside a line).
pub(crate) const COUNTED_SHARE: f64 = 0.75;
/// A window predicted from other tests ([`window_law`]) is confirmed when both channels' combs together
/// lie this many noise spreads below white noise's mean (one window tested, not the best of many).
pub(crate) const CONFIRM_SIGMAS: f64 = 3.0;
/// One comb frequency's depth counts down to this many decades (and up to one above): a single
/// near-empty bin of white noise must not pass for a comb.
const DEPTH_CLAMP: f64 = 2.5;
/// Bins a band must keep, beside the main lobe, for its noise level to mean something; with bands of
/// `l/window` bins the longest window checked is `l/25` (a record of 25 windows or more).
const MIN_BAND_BINS: usize = 16;
/// Comb frequencies of the force within this many bins of a harmonic of the drive are not counted (the
/// window's main lobe is ±4 bins).
const HARMONIC_GUARD_BINS: f64 = 6.0;
/// A bin this far above its band's noise level is a line (white noise: once in 4·10⁹ bins).
const LINE_FACTOR: f64 = 100.0;
/// A band counts only where the median of |ln| of the ratio of its ordinates four bins apart reaches this
/// (white noise: ln 3 ≈ 1.1; leakage of a noise-free signal: far less).
const MIN_ROUGHNESS: f64 = 0.5;
/// A band counts only where its strongest bin is at most this far (70 dB) above its noise level: the
/// window's sidelobes (−92 dB) then leak every line in it below the noise.
const LINE_TO_NOISE: f64 = 1e7;
/// The noise level of a band: this quantile of its bins (lines of the test's own harmonics fill the upper
/// part of a band; its lower part is the noise between them).
const BAND_QUANTILE: f64 = 0.2;
/// Noise gain of the deconvolution at the filter's first zero: `1/(2√c)` with the penalty
/// `c (N/2π)⁴ |Δ²u|²`.
const PENALTY: f64 = 0.01;

/// A detected moving average and what showed it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MovingAverage {
    /// Window, samples.
    pub window: usize,
    /// Mean depth of the comb below the noise of its bands, over the records, the comb frequencies counted
    /// and the channels that witness it, decades (negative).
    pub mean_depth: f64,
    /// Whether the window was predicted from other tests and confirmed (`confirm_moving_average`),
    /// rather than found among every window the records allow (`detect_moving_average`).
    pub predicted: bool,
}

/// The model's drive for a test whose channels went through a moving average: the motion before the
/// filter from `window − 1` samples before the record on, and the window the model's force goes through.
#[derive(Debug, Clone)]
pub struct Drive {
    /// The moving average found.
    pub filter: MovingAverage,
    /// `window − 1` lead-in samples, then one per sample of the test.
    pub inputs: Vec<Inputs>,
}

impl Drive {
    /// Its window, samples.
    pub fn window(&self) -> usize {
        self.filter.window
    }
}

/// Periodogram (|FFT|², 4-term Blackman–Harris window) of the first difference of `y`: the difference
/// whitens the signal so a zero of the filter stands out against its band, and the window's −92 dB
/// sidelobes keep a damper force's harmonic lines out of the gaps between them.
fn periodogram_of_differences(y: &[f64]) -> Vec<f64> {
    let d: Vec<f64> = y.windows(2).map(|w| w[1] - w[0]).collect();
    power_spectrum(&d, |a| {
        0.35875 - 0.48829 * a.cos() + 0.14128 * (2.0 * a).cos() - 0.01168 * (3.0 * a).cos()
    })
}

/// |FFT|² of `y` with its mean removed and the window `window(2πk/n)` applied, bins 0 to n/2.
fn power_spectrum(y: &[f64], window: impl Fn(f64) -> f64) -> Vec<f64> {
    let n = y.len();
    let mean = y.iter().sum::<f64>() / n as f64;
    let mut buf: Vec<Complex<f64>> = y
        .iter()
        .enumerate()
        .map(|(k, v)| Complex::from((v - mean) * window(2.0 * std::f64::consts::PI * k as f64 / n as f64)))
        .collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    buf[..n / 2 + 1].iter().map(|c| c.norm_sqr()).collect()
}

/// Depth, decades (negative = a dip), of the periodogram `p` (of `l` points) at `k/window` cycles per
/// sample: the least of the three bins around it against the noise level of its band (half a comb spacing
/// on either side, the window's main lobe left out). `None` where the band is too short or not noise, or
/// within `HARMONIC_GUARD_BINS` of a multiple of `harmonics` (the drive frequency in bins) or of a line.
fn null_depth(p: &[f64], l: usize, window: usize, k: usize, harmonics: Option<f64>) -> Option<f64> {
    let at = |f: f64| f * l as f64;
    let last = p.len() - 1;
    let c = (at(k as f64 / window as f64).round() as usize).min(last);
    // Near a harmonic of the drive a periodic signal has a line (odd) or a gap between lines (even) of its
    // own, whatever the filter: no evidence either way.
    if let Some(h) = harmonics.filter(|h| h.is_finite() && *h > 0.0) {
        let off = (c as f64 / h - (c as f64 / h).round()).abs() * h;
        if off <= HARMONIC_GUARD_BINS {
            return None;
        }
    }
    let lo = at((k as f64 - 0.5) / window as f64).ceil().max(1.0) as usize;
    let hi = (at((k as f64 + 0.5) / window as f64).floor() as usize).min(last);
    let mut band: Vec<f64> = (lo..=hi).filter(|b| b.abs_diff(c) > 4).map(|b| p[b]).collect();
    if band.len() < MIN_BAND_BINS || c == 0 {
        return None;
    }
    // The band must be noise: ordinates four bins apart (nearly independent under this window) differ by
    // a factor of 3 at the median when they are exponential; a spectrum of leakage from a clean signal is
    // smooth, and its lowest bins are no noise level to compare with.
    let mut rough: Vec<f64> = band
        .windows(5)
        .map(|w| {
            (w[4].max(f64::MIN_POSITIVE) / w[0].max(f64::MIN_POSITIVE))
                .ln()
                .abs()
        })
        .collect();
    let mid = rough.len() / 2;
    if rough.is_empty() || *rough.select_nth_unstable_by(mid, f64::total_cmp).1 < MIN_ROUGHNESS {
        return None;
    }
    let peak = band.iter().copied().fold(0.0, f64::max);
    let q = ((band.len() - 1) as f64 * BAND_QUANTILE).round() as usize;
    let level = *band.select_nth_unstable_by(q, f64::total_cmp).1;
    // A line close beside the comb frequency makes it a gap between lines, whatever the filter: no evidence.
    let mut near =
        c.saturating_sub(HARMONIC_GUARD_BINS as usize)..=(c + HARMONIC_GUARD_BINS as usize).min(last);
    if near.any(|b| b.abs_diff(c) > 1 && p[b] > LINE_FACTOR * level) {
        return None;
    }
    // A line this far above the band's noise leaks through the window's sidelobes into the whole band:
    // the band's lowest bins are then leakage, and a gap between lines would pass for a zero.
    if level <= 0.0 || peak > LINE_TO_NOISE * level {
        return None;
    }
    let null = p[c - 1].min(p[c]).min(p[(c + 1).min(last)]);
    Some(
        (null.max(1e-300 * level) / level)
            .log10()
            .clamp(-DEPTH_CLAMP, 1.0),
    )
}

/// Depths of comb frequencies, summed (over comb frequencies, records and channels).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Tally {
    /// Summed depth of the comb frequencies counted, decades.
    pub depth: f64,
    /// Comb frequencies counted (not left out by `null_depth`).
    pub counted: f64,
    /// ... of them below their band's noise level.
    pub below: f64,
    /// Comb frequencies tried.
    pub tried: f64,
}

impl Tally {
    fn add(&mut self, o: Tally) {
        self.depth += o.depth;
        self.counted += o.counted;
        self.below += o.below;
        self.tried += o.tried;
    }
}

/// One channel's comb for one window (and, pooled, over records and channels): a [`Tally`] for each of
/// its first [`NULLS`] comb frequencies.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Comb {
    /// `at[k − 1]`: the `k`-th comb frequency, `k/window` cycles per sample.
    pub at: [Tally; NULLS],
}

impl Comb {
    fn add(&mut self, o: &Comb) {
        self.at.iter_mut().zip(&o.at).for_each(|(a, b)| a.add(*b));
    }

    /// Over every comb frequency.
    pub fn total(&self) -> Tally {
        self.except_multiples_of(usize::MAX)
    }

    /// Over the comb frequencies `k` that are not multiples of `m`: for a window `m` times another, the
    /// zeros that the other window's average does not have.
    pub(crate) fn except_multiples_of(&self, m: usize) -> Tally {
        let mut t = Tally::default();
        for (_, a) in self.at.iter().enumerate().filter(|(k, _)| (k + 1) % m != 0) {
            t.add(*a);
        }
        t
    }
}

/// The comb of every candidate window that `keep` accepts (2 to a 25th of the record, so that a band can
/// keep `MIN_BAND_BINS` bins) in one channel's periodogram.
pub(crate) fn comb_depths(
    y: &[f64],
    harmonics: Option<f64>,
    keep: impl Fn(usize) -> bool,
) -> Vec<(usize, Comb)> {
    if y.len() < 64 {
        return Vec::new();
    }
    let p = periodogram_of_differences(y);
    let l = y.len() - 1;
    (2..=l / 25)
        .filter(|&window| keep(window))
        .map(|window| {
            let mut comb = Comb::default();
            for k in 1..=(window / 2).min(NULLS) {
                let at = &mut comb.at[k - 1];
                at.tried = 1.0;
                if let Some(d) = null_depth(&p, l, window, k, harmonics) {
                    at.depth = d;
                    at.counted = 1.0;
                    at.below = f64::from(u8::from(d < 0.0));
                }
            }
            (window, comb)
        })
        .collect()
}

/// One test's channels, as [`detect_moving_average`] reads them.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Channels<'a> {
    pub t: &'a [f64],
    pub x: &'a [f64],
    /// Velocity, when the file measured it (one derived here from `x` has comb-like zeros of its own
    /// differentiator, and is no witness).
    pub v: Option<&'a [f64]>,
    pub f: &'a [f64],
}

/// A channel's summed comb against what white noise gives: `NOISE_MEAN − sigmas · NOISE_SD / √count`
/// decades a value, summed over `count` values.
fn need(sigmas: f64, count: f64) -> f64 {
    (NOISE_MEAN - sigmas * NOISE_SD / count.sqrt()) * count
}

/// A channel's comb: deep enough on average, most of its frequencies below the noise (a damper force's
/// gaps between harmonic lines can be deep, but every second comb frequency then sits on a line), and
/// most of the frequencies tried counted (a window whose other comb frequencies all sit beside lines
/// would be judged on its few that fall on a true comb).
fn channel_ok(c: Tally, sigmas: f64) -> bool {
    c.counted > 0.0
        && c.counted >= COUNTED_SHARE * c.tried
        && c.depth <= need(sigmas, c.counted)
        && c.below >= BELOW_SHARE * c.counted
}

/// How far a summed comb lies below white noise's mean, in noise spreads of the mean over its values.
fn sigmas(t: Tally) -> f64 {
    (NOISE_MEAN * t.counted - t.depth) / (NOISE_SD * t.counted.sqrt())
}

/// The combs of the windows `keep` accepts, pooled over `records`: the displacement's, the force's, and the
/// measured velocity's where the displacement shows the window on its own (it must, in [`evidence`]).
fn pooled_combs(records: &[Channels<'_>], keep: impl Fn(usize) -> bool + Copy) -> BTreeMap<usize, [Comb; 3]> {
    let mut pooled: BTreeMap<usize, [Comb; 3]> = BTreeMap::new();
    for r in records {
        // The force's own harmonics of the drive are no evidence (lines at the odd ones, gaps at the even
        // ones); a sine's displacement has neither, so it is the witness where the zeros fall on them.
        let dt = r.t[1] - r.t[0];
        let drive_bins = (r.x.len() - 1) as f64 * dt / dominant_period(r.x, dt);
        for (channel, y, harmonics) in [(X, r.x, None), (F, r.f, Some(drive_bins))] {
            for (window, comb) in comb_depths(y, harmonics, keep) {
                pooled.entry(window).or_default()[channel].add(&comb);
            }
        }
    }
    let shown: BTreeSet<usize> = pooled
        .iter()
        .filter(|(_, c)| channel_ok(c[X].total(), CHANNEL_SIGMAS))
        .map(|(&window, _)| window)
        .collect();
    for r in records {
        let dt = r.t[1] - r.t[0];
        if let Some(v) =
            r.v.filter(|v| !shown.is_empty() && is_first_difference(r.x, v, dt))
        {
            for (window, comb) in comb_depths(v, None, |w| shown.contains(&w)) {
                pooled.entry(window).or_default()[V].add(&comb);
            }
        }
    }
    pooled
}

/// The evidence a window has: the motion's comb (the displacement's, or the velocity's where that shows
/// it more clearly: one record of the motion through two roundings, so one witness, not two), with the
/// force's where the force can witness; `None` where a needed witness does not show it.
fn evidence([x, f, v]: &[Comb; 3]) -> Option<Comb> {
    if !channel_ok(x.total(), CHANNEL_SIGMAS) {
        return None;
    }
    let mut all = if channel_ok(v.total(), CHANNEL_SIGMAS) && sigmas(v.total()) > sigmas(x.total()) {
        *v
    } else {
        *x
    };
    let force_witness = |f: Tally| f.counted > 0.0 && f.counted >= COUNTED_SHARE * f.tried;
    if force_witness(f.total()) {
        if !channel_ok(f.total(), CHANNEL_SIGMAS) {
            return None;
        }
        all.add(f);
    }
    Some(all)
}

/// Records `detect_moving_average` and `confirm_moving_average` can read: some, each of 64 samples or
/// more on an even clock.
fn readable(records: &[Channels<'_>]) -> bool {
    !records.is_empty()
        && records
            .iter()
            .all(|r| r.t.len() >= 64 && crate::signal::uniform_interval(r.t).is_some())
}

/// The moving average that every record of `records` (tests of one protocol, on one even clock) went
/// through, from their combs pooled over the records; `None` without such a comb or without [`readable`]
/// records. The displacement must show the comb on its own (see [`evidence`]).
pub(crate) fn detect_moving_average(records: &[Channels<'_>]) -> Option<MovingAverage> {
    if !readable(records) {
        return None;
    }
    let pooled = pooled_combs(records, |_| true);
    // Every witness together strongly: far beyond what white noise does. Where most comb frequencies of the
    // force lie on the drive's harmonics or beside lines, the motion alone must show it as strongly as the
    // motion and the force together otherwise would have to.
    let passing: Vec<(usize, Comb)> = pooled
        .iter()
        .filter_map(|(&window, combs)| evidence(combs).map(|all| (window, all)))
        .filter(|(_, all)| {
            let t = all.total();
            t.depth <= need(COMB_SIGMAS, t.counted)
        })
        .collect();
    // Every zero of a window is a zero of each multiple of it: a window whose multiple passes too, with
    // the zeros of its own that the window lacks showing clearly, is that multiple's comb seen in part.
    let explained = |window: usize| {
        passing.iter().any(|(longer, all)| {
            longer % window == 0
                && *longer > window
                && channel_ok(all.except_multiples_of(longer / window), CHANNEL_SIGMAS)
        })
    };
    // Of the others, the one whose comb stands out most from white noise (in noise spreads of its mean over
    // every value counted): a window a sample off has its zeros drifting off the true ones, so shallower
    // ones, and twice the window has a peak where every second zero of its own would be.
    passing
        .iter()
        .filter(|(window, _)| !explained(*window))
        .map(|(window, all)| (sigmas(all.total()), shown(*window, all, false)))
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, m)| m)
}

/// Whether the records show the comb of one window named beforehand ([`window_law`]), with the witnesses
/// [`detect_moving_average`] asks for but at [`CONFIRM_SIGMAS`] together (one hypothesis, not the best of many).
pub(crate) fn confirm_moving_average(records: &[Channels<'_>], window: usize) -> Option<MovingAverage> {
    if !readable(records) || window < 2 {
        return None;
    }
    let pooled = pooled_combs(records, |w| w == window);
    let all = evidence(pooled.get(&window)?)?;
    let t = all.total();
    (t.depth <= need(CONFIRM_SIGMAS, t.counted)).then(|| shown(window, &all, true))
}

/// The moving average of `window` whose pooled comb is `all`.
fn shown(window: usize, all: &Comb, predicted: bool) -> MovingAverage {
    let t = all.total();
    MovingAverage {
        window,
        mean_depth: t.depth / t.counted,
        predicted,
    }
}

/// The share of the drive period that the moving average of every protocol in `found` (window, sample
/// interval s, drive period s) spans, where there is one: two protocols or more, each window within half a
/// sample of the median share of its period (a source filtering over a fixed share: the UTFSM tests, a tenth).
pub(crate) fn window_law(found: &[(usize, f64, f64)]) -> Option<f64> {
    if found.len() < 2 {
        return None;
    }
    let mut shares: Vec<f64> = found.iter().map(|&(w, dt, p)| w as f64 * dt / p).collect();
    shares.sort_by(f64::total_cmp);
    let share = shares[shares.len() / 2];
    let fits = found
        .iter()
        .all(|&(w, dt, p)| (share * p / dt - w as f64).abs() <= 0.5);
    (share.is_finite() && share > 0.0 && fits).then_some(share)
}

/// Whether the velocity `v` is the backward first difference of the displacement `x` before its rounding:
/// closer to it by half in rms than to a difference over two samples or one a sample later. Only such a
/// velocity carries the displacement's comb and no other.
fn is_first_difference(x: &[f64], v: &[f64], dt: f64) -> bool {
    if v.len() != x.len() || x.len() < 3 {
        return false;
    }
    let (mut back, mut two, mut later) = (0.0, 0.0, 0.0);
    for k in 2..x.len() {
        let d = (x[k] - x[k - 1]) / dt;
        back += (v[k] - d).powi(2);
        two += (v[k] - (x[k] - x[k - 2]) / (2.0 * dt)).powi(2);
        later += (v[k - 1] - d).powi(2);
    }
    back < 0.25 * two.min(later)
}

/// The witnesses' places in a window's pooled combs.
const X: usize = 0;
const F: usize = 1;
const V: usize = 2;

/// Period of the strongest spectral line of `x` (mean removed, Hann window, the peak placed between bins by a
/// parabola through the log magnitudes: a tenth of a bin or better), s; NaN for fewer than 8 samples.
pub(crate) fn dominant_period(x: &[f64], dt: f64) -> f64 {
    let n = x.len();
    if n < 8 {
        return f64::NAN;
    }
    let power = power_spectrum(x, |a| 0.5 - 0.5 * a.cos());
    let mag = |b: usize| power[b].max(f64::MIN_POSITIVE).ln();
    let top = n / 2;
    let best = (1..top).max_by(|&a, &b| mag(a).total_cmp(&mag(b))).unwrap_or(1);
    let (a, b, c) = (mag(best - 1), mag(best), mag(best + 1));
    let den = a - 2.0 * b + c;
    let shift = if best > 1 && best + 1 < top && den < 0.0 {
        (0.5 * (a - c) / den).clamp(-0.5, 0.5)
    } else {
        0.0
    };
    n as f64 * dt / (best as f64 + shift)
}

/// The signal `u` (`y.len() + window − 1` samples, the first `window − 1` before `y`'s first) whose causal
/// moving average of `window` samples is `y`: `min |A u − y|² + μ |Δ²u|²`, `μ = c (N/2π)⁴` ([`PENALTY`]),
/// solved by a banded Cholesky factorisation (half-bandwidth `max(window − 1, 2)`).
pub(crate) fn deconvolve_moving_average(y: &[f64], window: usize) -> Vec<f64> {
    let n = y.len();
    if window <= 1 || n == 0 {
        return y.to_vec();
    }
    let lead = window - 1;
    let p = lead.max(2);
    let m = n + lead;
    let inv = 1.0 / window as f64;
    let mu = PENALTY * (window as f64 / (2.0 * std::f64::consts::PI)).powi(4);
    // Lower band of M = AᵀA + μ DᵀD, row-major: band[i * (p + 1) + d] = M[i, i − d].
    let w = p + 1;
    let mut band = vec![0.0; m * w];
    for i in 0..m {
        for d in 0..=lead.min(i) {
            let j = i - d;
            // Rows r of A cover columns r..=r + lead; both j and i: r in [i − lead, j] ∩ [0, n − 1].
            let lo = i.saturating_sub(lead);
            let hi = j.min(n - 1);
            if hi >= lo {
                band[i * w + d] = (hi - lo + 1) as f64 * inv * inv;
            }
        }
    }
    // μ DᵀD of the second difference, row by row of D (stencil 1, −2, 1 at r, r + 1, r + 2).
    const STENCIL: [f64; 3] = [1.0, -2.0, 1.0];
    for r in 0..m.saturating_sub(2) {
        for (a, ca) in STENCIL.iter().enumerate() {
            for (b, cb) in STENCIL.iter().enumerate().take(a + 1) {
                band[(r + a) * w + (a - b)] += mu * ca * cb;
            }
        }
    }
    // Aᵀy by prefix sums.
    let mut prefix = vec![0.0; n + 1];
    for k in 0..n {
        prefix[k + 1] = prefix[k] + y[k];
    }
    let mut rhs: Vec<f64> = (0..m)
        .map(|j| {
            let lo = j.saturating_sub(lead);
            let hi = j.min(n - 1);
            if hi >= lo {
                (prefix[hi + 1] - prefix[lo]) * inv
            } else {
                0.0
            }
        })
        .collect();
    // Banded Cholesky, in place: band[i * w + d] becomes L[i, i − d].
    for i in 0..m {
        for d in (0..=p.min(i)).rev() {
            let j = i - d;
            let mut s = band[i * w + d];
            // Σ_k L[i, k] L[j, k] over k in [i − p, j).
            let k0 = i.saturating_sub(p);
            for k in k0..j {
                s -= band[i * w + (i - k)] * band[j * w + (j - k)];
            }
            if d == 0 {
                band[i * w] = s.max(f64::MIN_POSITIVE).sqrt();
            } else {
                band[i * w + d] = s / band[j * w];
            }
        }
    }
    // L z = rhs, then Lᵀ u = z.
    for i in 0..m {
        let mut s = rhs[i];
        for k in i.saturating_sub(p)..i {
            s -= band[i * w + (i - k)] * rhs[k];
        }
        rhs[i] = s / band[i * w];
    }
    for i in (0..m).rev() {
        let mut s = rhs[i];
        for k in i + 1..(i + w).min(m) {
            s -= band[k * w + (k - i)] * rhs[k];
        }
        rhs[i] = s / band[i * w];
    }
    rhs
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::noise;
    use crate::signal::moving_average;

    /// A sine test as a rig logs it.
    struct Logged {
        t: Vec<f64>,
        x: Vec<f64>,
        /// Velocity: the difference of the filtered (unrounded) displacement over `span` samples.
        v: Vec<f64>,
        f: Vec<f64>,
    }

    impl Logged {
        fn channels(&self, with_velocity: bool) -> Channels<'_> {
            Channels {
                t: &self.t,
                x: &self.x,
                v: with_velocity.then_some(self.v.as_slice()),
                f: &self.f,
            }
        }
    }

    /// The test protocol of [`logged_sine`].
    #[derive(Clone, Copy)]
    struct Protocol {
        n: usize,
        fs: f64,
        f0: f64,
        window: usize,
        /// Displacement noise before the filter, m (rounding after it: 0.1 µm, as the UTFSM files).
        x_noise: f64,
        /// Samples the logged velocity is differenced over.
        span: usize,
    }

    /// A sine test through a causal moving average: white noise before the filter, rounding after it
    /// (0.1 µm, 1 µm/s, 0.01 N), the velocity differenced from the filtered displacement.
    fn logged_sine(p: Protocol, seed: u64) -> Logged {
        let (n, window, span, dt) = (p.n, p.window, p.span, 1.0 / p.fs);
        // `span` samples more than the record before it, for the first differences.
        let m = n + span + window - 1;
        let phase =
            |k: usize| 2.0 * std::f64::consts::PI * p.f0 * (k as f64 - (span + window - 1) as f64) * dt;
        let nz = noise(m, p.x_noise, seed);
        let u: Vec<f64> = (0..m).map(|k| 0.01 * phase(k).sin() + nz[k]).collect();
        let fnz = noise(m, 5.0, seed + 1);
        let f_true: Vec<f64> = (0..m)
            .map(|k| 1000.0 * (phase(k).cos() / 0.1).tanh() + fnz[k])
            .collect();
        let round = |v: f64, q: f64| (v / q).round() * q;
        let xf = moving_average(&u, window);
        let x = xf[span..].iter().map(|&v| round(v, 1e-7)).collect();
        let v = (span..xf.len())
            .map(|k| round((xf[k] - xf[k - span]) / (span as f64 * dt), 1e-6))
            .collect();
        let f = moving_average(&f_true, window)[span..]
            .iter()
            .map(|&v| round(v, 0.01))
            .collect();
        let t = (0..n).map(|k| k as f64 * dt).collect();
        Logged { t, x, v, f }
    }

    /// The three clocks and windows of the UTFSM tests (a tenth of the period), and two others.
    const PROTOCOLS: [(usize, f64, f64, usize); 5] = [
        (11000, 1000.0, 1.0, 100),
        (4600, 200.0, 0.25, 80),
        (450, 200.0, 5.0, 4),
        (6000, 2000.0, 2.0, 37),
        (3000, 500.0, 3.0, 9),
    ];

    fn protocol((n, fs, f0, window): (usize, f64, f64, usize), x_noise: f64) -> Protocol {
        Protocol {
            n,
            fs,
            f0,
            window,
            x_noise,
            span: 1,
        }
    }

    #[test]
    fn the_window_of_a_moving_average_is_found_from_its_comb() {
        // Five tests of each protocol pooled, as `load_tests` pools them, without their velocities.
        for p in PROTOCOLS {
            let p = protocol(p, 2e-6);
            for trial in 0..2u64 {
                let tests: Vec<_> = (0..5u64)
                    .map(|k| logged_sine(p, 100 * trial + 10 * k + p.window as u64))
                    .collect();
                let records: Vec<_> = tests.iter().map(|r| r.channels(false)).collect();
                let got = detect_moving_average(&records);
                assert_eq!(
                    got.map(|m| m.window),
                    Some(p.window),
                    "{} Hz, window {}, trial {trial}: {got:?}",
                    p.fs,
                    p.window
                );
            }
        }
    }

    #[test]
    fn a_velocity_differenced_from_the_filtered_displacement_shows_the_window_in_one_test() {
        // One test alone, as `validate` reads a held-out file: the displacement's rounding (0.1 µm) leaves
        // its comb too shallow to decide on its own, the velocity's finer one (1 µm/s) does not. (Not the
        // 450-sample protocol: its window has two comb frequencies, and two can show at most 5.6 spreads.)
        let (mut without, mut tries) = (0, 0);
        for p in PROTOCOLS.into_iter().filter(|p| p.0 != 450) {
            let p = protocol(p, 2e-6);
            for seed in 0..4u64 {
                let test = logged_sine(p, 1000 + 10 * seed + p.window as u64);
                let got = detect_moving_average(&[test.channels(true)]).map(|m| m.window);
                assert_eq!(got, Some(p.window), "{} Hz, seed {seed}", p.fs);
                // (The displacement alone found a window a sample too long in one of these.)
                let alone = detect_moving_average(&[test.channels(false)]).map(|m| m.window);
                without += usize::from(alone == Some(p.window));
                tries += 1;
            }
        }
        assert!(
            without < tries / 2,
            "the displacement alone: {without} of {tries}, with the velocity all"
        );
    }

    #[test]
    fn a_velocity_that_is_no_first_difference_is_no_witness() {
        // The same tests with a velocity differenced over 3 samples (a rig's smoothing differentiator, the
        // comb of a 3-sample average of its own): no witness, the detection as without it.
        for p in PROTOCOLS.into_iter().filter(|p| p.0 != 450) {
            let p = Protocol {
                span: 3,
                ..protocol(p, 2e-6)
            };
            for seed in 0..4u64 {
                let test = logged_sine(p, 1000 + 10 * seed + p.window as u64);
                assert!(!is_first_difference(&test.x, &test.v, 1.0 / p.fs));
                assert_eq!(
                    detect_moving_average(&[test.channels(true)]),
                    detect_moving_average(&[test.channels(false)])
                );
            }
            let direct = logged_sine(Protocol { span: 1, ..p }, 7);
            assert!(is_first_difference(&direct.x, &direct.v, 1.0 / p.fs));
        }
    }

    /// One of 200 unfiltered sine tests with white noise on every channel (four clocks and lengths, two
    /// displacement noise levels), the velocity differenced over one sample or smoothed over several (a
    /// rig's differentiator: a comb in the velocity alone).
    fn white_noise_record(seed: u64) -> (Logged, Protocol) {
        let (n, fs) = [(2000, 1000.0), (450, 200.0), (5000, 500.0), (8000, 2000.0)][seed as usize % 4];
        let p = Protocol {
            n,
            fs,
            f0: 1.7,
            window: 1,
            x_noise: [2e-6, 2e-8][seed as usize % 2],
            span: [1, 5, 10, 16][(seed as usize / 4) % 4],
        };
        (logged_sine(p, seed), p)
    }

    #[test]
    fn white_noise_shows_no_comb() {
        // No window in any of the unfiltered records, with their velocities or without.
        for seed in 0..100u64 {
            let (test, p) = white_noise_record(seed);
            for with_velocity in [false, true] {
                let got = detect_moving_average(&[test.channels(with_velocity)]);
                assert_eq!(
                    got, None,
                    "seed {seed}, span {}, velocity {with_velocity}",
                    p.span
                );
            }
        }
    }

    #[test]
    fn a_predicted_window_is_confirmed_in_one_short_test_where_no_window_is_found() {
        // The UTFSM 2mm5Hz clock alone (450 samples at 200 Hz, a window of 4): two comb frequencies, too few
        // for the search over every window, enough to confirm the one window predicted. Windows a sample
        // off are not confirmed, nor is the window in a test that was not filtered.
        let mut confirmed = 0;
        for seed in 0..20u64 {
            let filtered = logged_sine(protocol(PROTOCOLS[2], 2e-6), 1000 + seed);
            for with_velocity in [false, true] {
                let records = [filtered.channels(with_velocity)];
                assert_eq!(detect_moving_average(&records), None, "seed {seed}");
                if confirm_moving_average(&records, 4).is_some_and(|m| m.window == 4 && m.predicted) {
                    confirmed += 1;
                }
                for off in [3, 5, 6] {
                    assert_eq!(
                        confirm_moving_average(&records, off),
                        None,
                        "seed {seed}, window {off}"
                    );
                }
            }
            let unfiltered = logged_sine(protocol((450, 200.0, 5.0, 1), 2e-6), 2000 + seed);
            assert_eq!(
                confirm_moving_average(&[unfiltered.channels(true)], 4),
                None,
                "seed {seed}"
            );
        }
        assert!(confirmed >= 36, "confirmed in {confirmed} of 40");
    }

    #[test]
    fn white_noise_rarely_confirms_a_predicted_window() {
        // One window tested at 3 noise spreads (a one-sided normal tail of 0.13 %): over the 100 unfiltered
        // records of `white_noise_shows_no_comb` and four predicted windows each (400 tries), a handful at
        // most (at 1 % false confirmations, 4 would be expected).
        let mut passed = Vec::new();
        for seed in 0..100u64 {
            let (test, _) = white_noise_record(seed);
            for window in [4, 9, 12, 17] {
                if confirm_moving_average(&[test.channels(seed % 3 == 0)], window).is_some() {
                    passed.push((seed, window));
                }
            }
        }
        assert!(passed.len() <= 3, "{} of 400 confirmed: {passed:?}", passed.len());
    }

    #[test]
    fn a_share_of_the_period_is_a_law_only_where_every_protocol_keeps_it() {
        // The UTFSM protocols: a tenth of the period at 1 kHz/1 Hz, 200 Hz/0.25 Hz and 200 Hz/5 Hz.
        let utfsm = [(100, 0.001, 1.0), (80, 0.005, 4.0), (4, 0.005, 0.2)];
        let share = window_law(&utfsm).expect("a tenth");
        assert!((share - 0.1).abs() < 1e-12, "{share}");
        assert_eq!(window_law(&utfsm[..1]), None, "one protocol is no law");
        // A fixed window in time (20 ms at both clocks) is no share of the period.
        assert_eq!(window_law(&[(20, 0.001, 1.0), (4, 0.005, 0.2)]), None);
    }

    #[test]
    fn deconvolution_recovers_the_motion_inside_the_pass_band() {
        // A sine plus its third harmonic through a window of a tenth of the period: the average shrinks the
        // fundamental by 1.6 % and the harmonic by 14 % and delays both by half the window; the recovered
        // motion must match the original (including the lead-in before the record) to a small fraction of
        // either change.
        let (fs, f0, window, n) = (1000.0, 1.0, 100usize, 5000usize);
        let m = n + window - 1;
        let w = 2.0 * std::f64::consts::PI * f0 / fs;
        let u: Vec<f64> = (0..m)
            .map(|k| 0.01 * (w * k as f64).sin() + 0.002 * (3.0 * w * k as f64 + 0.4).sin())
            .collect();
        let rms = |a: &[f64], b: &[f64]| {
            (a.iter().zip(b).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / a.len() as f64).sqrt()
        };
        let y = moving_average(&u, window);
        let filt_err = rms(&y, &u[window - 1..]);
        let r = deconvolve_moving_average(&y, window);
        assert_eq!(r.len(), m);
        // Away from the first and last periods, where the record's ends leave the fit less determined.
        let err = rms(&r[window..m - window], &u[window..m - window]);
        assert!(
            err < 0.01 * filt_err,
            "recovered rms error {err:e} m against the filter's {filt_err:e} m"
        );
        // The whole record, ends included, to 2 % of the filter's change.
        let all = rms(&r, &u);
        assert!(all < 0.02 * filt_err, "whole record: {all:e} m");
        // And the recovered motion filtered again is the data.
        let fit = rms(&moving_average(&r, window), &y);
        assert!(fit < 1e-3 * filt_err, "refiltered misfit {fit:e} m");
    }

    #[test]
    fn moving_average_is_the_mean_of_the_last_window_samples() {
        let f = [1.0, 2.0, 6.0, 3.0, 8.0];
        assert_eq!(moving_average(&f, 3), vec![3.0, 11.0 / 3.0, 17.0 / 3.0]);
        assert_eq!(moving_average(&f, 1), f.to_vec());
    }
}
