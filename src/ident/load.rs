//! Reading measurements into [`Test`]s: the model's inputs estimated from each file (velocity and
//! acceleration where the file has none, the displacement smoothed), and the acquisition chain (a moving
//! average the files went through) found per protocol and undone.

use std::path::PathBuf;

use rayon::prelude::*;

use super::{acquisition, IdentError, Test};
use crate::device::{DataStats, Inputs};
use crate::measurement::Measurement;
use crate::signal::{channel_noise_std_on, widest_unbiased_derivative, QuinticFit};

/// The moving average that the measurements `ms` (tests of one protocol) went through, if their
/// displacements and forces (and measured velocities) show its comb ([`acquisition::detect_moving_average`]).
pub(crate) fn filter_of(ms: &[&Measurement]) -> Option<acquisition::MovingAverage> {
    acquisition::detect_moving_average(&channels(ms))
}

/// The channels of measurements as the acquisition chain's detection reads them.
fn channels<'a>(ms: &[&'a Measurement]) -> Vec<acquisition::Channels<'a>> {
    ms.iter()
        .map(|m| acquisition::Channels {
            t: &m.t_s,
            x: &m.x_m,
            v: m.velocity_measured.then_some(m.v_m_s.as_slice()),
            f: &m.f_n,
        })
        .collect()
}

/// Whether `bingham`, fitted to the measurements `ms` of one protocol, follows the measured force more
/// closely through `through` (the same measurements with a filter undone) than as logged. A comb in the
/// spectra is only a hypothesis: a drive smooth by design (a triangle's rounded corners) has one of its own,
/// and undoing a filter that is not there drives the model with a motion that never happened.
fn undoing_fits_better(ms: &[&Measurement], through: &[Test]) -> bool {
    use crate::device::{Model, Registry, PAPER_CURRENT_LIMIT_A};
    let model =
        Model::from_spec("bingham", &Registry::builtin(), PAPER_CURRENT_LIMIT_A).expect("bingham builds");
    let opts = super::FitOptions {
        std_errors: false,
        ..Default::default()
    };
    let rmse = |tests: &[Test]| super::fit(&model, tests, &super::fit::all_spans(tests), &opts).rmse_n();
    let as_logged: Vec<Test> = ms.iter().map(|m| Test::with_filter(m, None)).collect();
    rmse(through) < rmse(&as_logged)
}

/// The model's drive for a file whose displacement and force went through the moving average `filter`: the
/// displacement before the filter with `window − 1` samples before the first (on the clock extended
/// backwards), its derivatives as for a file without them, the first current command over the lead-in.
pub(crate) fn drive_of(m: &Measurement, filter: acquisition::MovingAverage) -> Option<acquisition::Drive> {
    let lead = filter.window - 1;
    let dt = crate::signal::uniform_interval(&m.t_s)?;
    let x = acquisition::deconvolve_moving_average(&m.x_m, filter.window);
    let t: Vec<f64> = (0..lead)
        .map(|k| m.t_s[0] - (lead - k) as f64 * dt)
        .chain(m.t_s.iter().copied())
        .collect();
    let i_a: Vec<f64> = std::iter::repeat_n(m.i_a[0], lead)
        .chain(m.i_a.iter().copied())
        .collect();
    // Only the motion and the command: no velocity or acceleration column (they were filtered too).
    let before = Measurement {
        path: m.path.clone(),
        v_m_s: crate::signal::smooth_derivative(&t, &x),
        velocity_measured: false,
        t_s: t,
        x_m: x,
        i_a,
        ..Default::default()
    };
    Some(acquisition::Drive {
        filter,
        inputs: inputs_of(&before),
    })
}

/// Model inputs of a measurement ([`Measurement::inputs`]), with the velocity, when the file has none, and
/// the acceleration, when the file has none, estimated for the least error (see
/// [`inputs_and_velocity_noise`]).
pub fn inputs_of(m: &Measurement) -> Vec<Inputs> {
    inputs_and_velocity_noise(m).0
}

