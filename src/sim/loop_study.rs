//! Discovery to feel: one scenario run against the same plant with each stage of a model discovery as the
//! feel controller's model (the base model, then the base with each effect in the order the diagnosis
//! added it), so the feel error can be read falling stage by stage.
//!
//! Figures per stage, over the samples where the law resists the motion (forces on the piston, N): the
//! force RMS error ([`super::Summary`]); the breakout error within 5 % of the stroke of centre (spring laws
//! with a breakout); the share within 14 CFR Part 60's feel tolerance (±2 lbf at the grip or ±10 %,
//! whichever is larger); and the error where the plant can render the force at all ([`Renderable`]), where
//! a better controller model can show.

use serde::Serialize;

use super::{build_rig, run, Devices, Results, RunOptions, SimError};
use crate::control::{FeelLaw, LoopMode};
use crate::device::{DeviceConfig, DeviceError, ForceInverse, Model, ModelSpec, Registry};
use crate::ident::diagnose::{diagnose, DiagnoseOptions};
use crate::ident::fit::{all_spans, fit};
use crate::ident::{IdentError, Test};
use crate::scenario::Scenario;

/// Share of the stroke about centre where a spring law's force is its breakout.
const BREAKOUT_BAND: f64 = 0.05;

/// A controller model: its spec and fitted parameters.
#[derive(Debug, Clone)]
pub struct StageModel {
    /// Model spec, `bingham+effect+…`.
    pub spec: String,
    /// The model with its fitted parameters, as the controller's device.
    pub device: DeviceConfig,
}

/// The feel figures of one stage.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct StageFigures {
    /// Model spec of the stage.
    pub model: String,
    /// Samples where the desired force resists the motion.
    pub resisting_samples: usize,
    /// RMS of (load cell − desired) over the resisting samples, N.
    pub force_rmse_n: f64,
    /// `force_rmse_n` over the RMS desired force there.
    pub force_nrmse: f64,
    /// RMS force error over the resisting samples near the centre (the breakout band), N; NaN without a breakout.
    pub breakout_rmse_n: f64,
    /// Share of resisting samples within ±2 lbf (at the grip) or ±10 %, whichever is larger.
    pub within_part60_share: f64,
    /// Resisting samples where the plant can render the desired force ([`Renderable`]).
    pub renderable_samples: usize,
    /// RMS of (load cell − desired) over the renderable samples, N.
    pub renderable_rmse_n: f64,
    /// `renderable_rmse_n` over the RMS desired force over them.
    pub renderable_nrmse: f64,
}

/// Share of the plant's force at the driver's limit up to which a desired force counts as renderable: the
/// feedback keeps some authority (as the flight metric's 90 % of the feel ceiling).
pub const RENDERABLE_SHARE: f64 = 0.9;

/// Which desired forces the plant can render at a speed: between its force at zero current and
/// [`RENDERABLE_SHARE`] of its force at the driver's limit, both with the lags settled and the plant's
/// states on their steady branch for the speed (the plant's own model, through the device code).
#[derive(Debug, Clone)]
pub struct Renderable {
    plant: ForceInverse,
    limit_a: f64,
}

impl Renderable {
    /// The band of `plant` with the driver limited to `limit_a` (a plant the inverse refuses has none).
    pub fn new(plant: &DeviceConfig, limit_a: f64) -> Result<Self, DeviceError> {
        Ok(Self {
            plant: ForceInverse::new(plant)?,
            limit_a: limit_a.min(plant.model.current_limit_a),
        })
    }

    /// The plant's force at zero current and at the driver's limit against a piston moving at `v_m_s` at
    /// `x_m`, N.
    fn range_n(&self, v_m_s: f64, x_m: f64) -> (f64, f64) {
        let (dir, speed) = (v_m_s.signum(), v_m_s.abs());
        (
            self.plant.force_n(0.0, dir, speed, x_m, false),
            self.plant.force_n(self.limit_a, dir, speed, x_m, false),
        )
    }

    /// Whether the plant can render `desired_n` against a piston moving at `v_m_s` at `x_m`.
    pub fn contains(&self, desired_n: f64, v_m_s: f64, x_m: f64) -> bool {
        let (lo, hi) = self.range_n(v_m_s, x_m);
        let f = desired_n.abs();
        f >= lo && f <= RENDERABLE_SHARE * hi
    }

