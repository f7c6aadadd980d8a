//! Sensors and data acquisition of the paper's feel-system bench (Section 6): a load cell between the piston
//! and the joystick (range 250 N, calibrated with dead weights), a laser displacement sensor on the piston, and
//! the NI DAQ that samples both and writes the coil current command.
//!
//! The controller only ever sees [`DaqSample`]s: calibrated, noisy, saturated, quantised, sampled at the DAQ's
//! rate and delayed by its latency. The velocity is not measured: it is a filtered differentiator of the
//! sampled position, as the paper derives the piston velocity from the laser sensor.

use std::collections::VecDeque;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use crate::signal::{quantise, FilteredDifferentiator};

/// Load cell: `reading = gain · F + offset + noise`, clipped at ±`range_n`.
///
/// `gain` and `offset_n` are the residual calibration errors after the dead-weight calibration the paper
/// describes (1 and 0 for a perfect calibration).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LoadCellConfig {
    /// Full scale, N: readings clip at ±this.
    pub range_n: f64,
    /// Residual calibration gain (1: perfect).
    pub gain: f64,
    /// Residual calibration offset, N.
    pub offset_n: f64,
    /// RMS noise, N.
    pub noise_rms_n: f64,
}

/// Laser displacement sensor on the piston: `reading = x + noise`, clipped at ±`range_m`; the velocity is
/// the sampled position differentiated and low-passed at `velocity_cutoff_hz`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LaserConfig {
    /// Full scale, m: readings clip at ±this.
    pub range_m: f64,
    /// RMS noise, m.
    pub noise_rms_m: f64,
    /// Low-pass cutoff of the differentiated velocity, Hz.
    pub velocity_cutoff_hz: f64,
}

/// The DAQ: sample rate, latency in whole samples (from sampling the inputs to the output command taking
/// effect; a LabVIEW single-point loop reads, computes and writes once per cycle, so 1 is typical), and the
/// ADC resolution over each channel's range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DaqConfig {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Samples from reading the inputs to the command taking effect.
    pub latency_samples: usize,
    /// ADC resolution, bits, over each channel's range.
    pub adc_bits: u32,
}

/// The rig's sensors and their DAQ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SensorsConfig {
    /// The load cell.
    pub load_cell: LoadCellConfig,
    /// The laser displacement sensor.
    pub laser: LaserConfig,
    /// The DAQ.
    pub daq: DaqConfig,
}

/// What the controller receives at one DAQ tick.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DaqSample {
    /// Time the inputs were sampled, s (the tick time minus the latency).
    pub sampled_t_s: f64,
    /// Load-cell force along +x on the piston, N.
    pub force_n: f64,
    /// Piston position from mid-stroke, m.
    pub x_m: f64,
    /// Piston velocity from the filtered differentiator, m/s.
    pub v_m_s: f64,
}

/// A sensor channel's setting that cannot be simulated: which channel, which field, the value given and
/// what it must be. Its message names all of them, e.g. ``load_cell.range` = -250: the full-scale range must
/// be a positive, finite number (readings saturate at ±range)`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("`{channel}.{field}` = {value}: {why}")]
pub struct SensorFieldError {
    /// The channel, e.g. `load_cell`, `displacement`, `velocity`.
    pub channel: String,
    /// The field: `noise_rms`, `range` or `adc_bits`.
    pub field: &'static str,
    /// The value as given.
    pub value: String,
    /// What the field must be.
    pub why: &'static str,
}

/// The largest ADC resolution a channel may have, bits.
pub const MAX_ADC_BITS: u32 = 32;

