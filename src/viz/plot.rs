//! Static plots (PNG and SVG) with plotters: line and point charts in a grid of panels.
//!
//! Every figure is written twice, `STEM.png` for a quick look and `STEM.svg` for reports. Text uses the
//! bundled DejaVu Sans (registered once), so plots render the same on a machine with no fonts installed.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::chart::SeriesAnno;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontStyle;

/// Errors writing a plot.
#[derive(Debug, thiserror::Error)]
#[error("{}: cannot write plot: {msg}", path.display())]
pub struct PlotError {
    /// The file not written.
    pub path: PathBuf,
    /// Why.
    pub msg: String,
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// A solid line.
    Line,
    /// Markers, no line.
    Points,
    /// A dashed dark-grey line: a reference (a paper's value, a target, a limit).
    Dashed,
}

/// One named series of (x, y) points.
#[derive(Debug, Clone)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// The (x, y) points, in the chart's axis units.
    pub points: Vec<(f64, f64)>,
    /// How it is drawn.
    pub kind: Kind,
}

impl Series {
    fn of(kind: Kind, name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        let name = name.into();
        Self { name, points, kind }
    }
    /// A solid line through `points`.
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self::of(Kind::Line, name, points)
    }
    /// Markers at `points`.
    pub fn points(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self::of(Kind::Points, name, points)
    }
    /// A dashed reference line through `points`.
    pub fn dashed(name: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self::of(Kind::Dashed, name, points)
    }
}

/// One panel: title, axis labels (with units) and series.
#[derive(Debug, Clone, Default)]
pub struct Chart {
    /// Title above the panel.
    pub title: String,
    /// x-axis label, with unit.
    pub x_label: String,
    /// y-axis label, with unit.
    pub y_label: String,
    /// The series, drawn in order.
    pub series: Vec<Series>,
    /// Shaded spans of x (fault windows), labelled `band_label` in the legend.
    pub bands: Vec<(f64, f64)>,
    /// Legend entry of the shaded spans.
    pub band_label: String,
}

impl Chart {
    /// An empty panel with a title and axis labels.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Self {
            title: title.into(),
            x_label: x_label.into(),
            y_label: y_label.into(),
            ..Self::default()
        }
    }
    /// The chart with `s` added.
    pub fn with(mut self, s: Series) -> Self {
        self.series.push(s);
        self
    }
    /// Shade the spans of x `bands` (each `(from, to)`), named `label` in the legend.
    pub fn with_bands(mut self, label: impl Into<String>, bands: Vec<(f64, f64)>) -> Self {
        self.band_label = label.into();
        self.bands = bands;
        self
    }
}

/// The corner of a chart whose quarter-sized box (a legend's place) covers the fewest of the points, so the
/// legend hides the least data.
fn emptiest_corner(series: &[Series], xs: (f64, f64), ys: (f64, f64)) -> SeriesLabelPosition {
    let mut count = [0usize; 4];
    for p in series.iter().flat_map(|s| s.points.iter()) {
        let u = (p.0 - xs.0) / (xs.1 - xs.0);
        let v = (p.1 - ys.0) / (ys.1 - ys.0);
        if !(u.is_finite() && v.is_finite()) {
            continue;
        }
        let (left, right, top, bottom) = (u < 0.4, u > 0.6, v > 0.65, v < 0.35);
        for (k, inside) in [left && top, right && top, left && bottom, right && bottom]
            .into_iter()
            .enumerate()
        {
            count[k] += usize::from(inside);
        }
    }
    match (0..4).min_by_key(|&k| count[k]).unwrap_or(0) {
        0 => SeriesLabelPosition::UpperLeft,
        1 => SeriesLabelPosition::UpperRight,
        2 => SeriesLabelPosition::LowerLeft,
        _ => SeriesLabelPosition::LowerRight,
    }
}

const FONT: &[u8] = include_bytes!("../../assets/DejaVuSans.ttf");
static FONT_ONCE: Once = Once::new();

