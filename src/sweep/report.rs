//! The end of a sweep: a summary table per group of runs, a one-page text report, and maps over the
//! envelope coloured by handling-qualities Level.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::plan::{MapSpec, Param};
use super::store::Record;

/// Counts of one group of runs.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Group {
    /// Runs in the group.
    pub runs: usize,
    /// Runs that stopped with an error.
    pub failed: usize,
    /// Runs per stick-force-per-g Level 1, 2, 3, worse; runs with no Level (no aircraft, or no steady pull-up
    /// at that speed).
    pub levels: [usize; 4],
    /// Runs with no Level.
    pub no_level: usize,
    /// Runs within the temporary force limit of 14 CFR 23.143 / 25.143.
    pub far_temporary_ok: usize,
    /// Runs within the prolonged force limit.
    pub far_prolonged_ok: usize,
    /// Runs within Part 60's force tolerance.
    pub part60_ok: usize,
    /// Runs judged by Part 60's force tolerance (with an aircraft).
    pub part60_judged: usize,
    /// Runs within Part 60's breakout tolerance.
    pub breakout_ok: usize,
    /// Runs judged by it (a breakout measured and a target's).
    pub breakout_judged: usize,
    /// Runs whose load cell stayed within its range.
    pub load_cell_ok: usize,
}

/// Runs grouped by the value of axis `by` (all runs in one group `all` when `None`).
pub fn groups(columns: &[String], records: &[Record], by: Option<&str>) -> BTreeMap<String, Group> {
    let k = by.and_then(|b| columns.iter().position(|c| c == b));
    let mut out: BTreeMap<String, Group> = BTreeMap::new();
    for r in records {
        let key = k
            .and_then(|k| r.params.get(k))
            .map_or("all".to_string(), Param::to_string);
        let g = out.entry(key).or_default();
        let o = &r.outcome;
        g.runs += 1;
        if o.error.is_some() {
            g.failed += 1;
            continue;
        }
        match o.per_g_level {
            Some(l @ 1..=4) => g.levels[l as usize - 1] += 1,
            _ => g.no_level += 1,
        }
        g.far_temporary_ok += usize::from(o.far_temporary_ok == Some(true));
        g.far_prolonged_ok += usize::from(o.far_prolonged_ok == Some(true));
        g.part60_judged += usize::from(o.part60_force_ok.is_some());
        g.part60_ok += usize::from(o.part60_force_ok == Some(true));
        g.breakout_judged += usize::from(o.part60_breakout_ok.is_some());
        g.breakout_ok += usize::from(o.part60_breakout_ok == Some(true));
        g.load_cell_ok += usize::from(o.load_cell_ok == Some(true));
    }
    out
}

/// The summary as a Markdown table.
pub fn summary_table(columns: &[String], records: &[Record], by: Option<&str>) -> String {
    let mut s = format!(
        "| {} | runs | failed | Level 1 | Level 2 | Level 3 | worse | no Level | FAR temporary ok | FAR prolonged ok | Part 60 force ok | Part 60 breakout ok | load cell ok |\n",
        by.unwrap_or("group")
    );
    s.push_str("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
    for (name, g) in groups(columns, records, by) {
        s.push_str(&format!(
            "| {name} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {}/{} | {}/{} | {} |\n",
            g.runs,
            g.failed,
            g.levels[0],
            g.levels[1],
            g.levels[2],
            g.levels[3],
            g.no_level,
            g.far_temporary_ok,
            g.far_prolonged_ok,
            g.part60_ok,
            g.part60_judged,
            g.breakout_ok,
            g.breakout_judged,
            g.load_cell_ok
        ));
    }
    s
}

/// The axis to group a summary by: the first axis whose values are names (feel systems, pilots), if any.
pub fn group_axis<'a>(columns: &'a [String], records: &[Record]) -> Option<&'a str> {
    let first = records.first()?;
    columns
        .iter()
        .zip(&first.params)
        .find(|(_, p)| matches!(p, Param::Text(_)))
        .map(|(c, _)| c.as_str())
}

