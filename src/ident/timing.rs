//! When a logged current command takes effect. A row pairs the sensors read at `t_k` with the command
//! logged at `t_k`, and nothing in the file says how:
//! - **after its sample** ([`CommandTiming::AfterSample`], the default): a DAQ loop reads, then writes, so
//!   the command of row `k` acts over `(t_k, t_{k+1}]` (the paper's rig, `mrfeel mts`);
//! - **at its sample** ([`CommandTiming::AtSample`]): the command of row `k` acted over `(t_{k−1}, t_k]`.
//!
//! Each current step read the wrong way leaves a sample off by the whole change of the yield force. `auto`
//! fits both ways where some test's command changes and keeps the smaller loss.

use super::fit::{all_spans, fit, FitOptions, FitResult};
use super::Test;
use crate::device::{Inputs, Model};
pub use crate::input::params::CommandTiming;

impl CommandTiming {
    /// In words, for reports.
    pub fn describe(self) -> &'static str {
        match self {
            Self::AfterSample => "each logged current command acts after its own sample",
            Self::AtSample => "each logged current command is already in force at its own sample",
        }
    }
}

/// What the command line asks for: a reading, or `auto` (decided by the data).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TimingChoice {
    #[default]
    /// Fit both ways where a command changes, keep the smaller error.
    Auto,
    /// Every command after its sample.
    AfterSample,
    /// Every command at its sample.
    AtSample,
}

impl TimingChoice {
    /// Every choice, in the order the command line lists them.
    pub const ALL: [TimingChoice; 3] = [Self::Auto, Self::AfterSample, Self::AtSample];

    /// The choice's name on the command line.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::AfterSample => CommandTiming::AfterSample.as_str(),
            Self::AtSample => CommandTiming::AtSample.as_str(),
        }
    }
}

impl std::str::FromStr for TimingChoice {
    type Err = String;

    fn from_str(name: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|c| c.as_str() == name)
            .ok_or_else(|| format!("{name}: expected auto, after-sample or at-sample"))
    }
}

/// Whether the current command is the same, to the bit, at every sample of `inputs`: the lags (Eq. 3–4)
/// then start settled on it and stay there, and both readings are the same model.
pub(crate) fn command_never_changes(inputs: &[Inputs]) -> bool {
    inputs
        .iter()
        .all(|s| s.current_cmd_a.to_bits() == inputs[0].current_cmd_a.to_bits())
}

/// The tests as the model reads them under `timing`, from tests loaded as logged ([`Test::from_measurement`]
/// reads them after their sample). At-sample: the model holds the command of row `k + 1` over
/// `(t_k, t_{k+1}]`; the last row keeps its own, and the first sample's lags start settled at the command of
/// row 1 (what is in force just after `t_0`).
pub(crate) fn retimed(mut tests: Vec<Test>, timing: CommandTiming) -> Vec<Test> {
    if timing == CommandTiming::AtSample {
        for t in &mut tests {
            let n = t.inputs.len();
            for k in 0..n.saturating_sub(1) {
                t.inputs[k].current_cmd_a = t.inputs[k + 1].current_cmd_a;
            }
        }
    }
    tests
}

/// The reading chosen, with the two fits that chose it when `auto` had to decide.
#[derive(Debug, Clone)]
pub struct TimingDecision {
    /// The reading chosen.
    pub timing: CommandTiming,
    /// `(after-sample fit, at-sample fit)` of the deciding model on every sample, when they were made.
    pub fits: Option<(FitResult, FitResult)>,
}

impl TimingDecision {
    /// The deciding fit of the reading kept, if any.
    pub(crate) fn kept_fit(&self) -> Option<&FitResult> {
        self.fits.as_ref().map(|(a, b)| match self.timing {
            CommandTiming::AfterSample => a,
            CommandTiming::AtSample => b,
        })
    }

    /// One line for stderr and reports.
    pub fn note(&self) -> String {
        match &self.fits {
            Some((a, b)) => format!(
                "current command timing: {} ({}; fitted both ways: NRMSE {:.4} after its sample, {:.4} at it; \
                 the fit's loss, which decides, {} and {} N²)",
                self.timing.as_str(),
                self.timing.describe(),
                a.nrmse(),
                b.nrmse(),
                crate::input::text::significant(a.loss, 7),
                crate::input::text::significant(b.loss, 7)
            ),
            None => format!("current command timing: {} ({})", self.timing.as_str(), self.timing.describe()),
        }
    }
}

