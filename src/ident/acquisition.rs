//! The acquisition chain: a moving-average filter that the data went through before it was logged, found in
//! the data and put into the comparison.
//!
//! Why: a test rig's software often smooths its channels before it writes them. A causal moving average of
//! `N` samples on the force and the displacement (the UTFSM tests in `shared/data` were filtered so by their
//! source: a tenth of the drive period on both channels, the velocity then differenced from the filtered
//! displacement) smears the force's turn at every reversal over `N` samples and delays both channels by
//! `(N − 1)/2` samples. A damper model driven by the filtered motion then has to bend its pre-yield branch to
//! match a smear that belongs to the filter, and the bend does not carry over to a test at another
//! amplitude or frequency: the window is a fixed share of the period, so in displacement it scales with the
//! amplitude. The model is compared with such data as the measurement chain saw it instead:
//!
//! 1. [`detect_moving_average`]: the filter leaves a comb of zeros in the spectrum of both channels, at
//!    every multiple of `fs/N`. For each candidate window the periodogram at its first (up to [`NULLS`])
//!    comb frequencies is compared with the noise level of the band around each ([`null_depth`]), pooled
//!    over the tests of one protocol (one clock, one drive period: they went through one chain). Both
//!    channels together must show it far beyond what white noise does ([`COMB_SIGMAS`]), and each on its
//!    own clearly ([`CHANNEL_SIGMAS`]) with most of its comb frequencies below the noise ([`BELOW_SHARE`]).
//!    A damper's force has lines at the odd harmonics and gaps at the even ones, which must not pass for a
//!    comb: the periodogram's window has low sidelobes, and a band counts only where it is noise
//!    ([`MIN_ROUGHNESS`]) and no line in it is strong enough to leak through the sidelobes
//!    ([`LINE_TO_NOISE`]). Near the drive's harmonics the force is no witness at all
//!    ([`HARMONIC_GUARD_BINS`]); where that leaves it nothing, the displacement alone must show the comb as
//!    strongly as both channels together otherwise would. White noise gives no window (200 unfiltered tests in
//!    `tests::white_noise_shows_no_comb`), nor do the hidden-effect sweeps' data sets.
//! 2. [`deconvolve_moving_average`]: the motion before the filter, by regularised least squares, with the
//!    `N − 1` samples before the record that the first filtered samples averaged. The penalty on the
//!    motion's second difference leaves what lies well inside the filter's pass band as it was and holds
//!    the noise gain at the first zero to 5.
//! 3. The model is driven by that motion from `N − 1` samples before the record ([`Drive`]), and its force
//!    goes through the same moving average ([`moving_average`]) before it is compared with the file.
//!
//! Whether the filter was causal or centred does not matter for a test at constant current: a centred one
//! makes the reconstructed motion `(N − 1)/2` samples early, the model's force is early by as much, and the
//! causal average put back on it lands where the centred one did.

use rustfft::num_complex::Complex;
use rustfft::FftPlanner;

use crate::device::Inputs;

/// Comb frequencies checked per candidate window (the first ones, up to the Nyquist frequency).
pub const NULLS: usize = 8;
/// The depth of one comb frequency on white noise ([`null_depth`]: the least of three ordinates against
/// the band's 20th percentile), measured over 2,731 of them in records of 450–8,000 samples: mean, decades.
const NOISE_MEAN: f64 = 0.04;
/// ... and its spread, decades.
const NOISE_SD: f64 = 0.64;
/// Both channels' combs together must lie this many noise spreads of a mean below white noise's, over
/// their `M` values (tests × channels × comb frequencies): `NOISE_MEAN − Z · NOISE_SD / √M` (−0.92 decades
/// for one test of eight comb frequencies, −1.88 for one of two). On white noise the deepest comb of any
/// candidate window, in one channel of 200 records, lay 5.4 spreads below.
pub const COMB_SIGMAS: f64 = 6.0;
/// ... and each channel on its own this many: the motion and the force went through one filter.
pub const CHANNEL_SIGMAS: f64 = 2.0;
/// ... with at least this share of each channel's comb frequencies below their band's noise level (white
/// noise: about 45 %).
pub const BELOW_SHARE: f64 = 2.0 / 3.0;
/// ... and at least this share of the comb frequencies tried left to count in it (not beside a line).
pub const COUNTED_SHARE: f64 = 0.75;
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
}

/// The model's drive for a test whose channels went through a moving average: the motion before the
/// filter from `window − 1` samples before the record on, and the window the model's force goes through.
#[derive(Debug, Clone)]
pub struct Drive {
    pub filter: MovingAverage,
    /// `window − 1` lead-in samples, then one per sample of the test.
    pub inputs: Vec<Inputs>,
}