/// Check one channel's noise (standard deviation, ≥ 0 and finite), full-scale range (> 0 and finite) and
/// ADC resolution (≤ [`MAX_ADC_BITS`]; 0 = no quantisation), in the channel's unit; the error names the
/// first field that is wrong, with its value.
pub fn check_channel(
    channel: &str,
    noise_rms: f64,
    range: f64,
    adc_bits: u32,
) -> Result<(), SensorFieldError> {
    let checks = [
        (
            !(noise_rms.is_finite() && noise_rms >= 0.0),
            "noise_rms",
            noise_rms.to_string(),
            "the noise's standard deviation must be a finite number ≥ 0",
        ),
        (
            !(range.is_finite() && range > 0.0),
            "range",
            range.to_string(),
            "the full-scale range must be a positive, finite number (readings saturate at ±range)",
        ),
        (
            adc_bits > MAX_ADC_BITS,
            "adc_bits",
            adc_bits.to_string(),
            "the ADC resolution must be at most 32 bits (0: no quantisation)",
        ),
    ];
    if let Some((_, field, value, why)) = checks.into_iter().find(|c| c.0) {
        return Err(SensorFieldError {
            channel: channel.to_string(),
            field,
            value,
            why,
        });
    }
    Ok(())
}

/// Load cell + laser + DAQ, with their own seeded noise. Call [`Daq::due`] every physics step and
/// [`Daq::acquire`] when it is due.
#[derive(Debug, Clone)]
pub struct Daq {
    cfg: SensorsConfig,
    period_s: f64,
    next_tick: u64,
    rng: ChaCha8Rng,
    diff: FilteredDifferentiator,
    line: VecDeque<DaqSample>,
}

impl Daq {
    /// A DAQ of `cfg` whose noise is seeded by `seed`, before its first tick.
    pub fn new(cfg: SensorsConfig, seed: u64) -> Self {
        let period_s = 1.0 / cfg.daq.sample_rate_hz;
        Self {
            cfg,
            period_s,
            next_tick: 0,
            rng: ChaCha8Rng::seed_from_u64(seed),
            diff: FilteredDifferentiator::new(cfg.laser.velocity_cutoff_hz, period_s),
            line: VecDeque::with_capacity(cfg.daq.latency_samples + 1),
        }
    }

    /// Sample period, s.
    pub fn period_s(&self) -> f64 {
        self.period_s
    }

    /// Whether a DAQ tick falls at or before physics time `t_s` (ticks at `k · period`, with a tolerance of
    /// a millionth of a period against rounding).
    pub fn due(&self, t_s: f64) -> bool {
        self.next_tick as f64 * self.period_s <= t_s + 1e-6 * self.period_s
    }

