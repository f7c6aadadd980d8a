//! A sweep plan (`scenarios/sweeps/*.toml`): a base scenario, axes over its values by dotted key, and how
//! they combine (every combination, or seeded draws). Expanded into runs, each with its index, its seed
//! (from the plan's seed and the index alone) and its overrides.

use std::path::PathBuf;

use crate::input::InputError;
use crate::scenario::{Origin, Override, Scenario};
use rand::{Rng, RngCore, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Most runs a plan may have (a typo in a grid multiplies).
pub const MAX_RUNS: u64 = 10_000_000;

/// A plan refused (its file, as `InputError`), or a run's scenario refused.
#[derive(Debug, thiserror::Error)]
pub enum PlanError {
    /// A bad plan file.
    #[error(transparent)]
    Input(#[from] InputError),
    /// A run's scenario refused (an axis value out of its key's range, an unknown key).
    #[error("run {index}: {error}")]
    Run {
        /// The run's index in the plan.
        index: u64,
        /// The scenario's error.
        error: InputError,
    },
}

/// A parameter's value in a run, as its column holds it.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum Param {
    /// A number.
    Num(f64),
    /// Text (a case's name, a file).
    Text(String),
}

impl std::fmt::Display for Param {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Param::Num(x) => write!(f, "{x}"),
            Param::Text(s) => f.write_str(s),
        }
    }
}

/// How an axis gives its values.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Source {
    /// Values as listed (numbers or any TOML value), each with its line.
    List(Vec<(toml::Value, usize)>),
    /// Named cases, each a set of overrides (`label`, overrides).
    Cases(Vec<(String, Vec<Override>)>),
    /// Seeded draws; in a grid, `count` of them.
    Draw { dist: Dist, count: Option<u64> },
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum Dist {
    Uniform { low: f64, high: f64 },
    Normal { mean: f64, sd: f64 },
    LogUniform { low: f64, high: f64 },
}

impl Dist {
    fn draw(&self, rng: &mut ChaCha8Rng) -> f64 {
        match *self {
            Dist::Uniform { low, high } => rng.random_range(low..=high),
            Dist::Normal { mean, sd } => Normal::new(mean, sd).map_or(mean, |d| d.sample(rng)),
            Dist::LogUniform { low, high } => (rng.random_range(low.ln()..=high.ln())).exp(),
        }
    }
}

/// One axis of a plan: a key and its values, or named cases.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// The column name: the dotted key, or the axis's `name` for cases.
    pub name: String,
    /// The dotted key a value axis sets (`None` for cases).
    pub(crate) key: Option<String>,
    pub(crate) source: Source,
    pub(crate) line: usize,
}

impl Axis {
    /// Values a grid takes along this axis (draw axes: `count`, drawn from the plan's seed and the axis).
    fn grid_len(&self) -> u64 {
        match &self.source {
            Source::List(v) => v.len() as u64,
            Source::Cases(c) => c.len() as u64,
            Source::Draw { count, .. } => count.unwrap_or(1),
        }
    }

    /// True if every value is a number (its column is numeric).
    pub fn numeric(&self) -> bool {
        match &self.source {
            Source::List(v) => v.iter().all(|(x, _)| x.is_float() || x.is_integer()),
            Source::Cases(_) => false,
            Source::Draw { .. } => true,
        }
    }
}

/// One run of a plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Run {
    /// The run's index in the plan.
    pub index: u64,
    /// The scenario's seed in this run: from the plan's seed and the index only.
    pub seed: u64,
    /// One value per axis, in the plan's order.
    pub params: Vec<Param>,
    /// The scenario overrides that make the run.
    pub overrides: Vec<Override>,
}

/// How the axes combine.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// Every combination (the last axis varies fastest).
    Grid,
    /// `runs` runs, each axis drawn independently per run (a list: one of its values, uniformly).
    Sample {
        /// Number of runs.
        runs: u64,
    },
}

/// Maps over the envelope (`[map]`): cells at (x, y), one panel per combination of the `facet` axes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MapSpec {
    /// The axis along x.
    pub x: String,
    /// The axis along y.
    pub y: String,
    /// The axes that split the maps into panels.
    pub facets: Vec<String>,
}