/// [`inputs_of`], and the noise standard deviation of the velocity when it was derived here.
///
/// A missing velocity is derived from the displacement, and the displacement smoothed, by the widest local
/// quintic that leaves the signal unbent (`widest_unbiased_derivative`); a missing acceleration from the
/// measured velocity once or the displacement twice, whichever is quieter (a noisy acceleration hides
/// `inertia`). Everything on the file's own time grid (`docs/explanation/ident.md`).
pub fn inputs_and_velocity_noise(m: &Measurement) -> (Vec<Inputs>, Option<Vec<f64>>) {
    let mut inputs = m.inputs();
    if m.len() < 32 {
        return (inputs, None);
    }
    // On an uneven grid (a jittered clock, lost samples) the same local fits in the samples' own times;
    // `dt` only sizes the route choice below.
    let dt = crate::signal::median_interval(&m.t_s);
    if dt.is_nan() || dt <= 0.0 {
        return (inputs, None);
    }
    let t = &m.t_s;
    let sd_x = channel_noise_std_on(t, &m.x_m);
    // Where no noise figure comes back, the estimate is its fallback: the value `inputs` holds already.
    let v_noise = if m.velocity_measured {
        None
    } else {
        let (v, sd_v) = widest_unbiased_derivative(t, &m.x_m, 1, sd_x, &m.v_m_s);
        inputs.iter_mut().zip(v).for_each(|(i, v)| i.v_m_s = v);
        sd_v
    };
    // The displacement smoothed by the same rule: the hysteresis law integrates the path `|dx|`, and noise
    // on `x` rectified there is travel the piston never made.
    let (x_smooth, _) = widest_unbiased_derivative(t, &m.x_m, 0, sd_x, &m.x_m);
    inputs.iter_mut().zip(x_smooth).for_each(|(i, x)| i.x_m = x);
    if m.a_m_s2.is_some() {
        return (inputs, v_noise);
    }
    let noise_of = |order: usize, sd: f64| {
        let w = QuinticFit::new(10).derivative_weights(order, 0.0);
        w.iter().map(|w| w * w).sum::<f64>().sqrt() * sd / dt.powi(order as i32)
    };
    let sd_v = m.velocity_measured.then(|| channel_noise_std_on(t, &m.v_m_s));
    let (y, order, sd) = match sd_v {
        Some(sd_v) if noise_of(2, sd_x) < noise_of(1, sd_v) => (&m.x_m, 2, sd_x),
        Some(sd_v) => (&m.v_m_s, 1, sd_v),
        None => (&m.x_m, 2, sd_x),
    };
    let (a, _) = widest_unbiased_derivative(t, y, order, sd, &m.acceleration());
    inputs.iter_mut().zip(a).for_each(|(i, a)| i.a_m_s2 = a);
    (inputs, v_noise)
}

/// The cross-validation group of a test: the `group` metadata key when present, else the file stem up to
/// its last `_` (`10mm1Hz_0p50A.csv` → `10mm1Hz`: the tests of one protocol at several currents), else the
/// stem itself. [`diagnose()`](fn@diagnose) falls back to one group per file when this gives a single group.
pub(crate) fn group_of(m: &Measurement) -> String {
    if let Some(g) = m.meta.get("group") {
        return g.trim().to_string();
    }
    let stem = m
        .path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    match stem.rsplit_once('_') {
        Some((head, _)) if !head.is_empty() => head.to_string(),
        _ => stem,
    }
}

/// Read files and directories of CSV files into tests, their acquisition chain found in the data.
pub fn load_tests(paths: &[PathBuf]) -> Result<Vec<Test>, IdentError> {
    if paths.is_empty() {
        return Err(IdentError::NoData);
    }
    let ms = crate::measurement::read_all(paths)?;
    refuse_zero_force(&ms)?;
    Ok(tests_from(&ms))
}

