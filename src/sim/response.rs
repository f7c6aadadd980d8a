//! Force response time of the feel loop, which the paper says it evaluated (Section 6) but does not report:
//! steps of the desired force while the pilot moves the stick at a constant rate, measured on the true
//! load-cell force, and how they degrade as the DAQ rate falls.
//!
//! Definitions (per step from `F0` to `F1` at `t_k`, on `y = |F_load cell|`, the force resisting the motion):
//! - rise time: from `y` first crossing `F0 + 10 % (F1 − F0)` to first crossing `F0 + 90 % (F1 − F0)`;
//! - delay: from `t_k` to the 10 % crossing;
//! - settling time: from `t_k` to the last sample outside `F∞ ± 5 % |F1 − F0|` within the step's window,
//!   where `F∞` is the final value (the mean over the last fifth of the window: the textbook definition;
//!   the loop tracks the *measured* force, so the load cell's calibration residual puts `F∞` a few tenths
//!   of a newton off `F1`), on the force averaged over the last `SETTLING_AVERAGE_S` (a 1 ms mean: the
//!   rig's true load-cell force carries a ≈0.35 N RMS ripple at 4–5 kHz, the solver's step-to-step
//!   alternation at 10 kHz physics, which would otherwise decide when a ±1.5 N band is last left).
//!
//! A step counts only where the piston keeps one direction and moves faster than the rest speed over the
//! whole window (otherwise the damper force is not the controlled quantity), and where the force is still
//! on the old level's side of the 10 % point when the step comes (at a DAQ slower than the steps it may
//! already have moved, and a "delay" of 0 ms would be measured).

use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;

use super::results::Results;
use super::{Devices, RunOptions};
use crate::control::FeelLaw;
use crate::control::LoopMode;
use crate::scenario::Scenario;
use crate::viz::plot::{save_charts, Chart, PlotError, Series};

/// Length of the trailing mean the settling time is measured on, s (see the module doc).
pub(crate) const SETTLING_AVERAGE_S: f64 = 1e-3;

#[derive(Debug, Clone, Copy, Serialize, PartialEq)]
pub(crate) struct StepResponse {
    pub t_step_s: f64,
    pub from_n: f64,
    pub to_n: f64,
    pub delay_s: f64,
    pub rise_s: f64,
    /// `None` when the force did not stay in the ±5 % band about its final value before the next step, or
    /// that final value is outside the band about the target.
    pub settling_s: Option<f64>,
}

/// Responses to every valid step of a `ForceSteps` law in a run.
pub(crate) fn step_responses(res: &Results, law: &FeelLaw) -> Vec<StepResponse> {
    let FeelLaw::ForceSteps { period_s, .. } = *law else {
        return Vec::new();
    };
    let rows = &res.rows;
    let (Some(last), [first, second, ..]) = (rows.last(), &rows[..]) else {
        return Vec::new();
    };
    let dt = second.t_s - first.t_s;
    let mut out = Vec::new();
    for t_k in law.step_times_s(last.t_s) {
        let f0 = law.step_level_n(t_k - 0.5 * dt);
        let f1 = law.step_level_n(t_k + 0.5 * dt);
        if f0 == f1 {
            continue;
        }
        let i0 = rows.partition_point(|r| r.t_s < t_k);
        let i1 = rows.partition_point(|r| r.t_s < t_k + period_s);
        if i1 >= rows.len() || i1 <= i0 + 2 {
            continue;
        }
        let w = &rows[i0..i1];
        let dir = w[0].piston_v_m_s.signum();
        let steady = w
            .iter()
            .all(|r| r.piston_v_m_s * dir >= res.rest_speed_m_s && r.mode != LoopMode::Released);
        if !steady || dir == 0.0 {
            continue;
        }
        let frac = |r: &crate::sim::Row| (r.load_cell_true_n * dir - f0) / (f1 - f0);
        if frac(&w[0]) >= 0.1 {
            // The force had left the old level before the step (a DAQ slower than the steps): what follows
            // is no response to this step.
            continue;
        }
        let t10 = w.iter().find(|r| frac(r) >= 0.1).map(|r| r.t_s);
        let t90 = w.iter().find(|r| frac(r) >= 0.9).map(|r| r.t_s);
        let (Some(t10), Some(t90)) = (t10, t90) else {
            continue;
        };
        // Trailing mean over SETTLING_AVERAGE_S (samples before the step included).
        let n_avg = ((SETTLING_AVERAGE_S / dt).round() as usize).max(1);
        let avg: Vec<f64> = (i0..i1)
            .map(|i| {
                let lo = (i + 1).saturating_sub(n_avg);
                rows[lo..=i].iter().map(|r| r.load_cell_true_n * dir).sum::<f64>() / (i + 1 - lo) as f64
            })
            .collect();
        let tail = &avg[avg.len() - (avg.len() / 5).max(1)..];
        let final_n = tail.iter().sum::<f64>() / tail.len() as f64;
        let band = 0.05 * (f1 - f0).abs();
        let outside = |y: &f64| (y - final_n).abs() > band;
        let settling_s = if outside(&avg[avg.len() - 1]) || (final_n - f1).abs() > band {
            // Not settled, or settled somewhere else than the target.
            None
        } else {
            let last_out = avg.iter().rposition(outside);
            Some(match last_out {
                Some(k) => w[k].t_s + dt - t_k,
                None => 0.0,
            })
        };
        out.push(StepResponse {
            t_step_s: t_k,
            from_n: f0,
            to_n: f1,
            delay_s: t10 - t_k,
            rise_s: t90 - t10,
            settling_s,
        });
    }
    out
}