/// Register the bundled font for plotters' text (idempotent; every module that draws text calls it).
pub(crate) fn register_font() {
    FONT_ONCE.call_once(|| {
        // The font is compiled in; registration can only fail on a corrupt build.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// A colour per series index, distinguishable and colour-blind friendly (Okabe–Ito).
pub(crate) fn palette(k: usize) -> RGBColor {
    const C: [RGBColor; 8] = [
        RGBColor(0, 114, 178),
        RGBColor(213, 94, 0),
        RGBColor(0, 158, 115),
        RGBColor(204, 121, 167),
        RGBColor(230, 159, 0),
        RGBColor(86, 180, 233),
        RGBColor(0, 0, 0),
        RGBColor(240, 228, 66),
    ];
    C[k % C.len()]
}

/// Write charts as a grid of panels (`cols` wide) to `DIR/STEM.png` and `DIR/STEM.svg`, each file whole or
/// not at all; errors name the file asked for, not the temporary one.
pub fn save_charts(charts: &[Chart], cols: usize, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, PlotError> {
    let cols = cols.max(1).min(charts.len().max(1));
    let rows = charts.len().div_ceil(cols).max(1);
    let size = (560 * cols as u32, 420 * rows as u32);
    struct Grid<'a>(&'a [Chart], usize);
    impl Picture for Grid<'_> {
        fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String> {
            render(root, self.0, self.1)
        }
    }
    save_pair(dir, stem, size, &Grid(charts, cols))
}

/// A picture drawn alike on any plotters backend (the PNG's and the SVG's).
pub(crate) trait Picture {
    /// Draw on `root` (presented by the caller).
    fn draw<DB: DrawingBackend>(&self, root: DrawingArea<DB, Shift>) -> Result<(), String>;
}

/// Draw `picture` at `size` px to `DIR/STEM.png` and `DIR/STEM.svg`, each file whole or not at all
/// (`write_whole`); errors name the file asked for, not the temporary one.
pub(crate) fn save_pair(
    dir: &Path,
    stem: &str,
    size: (u32, u32),
    picture: &impl Picture,
) -> Result<Vec<PathBuf>, PlotError> {
    register_font();
    let fail = |path: &Path, msg: String| PlotError {
        path: path.into(),
        msg,
    };
    std::fs::create_dir_all(dir).map_err(|e| fail(dir, e.to_string()))?;
    let files = [dir.join(format!("{stem}.png")), dir.join(format!("{stem}.svg"))];
    for (k, path) in files.iter().enumerate() {
        fn present<DB: DrawingBackend>(root: DrawingArea<DB, Shift>, p: &impl Picture) -> Result<(), String> {
            p.draw(root.clone())?;
            root.present().map_err(|e| e.to_string())
        }
        let draw = |tmp: &Path| match k {
            0 => present(BitMapBackend::new(tmp, size).into_drawing_area(), picture),
            _ => present(SVGBackend::new(tmp, size).into_drawing_area(), picture),
        };
        crate::outputs::write_whole(
            path,
            |tmp| draw(tmp).map_err(|m| fail(path, m)),
            |e| fail(path, e.to_string()),
        )?;
    }
    Ok(files.into())
}

fn bounds(points: impl Iterator<Item = f64>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in points.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    if hi - lo < 1e-12 * (1.0 + lo.abs()) {
        let d = 0.5 * (1.0 + lo.abs());
        return (lo - d, hi + d);
    }
    let pad = 0.04 * (hi - lo);
    (lo - pad, hi + pad)
}

/// Draw the charts as a grid of panels `cols` wide onto `root` and finish it.
fn render<DB: DrawingBackend>(
    root: DrawingArea<DB, Shift>,
    charts: &[Chart],
    cols: usize,
) -> Result<(), String> {
    root.fill(&WHITE).map_err(|e| e.to_string())?;
    let rows = charts.len().div_ceil(cols).max(1);
    for (chart, area) in charts.iter().zip(root.split_evenly((rows, cols)).iter()) {
        draw_chart(area, chart)?;
    }
    Ok(())
}

fn draw_chart<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, chart: &Chart) -> Result<(), String> {
    let e = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    let xs = bounds(chart.series.iter().flat_map(|s| s.points.iter().map(|p| p.0)));
    let ys = bounds(chart.series.iter().flat_map(|s| s.points.iter().map(|p| p.1)));
    let mut c = ChartBuilder::on(area)
        .caption(&chart.title, ("sans-serif", 17))
        .margin(10)
        .x_label_area_size(38)
        .y_label_area_size(62)
        .build_cartesian_2d(xs.0..xs.1, ys.0..ys.1)
        .map_err(e)?;
    c.configure_mesh()
        .x_desc(&chart.x_label)
        .y_desc(&chart.y_label)
        .label_style(("sans-serif", 13))
        .light_line_style(RGBColor(235, 235, 235))
        .draw()
        .map_err(e)?;
    let shade = RGBColor(213, 94, 0).mix(0.15);
    for (k, &(a, b)) in chart.bands.iter().enumerate() {
        let drawn = c
            .draw_series(std::iter::once(Rectangle::new(
                [(a, ys.0), (b, ys.1)],
                shade.filled(),
            )))
            .map_err(e)?;
        if k == 0 && !chart.band_label.is_empty() {
            drawn
                .label(chart.band_label.clone())
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 18, y + 5)], shade.filled()));
        }
    }
    for (k, s) in chart.series.iter().enumerate() {
        let color = if s.kind == Kind::Dashed {
            RGBColor(90, 90, 90)
        } else {
            palette(k)
        };
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|p| p.0.is_finite() && p.1.is_finite())
            .collect();
        let mut labelled = s.name.is_empty();
        let mut label = |drawn: &mut SeriesAnno<'_, DB>| {
            if !labelled {
                labelled = true;
                drawn
                    .label(s.name.clone())
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3)));
            }
        };
        match s.kind {
            Kind::Line | Kind::Dashed => {
                let pieces = strokes(&pts, |p| c.backend_coord(&p));
                for piece in pieces {
                    let piece = piece.iter().copied();
                    let drawn = if s.kind == Kind::Line {
                        c.draw_series(LineSeries::new(piece, color.stroke_width(2)))
                    } else {
                        c.draw_series(DashedLineSeries::new(piece, 6, 4, color.stroke_width(2)))
                    }
                    .map_err(e)?;
                    label(drawn);
                }
            }
            Kind::Points => {
                let drawn = c
                    .draw_series(pts.iter().map(|&p| Circle::new(p, 2, color.mix(0.5).filled())))
                    .map_err(e)?;
                label(drawn);
            }
        }
    }
    if chart.series.iter().any(|s| !s.name.is_empty()) {
        c.configure_series_labels()
            .background_style(WHITE.mix(0.6))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 12))
            .position(emptiest_corner(&chart.series, xs, ys))
            .draw()
            .map_err(e)?;
    }
    Ok(())
}

