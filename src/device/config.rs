//! Device files: the damper's model, parameters, driver and geometry, as a user edits them
//! (`models/*.toml`) or as `mrfeel fit --save` writes them (`PARAMS.json`). Both load into the same
//! [`DeviceConfig`], so a fitted model drops straight into the MTS machine or a stick-rig scenario.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::{Deserialize, Serialize};

use super::model::{Damper, Model, ModelSpec, Registry, PAPER_CURRENT_LIMIT_A};
use super::params::ParamValue;
use super::DeviceError;
use crate::input::text::{line_of, short_number as num};
use crate::measurement::CommandTiming;
use crate::units::IN_TO_M;

/// Table 1 geometry of the paper's device, in SI units (converted once from inches on load).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    pub piston_diameter_m: f64,
    pub piston_rod_length_m: f64,
    pub cylinder_id_m: f64,
    pub cylinder_od_m: f64,
    pub cylinder_length_m: f64,
    /// Half stroke: the piston travels ±`stroke_half_m` from mid-stroke.
    pub stroke_half_m: f64,
}

/// A loaded device: model, parameter values, driver limits, geometry.
#[derive(Debug, Clone)]
pub struct DeviceConfig {
    pub model: Arc<Model>,
    pub params: Vec<f64>,
    /// The supply's limit, A, above the driver's saturation (the paper's 17 A), where known.
    pub supply_limit_a: Option<f64>,
    pub geometry: Option<Geometry>,
    pub load_cell_range_n: Option<f64>,
    /// When the logged current commands of the data the parameters were fitted to took effect (a
    /// `PARAMS.json`'s `command_timing`; after their sample for device files).
    pub command_timing: CommandTiming,
    /// The share of the drive period that the fitted data's acquisition filter spanned in every protocol
    /// (a `PARAMS.json`'s `acquisition_window_periods`, where the fit found one; see
    /// `ident::acquisition::window_law`).
    pub acquisition_window_periods: Option<f64>,
    /// Each parameter's standard error as a `PARAMS.json` saved it (in the model's parameter order; all
    /// `None` for a device file).
    pub std_errs: Vec<Option<f64>>,
    pub path: PathBuf,
}

impl DeviceConfig {
    /// Load a `.toml` device file or a `.json` parameter file written by `mrfeel fit --save`, told apart
    /// by the extension in any case, or where there is none of the two (a pipe: `--params <(…)`) by the
    /// text: a JSON object opens with `{`, which no TOML document does.
    pub fn load(path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let text = crate::input::text::read_text(path).map_err(|msg| DeviceError::Io {
            path: path.to_path_buf(),
            msg,
        })?;
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let json = match ext.as_deref() {
            Some("json") => true,
            Some("toml") => false,
            _ => text.trim_start_matches('\u{feff}').trim_start().starts_with('{'),
        };
        if json {
            Self::from_json(&text, path, registry)
        } else {
            Self::from_toml(&text, path, registry)
        }
    }

    /// A damper in its initial state, ready to be stepped.
    pub fn damper(&self) -> Damper {
        Damper::new(self.model.clone(), self.params.clone()).expect("parameter count checked on load")
    }

    /// A model fitted to data, with its parameters (`path` names it in messages): no geometry, no
    /// load-cell range, the driver's limit of the model.
    pub fn from_model(model: Model, params: Vec<f64>, path: PathBuf) -> Self {
        Self {
            std_errs: vec![None; params.len()],
            model: Arc::new(model),
            params,
            supply_limit_a: None,
            geometry: None,
            load_cell_range_n: None,
            command_timing: CommandTiming::AfterSample,
            acquisition_window_periods: None,
            path,
        }
    }

    /// The same damper with no MR yield force (none at zero current, none from the field) and damping
    /// `c0_n_s_per_m`: a spring feel unit's own viscous damper on the same rig.
    pub fn viscous_damper(&self, c0_n_s_per_m: f64) -> Damper {
        let mut p = self.params.clone();
        p[super::bingham::FC0] = 0.0;
        p[super::bingham::FC_GAIN] = 0.0;
        p[super::bingham::C0] = c0_n_s_per_m;
        Damper::new(self.model.clone(), p).expect("parameter count checked on load")
    }

    /// Value of a named parameter.
    pub fn param(&self, name: &str) -> Option<f64> {
        self.model.param_index(name).map(|k| self.params[k])
    }

