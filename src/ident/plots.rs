//! Static plots (PNG + SVG) of a fit or a diagnosis: measured vs model force–time, force–displacement and
//! force–velocity per current level, the residual over |v| × current and over time, the candidate ranking
//! and the held-out error falling as effects are added.

use std::path::{Path, PathBuf};

use plotters::coord::Shift;
use plotters::prelude::*;

use super::diagnose::Diagnosis;
use super::residual::{heatmap, CurrentBins};
use super::{IdentError, Test};

fn e2s<E: std::fmt::Display>(e: E) -> IdentError {
    IdentError::Other(format!("plot: {e}"))
}

/// Draw the same figure into `NAME.png` and `NAME.svg`, each whole or not at all
/// ([`crate::outputs::write_whole`]), and list both in `$out`.
macro_rules! both {
    ($dir:expr, $name:expr, $size:expr, $out:expr, |$root:ident| $body:expr) => {{
        crate::viz::plot::register_font();
        let name = $name;
        let (png, svg) = ($dir.join(format!("{name}.png")), $dir.join(format!("{name}.svg")));
        both!(@ BitMapBackend, png, $size, |$root| $body);
        both!(@ SVGBackend, svg, $size, |$root| $body);
        $out.extend([png, svg]);
    }};
    (@ $backend:ident, $path:expr, $size:expr, |$root:ident| $body:expr) => {
        crate::outputs::write_whole(
            &$path,
            |tmp| -> Result<(), IdentError> {
                let $root = $backend::new(tmp, $size).into_drawing_area();
                $root.fill(&WHITE).map_err(e2s)?;
                $body?;
                $root.present().map_err(e2s)
            },
            e2s,
        )?
    };
}

/// Every `k`-th index so that at most `max` remain.
fn stride(n: usize, max: usize) -> usize {
    n.div_ceil(max.max(1)).max(1)
}

struct Panel {
    title: String,
    /// (x, measured, model) per sample, possibly from several tests (NaN x breaks a line).
    pts: Vec<(f64, f64, f64)>,
}

fn range(it: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in it.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let pad = 0.05 * (hi - lo).max(1e-12);
    (lo - pad, hi + pad)
}