/// A one-page report: what was run, the summary per group, and the runs that fared worst.
pub fn report(name: &str, columns: &[String], records: &[Record], maps: &[PathBuf]) -> String {
    let by = group_axis(columns, records);
    let mut s = format!("# Sweep `{name}`: {} runs\n\n", records.len());
    s.push_str(
        "Verdicts per run: 14 CFR 23.143(c) / 25.143(d) temporary and prolonged pitch force limits; stick force \
         per g in the steady pull-up against MIL-F-8785C Table V (centre stick) Levels; the felt force against \
         the aircraft's within the 14 CFR Part 60 tolerance (±5 lbf or ±10 %), the felt breakout against the \
         target's within ±2 lbf; the force through the load cell within its range. Sources and readings: docs/howto/sweep-a-design.md.\n\n",
    );
    s.push_str(&summary_table(columns, records, by));
    let mut worst: Vec<&Record> = records.iter().filter(|r| r.outcome.error.is_none()).collect();
    worst.sort_by(|a, b| {
        let key = |r: &Record| {
            (
                r.outcome.per_g_level.unwrap_or(0),
                r.outcome.part60_force_ratio.unwrap_or(0.0),
            )
        };
        let (ka, kb) = (key(a), key(b));
        kb.0.cmp(&ka.0)
            .then(kb.1.total_cmp(&ka.1))
            .then(a.index.cmp(&b.index))
    });
    s.push_str("\n## Worst runs (Level, then Part 60 force ratio)\n\n| index | ");
    s.push_str(&columns.join(" | "));
    s.push_str(" | Level | stick force per g, N/g | Part 60 ratio | peak grip force, N |\n|");
    s.push_str(&"---|".repeat(columns.len() + 5));
    s.push('\n');
    let num = |v: Option<f64>| v.map_or("–".to_string(), |x| format!("{x:.3}"));
    for r in worst.iter().take(8) {
        let params: Vec<String> = r.params.iter().map(Param::to_string).collect();
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} |\n",
            r.index,
            params.join(" | "),
            r.outcome.per_g_level.map_or("–".into(), |l| l.to_string()),
            num(r.outcome.per_g_judged_n()),
            num(r.outcome.part60_force_ratio),
            num(r.outcome.grip_force_peak_n)
        ));
    }
    let failed: Vec<&Record> = records.iter().filter(|r| r.outcome.error.is_some()).collect();
    if !failed.is_empty() {
        s.push_str(&format!("\n## Failed runs: {}\n\n", failed.len()));
        for r in failed.iter().take(5) {
            s.push_str(&format!(
                "- run {}: {}\n",
                r.index,
                r.outcome.error.as_deref().unwrap_or("")
            ));
        }
    }
    if !maps.is_empty() {
        s.push_str("\n## Maps\n\n");
        // By file name: the maps are beside the report, wherever the directory is.
        for m in maps {
            let name = m.file_name().map_or(m.as_os_str(), |n| n);
            s.push_str(&format!("- {}\n", Path::new(name).display()));
        }
    }
    s
}

/// Colour of a Level (1 green, 2 yellow, 3 orange: Okabe–Ito hues, told apart by colour-blind readers too;
/// worse a dark red, far from the orange), grey for a run with none, black failed.
fn level_colour(level: Option<u8>, failed: bool) -> RGBColor {
    match (failed, level) {
        (true, _) => RGBColor(40, 40, 40),
        (_, Some(1)) => RGBColor(0, 158, 115),
        (_, Some(2)) => RGBColor(240, 228, 66),
        (_, Some(3)) => RGBColor(230, 159, 0),
        (_, Some(_)) => RGBColor(150, 20, 45),
        (_, None) => RGBColor(200, 200, 200),
    }
}

/// The legend's entries: colour and label.
const LEGEND: [(Option<u8>, bool, &str); 6] = [
    (Some(1), false, "Level 1"),
    (Some(2), false, "Level 2"),
    (Some(3), false, "Level 3"),
    (Some(4), false, "worse than Level 3"),
    (None, false, "no Level"),
    (None, true, "run failed"),
];

/// A map cell: the worst of its runs (failed, then the highest Level), that run's stick force per g, and
/// whether any run there overloaded the load cell.
#[derive(Debug, Clone, Copy, PartialEq)]
struct MapCell {
    failed: bool,
    level: Option<u8>,
    per_g_n: Option<f64>,
    overload: bool,
}

impl MapCell {
    /// Severity: failed worst, then no Level, then Level 4 down to 1.
    fn rank(&self) -> u8 {
        if self.failed {
            6
        } else {
            self.level.map_or(5, |l| l)
        }
    }
}