impl Drive {
    pub fn window(&self) -> usize {
        self.filter.window
    }
}

/// Periodogram (|FFT|², 4-term Blackman–Harris window) of the first difference of `y`: the difference
/// whitens a signal whose power falls with frequency, so a zero of the filter stands out against the band
/// around it. The window's sidelobes (−92 dB) keep a damper force's harmonic lines out of the gaps between
/// them: under a Hann window (−31 dB) their leakage filled the bands, and the gaps at the even harmonics
/// looked like a comb for every window of a whole number of half periods.
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
        .map(|(k, v)| {
            Complex::new(
                (v - mean) * window(2.0 * std::f64::consts::PI * k as f64 / n as f64),
                0.0,
            )
        })
        .collect();
    FftPlanner::new().plan_fft_forward(n).process(&mut buf);
    buf[..n / 2 + 1].iter().map(|c| c.norm_sqr()).collect()
}

/// Depth, decades (negative = a dip), of the periodogram `p` (of `l` points) at `k/window` cycles per
/// sample: the least of the three bins around it against the noise level of its band (half a comb spacing
/// on either side, clipped at the Nyquist frequency, the nine bins of the window's main lobe left out;
/// [`BAND_QUANTILE`]). `None` when fewer than [`MIN_BAND_BINS`] bins are left in the band, when the band is
/// not noise, and within [`HARMONIC_GUARD_BINS`] of a multiple of `harmonics` (the drive frequency in
/// bins, given for a channel whose own harmonics fill its spectrum), or with a line ([`LINE_FACTOR`])
/// within as many bins of it.
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

/// One channel's comb for one window, summed over comb frequencies (and, pooled, over records).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Comb {
    /// Summed depth of the comb frequencies counted, decades.
    pub depth: f64,
    /// Comb frequencies counted (not left out by [`null_depth`]).
    pub counted: f64,
    /// ... of them below their band's noise level.
    pub below: f64,
    /// Comb frequencies tried.
    pub tried: f64,
}

impl Comb {
    fn add(&mut self, o: Comb) {
        self.depth += o.depth;
        self.counted += o.counted;
        self.below += o.below;
        self.tried += o.tried;
    }
}

/// The comb of every candidate window (2 to a 25th of the record, so that a band can keep
/// [`MIN_BAND_BINS`] bins) in one channel's periodogram.
pub fn comb_depths(y: &[f64], harmonics: Option<f64>) -> Vec<(usize, Comb)> {
    if y.len() < 64 {
        return Vec::new();
    }
    let p = periodogram_of_differences(y);
    let l = y.len() - 1;
    (2..=l / 25)
        .map(|window| {
            let tried = (window / 2).min(NULLS);
            let mut comb = Comb {
                tried: tried as f64,
                ..Comb::default()
            };
            for k in 1..=tried {
                if let Some(d) = null_depth(&p, l, window, k, harmonics) {
                    comb.depth += d;
                    comb.counted += 1.0;
                    comb.below += f64::from(u8::from(d < 0.0));
                }
            }
            (window, comb)
        })
        .collect()
}