    pub fn from_toml(text: &str, path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let file: TomlDevice = crate::input::text::parse_toml(text).map_err(|e| {
            // A missing key is reported with the span of the table that lacks it; a value of the wrong
            // type by the key of its line (toml's message does not name it).
            match e.field {
                Some(field) => field_err(path, e.line, &field, e.msg),
                None => DeviceError::Parse {
                    path: path.to_path_buf(),
                    line: e.line,
                    msg: e.msg,
                },
            }
        })?;
        let at = |v: &toml::Spanned<f64>| (*v.get_ref(), line_of(text, v.span().start));
        let limit = match &file.driver.current_limit_a {
            Some(v) => {
                let (limit, line) = at(v);
                check_current_limit(limit, path, line, "driver.current_limit_a")?
            }
            None => PAPER_CURRENT_LIMIT_A,
        };
        let supply_limit_a = match &file.driver.supply_limit_a {
            Some(v) => {
                let (supply, line) = at(v);
                let field = "driver.supply_limit_a";
                positive(supply, "A", path, line, field)?;
                if supply < limit {
                    return Err(field_err(
                        path,
                        line,
                        field,
                        format!(
                            "value {} A is below the driver's saturation current_limit_a = {} A: the \
                             driver saturates at a current the supply can give (the paper's 14 A from a 17 A \
                             supply), so the supply's limit is at least the saturation",
                            num(supply),
                            num(limit)
                        ),
                    ));
                }
                Some(supply)
            }
            None => None,
        };
        let model_line = line_of(text, file.model.span().start);
        // Effect files the spec names (`bingham+drag.toml`) are read relative to this file.
        let mut registry = registry.clone();
        let spec_text = super::formula::resolve_spec(file.model.get_ref(), &mut registry, path.parent())
            .map_err(|e| field_err(path, model_line, "model", e.to_string()))?;
        let spec =
            ModelSpec::parse(&spec_text).map_err(|e| field_err(path, model_line, "model", e.to_string()))?;
        let model = Model::new(&spec, &registry, limit)
            .map_err(|e| field_err(path, model_line, "model", e.to_string()))?;
        let params_line = line_of(text, file.params.span().start);
        let values: BTreeMap<String, ParamIn> = file
            .params
            .into_inner()
            .into_iter()
            .map(|(k, v)| {
                let (value, line) = at(&v);
                (
                    k,
                    ParamIn {
                        value,
                        std_err: None,
                        line,
                        unit: None,
                    },
                )
            })
            .collect();
        let params = assign_params(&model, &values, path, params_line)?;
        check_force(&model, &params, &values, path, params_line)?;
        let geometry = match &file.geometry {
            Some(g) => Some(g.check(path, text)?),
            None => None,
        };
        let load_cell_range_n = match &file.load_cell {
            Some(l) => {
                let (range, line) = at(&l.range_n);
                Some(positive(range, "N", path, line, "load_cell.range_n")?)
            }
            None => None,
        };
        Ok(Self {
            std_errs: vec![None; params.len()],
            model: Arc::new(model),
            params,
            supply_limit_a,
            geometry,
            load_cell_range_n,
            command_timing: CommandTiming::AfterSample,
            acquisition_window_periods: None,
            path: path.to_path_buf(),
        })
    }