/// One line of the DAQ-rate table.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SweepPoint {
    /// DAQ rate, Hz.
    pub daq_rate_hz: f64,
    /// Force steps in the run.
    pub steps: usize,
    /// Mean delay to 10 % over the steps measured, ms; `None` when no step could be measured at this rate (a DAQ too slow to follow the scenario's steps), not a made-up 0.
    pub mean_delay_ms: Option<f64>,
    /// Mean rise time 10–90 %, ms (`None` as for the delay).
    pub mean_rise_ms: Option<f64>,
    /// Longest rise time 10–90 %, ms (`None` as for the delay).
    pub max_rise_ms: Option<f64>,
    /// Mean settling time over the steps that settled, ms; `None` if none did.
    pub mean_settling_ms: Option<f64>,
    /// Longest settling time over the steps that settled, ms; `None` if none did.
    pub max_settling_ms: Option<f64>,
    /// Steps that never settled within their window.
    pub unsettled: usize,
    /// `None` where nothing was tracked ([`crate::sim::Summary::tracking_nrmse`]).
    pub tracking_nrmse: Option<f64>,
}

pub(crate) fn summarise(rate_hz: f64, steps: &[StepResponse], res: &Results) -> SweepPoint {
    let n = steps.len() as f64;
    let any = !steps.is_empty();
    let settled: Vec<f64> = steps.iter().filter_map(|s| s.settling_s).collect();
    SweepPoint {
        daq_rate_hz: rate_hz,
        steps: steps.len(),
        mean_delay_ms: any.then(|| 1e3 * steps.iter().map(|s| s.delay_s).sum::<f64>() / n),
        mean_rise_ms: any.then(|| 1e3 * steps.iter().map(|s| s.rise_s).sum::<f64>() / n),
        max_rise_ms: any.then(|| 1e3 * steps.iter().map(|s| s.rise_s).fold(0.0, f64::max)),
        mean_settling_ms: (!settled.is_empty())
            .then(|| 1e3 * settled.iter().sum::<f64>() / settled.len() as f64),
        max_settling_ms: (!settled.is_empty()).then(|| 1e3 * settled.iter().copied().fold(0.0, f64::max)),
        unsettled: steps.len() - settled.len(),
        tracking_nrmse: res.summary().tracking_nrmse,
    }
}

/// The table as Markdown.
pub fn markdown_table(points: &[SweepPoint]) -> String {
    let mut s = String::from(
        "| DAQ rate (Hz) | steps | delay (ms) | rise 10–90 % (ms), mean / max | settling ±5 % (ms), mean / max | unsettled | tracking NRMSE |\n|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    let opt = |v: Option<f64>| v.map(|x| format!("{x:.1}")).unwrap_or_else(|| "–".into());
    for p in points {
        s.push_str(&format!(
            "| {:.0} | {} | {} | {} / {} | {} / {} | {} | {} |\n",
            p.daq_rate_hz,
            p.steps,
            opt(p.mean_delay_ms),
            opt(p.mean_rise_ms),
            opt(p.max_rise_ms),
            opt(p.mean_settling_ms),
            opt(p.max_settling_ms),
            p.unsettled,
            p.tracking_nrmse.map_or("–".into(), |x| format!("{x:.3}"))
        ));
    }
    s
}

/// Plot delay, rise and settling time against the DAQ period (1/rate, linear: the latency is linear in it)
/// as `daq-sweep.png` and `daq-sweep.svg` in `dir`.
pub fn plot(points: &[SweepPoint], dir: &Path, title: &str) -> Result<Vec<std::path::PathBuf>, PlotError> {
    let per = |f: fn(&SweepPoint) -> Option<f64>| -> Vec<(f64, f64)> {
        points
            .iter()
            .filter_map(|p| f(p).map(|y| (1e3 / p.daq_rate_hz, y)))
            .collect()
    };
    let chart = Chart::new(title, "DAQ period (ms) = 1000 / rate (Hz)", "time (ms)")
        .with(Series::line("delay to 10 %", per(|p| p.mean_delay_ms)))
        .with(Series::line("rise 10–90 %, mean", per(|p| p.mean_rise_ms)))
        .with(Series::points("rise 10–90 %, max", per(|p| p.max_rise_ms)))
        .with(Series::line("settling ±5 %, mean", per(|p| p.mean_settling_ms)));
    save_charts(&[chart], 1, dir, "daq-sweep")
}

/// Run the scenario at each DAQ rate (in parallel, results in order) and measure the step responses;
/// `done` is called as each rate finishes.
pub fn sweep(
    scn: &Scenario,
    devices: &Devices,
    rates: &[f64],
    done: impl Fn() + Sync,
) -> anyhow::Result<Vec<SweepPoint>> {
    // The scenario's own fault first: a sweep of a scenario that is not a step test has no rate to try.
    anyhow::ensure!(
        matches!(scn.feel, crate::control::FeelLaw::ForceSteps { .. }),
        "{}:{}: `feel.law`: daq-sweep needs `feel.law = \"force-steps\"` (a step test of the feel loop)",
        scn.path.display(),
        scn.lines.feel_law
    );
    for &r in rates {
        anyhow::ensure!(
            r > 0.0 && r <= scn.physics_rate_hz(),
            "--rates: DAQ rate {r} Hz is outside (0, {}] Hz, the scenario's physics rate ({}:{}: `rig.physics_hz`)",
            scn.physics_rate_hz(),
            scn.path.display(),
            scn.lines.physics_hz
        );
    }
    rates
        .par_iter()
        .map(|&rate| {
            let s = scn.with_daq_rate(rate);
            let rig = super::build_rig(&s, &devices.plant)?;
            let res = super::run(&s, devices, rig, RunOptions::default(), |_| {})?;
            let steps = step_responses(&res, &s.feel);
            done();
            Ok(summarise(rate, &steps, &res))
        })
        .collect()
}