/// A measurement whose force column is zero throughout measured no force: every error figure, relative to
/// the rms measured force, would have no value.
pub(crate) fn refuse_zero_force(ms: &[Measurement]) -> Result<(), IdentError> {
    match ms.iter().find(|m| m.f_n.iter().all(|&f| f == 0.0)) {
        Some(m) => Err(IdentError::Other(format!(
            "{}:{}-{}: column `f_n` is zero in every one of the {} samples: no force was measured (a load cell \
             not connected?), and the error figures, relative to the rms measured force, have no value",
            m.path.display(),
            m.lines.first().copied().unwrap_or(0),
            m.lines.last().copied().unwrap_or(0),
            m.len()
        ))),
        None => Ok(()),
    }
}

/// The tests of measurements read together. Tests of one protocol (one clock, one drive period) went
/// through one acquisition chain: their spectra are pooled to find its filter (`filter_of`), and each
/// test is read with the protocol's filter.
pub fn tests_from(ms: &[Measurement]) -> Vec<Test> {
    tests_predicting(ms, None).0
}

/// [`tests_from`], and where a protocol's tests do not show a filter themselves, the window predicted by the
/// share of the drive period found across the protocols that do (`acquisition::window_law`), else by
/// `share` (saved with a model), is checked in their spectra. Returns the tests and the share found, if any.
pub(crate) fn tests_predicting(ms: &[Measurement], share: Option<f64>) -> (Vec<Test>, Option<f64>) {
    let mut protocols: Vec<(ProtocolKey, Vec<usize>)> = Vec::new();
    for (k, m) in ms.iter().enumerate() {
        let key = protocol_key(m);
        match protocols.iter_mut().find(|(p, _)| p.matches(&key)) {
            Some((_, members)) => members.push(k),
            None => protocols.push((key, vec![k])),
        }
    }
    let measurements_of =
        |members: &[usize]| -> Vec<&Measurement> { members.iter().map(|&k| &ms[k]).collect() };
    // A protocol's own filter, with its tests read through it (kept: they are the protocol's tests).
    let found: Vec<Option<(acquisition::MovingAverage, Vec<Test>)>> = protocols
        .iter()
        .map(|(_, members)| {
            let ms = measurements_of(members);
            let filter = filter_of(&ms)?;
            let through: Vec<Test> = ms
                .par_iter()
                .map(|m| Test::with_filter(m, Some(filter)))
                .collect();
            undoing_fits_better(&ms, &through).then_some((filter, through))
        })
        .collect();
    let shown: Vec<(usize, f64, f64)> = protocols
        .iter()
        .zip(&found)
        .filter_map(|((key, _), f)| Some((f.as_ref()?.0.window, key.interval?, key.period)))
        .collect();
    let law = acquisition::window_law(&shown);
    let mut filters = vec![None; ms.len()];
    let mut read: Vec<Option<Test>> = vec![None; ms.len()];
    for ((key, members), found) in protocols.iter().zip(found) {
        let found = found.map(|(filter, through)| {
            members.iter().zip(through).for_each(|(&k, t)| read[k] = Some(t));
            filter
        });
        let filter = found.or_else(|| {
            let share = law.or(share)?;
            let window = (share * key.period / key.interval?).round();
            (window >= 2.0 && window.is_finite())
                .then(|| {
                    acquisition::confirm_moving_average(&channels(&measurements_of(members)), window as usize)
                })
                .flatten()
        });
        members.iter().for_each(|&k| filters[k] = filter);
    }
    // In parallel: undoing a filter is a banded solve of a test's length times the window squared.
    let tests = ms
        .par_iter()
        .zip(filters)
        .zip(read)
        .map(|((m, f), read)| read.unwrap_or_else(|| Test::with_filter(m, f)))
        .collect();
    (tests, law)
}