    /// Samples, RMS error, N, and RMS error relative to the RMS desired force over the resisting samples
    /// of `res` inside the band.
    pub fn error(&self, res: &Results) -> (usize, f64, f64) {
        let rows = res.rows.iter();
        let inside =
            rows.filter(|r| resists(r) && self.contains(r.desired_force_n, r.piston_v_m_s, r.piston_x_m));
        let (se, sd, n) = inside.fold((0.0, 0.0, 0usize), |(se, sd, n), r| {
            (
                se + (r.load_cell_true_n - r.desired_force_n).powi(2),
                sd + r.desired_force_n.powi(2),
                n + 1,
            )
        });
        if n == 0 {
            return (0, f64::NAN, f64::NAN);
        }
        (n, (se / n as f64).sqrt(), (se / sd).sqrt())
    }

    /// RMS over the resisting samples of `res` of how far the desired force lies outside the plant's range
    /// at the sample's speed (0 A to the driver's limit, steady branch), N: the error no current removes
    /// on that motion.
    pub fn out_of_reach_n(&self, res: &Results) -> f64 {
        let (se, n) = res
            .rows
            .iter()
            .filter(|r| resists(r))
            .fold((0.0, 0usize), |(se, n), r| {
                let (lo, hi) = self.range_n(r.piston_v_m_s, r.piston_x_m);
                let f = r.desired_force_n.abs();
                (se + (f - hi).max(lo - f).max(0.0).powi(2), n + 1)
            });
        (se / n.max(1) as f64).sqrt()
    }
}

/// A row where the loop tracks a desired force that resists the motion.
fn resists(r: &super::Row) -> bool {
    r.mode == LoopMode::Tracking && r.desired_force_n * r.piston_v_m_s > 0.0
}

/// The diagnosis's stages on `tests` (base `bingham`, then each effect in the order it was added), each
/// fitted on all the data.
pub fn stages_from_data(
    tests: &[Test],
    current_limit_a: f64,
    registry: &Registry,
) -> Result<Vec<StageModel>, IdentError> {
    let opts = DiagnoseOptions {
        current_limit_a,
        ..Default::default()
    };
    let base = ModelSpec::parse(crate::device::model::BASE)?;
    let d = diagnose(tests, &base, registry, &opts)?;
    let spans = all_spans(tests);
    let mut out: Vec<StageModel> = Vec::new();
    let mut specs: Vec<String> = d.steps.iter().map(|s| s.model.clone()).collect();
    if !specs.contains(&d.final_model) {
        specs.push(d.final_model.clone());
    }
    for spec in specs {
        let model = Model::from_spec(&spec, registry, current_limit_a)?;
        let params = if spec == d.base_model {
            d.base_params.clone()
        } else if spec == d.final_model {
            d.final_params.clone()
        } else {
            fit(&model, tests, &spans, &opts.fit).params
        };
        let path = std::path::PathBuf::from(format!("{spec} fitted"));
        out.push(StageModel {
            device: DeviceConfig::from_model(model, params, path),
            spec,
        });
    }
    Ok(out)
}

/// Run `scn` on `plant` with each stage as the controller's model (in parallel; each run is independent
/// and seeded by the scenario, so the figures do not depend on the thread count).
pub fn run_stages(
    scn: &Scenario,
    plant: &DeviceConfig,
    stages: &[StageModel],
) -> anyhow::Result<Vec<(StageFigures, Results)>> {
    use rayon::prelude::*;
    stages
        .par_iter()
        .map(|st| {
            let devices = Devices {
                plant: plant.clone(),
                controller: st.device.clone(),
                controller_is_plant: false,
            };
            let rig = build_rig(scn, plant)?;
            let res = run(scn, &devices, rig, RunOptions::default(), |_| {})
                .map_err(|e: SimError| anyhow::anyhow!(e))?;
            Ok((figures(&st.spec, scn, plant, &res)?, res))
        })
        .collect()
}