/// A loaded, checked plan.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The plan file.
    pub path: PathBuf,
    /// The plan's name.
    pub name: String,
    /// The base scenario file.
    pub scenario_path: PathBuf,
    /// The base scenario's text, as read once.
    pub scenario_text: String,
    /// The plan's seed.
    pub seed: u64,
    /// How the axes combine.
    pub mode: Mode,
    /// The axes, in the plan's order.
    pub axes: Vec<Axis>,
    /// Window over which a held force counts as prolonged (14 CFR 23.143 / 25.143), s.
    pub prolonged_window_s: f64,
    /// The maps to draw, if any.
    pub map: Option<MapSpec>,
    /// SHA-256 of the plan's and the base scenario's texts: shards of one plan carry the same.
    pub digest: String,
    /// The plan's `seed` line (each run's scenario seed is set from it).
    pub(crate) seed_line: usize,
}

impl Plan {
    /// How many runs the plan has.
    pub fn run_count(&self) -> u64 {
        match self.mode {
            Mode::Grid => self
                .axes
                .iter()
                .map(Axis::grid_len)
                .fold(1u64, |a, b| a.saturating_mul(b)),
            Mode::Sample { runs } => runs,
        }
    }

    /// A generator for run `index`'s seed and draws: the plan's seed and the index only, whatever the
    /// worker, the shard or the order of the runs.
    fn rng(&self, index: u64, stream: u64) -> ChaCha8Rng {
        let mut r = ChaCha8Rng::seed_from_u64(self.seed);
        r.set_stream(stream);
        r.set_word_pos(u128::from(index) * 1024);
        r
    }

    /// Run `index` (0-based, below [`Plan::run_count`]).
    pub fn run(&self, index: u64) -> Run {
        // Stream 0: the runs' seeds and sampled draws, 1024 words per run; stream 1 + axis: a grid's draws.
        let mut rng = self.rng(index, 0);
        let seed = rng.next_u64() >> 1;
        let at = |line: usize| Origin::File {
            path: self.path.clone(),
            line,
        };
        let mut params = Vec::new();
        let mut overrides = vec![Override::set(
            "seed",
            toml::Value::Integer(seed as i64),
            at(self.seed_line),
        )];
        let mut rest = index;
        let sizes: Vec<u64> = self.axes.iter().map(Axis::grid_len).collect();
        let mut grid_pos = vec![0u64; self.axes.len()];
        for k in (0..self.axes.len()).rev() {
            grid_pos[k] = rest % sizes[k];
            rest /= sizes[k];
        }
        for (k, a) in self.axes.iter().enumerate() {
            let pick = match self.mode {
                Mode::Grid => grid_pos[k],
                Mode::Sample { .. } => rng.random_range(0..sizes[k]),
            };
            match &a.source {
                Source::List(v) => {
                    let (value, line) = &v[pick as usize];
                    params.push(match value {
                        toml::Value::Float(x) => Param::Num(*x),
                        toml::Value::Integer(i) if a.numeric() => Param::Num(*i as f64),
                        toml::Value::String(s) => Param::Text(s.clone()),
                        other => Param::Text(other.to_string()),
                    });
                    overrides.push(Override::set(
                        a.key.as_deref().unwrap_or(&a.name),
                        value.clone(),
                        at(*line),
                    ));
                }
                Source::Cases(c) => {
                    let (label, ov) = &c[pick as usize];
                    params.push(Param::Text(label.clone()));
                    overrides.extend(ov.iter().cloned());
                }
                Source::Draw { dist, .. } => {
                    let x = match self.mode {
                        Mode::Grid => dist.draw(&mut self.rng(pick, 1 + k as u64)),
                        Mode::Sample { .. } => dist.draw(&mut rng),
                    };
                    params.push(Param::Num(x));
                    overrides.push(Override::set(
                        a.key.as_deref().unwrap_or(&a.name),
                        toml::Value::Float(x),
                        at(a.line),
                    ));
                }
            }
        }
        Run {
            index,
            seed,
            params,
            overrides,
        }
    }

    /// The scenario of a run, checked.
    pub fn scenario(&self, run: &Run) -> Result<Scenario, PlanError> {
        Scenario::parse_with(&self.scenario_text, &self.scenario_path, &run.overrides).map_err(|error| {
            PlanError::Run {
                index: run.index,
                error,
            }
        })
    }
}
