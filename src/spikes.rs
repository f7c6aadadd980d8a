//! Samples that look like spikes: one reading far from its neighbours, beyond anything the column's own
//! spread allows, which no sensor on a moving damper can produce (a DAQ glitch, a corrupted field, a unit
//! slip). A Hampel-type test: a sample's distance from the median of the samples around it, against the
//! range of the column's central 90 %.

/// Samples on each side of a sample whose median it is compared with.
const HALF_WINDOW: usize = 3;

/// How many spreads ([`spread`]) a sample must lie from its neighbours' median to be a spike. A real
/// signal moves by at most its whole range from one sample to the next (a current step, a force reversal),
/// which is a few spreads at most for any drive (1 for a sine).
pub(crate) const SPIKE_FACTOR: f64 = 1e3;

/// One sample that looks like a spike.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Spike {
    /// Index of the sample in its column.
    pub index: usize,
    pub value: f64,
    /// The median of its neighbours.
    pub neighbours: f64,
    /// How far it lies from them, in units of the column's spread.
    pub spreads: f64,
}

/// The column's spread: the range of its central 90 % (5th to 95th percentile, which a few spikes do not
/// move), or where that is 0 (a constant column with a few other values) its median's magnitude; `None`
/// where both are 0 (nothing to judge a spike against).
fn spread(values: &[f64]) -> Option<f64> {
    let q = |p: f64| crate::signal::quantile(values.to_vec(), p);
    let central = q(0.95) - q(0.05);
    let scale = if central > 0.0 { central } else { q(0.5).abs() };
    (scale > 0.0 && scale.is_finite()).then_some(scale)
}

/// The samples of `values` (a column in time order) that lie more than `factor` spreads from the median
/// of the [`HALF_WINDOW`] samples each side of them (themselves excluded), largest first.
pub(crate) fn spikes(values: &[f64], factor: f64) -> Vec<Spike> {
    if values.len() < 2 * HALF_WINDOW + 1 {
        return Vec::new();
    }
    let Some(scale) = spread(values) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    let mut window = Vec::with_capacity(2 * HALF_WINDOW);
    for (k, &v) in values.iter().enumerate() {
        let lo = k.saturating_sub(HALF_WINDOW);
        let hi = (k + HALF_WINDOW + 1).min(values.len());
        window.clear();
        window.extend(values[lo..k].iter().chain(&values[k + 1..hi]));
        window.sort_by(f64::total_cmp);
        let m = window.len();
        let median = if m % 2 == 1 {
            window[m / 2]
        } else {
            0.5 * window[m / 2 - 1] + 0.5 * window[m / 2]
        };
        let spreads = (v - median).abs() / scale;
        if spreads > factor {
            out.push(Spike {
                index: k,
                value: v,
                neighbours: median,
                spreads,
            });
        }
    }
    out.sort_by(|a, b| b.spreads.total_cmp(&a.spreads));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sine(n: usize, per_cycle: f64) -> Vec<f64> {
        (0..n)
            .map(|k| 50.0 * (std::f64::consts::TAU * k as f64 / per_cycle).sin())
            .collect()
    }

    /// One corrupted sample in a sine, a square wave or a constant column is found at its index; clean
    /// signals with the sharpest moves a damper test has (a square-wave force sampled 4 times per cycle,
    /// current steps, a constant column) have none.
    #[test]
    fn a_single_corrupted_sample_is_a_spike_and_sharp_real_signals_are_not() {
        let square: Vec<f64> = (0..400)
            .map(|k| if (k / 5) % 2 == 0 { 70.0 } else { -70.0 })
            .collect();
        let steps: Vec<f64> = (0..400).map(|k| [0.0, 2.2, 5.0, 14.0][k / 100]).collect();
        let mostly_one: Vec<f64> = (0..400).map(|k| if k < 350 { 1.0 } else { 14.0 }).collect();
        let coarse = sine(400, 4.0);
        for clean in [&sine(400, 50.0), &square, &steps, &mostly_one, &coarse] {
            assert_eq!(spikes(clean, SPIKE_FACTOR), vec![], "{:?}", &clean[..8]);
            for (at, bad) in [(0, 1e20), (123, -1e149), (399, 3e5)] {
                let mut v = clean.clone();
                v[at] = bad;
                let found = spikes(&v, SPIKE_FACTOR);
                assert_eq!(found.len(), 1, "{bad} at {at}: {found:?}");
                assert_eq!((found[0].index, found[0].value), (at, bad));
            }
        }
        // A spike no larger than the signal's own range is not one.
        let mut v = sine(400, 50.0);
        v[200] = 100.0;
        assert!(spikes(&v, SPIKE_FACTOR).is_empty());
        // Nothing to judge against: a column of zeros.
        let mut z = vec![0.0; 100];
        z[5] = 1e20;
        assert!(spikes(&z, SPIKE_FACTOR).is_empty());
    }
}