    /// Read a `PARAMS.json` (the model-discovery contract's parameter file): the keys `model` and `params`
    /// (each parameter an object with `value`, and optionally `std_err` and `unit`), and the optional
    /// `current_limit_a` (default: the paper's 14 A), `command_timing` (default: `after-sample`, what files
    /// saved without the key meant) and `acquisition_window_periods` (default: none). Any other key, a key given twice, a unit other than the parameter's
    /// and a value of the wrong type are errors that name the line and the key. A leading UTF-8 byte-order
    /// mark is skipped, as the CSV and TOML readers do.
    pub fn from_json(text: &str, path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        if text.trim().is_empty() {
            return Err(DeviceError::Parse {
                path: path.to_path_buf(),
                line: 1,
                msg: "empty file: a parameter file is a JSON object {\"model\": …, \"params\": {…}}".into(),
            });
        }
        let root: serde_json::Value = serde_json::from_str(text).map_err(|e| json_err(&e, text, path))?;
        let keys = JsonKeys::scan(text);
        if let Some((key, line, first)) = keys.duplicate() {
            return Err(field_err(
                path,
                line,
                &json_field(key),
                format!("given twice (first at line {first}); each key may appear once"),
            ));
        }
        let Some(top) = root.as_object() else {
            return Err(DeviceError::Parse {
                path: path.to_path_buf(),
                line: 1,
                msg: format!(
                    "a parameter file is a JSON object {{\"model\": …, \"params\": {{…}}}}, not {}",
                    json_kind(&root)
                ),
            });
        };
        let line = |key: &[&str]| keys.key(key).unwrap_or_else(|| keys.object(&[]));
        for key in top.keys() {
            if !TOP_KEYS.contains(&key.as_str()) {
                return Err(field_err(
                    path,
                    line(&[key]),
                    key,
                    format!(
                        "unknown key; a parameter file has the keys {}",
                        TOP_KEYS.join(", ")
                    ),
                ));
            }
        }
        let missing = |key: &str, what: &str| {
            field_err(
                path,
                keys.object(&[]),
                key,
                format!("missing: a parameter file names {what}"),
            )
        };
        let wrong = |key: &[&str], want: &str, v: &serde_json::Value| {
            field_err(
                path,
                line(key),
                &json_field(key),
                format!("expected {want}, found {}", json_kind(v)),
            )
        };
        let model_spec = match top.get("model") {
            None => {
                return Err(missing(
                    "model",
                    "its model (`\"model\": \"bingham+hysteresis\"`)",
                ))
            }
            Some(serde_json::Value::String(s)) => s,
            Some(v) => {
                return Err(wrong(
                    &["model"],
                    "a model spec string such as \"bingham+hysteresis\"",
                    v,
                ))
            }
        };
        let limit = match top.get("current_limit_a") {
            None => PAPER_CURRENT_LIMIT_A,
            Some(v) => {
                let Some(limit) = v.as_f64() else {
                    return Err(wrong(&["current_limit_a"], "a number of amperes", v));
                };
                check_current_limit(limit, path, line(&["current_limit_a"]), "current_limit_a")?
            }
        };
        let command_timing = match top.get("command_timing") {
            None => CommandTiming::AfterSample,
            Some(serde_json::Value::String(name)) => {
                <CommandTiming as clap::ValueEnum>::from_str(name, false).map_err(|_| {
                    field_err(
                        path,
                        line(&["command_timing"]),
                        "command_timing",
                        format!(
                        "`{name}` is not a command timing: `after-sample` (a command acts after the sample \
                             it is logged with) or `at-sample` (in force at it)"
                    ),
                    )
                })?
            }
            Some(v) => return Err(wrong(&["command_timing"], "\"after-sample\" or \"at-sample\"", v)),
        };
        // How the fit's tests shared its loss: a record of how the parameters (and their standard errors) were
        // found; the model runs the same either way.
        match top.get("weighting") {
            None => {}
            Some(serde_json::Value::String(name)) if name == "tests" || name == "samples" => {}
            Some(serde_json::Value::String(name)) => {
                return Err(field_err(
                    path,
                    line(&["weighting"]),
                    "weighting",
                    format!("`{name}` is not a weighting: expected \"tests\" or \"samples\""),
                ))
            }
            Some(v) => return Err(wrong(&["weighting"], "\"tests\" or \"samples\"", v)),
        }
        let acquisition_window_periods = match top.get("acquisition_window_periods") {
            None => None,
            Some(v) => match v.as_f64() {
                Some(share) if share > 0.0 && share < 1.0 => Some(share),
                Some(share) => {
                    return Err(field_err(
                        path,
                        line(&["acquisition_window_periods"]),
                        "acquisition_window_periods",
                        format!("value {share} is not a share of the drive period between 0 and 1"),
                    ))
                }
                None => {
                    return Err(wrong(
                        &["acquisition_window_periods"],
                        "a share of the drive period between 0 and 1",
                        v,
                    ))
                }
            },
        };
        let model = Model::from_spec(model_spec, registry, limit)
            .map_err(|e| field_err(path, line(&["model"]), "model", e.to_string()))?;
        let params_obj = match top.get("params") {
            None => {
                return Err(missing(
                    "params",
                    "its parameters (`\"params\": {\"te_s\": {\"value\": …}}`)",
                ))
            }
            Some(serde_json::Value::Object(m)) => m,
            Some(v) => return Err(wrong(&["params"], "an object of parameters", v)),
        };
        let mut values = BTreeMap::new();
        for (name, entry) in params_obj {
            let at = |sub: &str| line(&["params", name, sub]);
            let here = line(&["params", name]);
            let Some(obj) = entry.as_object() else {
                return Err(wrong(
                    &["params", name],
                    "an object such as {\"value\": 0.01, \"std_err\": null, \"unit\": \"s\"}",
                    entry,
                ));
            };
            for key in obj.keys() {
                if !PARAM_KEYS.contains(&key.as_str()) {
                    return Err(field_err(
                        path,
                        line(&["params", name, key]),
                        &format!("{name}.{key}"),
                        format!("unknown key; a parameter has the keys {}", PARAM_KEYS.join(", ")),
                    ));
                }
            }
            let value = match obj.get("value") {
                None => {
                    return Err(field_err(
                        path,
                        here,
                        &format!("{name}.value"),
                        "missing: every parameter has a value".to_string(),
                    ))
                }
                Some(v) => v
                    .as_f64()
                    .ok_or_else(|| wrong(&["params", name, "value"], "a number", v))?,
            };
            let std_err = match obj.get("std_err") {
                None | Some(serde_json::Value::Null) => None,
                Some(v) => {
                    let e = v
                        .as_f64()
                        .ok_or_else(|| wrong(&["params", name, "std_err"], "a number or null", v))?;
                    // A spread is not negative; `fit` writes null where it has none.
                    if e < 0.0 {
                        return Err(field_err(
                            path,
                            at("std_err"),
                            &format!("{name}.std_err"),
                            format!("value {e} is negative: a standard error is ≥ 0 (null where unknown)"),
                        ));
                    }
                    Some(e)
                }
            };
            let unit = match obj.get("unit") {
                None => None,
                Some(serde_json::Value::String(u)) => Some((u.clone(), at("unit"))),
                Some(v) => return Err(wrong(&["params", name, "unit"], "a unit string", v)),
            };
            values.insert(
                name.clone(),
                ParamIn {
                    value,
                    std_err,
                    line: here,
                    unit,
                },
            );
        }
        let params_line = line(&["params"]);
        let params = assign_params(&model, &values, path, params_line)?;
        check_force(&model, &params, &values, path, params_line)?;
        let std_errs = model
            .param_specs()
            .iter()
            .map(|spec| values.get(spec.name).and_then(|p| p.std_err))
            .collect();
        Ok(Self {
            std_errs,
            model: Arc::new(model),
            params,
            supply_limit_a: None,
            geometry: None,
            load_cell_range_n: None,
            command_timing,
            acquisition_window_periods,
            path: path.to_path_buf(),
        })
    }
}