/// Decide the reading for `tests` (as loaded): the one asked for, or under `auto` the one whose fit of
/// `model` on every sample has the smaller loss (after-sample on a tie, and without fitting where no command
/// changes). Returns the tests as the model reads them.
pub fn decide(
    model: &Model,
    tests: Vec<Test>,
    choice: TimingChoice,
    opts: &FitOptions,
) -> (Vec<Test>, TimingDecision) {
    let timing = match choice {
        TimingChoice::AfterSample => CommandTiming::AfterSample,
        TimingChoice::AtSample => CommandTiming::AtSample,
        TimingChoice::Auto if tests.iter().all(|t| command_never_changes(&t.inputs)) => {
            CommandTiming::AfterSample
        }
        TimingChoice::Auto => {
            let spans = all_spans(&tests);
            let fa = fit(model, &tests, &spans, opts);
            let at = retimed(tests.clone(), CommandTiming::AtSample);
            let fb = fit(model, &at, &spans, opts);
            let (timing, read) = if fb.loss < fa.loss {
                (CommandTiming::AtSample, at)
            } else {
                (CommandTiming::AfterSample, tests)
            };
            let fits = Some((fa, fb));
            return (read, TimingDecision { timing, fits });
        }
    };
    (retimed(tests, timing), TimingDecision { timing, fits: None })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::effects::testkit;

    const NOISE_N: f64 = 0.2;
    /// Current levels of the paper's driver, each held 0.25 s.
    const LEVELS: [f64; 5] = [0.0, 14.0, 3.5, 10.5, 7.0];

    /// A 1 Hz, 20 mm sine at 1 kHz whose current steps every 250 samples, and a device whose force is written
    /// here by hand (Eq. 2: 2 N + 4.83 N/A, 60 N·s/m) from a coil current `ic` with one lag of `lag_s`
    /// (none at 0). Over `(t_k, t_k+1]` the coil follows the command of row `k + 1` (`at_sample`) or of row
    /// `k`; without a lag the current in force at sample `k` is then the command of row `k` or of row `k − 1`.
    /// Seeded load-cell noise.
    fn stepped(at_sample: bool, lag_s: f64, seed: u64) -> Vec<Test> {
        let mut inputs = testkit::sine(0.02, 1.0, 0.0, 1e-3, 3.999);
        for (k, inp) in inputs.iter_mut().enumerate() {
            inp.current_cmd_a = LEVELS[(k / 250) % LEVELS.len()];
        }
        let noise = crate::ident::noise(inputs.len(), NOISE_N, seed);
        let decay = if lag_s > 0.0 { (-1e-3 / lag_s).exp() } else { 0.0 };
        let mut ic = inputs[0].current_cmd_a;
        let mut f_n = Vec::with_capacity(inputs.len());
        for k in 0..inputs.len() {
            let v = inputs[k].v_m_s;
            f_n.push((2.0 + 4.83 * ic) * v.signum() + 60.0 * v + noise[k]);
            let cmd = inputs[(k + usize::from(at_sample)).min(inputs.len() - 1)].current_cmd_a;
            ic = cmd + (ic - cmd) * decay;
        }
        vec![Test::synthetic("steps.csv", "steps", inputs, f_n)]
    }

    fn quick() -> FitOptions {
        FitOptions {
            std_errors: false,
            ..FitOptions::default()
        }
    }

    #[test]
    fn a_step_in_force_at_its_own_sample_is_read_so_and_fitted_to_the_noise() {
        let model = testkit::model("bingham");
        for seed in [1, 2] {
            let tests = stepped(true, 0.0, seed);
            let (read, d) = decide(&model, tests.clone(), TimingChoice::Auto, &quick());
            assert_eq!(d.timing, CommandTiming::AtSample, "seed {seed}: {}", d.note());
            let (after, at) = d.fits.as_ref().expect("both readings fitted");
            let (after, at) = (after.rmse_n(), at.rmse_n());
            // Read after its sample, every step (16 of them) leaves a sample off by the whole change of the
            // yield force (17–68 N): several times the noise. Read at it, the right model meets the noise.
            assert!(at < 1.05 * NOISE_N, "seed {seed}: at-sample RMSE {at}");
            assert!(after > 2.0 * NOISE_N, "seed {seed}: after-sample RMSE {after}");
            // The tests handed on are the ones that fit: the command of row k + 1 over (t_k, t_k+1].
            assert_eq!(read[0].inputs[249].current_cmd_a, LEVELS[1]);
            assert_eq!(tests[0].inputs[249].current_cmd_a, LEVELS[0]);
        }
    }

    #[test]
    fn a_daq_that_writes_after_reading_is_read_after_its_sample() {
        let model = testkit::model("bingham");
        let tests = stepped(false, 0.0, 3);
        let (read, d) = decide(&model, tests.clone(), TimingChoice::Auto, &quick());
        assert_eq!(d.timing, CommandTiming::AfterSample, "{}", d.note());
        let (after, at) = d.fits.as_ref().expect("both readings fitted");
        assert!(
            after.rmse_n() < 1.05 * NOISE_N && at.rmse_n() > 2.0 * NOISE_N,
            "{}",
            d.note()
        );
        assert_eq!(read[0].inputs, tests[0].inputs);
    }

    #[test]
    fn a_command_that_never_changes_is_read_without_a_fit_and_asked_readings_are_kept() {
        let model = testkit::model("bingham");
        let mut tests = stepped(true, 0.0, 4);
        tests[0].inputs.iter_mut().for_each(|inp| inp.current_cmd_a = 7.0);
        let (_, d) = decide(&model, tests.clone(), TimingChoice::Auto, &quick());
        assert!(d.fits.is_none() && d.timing == CommandTiming::AfterSample);
        // Asked for, a reading is taken as it is, even where the other would fit better.
        let steps = stepped(true, 0.0, 4);
        let (read, d) = decide(&model, steps.clone(), TimingChoice::AfterSample, &quick());
        assert!(d.fits.is_none() && d.timing == CommandTiming::AfterSample);
        assert_eq!(read[0].inputs, steps[0].inputs);
    }

    #[test]
    fn a_lag_far_shorter_than_a_sample_is_held_on_its_bound() {
        // Read at their sample, the steps of a device without lags are fitted by lags that run to ~0, where
        // the force stops depending on them and their standard errors become enormous. They are held on their
        // bound, where the force is the same as where the search left them, not at their initial value
        // (5 sample intervals), which would spoil the fit.
        let model = testkit::model("bingham");
        let tests = retimed(stepped(true, 0.0, 5), CommandTiming::AtSample);
        let fr = fit(&model, &tests, &all_spans(&tests), &FitOptions::default());
        let rmse = fr.rmse_n();
        assert!(rmse < 1.05 * NOISE_N, "RMSE {rmse} N, notes {:?}", fr.notes);
        for k in [crate::device::bingham::TE, crate::device::bingham::TM] {
            assert!(fr.params[k] < 1e-4, "{}: {:?}", fr.params[k], fr.notes);
        }
    }

    #[test]
    fn a_coil_lag_as_short_as_a_sample_is_read_at_its_sample_when_so_logged() {
        // One lag of a sample interval: the step response is still mostly in the first sample, so the
        // reading still decides the fit.
        let model = testkit::model("bingham");
        for (at_sample, want) in [
            (true, CommandTiming::AtSample),
            (false, CommandTiming::AfterSample),
        ] {
            let tests = stepped(at_sample, 1e-3, 6);
            let (_, d) = decide(&model, tests.clone(), TimingChoice::Auto, &FitOptions::default());
            let note = d.note();
            assert_eq!(d.timing, want, "{note}");
            let fr = d.kept_fit().expect("fitted");
            let rmse = fr.rmse_n();
            assert!(rmse < 1.05 * NOISE_N, "{note}: RMSE {rmse} N");
            let te = fr.params[crate::device::bingham::TE].max(fr.params[crate::device::bingham::TM]);
            assert!((te - 1e-3).abs() < 2e-4, "{note}: lags {:?}", &fr.params[3..5]);
        }
    }
}
