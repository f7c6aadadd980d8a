//! Clipped force channels: a load cell driven past its range logs the same extreme value sample after
//! sample. Those samples say only that the force was at least the rail, so they are found here and left
//! out of the fit's loss and of every score ([`super::residual::direction_weights`],
//! [`super::validate::figures`]).
//!
//! Rule: a run of at least [`MIN_RUN`] samples exactly equal to the channel's largest (or smallest) value,
//! which on each side, within a run's length beyond its end, falls more than [`DROP`] resolution steps
//! below the rail (the resolution: the channel's white noise or its smallest step, whichever is larger). A
//! natural peak logged by a coarse ADC as a run of equal values falls by less than about nine steps there.

use std::ops::Range;

/// The shortest run of equal extreme values that is read as a clip.
pub const MIN_RUN: usize = 8;
/// How many resolution steps the signal must fall below the rail, a run's length beyond its ends.
pub const DROP: f64 = 30.0;

/// A rail a channel was stuck at.
#[derive(Debug, Clone, PartialEq)]
pub struct Clip {
    /// The value logged at the rail, in the channel's unit.
    pub value: f64,
    /// Samples stuck there.
    pub samples: usize,
    /// The runs of consecutive samples stuck there.
    pub runs: Vec<Range<usize>>,
}

/// The clips of a channel (at most two: the top and the bottom rail).
pub fn clips(y: &[f64]) -> Vec<Clip> {
    let n = y.len();
    if n < 2 * MIN_RUN {
        return Vec::new();
    }
    let step = crate::signal::smallest_change(y);
    if !step.is_finite() {
        return Vec::new(); // constant
    }
    let resolution = step.max(crate::signal::white_noise_std(y));
    let top = y.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let bottom = y.iter().copied().fold(f64::INFINITY, f64::min);
    let mut out = Vec::new();
    for rail in [top, bottom] {
        if out.iter().any(|c: &Clip| c.value == rail) {
            continue;
        }
        let falls = |k: usize| (y[k] - rail).abs() > DROP * resolution;
        let mut runs = Vec::new();
        let mut k = 0;
        while k < n {
            if y[k] != rail {
                k += 1;
                continue;
            }
            let start = k;
            while k < n && y[k] == rail {
                k += 1;
            }
            let len = k - start;
            // The samples within a run's length beyond each end (up to the record's end).
            let sides = [start.saturating_sub(len)..start, k..(k + len).min(n)];
            let sides: Vec<Range<usize>> = sides.into_iter().filter(|s| !s.is_empty()).collect();
            if len >= MIN_RUN && !sides.is_empty() && sides.into_iter().all(|mut s| s.any(falls)) {
                runs.push(start..k);
            }
        }
        if !runs.is_empty() {
            out.push(Clip {
                value: rail,
                samples: runs.iter().map(|r| r.len()).sum(),
                runs,
            });
        }
    }
    out
}

/// 1 where a sample of `y` counts, 0 where it is stuck at a rail ([`clips`]).
pub fn unclipped(y: &[f64]) -> Vec<f64> {
    let mut w = vec![1.0; y.len()];
    for r in clips(y).into_iter().flat_map(|c| c.runs) {
        w[r].fill(0.0);
    }
    w
}

/// One line per clipped force channel of the tests, for stderr.
pub fn notes(tests: &[super::Test]) -> Vec<String> {
    let note = |t: &super::Test, c: Clip| {
        format!(
            "{}: f_n stuck at {} N over {} samples ({} run{}): a saturated load cell; those samples are left out \
             of the fit and of every score",
            t.name,
            c.value,
            c.samples,
            c.runs.len(),
            if c.runs.len() == 1 { "" } else { "s" }
        )
    };
    tests
        .iter()
        .flat_map(|t| clips(&t.f_n).into_iter().map(move |c| note(t, c)))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A noisy 1 kHz sine force of ±100 N through a load cell whose range is `range` N.
    fn logged(range: f64, seed: u64) -> (Vec<f64>, Vec<bool>) {
        let noise = crate::ident::noise(4000, 0.5, seed);
        let truth: Vec<f64> = (0..4000)
            .map(|k| 100.0 * (std::f64::consts::TAU * 2.0 * k as f64 * 1e-3).sin() + noise[k])
            .collect();
        let rail: Vec<bool> = truth.iter().map(|f| f.abs() >= range).collect();
        (truth.iter().map(|f| f.clamp(-range, range)).collect(), rail)
    }

    /// A load cell of ±80 N on a ±100 N force: every sample at a rail is found, none other, and both
    /// rails are named with their counts.
    #[test]
    fn a_saturated_load_cell_is_found_sample_by_sample() {
        let (f, rail) = logged(80.0, 1);
        let cs = clips(&f);
        assert_eq!(cs.len(), 2, "{cs:?}");
        let w = unclipped(&f);
        let stuck = rail.iter().filter(|r| **r).count();
        assert!(stuck > 500, "the force must clip here: {stuck}");
        // Runs shorter than MIN_RUN at the edges of a rail (noise crossing it) may stay in.
        let missed = rail.iter().zip(&w).filter(|(r, w)| **r && **w == 1.0).count();
        let wrong = rail.iter().zip(&w).filter(|(r, w)| !**r && **w == 0.0).count();
        assert_eq!(wrong, 0);
        assert!(missed < stuck / 50, "{missed} of {stuck} clipped samples kept");
        assert_eq!(cs.iter().map(|c| c.samples).sum::<usize>(), stuck - missed);
        assert_eq!(cs[0].value, 80.0);
        assert_eq!(cs[1].value, -80.0);
    }

    /// The same force inside the range, logged by a 12-bit ADC (0.05 N steps, a tenth of the noise), and a
    /// noiseless quantised sine (its peaks repeat a value over tens of samples): nothing is clipped.
    #[test]
    fn a_force_inside_the_range_is_not_clipped_even_quantised() {
        let (f, _) = logged(1000.0, 2);
        let q: Vec<f64> = f.iter().map(|v| (v / 0.05).round() * 0.05).collect();
        assert!(clips(&q).is_empty(), "{:?}", clips(&q));
        let sine: Vec<f64> = (0..20000)
            .map(|k| (100.0 * (std::f64::consts::TAU * 0.25 * k as f64 * 1e-3).sin()).round())
            .collect();
        assert!(clips(&sine).is_empty(), "{:?}", clips(&sine));
    }
}