/// The keys of a `PARAMS.json`, and of each of its parameters.
const TOP_KEYS: [&str; 6] = [
    "model",
    "current_limit_a",
    "command_timing",
    "acquisition_window_periods",
    "weighting",
    "params",
];
const PARAM_KEYS: [&str; 3] = ["value", "std_err", "unit"];

/// One parameter value as a file gives it: the line it is on, and the unit it is said to be in (JSON).
struct ParamIn {
    value: f64,
    std_err: Option<f64>,
    line: usize,
    unit: Option<(String, usize)>,
}

fn field_err(path: &Path, line: usize, field: &str, msg: String) -> DeviceError {
    DeviceError::Field {
        path: path.to_path_buf(),
        line,
        field: field.to_string(),
        msg,
    }
}

/// A value that must be a positive, finite number of `unit`.
fn positive(v: f64, unit: &str, path: &Path, line: usize, field: &str) -> Result<f64, DeviceError> {
    if v.is_finite() && v > 0.0 {
        Ok(v)
    } else {
        Err(field_err(
            path,
            line,
            field,
            format!("value {} {unit}: must be a positive, finite number", num(v)),
        ))
    }
}

/// The driver's saturation: the command is limited to ±limit, so the limit is a positive number of amperes.
fn check_current_limit(limit: f64, path: &Path, line: usize, field: &str) -> Result<f64, DeviceError> {
    if limit.is_finite() && limit > 0.0 {
        Ok(limit)
    } else {
        Err(field_err(
            path,
            line,
            field,
            format!(
                "value {} A: the driver's saturation limits the coil current command to ±current_limit_a, \
                 so it must be a positive, finite number of amperes (the paper's driver: 14 A)",
                num(limit)
            ),
        ))
    }
}

/// A JSON syntax error at its line, without serde_json's own " at line L column C" (the line leads the
/// error already), naming the key whose value it is in where there is one (not for a file that ends early).
fn json_err(e: &serde_json::Error, text: &str, path: &Path) -> DeviceError {
    let s = e.to_string();
    let msg = match s.rfind(" at line ") {
        Some(k) => format!("{} (column {})", &s[..k], e.column()),
        None => s,
    };
    let line = e.line().max(1);
    let key = match e.classify() {
        serde_json::error::Category::Eof => None,
        // After the closing brace no key is at fault: the file goes on past its object.
        _ if msg.starts_with("trailing characters") => None,
        _ => {
            // The byte the reader stopped at: its line's start plus the column.
            let start: usize = text.split_inclusive('\n').take(line - 1).map(str::len).sum();
            let mut end = (start + e.column()).min(text.len());
            while !text.is_char_boundary(end) {
                end -= 1;
            }
            JsonKeys::scan(&text[..end]).keys.pop().map(|(p, _)| p)
        }
    };
    match key {
        Some(key) => field_err(path, line, &json_field(&key), msg),
        None => DeviceError::Parse {
            path: path.to_path_buf(),
            line,
            msg,
        },
    }
}

/// The field a JSON key path names in a message: `te_s.unit` for `params.te_s.unit` (parameters are named
/// as in a device file), the top-level keys as they are.
fn json_field<S: AsRef<str>>(path: &[S]) -> String {
    let parts: Vec<&str> = path.iter().map(AsRef::as_ref).collect();
    match parts.as_slice() {
        ["params", rest @ ..] if !rest.is_empty() => rest.join("."),
        all => all.join("."),
    }
}

fn json_kind(v: &serde_json::Value) -> &'static str {
    match v {
        serde_json::Value::Null => "null",
        serde_json::Value::Bool(_) => "a boolean",
        serde_json::Value::Number(_) => "a number",
        serde_json::Value::String(_) => "a string",
        serde_json::Value::Array(_) => "an array",
        serde_json::Value::Object(_) => "an object",
    }
}

/// Where the keys of a JSON text are: each key's path (the keys and array indices above it, then itself)
/// with the line it starts on, in text order, and the line each object opens on. It reads text that
/// `serde_json` has accepted (on other text it gives some lines, never a panic).
struct JsonKeys {
    keys: Vec<(Vec<String>, usize)>,
    objects: Vec<(Vec<String>, usize)>,
}