    /// Sample the true load-cell force and piston position at a tick; returns the sample the controller
    /// sees now, which is the one taken `latency_samples` ticks ago (or `None` while the line fills).
    pub fn acquire(&mut self, t_s: f64, true_force_n: f64, true_x_m: f64) -> Option<DaqSample> {
        self.next_tick += 1;
        let lc = self.cfg.load_cell;
        let ls = self.cfg.laser;
        let bits = self.cfg.daq.adc_bits;
        let nf: f64 = StandardNormal.sample(&mut self.rng);
        let nx: f64 = StandardNormal.sample(&mut self.rng);
        let force = quantise(
            lc.gain * true_force_n + lc.offset_n + lc.noise_rms_n * nf,
            lc.range_n,
            bits,
        );
        let x = quantise(true_x_m + ls.noise_rms_m * nx, ls.range_m, bits);
        let v = self.diff.update(x);
        self.line.push_back(DaqSample {
            sampled_t_s: t_s,
            force_n: force,
            x_m: x,
            v_m_s: v,
        });
        if self.line.len() > self.cfg.daq.latency_samples {
            self.line.pop_front()
        } else {
            None
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg(rate: f64, latency: usize, bits: u32, noise: f64) -> SensorsConfig {
        SensorsConfig {
            load_cell: LoadCellConfig {
                range_n: 250.0,
                gain: 1.0,
                offset_n: 0.0,
                noise_rms_n: noise,
            },
            laser: LaserConfig {
                range_m: 0.06,
                noise_rms_m: 0.0,
                velocity_cutoff_hz: 50.0,
            },
            daq: DaqConfig {
                sample_rate_hz: rate,
                latency_samples: latency,
                adc_bits: bits,
            },
        }
    }

    #[test]
    fn a_channel_error_names_the_channel_the_field_and_the_value() {
        assert_eq!(check_channel("load_cell", 0.15, 250.0, 16), Ok(()));
        assert_eq!(check_channel("load_cell", 0.0, 250.0, 0), Ok(()));
        for (noise, range, bits, field, value) in [
            (0.15, -250.0, 16, "range", "-250"),
            (0.15, 0.0, 16, "range", "0"),
            (0.15, f64::NAN, 16, "range", "NaN"),
            (-1.0, 250.0, 16, "noise_rms", "-1"),
            (f64::INFINITY, 250.0, 16, "noise_rms", "inf"),
            (0.15, 250.0, 64, "adc_bits", "64"),
        ] {
            let e = check_channel("load_cell", noise, range, bits).unwrap_err();
            assert_eq!((e.field, e.value.as_str()), (field, value));
            let msg = e.to_string();
            assert!(
                msg.starts_with(&format!("`load_cell.{field}` = {value}: ")),
                "{msg}"
            );
        }
    }

    #[test]
    fn load_cell_saturates_at_its_250_n_range() {
        let mut d = Daq::new(cfg(1000.0, 0, 16, 0.0), 1);
        let s = d.acquire(0.0, 400.0, 0.0).unwrap();
        assert!((s.force_n - 250.0).abs() < 0.01, "{}", s.force_n);
        let s = d.acquire(0.001, -1000.0, 0.0).unwrap();
        assert!((s.force_n + 250.0).abs() < 0.01);
    }

    #[test]
    fn quantisation_step_is_range_over_two_to_the_bits() {
        // 12 bits over ±250 N: LSB = 500/4096 = 0.122 N; every reading is a multiple of it, error ≤ LSB/2.
        let lsb = 500.0 / 4096.0;
        for k in 0..200 {
            let f = -60.0 + 0.37 * k as f64;
            let q = quantise(f, 250.0, 12);
            assert!((q / lsb - (q / lsb).round()).abs() < 1e-9);
            assert!((q - f).abs() <= 0.5 * lsb + 1e-12);
        }
    }

    #[test]
    fn latency_delays_samples_by_whole_ticks() {
        let mut d = Daq::new(cfg(100.0, 2, 0, 0.0), 1);
        assert!(d.acquire(0.00, 1.0, 0.0).is_none());
        assert!(d.acquire(0.01, 2.0, 0.0).is_none());
        let s = d.acquire(0.02, 3.0, 0.0).unwrap();
        assert_eq!(s.force_n, 1.0);
        assert_eq!(s.sampled_t_s, 0.0);
    }

    #[test]
    fn calibration_error_and_noise_statistics() {
        let mut c = cfg(1000.0, 0, 0, 0.5);
        c.load_cell.gain = 1.02;
        c.load_cell.offset_n = -0.3;
        let mut d = Daq::new(c, 7);
        let n = 20000;
        let xs: Vec<f64> = (0..n)
            .map(|k| d.acquire(k as f64 * 1e-3, 50.0, 0.0).unwrap().force_n)
            .collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / n as f64).sqrt();
        assert!((mean - (1.02 * 50.0 - 0.3)).abs() < 0.02, "mean {mean}");
        assert!((sd - 0.5).abs() < 0.02, "sd {sd}");
    }

    #[test]
    fn same_seed_same_noise() {
        let mut a = Daq::new(cfg(1000.0, 1, 16, 0.3), 42);
        let mut b = Daq::new(cfg(1000.0, 1, 16, 0.3), 42);
        for k in 0..100 {
            let t = k as f64 * 1e-3;
            assert_eq!(a.acquire(t, 10.0, 0.01), b.acquire(t, 10.0, 0.01));
        }
    }
}