/// The moving average that the displacement `x` and force `f` of every record in `records` (tests of one
/// protocol, on one even clock) went through, from their combs pooled over the records (see the module's
/// notes); `None` without such a comb, on an uneven clock, or with fewer than 64 samples in a record.
pub fn detect_moving_average(records: &[(&[f64], &[f64], &[f64])]) -> Option<MovingAverage> {
    if records.is_empty()
        || records
            .iter()
            .any(|(t, _, _)| t.len() < 64 || crate::measurement::uniform_interval(t).is_none())
    {
        return None;
    }
    // Pooled per window: the displacement's comb and the force's.
    let mut pooled: std::collections::BTreeMap<usize, [Comb; 2]> = Default::default();
    for (t, x, f) in records {
        // The force's own harmonics of the drive (in bins of its differences' periodogram) are no evidence:
        // a damper's force has lines at the odd ones and gaps at the even ones. The displacement of a sine
        // test has neither, so it is the witness where the filter's zeros fall on the drive's harmonics
        // (the UTFSM source's window is a tenth of the period: every zero on an even harmonic).
        let dt = t[1] - t[0];
        let drive_bins = (x.len() - 1) as f64 * dt / dominant_period(x, dt);
        for (channel, y, harmonics) in [(0, x, None), (1, f, Some(drive_bins))] {
            for (window, comb) in comb_depths(y, harmonics) {
                pooled.entry(window).or_default()[channel].add(comb);
            }
        }
    }
    let need = |sigmas: f64, count: f64| (NOISE_MEAN - sigmas * NOISE_SD / count.sqrt()) * count;
    // A channel's comb: deep enough on average, most of its frequencies below the noise (a damper force's
    // gaps between harmonic lines can be deep, but every second comb frequency then sits on a line), and
    // most of the frequencies tried counted (a window whose other comb frequencies all sit beside lines
    // would be judged on its few that fall on a true comb).
    let channel_ok = |c: Comb, sigmas: f64| {
        c.counted > 0.0
            && c.counted >= COUNTED_SHARE * c.tried
            && c.depth <= need(sigmas, c.counted)
            && c.below >= BELOW_SHARE * c.counted
    };
    // Both channels, each clearly and together strongly; or, where most comb frequencies of the force lie
    // on the drive's harmonics or beside lines, the displacement alone as strongly as both together would
    // have to.
    let force_witness = |f: Comb| f.counted > 0.0 && f.counted >= COUNTED_SHARE * f.tried;
    let passes = |x: Comb, f: Comb| {
        if force_witness(f) {
            channel_ok(x, CHANNEL_SIGMAS)
                && channel_ok(f, CHANNEL_SIGMAS)
                && x.depth + f.depth <= need(COMB_SIGMAS, x.counted + f.counted)
        } else {
            channel_ok(x, COMB_SIGMAS)
        }
    };
    // Of the windows that pass, the one whose comb stands out most from white noise (in noise spreads of
    // its mean over every value counted): a window's half has only every second zero of the window's, so
    // fewer values, and a window a sample off has its zeros drifting off the true ones, so shallower ones;
    // twice the window has a peak where its first zero would be and does not pass.
    let sigmas = |sum: f64, count: f64| (NOISE_MEAN * count - sum) / (NOISE_SD * count.sqrt());
    pooled
        .into_iter()
        .filter(|(_, [x, f])| passes(*x, *f))
        .map(|(window, [x, f])| {
            let (sum, count) = if force_witness(f) {
                (x.depth + f.depth, x.counted + f.counted)
            } else {
                (x.depth, x.counted)
            };
            (
                sigmas(sum, count),
                MovingAverage {
                    window,
                    mean_depth: sum / count,
                },
            )
        })
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map(|(_, m)| m)
}

/// Period of the strongest spectral line of `x` (mean removed, Hann window, the peak placed between bins by a
/// parabola through the log magnitudes: a tenth of a bin or better), s; NaN for fewer than 8 samples.
pub fn dominant_period(x: &[f64], dt: f64) -> f64 {
    let n = x.len();
    if n < 8 {
        return f64::NAN;
    }
    let power = power_spectrum(x, |a| 0.5 - 0.5 * a.cos());
    let mag = |b: usize| power[b].max(f64::MIN_POSITIVE).ln();
    let top = n / 2;
    let best = (1..top).max_by(|&a, &b| mag(a).total_cmp(&mag(b))).unwrap_or(1);
    let shift = if best > 1 && best + 1 < top {
        let (a, b, c) = (mag(best - 1), mag(best), mag(best + 1));
        let den = a - 2.0 * b + c;
        if den < 0.0 {
            (0.5 * (a - c) / den).clamp(-0.5, 0.5)
        } else {
            0.0
        }
    } else {
        0.0
    };
    n as f64 * dt / (best as f64 + shift)
}

/// The causal moving average of `window` samples over `f` (which starts `window − 1` samples before the
/// first output): `f.len() − window + 1` values.
pub fn moving_average(f: &[f64], window: usize) -> Vec<f64> {
    if window <= 1 {
        return f.to_vec();
    }
    let mut out = Vec::with_capacity(f.len().saturating_sub(window - 1));
    let mut sum: f64 = f[..window - 1].iter().sum();
    for k in window - 1..f.len() {
        sum += f[k];
        out.push(sum / window as f64);
        sum -= f[k + 1 - window];
    }
    out
}

