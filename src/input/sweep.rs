//! Sweep files: the plan (`scenarios/sweeps/*.toml`: a base scenario, axes over its values, how they
//! combine), read into a [`Plan`], and an output directory's manifest (`sweep.toml`).

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use super::{InputError, Source as Text};
use crate::scenario::{Origin, Override, Scenario};
use crate::sweep::plan::{Axis, Dist, MapSpec, Mode, Plan, PlanError, Source, MAX_RUNS};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct PlanFile {
    name: String,
    #[serde(default)]
    #[allow(dead_code)]
    description: String,
    scenario: Spanned<PathBuf>,
    seed: Spanned<i64>,
    mode: Option<Spanned<ModeName>>,
    runs: Option<Spanned<i64>>,
    prolonged_window_s: Option<Spanned<f64>>,
    #[serde(default)]
    axis: Vec<Spanned<AxisFile>>,
    map: Option<Spanned<MapFile>>,
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "lowercase")]
enum ModeName {
    Grid,
    Sample,
}

#[derive(Deserialize, Clone, Copy, PartialEq)]
#[serde(rename_all = "kebab-case")]
enum DistName {
    Uniform,
    Normal,
    LogUniform,
}

impl DistName {
    fn as_str(self) -> &'static str {
        match self {
            Self::Uniform => "uniform",
            Self::Normal => "normal",
            Self::LogUniform => "log-uniform",
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MapFile {
    x: Spanned<String>,
    y: Spanned<String>,
    #[serde(default)]
    facets: Vec<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisFile {
    key: Option<Spanned<String>>,
    name: Option<Spanned<String>>,
    values: Option<Vec<Spanned<toml::Value>>>,
    range: Option<Spanned<RangeFile>>,
    draw: Option<Spanned<DrawFile>>,
    case: Option<Vec<Spanned<CaseFile>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RangeFile {
    from: f64,
    to: f64,
    count: i64,
    #[serde(default)]
    log: bool,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DrawFile {
    dist: DistName,
    low: Option<f64>,
    high: Option<f64>,
    mean: Option<f64>,
    sd: Option<f64>,
    count: Option<i64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CaseFile {
    label: Spanned<String>,
    set: Option<Spanned<toml::Table>>,
    #[serde(default)]
    unset: Vec<Spanned<String>>,
}

impl Plan {
    /// Read and check a sweep plan and its base scenario.
    pub fn load(path: &Path) -> Result<Self, PlanError> {
        Self::parse(&Text::read(path)?.text, path)
    }

    /// Check a plan's text; `path` places its errors and its relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Self, PlanError> {
        let src = Text::new(path, text);
        let f: PlanFile = src.toml()?;
        let scenario_path = path.parent().unwrap_or(Path::new("")).join(f.scenario.get_ref());
        let at_scenario = |msg: String| src.err(&f.scenario, "scenario", msg);
        let scenario_text = crate::input::text::read_text(&scenario_path)
            .map_err(|msg| at_scenario(format!("{}: {msg}", scenario_path.display())))?;
        // The base itself must be a good scenario: its errors are its own, not the axes'.
        Scenario::parse(&scenario_text, &scenario_path).map_err(|e| at_scenario(e.to_string()))?;
        let seed = *f.seed.get_ref();
        if seed < 0 {
            return Err(src
                .err(&f.seed, "seed", format!("{seed} is negative: give 0 or more"))
                .into());
        }
        let mode = match (f.mode.as_ref().map(|m| (*m.get_ref(), m)), &f.runs) {
            (None | Some((ModeName::Grid, _)), None) => Mode::Grid,
            (Some((ModeName::Sample, m)), None) => {
                let msg = "required by mode = \"sample\" (how many runs to draw)";
                return Err(src.err(m, "runs", msg).into());
            }
            (Some((ModeName::Sample, _)), Some(r)) => Mode::Sample {
                runs: count(*r.get_ref()).ok_or_else(|| src.err(r, "runs", outside(r.get_ref())))?,
            },
            (None | Some((ModeName::Grid, _)), Some(r)) => {
                let msg = "only with mode = \"sample\" (a grid runs every combination)";
                return Err(src.err(r, "runs", msg).into());
            }
        };
        let prolonged_window_s = match &f.prolonged_window_s {
            Some(w) if !(w.get_ref().is_finite() && (0.1..=600.0).contains(w.get_ref())) => {
                let msg = format!("value {} outside the allowed range [0.1, 600] s", w.get_ref());
                return Err(src.err(w, "prolonged_window_s", msg).into());
            }
            Some(w) => *w.get_ref(),
            None => 5.0,
        };
        if f.axis.is_empty() {
            return Err(InputError::line(path, 1, "no `[[axis]]`: a plan sweeps at least one key").into());
        }
        let mut axes: Vec<Axis> = Vec::new();
        for a in &f.axis {
            let axis = axis(&src, a, mode)?;
            if axes.iter().any(|b| b.name == axis.name) {
                let msg = "a second axis of this name: one axis per key";
                return Err(InputError::field(path, axis.line, &axis.name, msg).into());
            }
            axes.push(axis);
        }
        let map = match &f.map {
            None => None,
            Some(m) => {
                let m = m.get_ref();
                for s in std::iter::once(&m.x).chain([&m.y]).chain(&m.facets) {
                    if !axes.iter().any(|a| a.name == *s.get_ref()) {
                        let names: Vec<&str> = axes.iter().map(|a| a.name.as_str()).collect();
                        let msg = format!("`{}` is not an axis (axes: {})", s.get_ref(), names.join(", "));
                        return Err(src.err(s, "map", msg).into());
                    }
                }
                Some(MapSpec {
                    x: m.x.get_ref().clone(),
                    y: m.y.get_ref().clone(),
                    facets: m.facets.iter().map(|s| s.get_ref().clone()).collect(),
                })
            }
        };
        let digest = {
            use sha2::Digest;
            let mut h = sha2::Sha256::new();
            h.update(text.as_bytes());
            h.update([0u8]);
            h.update(scenario_text.as_bytes());
            format!("{:x}", h.finalize())
        };
        let plan = Plan {
            path: path.to_path_buf(),
            name: f.name,
            scenario_path,
            scenario_text,
            seed: seed as u64,
            mode,
            axes,
            prolonged_window_s,
            map,
            digest,
            seed_line: src.line_at(f.seed.span()),
        };
        let n = plan.run_count();
        if n > MAX_RUNS {
            let msg = format!("{n} runs: at most {MAX_RUNS} (the axes multiply in a grid)");
            return Err(InputError::line(path, 1, msg).into());
        }
        Ok(plan)
    }
}

/// A number of runs or draws, if it is in `[1, MAX_RUNS]`.
fn count(n: i64) -> Option<u64> {
    u64::try_from(n).ok().filter(|n| (1..=MAX_RUNS).contains(n))
}

fn outside(n: impl std::fmt::Display) -> String {
    format!("{n} outside the allowed range [1, {MAX_RUNS}]")
}

/// One `[[axis]]`: a key with its values, range or draw, or a name with its cases.
fn axis(src: &Text, at: &Spanned<AxisFile>, mode: Mode) -> Result<Axis, InputError> {
    let a = at.get_ref();
    let key = match (&a.key, &a.name, &a.case) {
        (Some(key), None, None) => key,
        (None, Some(name), Some(cases)) => return cases_axis(src, a, name, cases),
        _ => {
            let msg = "an axis is either `key` with `values`, `range` or `draw`, or `name` with \
                       `[[axis.case]]` tables";
            return Err(src.err(at, "axis", msg));
        }
    };
    let k = key.get_ref();
    let source = match (&a.values, &a.range, &a.draw) {
        (Some(v), None, None) if v.is_empty() => {
            return Err(src.err(key, "values", "an empty list: give at least one value"));
        }
        (Some(v), None, None) => Source::List(
            v.iter()
                .map(|x| (x.get_ref().clone(), src.line_at(x.span())))
                .collect(),
        ),
        (None, Some(r), None) => range(src, r)?,
        (None, None, Some(d)) => draw(src, d, mode)?,
        _ => return Err(src.err(key, k, "give exactly one of `values`, `range`, `draw`")),
    };
    Ok(Axis {
        name: k.clone(),
        key: Some(k.clone()),
        source,
        line: src.line_at(key.span()),
    })
}

/// An axis of named cases, each a set of overrides.
fn cases_axis(
    src: &Text,
    a: &AxisFile,
    name: &Spanned<String>,
    cases: &[Spanned<CaseFile>],
) -> Result<Axis, InputError> {
    if a.values.is_some() || a.range.is_some() || a.draw.is_some() {
        return Err(src.err(name, "case", "an axis of cases takes no values, range or draw"));
    }
    if cases.is_empty() {
        return Err(src.err(name, "case", "no cases: give at least one `[[axis.case]]`"));
    }
    let origin = |span: std::ops::Range<usize>| Origin::File {
        path: src.path.clone(),
        line: src.line_at(span),
    };
    let mut out: Vec<(String, Vec<Override>)> = Vec::new();
    for c in cases {
        let c = c.get_ref();
        let label = c.label.get_ref().clone();
        if out.iter().any(|(l, _)| *l == label) {
            return Err(src.err(&c.label, "label", format!("`{label}` given twice in this axis")));
        }
        let mut ov = Vec::new();
        if let Some(set) = &c.set {
            let o = origin(set.span());
            flatten("", set.get_ref(), &mut |k, v| {
                ov.push(Override::set(&k, v.clone(), o.clone()))
            });
        }
        ov.extend(c.unset.iter().map(|u| Override {
            key: u.get_ref().clone(),
            value: None,
            origin: origin(u.span()),
        }));
        out.push((label, ov));
    }
    Ok(Axis {
        name: name.get_ref().clone(),
        key: None,
        source: Source::Cases(out),
        line: src.line_at(name.span()),
    })
}

/// `count` values evenly spaced from `from` to `to` (on a log scale with `log`).
fn range(src: &Text, at: &Spanned<RangeFile>) -> Result<Source, InputError> {
    let r = at.get_ref();
    let n = count(r.count).ok_or_else(|| src.err(at, "range.count", outside(r.count)))?;
    if !(r.from.is_finite() && r.to.is_finite()) || (r.log && (r.from <= 0.0 || r.to <= 0.0)) {
        return Err(src.err(
            at,
            "range",
            "from and to must be finite (and positive with log = true)",
        ));
    }
    let line = src.line_at(at.span());
    let value = |i: u64| {
        let u = if n == 1 { 0.0 } else { i as f64 / (n - 1) as f64 };
        let x = if r.log {
            (r.from.ln() + u * (r.to.ln() - r.from.ln())).exp()
        } else {
            r.from + u * (r.to - r.from)
        };
        (toml::Value::Float(x), line)
    };
    Ok(Source::List((0..n).map(value).collect()))
}

/// Values drawn from a distribution: `count` of them in a grid, one per run in a sample.
fn draw(src: &Text, at: &Spanned<DrawFile>, mode: Mode) -> Result<Source, InputError> {
    let d = at.get_ref();
    let dist_name = d.dist.as_str();
    let need = |v: Option<f64>, name: &str| {
        v.filter(|x| x.is_finite()).ok_or_else(|| {
            let msg = format!("required (a finite number) by dist = \"{dist_name}\"");
            src.err(at, &format!("draw.{name}"), msg)
        })
    };
    let dist = match d.dist {
        DistName::Uniform | DistName::LogUniform => {
            let (low, high) = (need(d.low, "low")?, need(d.high, "high")?);
            if d.mean.is_some() || d.sd.is_some() {
                let msg = format!("mean and sd are not used by dist = \"{dist_name}\"");
                return Err(src.err(at, "draw", msg));
            }
            if low > high || (d.dist == DistName::LogUniform && low <= 0.0) {
                let msg = format!("low {low} must be at most high {high} (and above 0 for log-uniform)");
                return Err(src.err(at, "draw.low", msg));
            }
            if d.dist == DistName::Uniform {
                Dist::Uniform { low, high }
            } else {
                Dist::LogUniform { low, high }
            }
        }
        DistName::Normal => {
            let (mean, sd) = (need(d.mean, "mean")?, need(d.sd, "sd")?);
            if d.low.is_some() || d.high.is_some() {
                return Err(src.err(at, "draw", "low and high are not used by dist = \"normal\""));
            }
            if sd < 0.0 {
                return Err(src.err(at, "draw.sd", format!("{sd} is negative")));
            }
            Dist::Normal { mean, sd }
        }
    };
    let count = match (mode, d.count) {
        (Mode::Grid, Some(c)) => Some(count(c).ok_or_else(|| src.err(at, "draw.count", outside(c)))?),
        (Mode::Grid, None) => {
            return Err(src.err(
                at,
                "draw.count",
                "required in a grid (how many draws this axis takes)",
            ));
        }
        (Mode::Sample { .. }, Some(_)) => {
            return Err(src.err(
                at,
                "draw.count",
                "not used by mode = \"sample\" (each run draws once)",
            ));
        }
        (Mode::Sample { .. }, None) => None,
    };
    Ok(Source::Draw { dist, count })
}

/// Every leaf of a table as `dotted.key = value` (a table in a table is a deeper key; arrays are values).
fn flatten(prefix: &str, t: &toml::Table, out: &mut dyn FnMut(String, &toml::Value)) {
    for (k, v) in t {
        let key = if prefix.is_empty() {
            k.clone()
        } else {
            format!("{prefix}.{k}")
        };
        match v {
            toml::Value::Table(inner) => flatten(&key, inner, out),
            _ => out(key, v),
        }
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct ManifestFile {
    pub(crate) name: String,
    pub(crate) plan: String,
    pub(crate) digest: Spanned<String>,
    pub(crate) runs: Spanned<u64>,
    pub(crate) shard: Spanned<String>,
    pub(crate) columns: Spanned<Vec<String>>,
    pub(crate) numeric: Vec<bool>,
}

/// What a sweep directory's manifest says, and where.
pub(crate) struct Loaded {
    pub(crate) src: Text,
    pub(crate) file: ManifestFile,
}

impl Loaded {
    /// The manifest at `path`, if there is one.
    pub(crate) fn read(path: &Path) -> Result<Option<Self>, InputError> {
        if !path.exists() {
            return Ok(None);
        }
        let src = Text::read(path)?;
        let file = src.toml()?;
        Ok(Some(Self { src, file }))
    }
}