/// A polyline cut into strokes wherever it turns back on itself by more than 120° in pixels (`to_px`, the
/// chart's own mapping). A thick line's joins are mitred without a limit in the bitmap backend, so a
/// reversal between neighbouring pixels (a current command dropping to 0 A for one sample) would
/// otherwise draw a spike far beyond the data, out of the plot area.
fn strokes(pts: &[(f64, f64)], to_px: impl Fn((f64, f64)) -> (i32, i32)) -> Vec<&[(f64, f64)]> {
    let px: Vec<(i32, i32)> = pts.iter().map(|&p| to_px(p)).collect();
    let mut out = Vec::new();
    let mut start = 0;
    let mut last: Option<(f64, f64)> = None;
    for k in 1..px.len() {
        let d = ((px[k].0 - px[k - 1].0) as f64, (px[k].1 - px[k - 1].1) as f64);
        let n = d.0.hypot(d.1);
        if n == 0.0 {
            continue;
        }
        let d = (d.0 / n, d.1 / n);
        if let Some(l) = last {
            if l.0 * d.0 + l.1 * d.1 < -0.5 {
                out.push(&pts[start..k]);
                start = k - 1;
            }
        }
        last = Some(d);
    }
    if pts.len() > start {
        out.push(&pts[start..]);
    }
    out
}