/// The signal `u` (`y.len() + window − 1` samples, the first `window − 1` before `y`'s first) whose causal
/// moving average of `window` samples is `y`: `min |A u − y|² + μ |Δ²u|²`, `μ = c (N/2π)⁴` with
/// `c` = 0.01 (the penalty reaches the data's weight at the filter's first zero, and at the fundamental of
/// a test whose window is a tenth of its period it is 10⁻⁶ of it), solved by a banded Cholesky
/// factorisation (half-bandwidth `max(window − 1, 2)`).
pub fn deconvolve_moving_average(y: &[f64], window: usize) -> Vec<f64> {
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
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn noise(n: usize, sd: f64, seed: u64) -> Vec<f64> {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let d = Normal::new(0.0, sd).unwrap();
        (0..n).map(|_| d.sample(&mut rng)).collect()
    }

    /// A sine test through a causal moving average, with white noise before the filter and rounding after.
    fn filtered_sine(n: usize, fs: f64, f0: f64, window: usize, seed: u64) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
        let dt = 1.0 / fs;
        let m = n + window - 1;
        let nz = noise(m, 2e-6, seed);
        let u: Vec<f64> = (0..m)
            .map(|k| {
                0.01 * (2.0 * std::f64::consts::PI * f0 * (k as f64 - (window - 1) as f64) * dt).sin() + nz[k]
            })
            .collect();
        let fnz = noise(m, 5.0, seed + 1);
        let f_true: Vec<f64> = (0..m)
            .map(|k| {
                let v = (2.0 * std::f64::consts::PI * f0 * (k as f64 - (window - 1) as f64) * dt).cos();
                1000.0 * (v / 0.1).tanh() + fnz[k]
            })
            .collect();
        let round = |v: f64, q: f64| (v / q).round() * q;
        let x: Vec<f64> = moving_average(&u, window)
            .into_iter()
            .map(|v| round(v, 1e-7))
            .collect();
        let f: Vec<f64> = moving_average(&f_true, window)
            .into_iter()
            .map(|v| round(v, 0.01))
            .collect();
        let t: Vec<f64> = (0..n).map(|k| k as f64 * dt).collect();
        (t, x, f)
    }

    #[test]
    fn the_window_of_a_moving_average_is_found_from_its_comb() {
        // The three clocks and windows of the UTFSM tests (a tenth of the period), and two others; five
        // tests of each protocol pooled, as `load_tests` pools them.
        for (n, fs, f0, window) in [
            (11000, 1000.0, 1.0, 100),
            (4600, 200.0, 0.25, 80),
            (450, 200.0, 5.0, 4),
            (6000, 2000.0, 2.0, 37),
            (3000, 500.0, 3.0, 9),
        ] {
            for trial in 0..2u64 {
                let tests: Vec<_> = (0..5u64)
                    .map(|k| filtered_sine(n, fs, f0, window, 100 * trial + 10 * k + window as u64))
                    .collect();
                let records: Vec<(&[f64], &[f64], &[f64])> = tests
                    .iter()
                    .map(|(t, x, f)| (t.as_slice(), x.as_slice(), f.as_slice()))
                    .collect();
                let got = detect_moving_average(&records);
                assert_eq!(
                    got.map(|m| m.window),
                    Some(window),
                    "{fs} Hz, window {window}, trial {trial}: {got:?}"
                );
            }
        }
    }

    #[test]
    fn white_noise_shows_no_comb() {
        // Unfiltered sine tests with white noise on both channels: no window may be found.
        for seed in 0..200u64 {
            let (n, fs) = [(2000, 1000.0), (450, 200.0), (5000, 500.0), (8000, 2000.0)][seed as usize % 4];
            let (t, x, f) = filtered_sine(n, fs, 1.7, 1, seed);
            assert_eq!(detect_moving_average(&[(&t, &x, &f)]), None, "seed {seed}");
        }
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
        let y = moving_average(&u, window);
        let filt_err = (y
            .iter()
            .zip(&u[window - 1..])
            .map(|(a, b)| (a - b).powi(2))
            .sum::<f64>()
            / n as f64)
            .sqrt();
        let r = deconvolve_moving_average(&y, window);
        assert_eq!(r.len(), m);
        // Away from the first and last periods, where the record's ends leave the fit less determined.
        let inner = window..m - window;
        let err = (inner.clone().map(|k| (r[k] - u[k]).powi(2)).sum::<f64>() / inner.len() as f64).sqrt();
        assert!(
            err < 0.01 * filt_err,
            "recovered rms error {err:e} m against the filter's {filt_err:e} m"
        );
        // The whole record, ends included, to 2 % of the filter's change.
        let all = (0..m).map(|k| (r[k] - u[k]).powi(2)).sum::<f64>() / m as f64;
        assert!(all.sqrt() < 0.02 * filt_err, "whole record: {:e} m", all.sqrt());
        // And the recovered motion filtered again is the data.
        let back = moving_average(&r, window);
        let fit = (back.iter().zip(&y).map(|(a, b)| (a - b).powi(2)).sum::<f64>() / n as f64).sqrt();
        assert!(fit < 1e-3 * filt_err, "refiltered misfit {fit:e} m");
    }

    #[test]
    fn moving_average_is_the_mean_of_the_last_window_samples() {
        let f = [1.0, 2.0, 6.0, 3.0, 8.0];
        assert_eq!(moving_average(&f, 3), vec![3.0, 11.0 / 3.0, 17.0 / 3.0]);
        assert_eq!(moving_average(&f, 1), f.to_vec());
    }
}