impl JsonKeys {
    fn scan(text: &str) -> Self {
        enum Frame {
            Object { key: Option<String>, want_key: bool },
            Array { index: usize },
        }
        fn here(stack: &[Frame]) -> Vec<String> {
            stack
                .iter()
                .filter_map(|f| match f {
                    Frame::Object { key, .. } => key.clone(),
                    Frame::Array { index } => Some(index.to_string()),
                })
                .collect()
        }
        let b = text.as_bytes();
        let (mut keys, mut objects) = (Vec::new(), Vec::new());
        let mut stack: Vec<Frame> = Vec::new();
        let (mut i, mut line) = (0usize, 1usize);
        while i < b.len() {
            match b[i] {
                b'\n' => line += 1,
                b'"' => {
                    let (start, start_line) = (i, line);
                    i += 1;
                    while i < b.len() && b[i] != b'"' {
                        if b[i] == b'\\' {
                            i += 1;
                        } else if b[i] == b'\n' {
                            line += 1;
                        }
                        i += 1;
                    }
                    let end = (i + 1).min(b.len());
                    if let Some(Frame::Object { key, want_key }) = stack.last_mut() {
                        if *want_key {
                            let raw = text.get(start..end).unwrap_or_default();
                            let name = serde_json::from_str::<String>(raw)
                                .unwrap_or_else(|_| raw.trim_matches('"').to_string());
                            *key = Some(name);
                            *want_key = false;
                            keys.push((here(&stack), start_line));
                        }
                    }
                }
                b'{' => {
                    objects.push((here(&stack), line));
                    stack.push(Frame::Object {
                        key: None,
                        want_key: true,
                    });
                }
                b'[' => stack.push(Frame::Array { index: 0 }),
                b'}' | b']' => {
                    stack.pop();
                }
                b',' => match stack.last_mut() {
                    Some(Frame::Object { want_key, .. }) => *want_key = true,
                    Some(Frame::Array { index }) => *index += 1,
                    None => {}
                },
                _ => {}
            }
            i += 1;
        }
        Self { keys, objects }
    }

    /// Line of the first occurrence of a key.
    fn key(&self, path: &[&str]) -> Option<usize> {
        self.keys
            .iter()
            .find(|(p, _)| p.iter().map(String::as_str).eq(path.iter().copied()))
            .map(|(_, l)| *l)
    }

    /// Line on which the object at `path` opens (1 when there is none).
    fn object(&self, path: &[&str]) -> usize {
        self.objects
            .iter()
            .find(|(p, _)| p.iter().map(String::as_str).eq(path.iter().copied()))
            .map_or(1, |(_, l)| *l)
    }

    /// The first key given twice in the same object: its path, its second line and its first line.
    fn duplicate(&self) -> Option<(&[String], usize, usize)> {
        let mut seen: BTreeMap<&[String], usize> = BTreeMap::new();
        for (p, line) in &self.keys {
            if let Some(first) = seen.insert(p.as_slice(), *line) {
                return Some((p.as_slice(), *line, first));
            }
        }
        None
    }
}