/// How the acquisition chain of the tests is taken (`--acquisition`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum AcquisitionChoice {
    /// Found in the data: a moving average whose comb of zeros shows in the pooled spectra of a protocol's
    /// tests ([`tests_from`]); none where none shows.
    #[default]
    Auto,
    /// The files are compared as they are, whatever their spectra show.
    AsLogged,
    /// Every file went through a causal moving average of this many samples (the user knows the chain).
    MovingAverage(usize),
}

impl std::str::FromStr for AcquisitionChoice {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim() {
            "auto" => Ok(Self::Auto),
            "as-logged" | "none" => Ok(Self::AsLogged),
            other => match other.parse::<usize>() {
                Ok(n) if n >= 2 => Ok(Self::MovingAverage(n)),
                Ok(n) => Err(format!(
                    "a moving average of {n} sample(s) is no filter: give 2 or more samples, or `as-logged`"
                )),
                Err(_) => Err(format!(
                    "`{other}`: expected `auto`, `as-logged` or the moving average's window in samples (an \
                     integer of 2 or more)"
                )),
            },
        }
    }
}

/// The tests of measurements read together, their acquisition chain taken as `choice` says. A window the
/// user gives must be undone on every file: a file whose clock is not uniform, or that is not four windows
/// long, is an error that names it, not a silent fallback to the file as logged.
pub fn tests_with(ms: &[Measurement], choice: AcquisitionChoice) -> Result<Vec<Test>, IdentError> {
    match choice {
        AcquisitionChoice::Auto => Ok(tests_from(ms)),
        AcquisitionChoice::AsLogged => Ok(ms.par_iter().map(|m| Test::with_filter(m, None)).collect()),
        AcquisitionChoice::MovingAverage(window) => ms
            .par_iter()
            .map(|m| {
                let fail = |why: String| {
                    IdentError::Other(format!("{}: --acquisition {window}: {why}", m.path.display()))
                };
                if m.t_s.len() < 4 * window {
                    return Err(fail(format!(
                        "the file has {} samples, fewer than four windows",
                        m.t_s.len()
                    )));
                }
                let filter = acquisition::MovingAverage {
                    window,
                    mean_depth: f64::NAN,
                    predicted: false,
                };
                let test = Test::with_filter(m, Some(filter));
                // [`drive_of`] undoes the filter on a uniform clock only.
                match test.drive {
                    Some(_) => Ok(test),
                    None => Err(fail(
                        "its clock is not uniform (the format allows that, but a moving average over \
                         samples cannot be undone on it)"
                            .into(),
                    )),
                }
            })
            // Every file in parallel, the first failing one in the order given named.
            .collect::<Vec<_>>()
            .into_iter()
            .collect(),
    }
}

/// Lines for a person: which tests were found logged through a moving average, and what is done about it
/// (one line per window and clock, with the tests' groups), and which could not be searched for one (an
/// uneven clock); empty when neither.
pub(crate) fn acquisition_note(tests: &[Test]) -> Vec<String> {
    let mut seen: Vec<(usize, f64, bool, Vec<String>, usize)> = Vec::new();
    for t in tests {
        let Some(d) = &t.drive else { continue };
        let dt = d.inputs.get(1).map_or(f64::NAN, |b| b.t_s - d.inputs[0].t_s);
        let predicted = d.filter.predicted;
        match seen.iter_mut().find(|(w, step, p, _, _)| {
            *w == d.window() && *p == predicted && (*step - dt).abs() <= 1e-9 * dt.abs()
        }) {
            Some((_, _, _, groups, n)) => {
                *n += 1;
                if !groups.contains(&t.group) {
                    groups.push(t.group.clone());
                }
            }
            None => seen.push((d.window(), dt, predicted, vec![t.group.clone()], 1)),
        }
    }
    // A test on an uneven clock (a gap, lost samples) cannot show a comb: say so, not fall back in silence.
    let uneven: Vec<&str> = tests
        .iter()
        .filter(|t| {
            t.drive.is_none() && {
                let times: Vec<f64> = t.inputs.iter().map(|i| i.t_s).collect();
                crate::signal::uniform_interval(&times).is_none()
            }
        })
        .map(|t| t.name.as_str())
        .collect();
    let mut notes = Vec::new();
    if !uneven.is_empty() {
        let shown: Vec<&str> = uneven.iter().copied().take(3).collect();
        notes.push(format!(
            "acquisition: {} test(s) ({}{}) are on an uneven clock, where the comb of a moving average cannot be \
             looked for: compared as logged (give them on an even clock to have their chain found)",
            uneven.len(),
            shown.join(", "),
            if uneven.len() > 3 { ", …" } else { "" }
        ));
    }
    notes.extend(seen.into_iter().map(|(w, dt, predicted, groups, n)| {
        let why = if predicted {
            "the share of the drive period that the other protocols' filters span (or the model's \
                 PARAMS.json saved) predicts it, and its comb of zeros shows in their spectra"
        } else {
            "its comb of zeros shows in their spectra"
        };
        format!(
            "acquisition: {n} test(s) ({}) were logged through a moving average of {w} samples ({:.3} s): \
                 {why}; the model is driven by the motion before the filter and its force goes through the \
                 same average (`--acquisition as-logged` compares the files as they are)",
            groups.join(", "),
            w as f64 * dt
        )
    }));
    notes
}