fn draw_panels<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    caption: &str,
    xlabel: &str,
    panels: &[Panel],
) -> Result<(), IdentError> {
    let root = root.titled(caption, ("sans-serif", 22)).map_err(e2s)?;
    let cols = panels.len().clamp(1, 3);
    let rows = panels.len().div_ceil(cols).max(1);
    let areas = root.split_evenly((rows, cols));
    for (p, area) in panels.iter().zip(areas.iter()) {
        let (x0, x1) = range(p.pts.iter().map(|q| q.0));
        let (y0, y1) = range(p.pts.iter().flat_map(|q| [q.1, q.2]));
        let mut chart = ChartBuilder::on(area)
            .caption(&p.title, ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(32)
            .y_label_area_size(56)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(e2s)?;
        chart
            .configure_mesh()
            .x_desc(xlabel)
            .y_desc("force, N")
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(e2s)?;
        for (k, color) in [(1usize, RGBColor(90, 90, 90)), (2usize, RGBColor(220, 40, 30))] {
            // One line per stretch between the NaN breaks.
            for (i, s) in p.pts.split(|q| q.0.is_nan()).enumerate() {
                let line = s.iter().map(|q| (q.0, if k == 1 { q.1 } else { q.2 }));
                let series = chart
                    .draw_series(LineSeries::new(line, color.stroke_width(1)))
                    .map_err(e2s)?;
                if i == 0 {
                    series
                        .label(if k == 1 { "measured" } else { "model" })
                        .legend(move |(x, y)| {
                            PathElement::new(vec![(x, y), (x + 16, y)], color.stroke_width(2))
                        });
                }
            }
        }
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .label_font(("sans-serif", 12))
            .draw()
            .map_err(e2s)?;
    }
    Ok(())
}

/// Panels per current level: `x_of` picks the abscissa of a sample; `one_test` keeps only the test with the
/// most samples at that level (for time plots).
#[allow(clippy::needless_range_loop)] // several parallel per-sample arrays
fn panels_by_current(
    tests: &[Test],
    pred: &[Vec<f64>],
    x_of: impl Fn(&Test, usize) -> f64,
    one_test: bool,
) -> Vec<Panel> {
    let cb = CurrentBins::of(tests);
    (0..cb.len())
        .filter_map(|b| {
            let counts: Vec<usize> = tests
                .iter()
                .map(|t| t.inputs.iter().filter(|i| cb.index(i.current_cmd_a) == b).count())
                .collect();
            let total: usize = counts.iter().sum();
            if total == 0 {
                return None;
            }
            let best = (0..tests.len()).max_by_key(|&j| counts[j]).unwrap_or(0);
            let keep = stride(if one_test { counts[best] } else { total }, 6000);
            let mut pts = Vec::new();
            let mut seen = 0usize;
            for (j, (t, p)) in tests.iter().zip(pred).enumerate() {
                if one_test && j != best {
                    continue;
                }
                let mut last_in = false;
                for k in 0..t.len() {
                    let inside = cb.index(t.inputs[k].current_cmd_a) == b;
                    if inside {
                        if seen.is_multiple_of(keep) {
                            pts.push((x_of(t, k), t.f_n[k], p[k]));
                        }
                        seen += 1;
                    } else if last_in {
                        pts.push((f64::NAN, 0.0, 0.0));
                    }
                    last_in = inside;
                }
                pts.push((f64::NAN, 0.0, 0.0));
            }
            let title = if one_test {
                format!("{} ({})", cb.label(b), tests[best].name)
            } else {
                cb.label(b)
            };
            Some(Panel { title, pts })
        })
        .collect()
}

/// The abscissa of a sample of a test in a panel.
type Abscissa = fn(&Test, usize) -> f64;

/// Measured vs model plots and residual maps for one model on some tests. Returns the files written.
pub fn plot_model(
    dir: &Path,
    tests: &[Test],
    pred: &[Vec<f64>],
    model: &str,
    prefix: &str,
) -> Result<Vec<PathBuf>, IdentError> {
    std::fs::create_dir_all(dir).map_err(|e| IdentError::Other(format!("{}: {e}", dir.display())))?;
    let mut out = Vec::new();
    let size = (1500, 900);
    let pfx = format!("{prefix}{}", if prefix.is_empty() { "" } else { "_" });
    // Measured vs model force over time (the test with most samples at each current), displacement, velocity.
    let views: [(&str, Abscissa, bool, &str, &str); 3] = [
        (
            "force_time",
            |t, k| t.inputs[k].t_s,
            true,
            "measured vs model force over time",
            "time, s",
        ),
        (
            "force_displacement",
            |t, k| t.inputs[k].x_m * 1e3,
            false,
            "force vs displacement",
            "displacement, mm",
        ),
        (
            "force_velocity",
            |t, k| t.inputs[k].v_m_s,
            false,
            "force vs velocity",
            "velocity, m/s",
        ),
    ];
    for (name, x_of, one_test, what, xlabel) in views {
        let panels = panels_by_current(tests, pred, x_of, one_test);
        let caption = format!("{model}: {what}");
        both!(dir, format!("{pfx}{name}"), size, out, |root| draw_panels(
            &root, &caption, xlabel, &panels
        ));
    }
    let hm = heatmap(tests, pred, 12);
    both!(dir, format!("{pfx}residual_heatmap"), (1000, 600), out, |root| {
        draw_heatmap(&root, model, &hm)
    });
    both!(dir, format!("{pfx}residual_time"), (1400, 500), out, |root| {
        draw_residual_time(&root, model, tests, pred)
    });
    Ok(out)
}

fn draw_heatmap<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    model: &str,
    hm: &super::residual::Heatmap,
) -> Result<(), IdentError> {
    let nv = hm.v_edges_m_s.len() - 1;
    let ni = hm.current_labels.len();
    let vmax = *hm.v_edges_m_s.last().unwrap_or(&1.0);
    let rmax = hm
        .rms_n
        .iter()
        .flatten()
        .filter(|v| v.is_finite())
        .fold(0.0f64, |m, v| m.max(*v))
        .max(1e-12);
    let (main, bar) = root.split_horizontally(880);
    let labels = hm.current_labels.clone();
    let mut chart = ChartBuilder::on(&main)
        .caption(
            format!(
                "{model}: RMS residual over |v| × current (max {} N)",
                crate::input::text::significant(rmax, 3)
            ),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(110)
        .build_cartesian_2d(0.0..vmax, 0.0..ni as f64)
        .map_err(e2s)?;
    chart
        .configure_mesh()
        .disable_mesh()
        .x_desc("|velocity|, m/s")
        // Ticks every half row, labelled at the rows' centres only: each current beside its own row.
        .y_labels(2 * ni + 1)
        .y_label_formatter(&|y| {
            let k = y.floor() as usize;
            let centre = (y - y.floor() - 0.5).abs() < 1e-9;
            labels.get(k).filter(|_| centre).cloned().unwrap_or_default()
        })
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(e2s)?;
    let color = crate::viz::plot::colormap;
    for (i, row) in hm.rms_n.iter().enumerate() {
        for (v, val) in row.iter().enumerate().filter(|(_, val)| val.is_finite()) {
            let x0 = hm.v_edges_m_s[v];
            let x1 = hm.v_edges_m_s[(v + 1).min(nv)];
            chart
                .draw_series(std::iter::once(Rectangle::new(
                    [(x0, i as f64), (x1, i as f64 + 1.0)],
                    color(val / rmax).filled(),
                )))
                .map_err(e2s)?;
        }
    }
    // Colour bar.
    let mut cb = ChartBuilder::on(&bar)
        .margin(20)
        .y_label_area_size(50)
        .caption("N", ("sans-serif", 14))
        .build_cartesian_2d(0.0..1.0, 0.0..rmax)
        .map_err(e2s)?;
    cb.configure_mesh()
        .disable_mesh()
        .disable_x_axis()
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(e2s)?;
    cb.draw_series((0..50).map(|k| {
        let a = rmax * k as f64 / 50.0;
        let b = rmax * (k + 1) as f64 / 50.0;
        Rectangle::new([(0.0, a), (1.0, b)], color(k as f64 / 50.0).filled())
    }))
    .map_err(e2s)?;
    Ok(())
}

fn draw_residual_time<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    model: &str,
    tests: &[Test],
    pred: &[Vec<f64>],
) -> Result<(), IdentError> {
    // Tests placed one after the other on a common axis (each from its own start).
    let mut offset = 0.0;
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for (t, p) in tests.iter().zip(pred) {
        let n = t.len();
        if n == 0 {
            continue;
        }
        let t0 = t.inputs[0].t_s;
        let s = stride(n, 20_000 / tests.len().max(1));
        let pts: Vec<(f64, f64)> = (0..n)
            .step_by(s)
            .map(|k| (offset + t.inputs[k].t_s - t0, p[k] - t.f_n[k]))
            .collect();
        offset += t.inputs[n - 1].t_s - t0;
        series.push((t.name.clone(), pts));
    }
    let (y0, y1) = range(series.iter().flat_map(|s| s.1.iter().map(|q| q.1)));
    // The legend (a colour and a file name per test) beside the plot, where it hides no data.
    let (plot, legend) = root.split_horizontally(root.dim_in_pixel().0.saturating_sub(260));
    let row_px = ((legend.dim_in_pixel().1 as i32 - 60) / series.len().max(1) as i32).clamp(8, 22);
    for (k, (name, _)) in series.iter().enumerate() {
        let y = 50 + k as i32 * row_px;
        let c = Palette99::pick(k).to_rgba();
        legend
            .draw(&Rectangle::new([(6, y - 3), (26, y + 3)], c.filled()))
            .map_err(e2s)?;
        legend
            .draw(&Text::new(
                name.clone(),
                (32, y - 6),
                ("sans-serif", (row_px - 2).clamp(8, 13)),
            ))
            .map_err(e2s)?;
    }
    let mut chart = ChartBuilder::on(&plot)
        .caption(
            format!("{model}: residual (model − measured) over time, tests one after another"),
            ("sans-serif", 18),
        )
        .margin(10)
        .x_label_area_size(36)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..offset.max(1e-9), y0..y1)
        .map_err(e2s)?;
    chart
        .configure_mesh()
        .x_desc("time (tests concatenated), s")
        .y_desc("residual, N")
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(e2s)?;
    for (k, (_, pts)) in series.into_iter().enumerate() {
        let c = Palette99::pick(k).to_rgba();
        chart
            .draw_series(LineSeries::new(pts, c.stroke_width(1)))
            .map_err(e2s)?;
    }
    Ok(())
}