/// Maps of the stick-force-per-g Level over (x, y), one panel per combination of the facet axes, each cell
/// the worst run at its (x, y), coloured and labelled by Level and N/g; thick lines mark Level boundaries
/// and `overload` a run past the load cell's range. Written to `DIR/map-level.png` and `.svg`.
pub fn maps(
    dir: &Path,
    spec: &MapSpec,
    columns: &[String],
    records: &[Record],
) -> Result<Vec<PathBuf>, String> {
    let col = |n: &str| {
        columns
            .iter()
            .position(|c| c == n)
            .ok_or(format!("no axis `{n}`"))
    };
    let (ix, iy) = (col(&spec.x)?, col(&spec.y)?);
    let facets: Vec<usize> = spec.facets.iter().map(|f| col(f)).collect::<Result<_, _>>()?;
    let text = |r: &Record, k: usize| r.params.get(k).map_or(String::new(), Param::to_string);
    let num = |r: &Record, k: usize| match r.params.get(k) {
        Some(Param::Num(x)) => *x,
        _ => f64::NAN,
    };
    // An axis's distinct finite values, in order.
    let values = |k: usize| {
        let mut v: Vec<f64> = records
            .iter()
            .map(|r| num(r, k))
            .filter(|x| x.is_finite())
            .collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let (xs, ys) = (values(ix), values(iy));
    if xs.is_empty() || ys.is_empty() {
        return Err(format!(
            "the map's axes `{}` and `{}` must be numeric",
            spec.x, spec.y
        ));
    }
    let mut panels: Panels = BTreeMap::new();
    for r in records {
        let panel: Vec<String> = facets.iter().map(|&k| text(r, k)).collect();
        let (Some(cx), Some(cy)) = (
            xs.iter().position(|&x| x == num(r, ix)),
            ys.iter().position(|&y| y == num(r, iy)),
        ) else {
            continue;
        };
        let o = &r.outcome;
        let cell = MapCell {
            failed: o.error.is_some(),
            level: o.per_g_level,
            per_g_n: o.per_g_judged_n(),
            overload: o.load_cell_ok == Some(false),
        };
        let e = panels
            .entry(panel.join(", "))
            .or_default()
            .entry((cx, cy))
            .or_insert(cell);
        let overload = e.overload || cell.overload;
        if cell.rank() > e.rank() {
            *e = cell;
        }
        e.overload = overload;
    }
    let n = panels.len().max(1);
    let cols = n.min(3);
    let rows = n.div_ceil(cols);
    // at least the header's width: its title and legend are one line each
    let size = ((460 * cols as u32).max(1000), 360 * rows as u32 + HEADER_PX);
    struct Map<'a>(&'a Panels, Grid, &'a MapSpec);
    impl crate::viz::plot::Picture for Map<'_> {
        fn draw<DB: DrawingBackend>(
            &self,
            root: DrawingArea<DB, plotters::coord::Shift>,
        ) -> Result<(), String> {
            draw_panels(root, self.0, &self.1, self.2)
        }
    }
    let map = Map(&panels, Grid { xs, ys }, spec);
    crate::viz::plot::save_pair(dir, "map-level", size, &map).map_err(|e| e.to_string())
}

/// Height of the maps' title and legend, px.
const HEADER_PX: u32 = 64;

type Panels = BTreeMap<String, BTreeMap<(usize, usize), MapCell>>;

/// The map's axis values. Cells are drawn of equal size in index space (cell `k` from `k − ½` to `k + ½`),
/// with each axis labelled by its values at the cells' centres.
struct Grid {
    xs: Vec<f64>,
    ys: Vec<f64>,
}

impl Grid {
    /// Cell edges in index space.
    fn edges(v: &[f64]) -> Vec<f64> {
        (0..=v.len()).map(|k| k as f64 - 0.5).collect()
    }

    /// The label of an index-space tick: the value at a cell's centre, nothing between cells.
    fn label(v: &[f64], at: f64) -> String {
        let k = at.round();
        if (at - k).abs() < 1e-6 && k >= 0.0 && (k as usize) < v.len() {
            format!("{}", v[k as usize])
        } else {
            String::new()
        }
    }
}