/// The perceptual colour scale of every heat map (viridis: lightness rises steadily, readable in grey and
/// by colour-blind readers), for `v` in [0, 1].
pub(crate) fn colormap(v: f64) -> RGBColor {
    use plotters::style::colors::colormaps::{ColorMap, ViridisRGB};
    ViridisRGB.get_color(v.clamp(0.0, 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn writes_png_and_svg_with_each_series_drawn() {
        let dir = tempfile::tempdir().unwrap();
        let pts: Vec<(f64, f64)> = (0..100).map(|k| (k as f64, (k as f64 / 10.0).sin())).collect();
        let one = Chart::new("sine", "t [s]", "y [-]").with(Series::line("y", pts.clone()));
        let two = one
            .clone()
            .with(Series::line("y2", pts.iter().map(|p| (p.0, 2.0 * p.1)).collect()));
        let f1 = save_charts(&[one], 1, dir.path(), "one").unwrap();
        let f2 = save_charts(&[two], 1, dir.path(), "two").unwrap();
        let png = std::fs::read(&f1[0]).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        // Each series is drawn in its palette colour: once as the line, once as its legend mark.
        let strokes = |f: &PathBuf, c: RGBColor| {
            let hex = format!("stroke=\"#{:02X}{:02X}{:02X}\"", c.0, c.1, c.2);
            std::fs::read_to_string(f).unwrap().matches(&hex).count()
        };
        assert_eq!((strokes(&f1[1], palette(0)), strokes(&f1[1], palette(1))), (2, 0));
        assert_eq!((strokes(&f2[1], palette(0)), strokes(&f2[1], palette(1))), (2, 2));
        let svg = std::fs::read_to_string(&f2[1]).unwrap();
        assert!(svg.contains("t [s]") && svg.contains("y2"));
    }

    #[test]
    fn a_chattering_line_stays_inside_its_chart() {
        // A current command held near 12.7 A that drops to 0 for single samples, as at a stroke end: every
        // pixel of the line must fall inside the plotting area, none in the caption band above it.
        let pts: Vec<(f64, f64)> = (0..4000)
            .map(|k| {
                let dropped = [1101, 1166, 1262, 1268, 3130, 3144, 3168].contains(&k);
                (
                    k as f64 * 1e-3,
                    if dropped { 0.0 } else { 12.72 + 1e-4 * k as f64 },
                )
            })
            .collect();
        let chart = Chart::new("chatter", "t", "A").with(Series::line("", pts));
        register_font();
        let (w, h) = (560u32, 420u32);
        let mut buf = vec![0u8; (w * h * 3) as usize];
        render(
            BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area(),
            &[chart],
            1,
        )
        .unwrap();
        let blue = palette(0);
        let px = |x: u32, y: u32| {
            let i = ((y * w + x) * 3) as usize;
            (buf[i], buf[i + 1], buf[i + 2])
        };
        let drawn_in = |rows: std::ops::Range<u32>| {
            rows.flat_map(|y| (0..w).map(move |x| (x, y)))
                .filter(|&(x, y)| px(x, y) == (blue.0, blue.1, blue.2))
                .count()
        };
        assert!(drawn_in(30..h) > 1000, "the line itself is drawn");
        assert_eq!(drawn_in(0..30), 0, "no stroke reaches the caption band");
    }

    #[test]
    fn colormap_is_monotone_in_brightness() {
        let lum = |c: RGBColor| 0.2126 * c.0 as f64 + 0.7152 * c.1 as f64 + 0.0722 * c.2 as f64;
        let mut last = -1.0;
        for k in 0..=20 {
            let l = lum(colormap(k as f64 / 20.0));
            assert!(l > last, "luminance must rise along the scale");
            last = l;
        }
    }
}