/// Plots of a diagnosis: the base model's fit and residual maps, the final model's, the first-step
/// candidate ranking and the held-out error falling step by step.
pub fn plot_diagnosis(dir: &Path, tests: &[Test], d: &Diagnosis) -> Result<Vec<PathBuf>, IdentError> {
    let mut out = plot_model(dir, tests, &d.base_pred, &d.base_model, "base")?;
    if d.final_model != d.base_model {
        out.extend(plot_model(dir, tests, &d.final_pred, &d.final_model, "final")?);
    }
    let steps: Vec<(String, f64)> = d
        .steps
        .iter()
        .enumerate()
        .map(|(k, s)| {
            let name = match (k, &s.added) {
                (0, _) => s.model.clone(),
                (_, Some(a)) => format!("+{a}"),
                _ => "pruned".into(),
            };
            (name, s.heldout_nrmse)
        })
        .collect();
    both!(dir, "error_falling", (1000, 600), out, |root| draw_bars(
        &root,
        "held-out NRMSE as each missing effect is added",
        &steps,
        d.noise_floor_nrmse,
        NRMSE_AXIS,
    ));
    let mut cands: Vec<(String, f64)> = vec![(d.base_model.clone(), d.base_heldout_nrmse)];
    cands.extend(
        d.candidates
            .iter()
            .map(|c| (format!("+{}", c.effect), c.heldout_nrmse)),
    );
    both!(dir, "candidates", (1200, 600), out, |root| draw_bars(
        &root,
        &format!("held-out NRMSE of {} with each effect added", d.base_model),
        &cands,
        d.noise_floor_nrmse,
        NRMSE_AXIS,
    ));
    // What is left: the share of the final model's held-out residual a regressor predicts out of sample,
    // from all signals and from each alone, against the share that separates structure from noise.
    let v = &d.verdict;
    let mut shares: Vec<(String, f64)> = vec![("all signals".into(), v.predictable_share.max(0.0))];
    shares.extend(v.correlates_with.iter().map(|(n, s)| (n.clone(), *s)));
    let caption = if v.structure && !v.predicted() {
        format!(
            "UNEXPLAINED: what {} leaves is {:.1}x the noise floor, yet not predictable from these signals",
            d.final_model,
            v.heldout_nrmse / v.floor_nrmse
        )
    } else if v.structure {
        format!(
            "UNEXPLAINED: {:.0} % of what {} leaves is predictable (structure, not noise)",
            100.0 * v.predictable_share,
            d.final_model
        )
    } else {
        format!(
            "what {} leaves is noise: predictable share of the held-out residual",
            d.final_model
        )
    };
    both!(dir, "what_is_left", (1000, 600), out, |root| draw_bars(
        &root,
        &caption,
        &shares,
        super::discover::MIN_PREDICTABLE_SHARE,
        (
            "predictable share of the held-out residual",
            "structure threshold"
        ),
    ));
    Ok(out)
}