fn draw_panels<DB: DrawingBackend>(
    root: DrawingArea<DB, plotters::coord::Shift>,
    panels: &Panels,
    grid: &Grid,
    spec: &MapSpec,
) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let (ex, ey) = (Grid::edges(&grid.xs), Grid::edges(&grid.ys));
    root.fill(&WHITE).map_err(e)?;
    let (top, body) = root.split_vertically(HEADER_PX);
    top.draw_text(
        "Stick force per g (steady pull-up; flown, fly-by-wire), MIL-F-8785C Table V (centre stick): the \
         worst run per cell, its Level and N/g; thick lines: Level boundaries",
        &("sans-serif", 14).into_text_style(&top),
        (10, 8),
    )
    .map_err(e)?;
    let mut x = 10;
    for (level, failed, label) in LEGEND {
        top.draw(&Rectangle::new(
            [(x, 32), (x + 16, 48)],
            level_colour(level, failed).filled(),
        ))
        .map_err(e)?;
        top.draw(&Rectangle::new([(x, 32), (x + 16, 48)], BLACK.stroke_width(1)))
            .map_err(e)?;
        top.draw_text(label, &("sans-serif", 13).into_text_style(&top), (x + 22, 34))
            .map_err(e)?;
        x += 30 + 7 * label.len() as i32;
    }
    top.draw_text(
        "overload: the load cell past its range",
        &("sans-serif", 13).into_text_style(&top),
        (x + 10, 34),
    )
    .map_err(e)?;
    let n = panels.len().max(1);
    let cols = n.min(3);
    let rows = n.div_ceil(cols);
    let areas = body.split_evenly((rows, cols));
    let fx = |v: &f64| Grid::label(&grid.xs, *v);
    let fy = |v: &f64| Grid::label(&grid.ys, *v);
    for ((title, cells), area) in panels.iter().zip(areas) {
        let mut c = ChartBuilder::on(&area)
            .caption(
                if title.is_empty() { "all runs" } else { title },
                ("sans-serif", 15),
            )
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(ex[0]..ex[ex.len() - 1], ey[0]..ey[ey.len() - 1])
            .map_err(e)?;
        // At most one tick per cell: the nice step of `len` ticks over `len` cells is one cell.
        c.configure_mesh()
            .x_desc(spec.x.as_str())
            .y_desc(spec.y.as_str())
            .x_labels(grid.xs.len())
            .y_labels(grid.ys.len())
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .label_style(("sans-serif", 12))
            .disable_mesh()
            .draw()
            .map_err(e)?;
        for (&(cx, cy), cell) in cells {
            let r = [(ex[cx], ey[cy]), (ex[cx + 1], ey[cy + 1])];
            c.draw_series(std::iter::once(Rectangle::new(
                r,
                level_colour(cell.level, cell.failed).filled(),
            )))
            .map_err(e)?;
            c.draw_series(std::iter::once(Rectangle::new(r, WHITE.stroke_width(1))))
                .map_err(e)?;
            // Light text on the dark fills (failed, worse than Level 3), dark on the others.
            let ink = if cell.failed || cell.level.is_some_and(|l| l >= 4) {
                WHITE
            } else {
                BLACK
            };
            let label = match (cell.failed, cell.level, cell.per_g_n) {
                (true, ..) => "failed".to_string(),
                (_, Some(l), Some(g)) => format!("L{l}  {g:.1} N/g"),
                _ => "–".to_string(),
            };
            let style = ("sans-serif", 12)
                .into_font()
                .color(&ink)
                .pos(Pos::new(HPos::Center, VPos::Center));
            let (mx, my) = ((ex[cx] + ex[cx + 1]) / 2.0, (ey[cy] + ey[cy + 1]) / 2.0);
            let dy = (ey[cy + 1] - ey[cy]) * 0.2;
            let at = if cell.overload { my + dy } else { my };
            c.draw_series(std::iter::once(Text::new(label, (mx, at), style.clone())))
                .map_err(e)?;
            if cell.overload {
                c.draw_series(std::iter::once(Text::new("overload", (mx, my - dy), style)))
                    .map_err(e)?;
            }
        }
        // Level boundaries: a thick line along each edge between neighbouring cells of different rank.
        let rank = |cx: usize, cy: usize| cells.get(&(cx, cy)).map(MapCell::rank);
        let mut edges = Vec::new();
        for (&(cx, cy), cell) in cells {
            if rank(cx + 1, cy).is_some_and(|r| r != cell.rank()) {
                edges.push([(ex[cx + 1], ey[cy]), (ex[cx + 1], ey[cy + 1])]);
            }
            if rank(cx, cy + 1).is_some_and(|r| r != cell.rank()) {
                edges.push([(ex[cx], ey[cy + 1]), (ex[cx + 1], ey[cy + 1])]);
            }
        }
        c.draw_series(
            edges
                .into_iter()
                .map(|p| PathElement::new(p.to_vec(), BLACK.stroke_width(3))),
        )
        .map_err(e)?;
    }
    Ok(())
}