/// The feel figures of a run (see the module documentation).
pub fn figures(
    model: &str,
    scn: &Scenario,
    plant: &DeviceConfig,
    res: &Results,
) -> Result<StageFigures, DeviceError> {
    let s = res.summary();
    let (renderable_samples, renderable_rmse_n, renderable_nrmse) =
        Renderable::new(plant, scn.controller.gains.out_max)?.error(res);
    let band = BREAKOUT_BAND * res.stroke_half_m;
    let has_breakout = matches!(scn.feel, FeelLaw::Spring { breakout_n, .. } if breakout_n > 0.0);
    let near = res
        .rows
        .iter()
        .filter(|r| resists(r) && r.piston_x_m.abs() < band);
    let (se, n) = near.fold((0.0, 0usize), |(se, n), r| {
        (se + (r.load_cell_true_n - r.desired_force_n).powi(2), n + 1)
    });
    let breakout_rmse_n = if has_breakout && n > 0 {
        (se / n as f64).sqrt()
    } else {
        f64::NAN
    };
    // 2 lbf at the grip, on the piston: F_piston = F_grip · arm / gearing.
    let abs_tol_n = 2.0 * crate::units::LBF_TO_N * res.grip_arm_m / res.gearing_at_centre_m_per_rad;
    let (within, total) = res
        .rows
        .iter()
        .filter(|r| resists(r))
        .fold((0usize, 0usize), |(w, t), r| {
            let tol = abs_tol_n.max(0.1 * r.desired_force_n.abs());
            (
                w + usize::from((r.load_cell_true_n - r.desired_force_n).abs() <= tol),
                t + 1,
            )
        });
    Ok(StageFigures {
        model: model.to_string(),
        resisting_samples: s.resisting_samples,
        force_rmse_n: s.tracking_rmse_n.unwrap_or(f64::NAN),
        force_nrmse: s.tracking_nrmse.unwrap_or(f64::NAN),
        breakout_rmse_n,
        within_part60_share: if total > 0 {
            within as f64 / total as f64
        } else {
            f64::NAN
        },
        renderable_samples,
        renderable_rmse_n,
        renderable_nrmse,
    })
}

/// The stages as a Markdown table, each with its change of the force RMS error against the first.
pub fn markdown_table(figs: &[StageFigures]) -> String {
    let mut s = String::from(
        "| stage | controller model | force RMS error N | % of RMS desired | vs first stage | where renderable N | % | vs first stage | breakout RMS error N | within ±2 lbf / 10 % |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    let first = figs.first().map_or(f64::NAN, |f| f.force_rmse_n);
    let first_r = figs.first().map_or(f64::NAN, |f| f.renderable_rmse_n);
    for (k, f) in figs.iter().enumerate() {
        s += &format!(
            "| {k} | {} | {:.2} | {:.1} | {:+.0} % | {:.2} | {:.1} | {:+.0} % | {:.2} | {:.0} % |\n",
            f.model,
            f.force_rmse_n,
            100.0 * f.force_nrmse,
            100.0 * (f.force_rmse_n / first - 1.0),
            f.renderable_rmse_n,
            100.0 * f.renderable_nrmse,
            100.0 * (f.renderable_rmse_n / first_r - 1.0),
            f.breakout_rmse_n,
            100.0 * f.within_part60_share
        );
    }
    s
}

/// `loop-study.png` and `.svg` in `dir`: the force RMS error and the breakout error against the stage.
pub fn plot(
    figs: &[StageFigures],
    dir: &std::path::Path,
    title: &str,
) -> Result<Vec<std::path::PathBuf>, crate::viz::plot::PlotError> {
    use crate::viz::plot::{save_charts, Chart, Series};
    let per = |f: fn(&StageFigures) -> f64| -> Vec<(f64, f64)> {
        figs.iter()
            .enumerate()
            .filter(|(_, s)| f(s).is_finite())
            .map(|(k, s)| (k as f64, f(s)))
            .collect()
    };
    let stages: Vec<String> = figs
        .iter()
        .enumerate()
        .map(|(k, f)| format!("{k}: {}", f.model))
        .collect();
    let chart = Chart::new(
        format!("{title} ({})", stages.join(", ")),
        "discovery stage (controller model)",
        "error on the piston (N)",
    )
    .with(Series::line(
        "force RMS error where the law resists",
        per(|s| s.force_rmse_n),
    ))
    .with(Series::line(
        "force RMS error where the plant can render it",
        per(|s| s.renderable_rmse_n),
    ))
    .with(Series::line("breakout RMS error", per(|s| s.breakout_rmse_n)));
    save_charts(&[chart], 1, dir, "loop-study")
}