/// Axis and line labels of the held-out error charts.
const NRMSE_AXIS: (&str, &str) = ("held-out NRMSE", "noise floor");

fn draw_bars<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    caption: &str,
    bars: &[(String, f64)],
    floor: f64,
    (y_desc, floor_label): (&str, &str),
) -> Result<(), IdentError> {
    let ymax = bars.iter().fold(floor, |m, b| m.max(b.1)) * 1.15 + 1e-12;
    let n = bars.len();
    let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
    let mut chart = ChartBuilder::on(root)
        .caption(caption, ("sans-serif", 18))
        .margin(10)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0.0..n as f64, 0.0..ymax)
        .map_err(e2s)?;
    chart
        .configure_mesh()
        .disable_x_mesh()
        .x_labels(n.max(1) * 2 + 1)
        .x_label_formatter(&|x| {
            let k = x.floor() as usize;
            if (x - k as f64 - 0.5).abs() < 0.26 {
                names.get(k).cloned().unwrap_or_default()
            } else {
                String::new()
            }
        })
        .y_desc(y_desc)
        .label_style(("sans-serif", 12))
        .draw()
        .map_err(e2s)?;
    chart
        .draw_series(bars.iter().enumerate().map(|(k, b)| {
            Rectangle::new(
                [(k as f64 + 0.15, 0.0), (k as f64 + 0.85, b.1)],
                RGBColor(60, 110, 200).filled(),
            )
        }))
        .map_err(e2s)?;
    chart
        .draw_series(bars.iter().enumerate().map(|(k, b)| {
            Text::new(
                format!("{:.4}", b.1),
                (k as f64 + 0.3, b.1 + 0.02 * ymax),
                ("sans-serif", 12),
            )
        }))
        .map_err(e2s)?;
    if floor > 0.0 {
        chart
            .draw_series(LineSeries::new(
                vec![(0.0, floor), (n as f64, floor)],
                RED.stroke_width(1),
            ))
            .map_err(e2s)?
            .label(floor_label)
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], RED));
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.8))
            .border_style(BLACK)
            .draw()
            .map_err(e2s)?;
    }
    Ok(())
}
