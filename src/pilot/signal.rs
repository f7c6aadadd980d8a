//! Command signals for the pilot: hold, step, ramp, sine, triangle and seeded random tracking.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

/// A command signal in the pilot's units (stick angle in rad for position tasks, N for force tasks).
#[derive(Debug, Clone, PartialEq)]
pub enum Signal {
    /// A constant.
    Hold {
        /// The value held.
        value: f64,
    },
    /// `initial`, then `last` from `at_s`.
    Step {
        /// Value before the step.
        initial: f64,
        /// Value from the step on.
        last: f64,
        /// Time of the step, s.
        at_s: f64,
    },
    /// Linear from `from` to `to` over `[start_s, start_s + duration_s]`, held before and after.
    Ramp {
        /// Start value.
        from: f64,
        /// End value.
        to: f64,
        /// Start time, s.
        start_s: f64,
        /// Ramp time, s.
        duration_s: f64,
    },
    /// `offset + amplitude sin(2π f t)`.
    Sine {
        /// Mean value.
        offset: f64,
        /// Peak deviation from `offset`.
        amplitude: f64,
        /// Frequency, Hz.
        frequency_hz: f64,
    },
    /// Symmetric triangle starting at `offset` and rising first, peak `offset ± amplitude`.
    Triangle {
        /// Start and mean value.
        offset: f64,
        /// Peak deviation from `offset`.
        amplitude: f64,
        /// Frequency, Hz.
        frequency_hz: f64,
    },
    /// Seeded white noise through two cascaded first-order low-passes at `cutoff_hz`, scaled to `rms`
    /// around `offset`; precomputed on the physics grid `dt_s`.
    Random {
        /// Mean value.
        offset: f64,
        /// The filtered noise, one sample per step.
        samples: Vec<f64>,
        /// Grid step, s.
        dt_s: f64,
    },
    /// A command given sample by sample on the physics grid `dt_s` (the nearest sample; the last one
    /// after the end). A NaN sample means hands off the stick.
    Sampled {
        /// One value per step.
        samples: Vec<f64>,
        /// Grid step, s.
        dt_s: f64,
    },
}

impl Signal {
    /// Build the seeded random tracking signal over `duration_s` on the grid `dt_s`.
    pub fn random(offset: f64, rms: f64, cutoff_hz: f64, duration_s: f64, dt_s: f64, seed: u64) -> Self {
        let n = (duration_s / dt_s).ceil() as usize + 2;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let a = (-2.0 * std::f64::consts::PI * cutoff_hz * dt_s).exp();
        let (mut y1, mut y2) = (0.0, 0.0);
        // Run the filters through 5 time constants first so the signal starts stationary.
        let warm = (5.0 / (2.0 * std::f64::consts::PI * cutoff_hz * dt_s)).ceil() as usize;
        let mut samples = Vec::with_capacity(n);
        for k in 0..warm + n {
            let w: f64 = StandardNormal.sample(&mut rng);
            y1 = a * y1 + (1.0 - a) * w;
            y2 = a * y2 + (1.0 - a) * y1;
            if k >= warm {
                samples.push(y2);
            }
        }
        let mean = samples.iter().sum::<f64>() / n as f64;
        let sd = (samples.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
        let scale = if sd > 0.0 { rms / sd } else { 0.0 };
        for s in &mut samples {
            *s = (*s - mean) * scale;
        }
        Signal::Random {
            offset,
            samples,
            dt_s,
        }
    }

    /// The command at `t_s`.
    pub fn value(&self, t_s: f64) -> f64 {
        match self {
            Signal::Hold { value } => *value,
            Signal::Step { initial, last, at_s } => {
                if t_s < *at_s {
                    *initial
                } else {
                    *last
                }
            }
            Signal::Ramp {
                from,
                to,
                start_s,
                duration_s,
            } => {
                let f = ((t_s - start_s) / duration_s.max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
                from + (to - from) * f
            }
            Signal::Sine {
                offset,
                amplitude,
                frequency_hz,
            } => offset + amplitude * (2.0 * std::f64::consts::PI * frequency_hz * t_s).sin(),
            Signal::Triangle {
                offset,
                amplitude,
                frequency_hz,
            } => {
                let p = (t_s * frequency_hz + 0.25).rem_euclid(1.0); // 0.25: start at the offset, rising
                let tri = if p < 0.5 { 4.0 * p - 1.0 } else { 3.0 - 4.0 * p };
                offset + amplitude * tri
            }
            Signal::Random {
                offset,
                samples,
                dt_s,
            } => {
                let u = (t_s / dt_s).max(0.0);
                let k = (u.floor() as usize).min(samples.len().saturating_sub(2));
                let f = (u - k as f64).clamp(0.0, 1.0);
                offset + samples[k] * (1.0 - f) + samples[k + 1] * f
            }
            Signal::Sampled { samples, dt_s } => {
                let k = ((t_s / dt_s).max(0.0).round() as usize).min(samples.len().saturating_sub(1));
                samples.get(k).copied().unwrap_or(f64::NAN)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn triangle_starts_at_offset_rising_and_peaks_at_quarter_period() {
        let s = Signal::Triangle {
            offset: 0.1,
            amplitude: 0.2,
            frequency_hz: 0.5,
        };
        assert!((s.value(0.0) - 0.1).abs() < 1e-12);
        assert!((s.value(0.5) - 0.3).abs() < 1e-12);
        assert!((s.value(1.5) + 0.1).abs() < 1e-12);
        assert!(s.value(0.1) > 0.1);
    }

    #[test]
    fn random_signal_has_the_requested_rms_and_bandwidth_and_is_seeded() {
        let a = Signal::random(0.0, 0.05, 1.0, 60.0, 1e-3, 3);
        let b = Signal::random(0.0, 0.05, 1.0, 60.0, 1e-3, 3);
        let c = Signal::random(0.0, 0.05, 1.0, 60.0, 1e-3, 4);
        assert_eq!(a, b);
        assert_ne!(a, c);
        let xs: Vec<f64> = (0..60000).map(|k| a.value(k as f64 * 1e-3)).collect();
        let rms = (xs.iter().map(|x| x * x).sum::<f64>() / xs.len() as f64).sqrt();
        assert!((rms - 0.05).abs() < 0.002, "rms {rms}");
        // Band-limited: the RMS rate is of order 2π·fc·rms (a 1 Hz-wide signal), far below white noise.
        let rate_rms = (xs.windows(2).map(|w| ((w[1] - w[0]) / 1e-3).powi(2)).sum::<f64>()
            / (xs.len() - 1) as f64)
            .sqrt();
        assert!(
            rate_rms < 2.0 * std::f64::consts::PI * 1.0 * 0.05 * 2.0,
            "rate rms {rate_rms}"
        );
    }
}