/// What makes two tests one protocol for the acquisition chain: the sample interval and the drive's
/// period (the strongest line of the displacement's spectrum), s.
#[derive(Debug, Clone, Copy)]
struct ProtocolKey {
    interval: Option<f64>,
    period: f64,
}

impl ProtocolKey {
    /// Same clock to 0.1 %, same period to 5 %.
    fn matches(&self, o: &ProtocolKey) -> bool {
        match (self.interval, o.interval) {
            (Some(a), Some(b)) => {
                (a - b).abs() <= 1e-3 * a
                    && (self.period - o.period).abs() <= 0.05 * self.period.min(o.period)
            }
            _ => false,
        }
    }
}

fn protocol_key(m: &Measurement) -> ProtocolKey {
    let interval = crate::signal::uniform_interval(&m.t_s);
    let period = interval.map_or(f64::NAN, |dt| acquisition::dominant_period(&m.x_m, dt));
    ProtocolKey { interval, period }
}

/// Statistics the elements derive their initial guesses from.
pub fn data_stats(tests: &[Test]) -> DataStats {
    super::fit::span_stats(tests, &super::fit::all_spans(tests))
}

/// Driver saturation to build models with when the user gives none: the paper's 14 A, or the largest
/// command in the data when that is higher (a command the rig applied was not saturated by our model).
pub fn default_current_limit_a(tests: &[Test]) -> f64 {
    let imax = tests
        .iter()
        .flat_map(|t| t.inputs.iter())
        .fold(0.0f64, |m, i| m.max(i.current_cmd_a.abs()));
    imax.max(crate::device::PAPER_CURRENT_LIMIT_A)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ident::noise;
    use crate::ident::residual;
    use rand::SeedableRng;

    /// A 1 Hz sine at 1 kHz with a 0.2 mm/s noisy velocity channel: the estimated acceleration is far closer
    /// to the truth than the 7-sample derivative of the noisy velocity, and not attenuated.
    #[test]
    fn acceleration_from_a_noisy_velocity_channel_is_close_to_the_truth() {
        let w = 2.0 * std::f64::consts::PI;
        let n = 6000;
        let nd = noise(n, 2e-4, 3);
        let t: Vec<f64> = (0..n).map(|k| k as f64 * 1e-3).collect();
        let m = Measurement {
            path: "a.csv".into(),
            x_m: t
                .iter()
                .map(|t| ((0.02 * (w * t).sin()) / 1e-6).round() * 1e-6)
                .collect(),
            v_m_s: t
                .iter()
                .zip(&nd)
                .map(|(t, e)| 0.02 * w * (w * t).cos() + e)
                .collect(),
            velocity_measured: true,
            i_a: vec![1.0; n],
            f_n: vec![0.0; n],
            t_s: t.clone(),
            ..Default::default()
        };
        let truth: Vec<f64> = t.iter().map(|t| -0.02 * w * w * (w * t).sin()).collect();
        let rms_err = |a: &[f64]| {
            (a[50..n - 50]
                .iter()
                .zip(&truth[50..n - 50])
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                / (n - 100) as f64)
                .sqrt()
        };
        let est: Vec<f64> = inputs_of(&m).iter().map(|i| i.a_m_s2).collect();
        let (est_err, naive_err) = (rms_err(&est), rms_err(&m.acceleration()));
        assert!(est_err < 0.2 * naive_err, "{est_err} vs {naive_err}");
        // Not attenuated: the fitted amplitude is the true 0.79 m/s² within 1 %.
        let gain = est[50..n - 50]
            .iter()
            .zip(&truth[50..n - 50])
            .map(|(a, b)| a * b)
            .sum::<f64>()
            / truth[50..n - 50].iter().map(|b| b * b).sum::<f64>();
        assert!((gain - 1.0).abs() < 0.01, "gain {gain}");
    }

    /// A file of `n` samples at `rate` of a sine displacement with 2 µm white noise (seeded) and no velocity
    /// channel (the reader's 7-sample derivative in its place, as when such a file is read); with `jitter`,
    /// sample `k` at `(k + u) / rate`, `u` uniform in ±¼ (intervals 0.5–1.5 of the nominal one).
    fn sine_without_velocity(
        amp: f64,
        f_hz: f64,
        rate: f64,
        n: usize,
        seed: u64,
        jitter: bool,
    ) -> Measurement {
        use rand::Rng;
        let mut clock = rand_chacha::ChaCha8Rng::seed_from_u64(seed + 1_000_000);
        let mut u = || {
            if jitter {
                clock.random_range(-0.25..0.25)
            } else {
                0.0
            }
        };
        let t: Vec<f64> = (0..n).map(|k| (k as f64 + u()) / rate).collect();
        let n = t.len();
        let w = std::f64::consts::TAU * f_hz;
        let nd = noise(n, 2e-6, seed);
        let x: Vec<f64> = t.iter().zip(&nd).map(|(t, e)| amp * (w * t).sin() + e).collect();
        Measurement {
            path: "a.csv".into(),
            v_m_s: crate::signal::smooth_derivative(&t, &x),
            x_m: x,
            velocity_measured: false,
            i_a: vec![1.0; n],
            f_n: vec![0.0; n],
            t_s: t,
            ..Default::default()
        }
    }

    /// The hysteresis law integrates the path `|dx|` sample by sample. Near the reversals of a 20 mm 1 Hz
    /// sine at 2 kHz (|v| < 20 mm/s) a 2 µm displacement noise adds 8 % to that path, travel the piston never
    /// made; the displacement handed to the model is smoothed, and adds under 1 %.
    #[test]
    fn the_path_near_reversals_is_the_piston_s_not_the_noise_s() {
        let (amp, f_hz, rate, n) = (0.02, 1.0, 2000.0, 8000usize);
        let w = std::f64::consts::TAU * f_hz;
        let m = sine_without_velocity(amp, f_hz, rate, n, 11, false);
        let inputs = inputs_of(&m);
        let (mut truth, mut raw, mut model) = (0.0, 0.0, 0.0);
        for k in 0..n - 1 {
            if (amp * w * (w * m.t_s[k]).cos()).abs() < 0.02 {
                truth += (amp * ((w * m.t_s[k + 1]).sin() - (w * m.t_s[k]).sin())).abs();
                raw += (m.x_m[k + 1] - m.x_m[k]).abs();
                model += (inputs[k + 1].x_m - inputs[k].x_m).abs();
            }
        }
        assert!(
            raw / truth - 1.0 > 0.04,
            "the noise must matter here: raw path {raw}, truth {truth}"
        );
        assert!(
            (model / truth - 1.0).abs() < 0.01,
            "model path {model} m, truth {truth} m (raw {raw} m)"
        );
    }

    /// 2 mm at 5 Hz sampled at 500 Hz, the first reversal 25 samples in: a centred 61-sample quintic would
    /// bend the first and last 30 samples (0.65 mm/s rms, 20× the noise), so the ends take their own window;
    /// they keep the velocity's sign at the reversal and report noise that covers their error.
    #[test]
    fn the_ends_of_a_short_fast_test_keep_their_velocity_sign_and_its_noise() {
        let (amp, f_hz, rate, n) = (0.002, 5.0, 500.0, 400usize);
        let w = std::f64::consts::TAU * f_hz;
        for seed in 0..8u64 {
            let test = Test::from_measurement(&sine_without_velocity(amp, f_hz, rate, n, 300 + seed, false));
            let sd = test.velocity_noise_m_s.as_ref().expect("derived velocity noise");
            let weights = residual::direction_weights(&test);
            let (mut ss, mut var) = (0.0, 0.0);
            for (k, i) in test.inputs.iter().enumerate() {
                let truth = amp * w * (w * i.t_s).cos();
                if weights[k] > 0.0 && truth.abs() > 1e-9 {
                    assert_eq!(
                        i.v_m_s.signum(),
                        truth.signum(),
                        "seed {seed}, sample {k}: {} m/s counted as known, truth {truth} m/s",
                        i.v_m_s
                    );
                }
                if k < 30 || k >= n - 30 {
                    ss += (i.v_m_s - truth).powi(2);
                    var += sd[k] * sd[k];
                }
            }
            // The error at the ends is within twice the noise reported there.
            assert!(
                ss < 4.0 * var,
                "seed {seed}: end error {} against noise {}",
                ss.sqrt(),
                var.sqrt()
            );
        }
    }

    /// Near the ends of a test, where a centred window does not reach, the off-centre windows give
    /// derivatives about as good as inside.
    #[test]
    fn derivatives_near_the_ends_of_a_test_are_as_good_as_inside() {
        let (amp, f_hz, rate, n) = (0.02, 1.0, 2000.0, 6000usize);
        let w = std::f64::consts::TAU * f_hz;
        let test = Test::from_measurement(&sine_without_velocity(amp, f_hz, rate, n, 7, false));
        let ends: Vec<&Inputs> = test.inputs[..40].iter().chain(&test.inputs[n - 40..]).collect();
        let a_rms = amp * w * w / 2f64.sqrt();
        let v_rms = amp * w / 2f64.sqrt();
        for i in ends {
            let a_err = i.a_m_s2 + amp * w * w * (w * i.t_s).sin();
            let v_err = i.v_m_s - amp * w * (w * i.t_s).cos();
            for (what, err, tol, unit) in [
                ("acceleration", a_err, 0.3 * a_rms, "m/s²"),
                ("velocity", v_err, 0.01 * v_rms, "m/s"),
            ] {
                assert!(err.abs() < tol, "t = {} s: {what} off by {err} {unit}", i.t_s);
            }
        }
    }

    /// Slow sines (0.4 and 1 Hz at 1 kHz), displacement only (2 µm noise), on eight noise seeds: the window
    /// widens every time, so the acceleration from the displacement twice is within 5 % of the signal. The
    /// derived velocity's noise is estimated within 25 %.
    #[test]
    fn acceleration_and_velocity_noise_from_displacement_alone_on_every_seed() {
        for (seed, f_hz) in (0..8u64).map(|s| (s, if s % 2 == 0 { 0.4 } else { 1.0 })) {
            let m = sine_without_velocity(0.02, f_hz, 1000.0, 5000, 100 + seed, false);
            check_sine_derivatives(&m, 0.02, f_hz, 100..4900);
        }
    }

    /// The same on a clock jittered by up to ¼ sample (the format asks only for increasing times), the
    /// acceleration checked at every sample.
    #[test]
    fn derivatives_on_a_jittered_clock_are_as_good_as_on_an_even_one() {
        for (seed, f_hz) in [(0u64, 0.4), (1, 1.0), (2, 2.5)] {
            let m = sine_without_velocity(0.02, f_hz, 1000.0, 5000, 200 + seed, true);
            assert!(crate::signal::uniform_interval(&m.t_s).is_none());
            check_sine_derivatives(&m, 0.02, f_hz, 0..5000);
        }
    }

    /// A record with a hole (100 samples lost in the middle of a 10 mm 2.5 Hz sine at 1 kHz, displacement
    /// only): each side is differentiated on its own, as well as a record without one.
    #[test]
    fn derivatives_on_either_side_of_a_hole_in_the_record() {
        let (amp, f_hz) = (0.01, 2.5);
        let mut m = sine_without_velocity(amp, f_hz, 1000.0, 5000, 300, false);
        for c in [&mut m.t_s, &mut m.x_m, &mut m.v_m_s, &mut m.i_a, &mut m.f_n] {
            c.drain(2000..2100);
        }
        m.v_m_s = crate::signal::smooth_derivative(&m.t_s, &m.x_m);
        check_sine_derivatives(&m, amp, f_hz, 0..4900);
        // Beside the hole, as at the ends of a test: the velocity's error within the noise it reports there
        // (the sign of a velocity more than 4 of them from zero is taken as known), and the acceleration
        // within 30 % of the signal.
        let test = Test::from_measurement(&m);
        let sd = test.velocity_noise_m_s.as_ref().expect("derived velocity noise");
        let w = std::f64::consts::TAU * f_hz;
        let a_rms = amp * w * w / 2f64.sqrt();
        let (mut worst_v, mut worst_a) = (0.0f64, 0.0f64);
        for (k, i) in test.inputs.iter().enumerate().take(2050).skip(1950) {
            let v_err = i.v_m_s - amp * w * (w * i.t_s).cos();
            worst_v = worst_v.max(v_err.abs() / sd[k]);
            worst_a = worst_a.max((i.a_m_s2 + amp * w * w * (w * i.t_s).sin()).abs() / a_rms);
        }
        assert!(
            worst_v < 4.0 && worst_a < 0.3,
            "beside the hole: velocity off by {worst_v:.2} of its noise, acceleration by {worst_a:.3} of its rms"
        );
    }

    /// On a displacement-only sine of amplitude `amp`: the acceleration derived twice is within 5 % (rms)
    /// of the signal over the samples `a_span`, and the derived velocity's noise, away from the ends, is
    /// estimated within 25 %.
    fn check_sine_derivatives(m: &Measurement, amp: f64, f_hz: f64, a_span: std::ops::Range<usize>) {
        let w = std::f64::consts::TAU * f_hz;
        let rms = |e: &mut dyn Iterator<Item = f64>| {
            let (s, c) = e.fold((0.0, 0usize), |(s, c), e| (s + e * e, c + 1));
            (s / c as f64).sqrt()
        };
        let test = Test::from_measurement(m);
        let a_err = rms(&mut test.inputs[a_span]
            .iter()
            .map(|i| i.a_m_s2 + amp * w * w * (w * i.t_s).sin()));
        let a_rms = amp * w * w / 2f64.sqrt();
        assert!(
            a_err < 0.05 * a_rms,
            "{f_hz} Hz: acceleration error {a_err} of {a_rms} m/s²"
        );
        let n = test.len();
        let inner = &test.inputs[100..n - 100];
        let v_err = rms(&mut inner.iter().map(|i| i.v_m_s - amp * w * (w * i.t_s).cos()));
        let sigma = residual::velocity_noise_std(&test);
        assert!(
            (sigma / v_err - 1.0).abs() < 0.25,
            "{f_hz} Hz: derived velocity noise {v_err} m/s, estimated {sigma}"
        );
    }
}