/// Match named values to the model's parameters: every parameter present (or one whose absence has a
/// meaning, [`ParamSpec::absent`](super::ParamSpec::absent)), no unknown name, in the parameter's unit where a unit is given, inside
/// bounds. A missing parameter is reported at `section_line`, the line of the table or object that lacks it.
fn assign_params(
    model: &Model,
    values: &BTreeMap<String, ParamIn>,
    path: &Path,
    section_line: usize,
) -> Result<Vec<f64>, DeviceError> {
    for (name, p) in values {
        let Some(k) = model.param_index(name) else {
            return Err(field_err(
                path,
                p.line,
                name,
                format!(
                    "unknown parameter for model `{}`; its parameters are: {}",
                    model.name(),
                    model
                        .param_specs()
                        .iter()
                        .map(|p| p.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            ));
        };
        let spec = &model.param_specs()[k];
        if let Some((unit, line)) = &p.unit {
            if unit != spec.unit {
                return Err(field_err(
                    path,
                    *line,
                    &format!("{name}.unit"),
                    format!(
                        "unit \"{unit}\" is not the parameter's: {name} is in \"{}\" (values are read in that \
                         unit only; convert the value)",
                        spec.unit
                    ),
                ));
            }
        }
    }
    let mut out = Vec::with_capacity(model.n_params());
    for spec in model.param_specs() {
        let (v, line) = match (values.get(spec.name), spec.absent) {
            (Some(p), _) => (p.value, p.line),
            (None, Some(v)) => (v, section_line),
            (None, None) => {
                return Err(field_err(
                    path,
                    section_line,
                    spec.name,
                    format!("missing parameter ({}, {})", spec.unit, spec.doc),
                ))
            }
        };
        if !v.is_finite() || v < spec.lower || v > spec.upper {
            return Err(field_err(
                path,
                line,
                spec.name,
                format!(
                    "value {} outside the allowed range [{}, {}] {}",
                    num(v),
                    spec.lower,
                    spec.upper,
                    spec.unit
                ),
            ));
        }
        out.push(v);
    }
    Ok(out)
}

/// Refuse parameters with which the model's force is not a usable number anywhere a damper works
/// ([`Model::unusable_force`]): name the parameter that makes it so (the one whose return to zero, or its
/// nearest bound, gives a usable force), or every parameter when no single one does.
fn check_force(
    model: &Model,
    params: &[f64],
    values: &BTreeMap<String, ParamIn>,
    path: &Path,
    section_line: usize,
) -> Result<(), DeviceError> {
    let Some((inp, f)) = model.unusable_force(params) else {
        return Ok(());
    };
    let specs = model.param_specs();
    let at = format!(
        "a damper force of {f:e} N at v = {} m/s, x = {} m, a = {} m/s², i = {} A (beyond ±{:e} N, where the \
         force and the error figures stop being numbers)",
        inp.v_m_s,
        inp.x_m,
        inp.a_m_s2,
        inp.current_cmd_a,
        super::model::FORCE_LIMIT_N
    );
    for (k, spec) in specs.iter().enumerate() {
        let mut q = params.to_vec();
        q[k] = spec.clamp(0.0);
        if q[k] != params[k] && model.unusable_force(&q).is_none() {
            let line = values.get(spec.name).map_or(section_line, |p| p.line);
            return Err(field_err(
                path,
                line,
                spec.name,
                format!(
                    "value {} {} gives {at}; correct the value or refit",
                    num(params[k]),
                    spec.unit
                ),
            ));
        }
    }
    let all = specs
        .iter()
        .zip(params)
        .map(|(s, v)| format!("{} = {}", s.name, num(*v)))
        .collect::<Vec<_>>()
        .join(", ");
    Err(field_err(
        path,
        section_line,
        "params",
        format!("these parameters ({all}) give {at}; correct them or refit"),
    ))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlDevice {
    model: toml::Spanned<String>,
    #[serde(default)]
    driver: TomlDriver,
    params: toml::Spanned<BTreeMap<String, toml::Spanned<f64>>>,
    geometry: Option<TomlGeometry>,
    load_cell: Option<TomlLoadCell>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct TomlDriver {
    current_limit_a: Option<toml::Spanned<f64>>,
    supply_limit_a: Option<toml::Spanned<f64>>,
}

/// Table 1 geometry, inches as printed.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlGeometry {
    piston_diameter_in: toml::Spanned<f64>,
    piston_rod_length_in: toml::Spanned<f64>,
    cylinder_id_in: toml::Spanned<f64>,
    cylinder_od_in: toml::Spanned<f64>,
    cylinder_length_in: toml::Spanned<f64>,
    stroke_half_in: toml::Spanned<f64>,
}

impl TomlGeometry {
    /// Every dimension a positive length, and the parts fit together: the piston in the bore, the bore in the
    /// tube's outside, the full stroke in the cylinder.
    fn check(&self, path: &Path, text: &str) -> Result<Geometry, DeviceError> {
        let line = |v: &toml::Spanned<f64>| line_of(text, v.span().start);
        let len = |v: &toml::Spanned<f64>, name: &str| {
            positive(*v.get_ref(), "in", path, line(v), &format!("geometry.{name}"))
        };
        let piston = len(&self.piston_diameter_in, "piston_diameter_in")?;
        let rod = len(&self.piston_rod_length_in, "piston_rod_length_in")?;
        let id = len(&self.cylinder_id_in, "cylinder_id_in")?;
        let od = len(&self.cylinder_od_in, "cylinder_od_in")?;
        let cyl_len = len(&self.cylinder_length_in, "cylinder_length_in")?;
        let stroke = len(&self.stroke_half_in, "stroke_half_in")?;
        let clash = |v: &toml::Spanned<f64>, name: &str, why: String| {
            Err(field_err(path, line(v), &format!("geometry.{name}"), why))
        };
        if piston > id {
            return clash(
                &self.piston_diameter_in,
                "piston_diameter_in",
                format!("value {piston} in is larger than the cylinder's bore, cylinder_id_in = {id} in"),
            );
        }
        if id >= od {
            return clash(
                &self.cylinder_id_in,
                "cylinder_id_in",
                format!("value {id} in is not smaller than the cylinder's outside diameter, cylinder_od_in = {od} in"),
            );
        }
        if 2.0 * stroke > cyl_len {
            return clash(
                &self.stroke_half_in,
                "stroke_half_in",
                format!(
                    "value {stroke} in: the full stroke, 2 × {stroke} in, is longer than the cylinder, \
                     cylinder_length_in = {cyl_len} in"
                ),
            );
        }
        Ok(Geometry {
            piston_diameter_m: piston * IN_TO_M,
            piston_rod_length_m: rod * IN_TO_M,
            cylinder_id_m: id * IN_TO_M,
            cylinder_od_m: od * IN_TO_M,
            cylinder_length_m: cyl_len * IN_TO_M,
            stroke_half_m: stroke * IN_TO_M,
        })
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlLoadCell {
    range_n: toml::Spanned<f64>,
}

/// `PARAMS.json` as written by `mrfeel fit --save` and read by `mrfeel validate --params`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ParamsFile {
    pub model: String,
    /// Driver saturation the model was fitted with, A.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub current_limit_a: Option<f64>,
    /// When the fitted data's logged current commands took effect, `after-sample` or `at-sample`
    /// ([`CommandTiming`]); absent in older files, which were all read after their sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command_timing: Option<String>,
    /// The share of the drive period that the fitted data's acquisition filter (a moving average) spanned
    /// in every protocol, where the fit found one; `validate` then checks new tests for the window it
    /// predicts where their own spectra are too short to show one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acquisition_window_periods: Option<f64>,
    /// How the fit's tests shared its loss, `tests` (each once) or `samples` (each sample once); absent in
    /// older files, whose fits counted samples. A record only: `validate` runs the model
    /// the same either way.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub weighting: Option<String>,
    pub params: BTreeMap<String, ParamValue>,
}

impl ParamsFile {
    /// Build from a model and values (and standard errors, where known).
    pub fn new(model: &Model, values: &[f64], std_errs: Option<&[Option<f64>]>) -> Self {
        let params = model
            .param_specs()
            .iter()
            .enumerate()
            .map(|(k, s)| {
                (
                    s.name.to_string(),
                    ParamValue {
                        value: values[k],
                        std_err: std_errs.and_then(|e| e[k]),
                        unit: s.unit.to_string(),
                    },
                )
            })
            .collect();
        Self {
            model: model.name(),
            current_limit_a: Some(model.current_limit_a),
            command_timing: None,
            acquisition_window_periods: None,
            weighting: None,
            params,
        }
    }

    /// Refuse, before any work, a path to save parameters to that would not be read back as such:
    /// [`ParamsFile::write`] writes JSON, and [`DeviceConfig::load`] reads a file by its extension (a `.toml`
    /// as a device file, which JSON is not).
    pub fn check_path(flag: &str, path: &Path) -> Result<(), String> {
        if path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        {
            Ok(())
        } else {
            Err(format!(
                "{flag} {}: parameters are saved as JSON and read back by the file's extension; name the file \
                 *.json (nothing was run)",
                path.display()
            ))
        }
    }

    /// Write as pretty JSON with a final newline (what `fit --save` and `mts --save-device` write), whole or
    /// not at all ([`crate::outputs::write_whole`]).
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(std::io::Error::other)? + "\n";
        crate::outputs::write_whole(path, |tmp| std::fs::write(tmp, &text), |e| e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The key scanner finds each key's line by its path, objects' opening lines, and keys given twice in
    /// the same object only (the same name in two objects is no duplicate); escaped quotes and keys inside
    /// string values do not confuse it.
    #[test]
    fn json_keys_are_found_at_their_lines_by_path() {
        let text =
            "{\n  \"a\": \"not \\\"b\\\": a key\",\n  \"p\": {\n    \"x\": {\"value\": 1},\n    \"y\": \
                    [ {\"value\": 2}, {\"value\": 3} ]\n  }\n}";
        let k = JsonKeys::scan(text);
        assert_eq!(k.key(&["a"]), Some(2));
        assert_eq!(k.key(&["b"]), None);
        assert_eq!(k.key(&["p"]), Some(3));
        assert_eq!(k.key(&["p", "x", "value"]), Some(4));
        assert_eq!(k.key(&["p", "y", "1", "value"]), Some(5));
        assert_eq!(k.object(&[]), 1);
        assert_eq!(k.object(&["p"]), 3);
        assert_eq!(k.duplicate(), None);
        let twice = JsonKeys::scan("{\"p\": {\"x\": 1,\n \"y\": 2,\n \"x\": 3}}");
        let (path, line, first) = twice.duplicate().expect("x twice");
        assert_eq!((path.join("."), line, first), ("p.x".to_string(), 3, 1));
        // Text serde_json would refuse: some lines, no panic.
        for bad in ["{\"a", "}}]]", "{\"a\": \"\\", "\""] {
            let _ = JsonKeys::scan(bad);
        }
    }

    /// A saved parameter file reads back as the numbers written, to the bit: `validate` runs the fitted
    /// model unchanged. serde_json's fast float parser reads some shortest decimals one unit in the last
    /// place off (3991.6813567412532 as 3991.681356741253, found by a probe of `fit --save` on the real
    /// damper), which its `float_roundtrip` feature corrects.
    #[test]
    fn saved_parameters_read_back_to_the_bit() {
        let registry = Registry::builtin();
        let model = Model::from_spec("bingham", &registry, PAPER_CURRENT_LIMIT_A).unwrap();
        let values = [
            28.330844594579858,
            1268.5364,
            3991.6813567412532,
            0.1 + 0.2,
            1.0 / 3.0,
        ];
        let errs = [Some(0.1 + 0.7), None, Some(3.0f64.sqrt()), None, None];
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.json");
        ParamsFile::new(&model, &values, Some(&errs))
            .write(&path)
            .unwrap();
        let back = DeviceConfig::load(&path, &registry).unwrap();
        for (spec, v) in model.param_specs().iter().zip(values) {
            assert_eq!(
                back.param(spec.name).map(f64::to_bits),
                Some(v.to_bits()),
                "{}",
                spec.name
            );
        }
        let text = std::fs::read_to_string(&path).unwrap();
        let file: ParamsFile = serde_json::from_str(&text).unwrap();
        assert_eq!(
            file.params["fc0_n"].std_err.map(f64::to_bits),
            Some((0.1f64 + 0.7).to_bits())
        );
        assert_eq!(
            file.params["c0_n_s_per_m"].std_err.map(f64::to_bits),
            Some(3.0f64.sqrt().to_bits())
        );
    }

    /// A negative standard error is refused at its line (it was read as given).
    #[test]
    fn a_negative_standard_error_is_refused_at_its_line() {
        let registry = Registry::builtin();
        let text = "{\"model\": \"bingham\",\n \"params\": {\n  \"fc0_n\": {\"value\": 1.0,\n   \"std_err\": -0.5}\n}}";
        match DeviceConfig::from_json(text, Path::new("p.json"), &registry) {
            Err(DeviceError::Field { line, field, msg, .. }) => {
                assert_eq!((line, field.as_str()), (4, "fc0_n.std_err"));
                assert!(msg.contains("negative"), "{msg}");
            }
            other => panic!("{other:?}"),
        }
    }

    /// Text after the JSON object is the file's fault at its line, not the last key's before it (it was
    /// blamed on `tm_s.unit`).
    #[test]
    fn text_after_the_object_names_no_key() {
        let registry = Registry::builtin();
        let text =
            "{\"model\": \"bingham\",\n \"params\": {\"te_s\": {\"value\": 0.01, \"unit\": \"s\"}}}\nx\n";
        match DeviceConfig::from_json(text, Path::new("p.json"), &registry) {
            Err(DeviceError::Parse { line, msg, .. }) => {
                assert_eq!(line, 3);
                assert!(msg.contains("trailing characters"), "{msg}");
            }
            other => panic!("{other:?}"),
        }
    }

    /// Every load error carries a line ≥ 1: the offending key's, or the table's or object's that lacks one.
    #[test]
    fn no_error_is_at_line_zero() {
        let registry = Registry::builtin();
        let json = |t: &str| DeviceConfig::from_json(t, Path::new("p.json"), &registry).unwrap_err();
        let toml = |t: &str| DeviceConfig::from_toml(t, Path::new("d.toml"), &registry).unwrap_err();
        let line = |e: DeviceError| match e {
            DeviceError::Parse { line, .. } | DeviceError::Field { line, .. } => line,
            other => panic!("{other}"),
        };
        for e in [
            json(""),
            json("[]"),
            json("{}"),
            json("{\"model\": \"bingham\"}"),
            json("{\"model\": \"bingham\",\n \"params\": {}}"),
            json("{\"model\": \"bingham\",\n \"params\": {\"te_s\": {}}}"),
            toml(""),
            toml("model = \"bingham\""),
            toml("model = \"bingham\"\n[params]\n"),
        ] {
            assert!(line(e) >= 1);
        }
        match json("{\"model\": \"bingham\",\n \"params\": {\n}}") {
            DeviceError::Field { line, field, .. } => assert_eq!((line, field.as_str()), (2, "fc0_n")),
            other => panic!("{other}"),
        }
    }

    #[test]
    fn numbers_in_messages_are_short() {
        assert_eq!(num(1e300), "1e300");
        assert_eq!(num(-14.0), "-14");
        assert_eq!(num(0.015), "0.015");
        assert_eq!(num(f64::NAN), "NaN");
        assert_eq!(num(2.5e-7), "2.5e-7");
    }

    /// A parameter file saved before `hysteresis` had its shape parameters (older `fit --save` output)
    /// describes the Dahl element; it still loads, as that model. A parameter without such a meaning is
    /// still required, by name.
    #[test]
    fn a_file_from_before_a_parameter_existed_means_the_model_it_was_saved_with() {
        let registry = Registry::builtin();
        let path = Path::new("old_params.json");
        let file = |extra: &str| {
            format!(
                r#"{{"model": "bingham+hysteresis", "params": {{"c0_n_s_per_m": {{"value": 60.0}},
                "fc0_n": {{"value": 2.0}}, "fc_gain_n_per_a": {{"value": 4.8}}, "te_s": {{"value": 0.01}},
                "tm_s": {{"value": 0.02}}, "hyst_v_yield_m_s": {{"value": 0.01}}{extra}}}}}"#
            )
        };
        let old = DeviceConfig::from_json(&file(r#", "hyst_x_yield_m": {"value": 0.0003}"#), path, &registry)
            .expect("an old file loads");
        assert_eq!(old.param("hyst_knee"), Some(0.0));
        assert_eq!(old.param("hyst_gamma_share"), Some(0.0));
        assert_eq!(old.param("hyst_x_yield_m"), Some(0.0003));
        match DeviceConfig::from_json(&file(""), path, &registry) {
            Err(DeviceError::Field { field, msg, .. }) => {
                assert_eq!(field, "hyst_x_yield_m");
                assert!(msg.contains("missing"), "{msg}");
            }
            other => panic!("a file without the yield displacement: {other:?}"),
        }
    }
}
