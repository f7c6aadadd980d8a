//! Parameter files (`PARAMS.json`, as `mrfeel fit --save` writes them), read with the line of every key.

use super::json::{self, Entry, Node, Object};
use super::{InputError, Source};

/// When the current command logged at a sample takes effect (`ident::timing`): after its sample (a DAQ
/// loop that reads the sensors, then writes the command) or at it (in force at the sample it is logged
/// with).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CommandTiming {
    /// Over the interval after its sample (read the sensors, then write the command).
    #[default]
    AfterSample,
    /// Over the interval before its sample: in force at the sample it is logged with.
    AtSample,
}

impl CommandTiming {
    /// The name a parameter file and the command line use.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::AfterSample => "after-sample",
            Self::AtSample => "at-sample",
        }
    }
}

/// A parameter file's top-level keys, and each parameter's.
const TOP_KEYS: [&str; 6] = [
    "model",
    "current_limit_a",
    "command_timing",
    "acquisition_window_periods",
    "weighting",
    "params",
];
const PARAM_KEYS: [&str; 3] = ["value", "std_err", "unit"];

/// A value with the line it is on.
#[derive(Debug, Clone, PartialEq)]
pub struct At<T> {
    pub value: T,
    pub line: usize,
}

/// A `PARAMS.json` as read: every key known, of its type and in its range, each with its line. What the
/// parameters must be for the model (names, units, bounds) is checked where the model is built.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ParamsJson {
    /// The model spec (`bingham+hysteresis`).
    pub model: At<String>,
    /// The driver's saturation, A, positive.
    pub current_limit_a: Option<At<f64>>,
    pub command_timing: CommandTiming,
    /// The share of the drive period the fitted data's acquisition filter spanned, in (0, 1).
    pub acquisition_window_periods: Option<f64>,
    /// The line of `"params"`, and the parameters in file order.
    pub params: At<Vec<Param>>,
}

/// One parameter: its name's line, value, standard error (≥ 0) and unit as written.
#[derive(Debug, Clone, PartialEq)]
pub struct Param {
    pub name: String,
    pub line: usize,
    pub value: f64,
    pub std_err: Option<f64>,
    pub unit: Option<At<String>>,
}

/// The field a key path names: `te_s.unit` for `params.te_s.unit` (parameters are named as in a device
/// file), the top-level keys as they are.
fn field<S: AsRef<str>>(path: &[S]) -> String {
    let path: Vec<&str> = path.iter().map(AsRef::as_ref).collect();
    match path.as_slice() {
        ["params", rest @ ..] if !rest.is_empty() => rest.join("."),
        all => all.join("."),
    }
}

impl ParamsJson {
    /// Read a parameter file's text: a syntax error, an unknown or repeated key, a value of the wrong type
    /// or out of its range names its line and key.
    pub fn parse(src: &Source) -> Result<Self, InputError> {
        let text = src.text.strip_prefix('\u{feff}').unwrap_or(&src.text);
        if text.trim().is_empty() {
            let msg = "empty file: a parameter file is a JSON object {\"model\": …, \"params\": {…}}";
            return Err(InputError::line(&src.path, 1, msg));
        }
        let top = match json::parse(src, field)? {
            Node::Object(top) => top,
            other => {
                let msg = format!(
                    "a parameter file is a JSON object {{\"model\": …, \"params\": {{…}}}}, not {}",
                    other.kind()
                );
                return Err(InputError::line(&src.path, 1, msg));
            }
        };
        let err = |line, path: &[&str], msg: String| InputError::field(&src.path, line, field(path), msg);
        let known = |o: &Object, keys: &[&str], within: &[&str], what: &str| {
            if let Some((e, first)) = o.duplicate() {
                let msg = format!("given twice (first at line {first}); each key may appear once");
                return Err(err(e.line, &[within, &[e.key.as_str()]].concat(), msg));
            }
            match o.entries.iter().find(|e| !keys.contains(&e.key.as_str())) {
                Some(e) => {
                    let msg = format!("unknown key; {what} has the keys {}", keys.join(", "));
                    Err(err(e.line, &[within, &[e.key.as_str()]].concat(), msg))
                }
                None => Ok(()),
            }
        };
        known(&top, &TOP_KEYS, &[], "a parameter file")?;
        let missing = |key: &str, what: &str| {
            err(
                top.line,
                &[key],
                format!("missing: a parameter file names {what}"),
            )
        };

        let model = top
            .get("model")
            .ok_or_else(|| missing("model", "its model (`\"model\": \"bingham+hysteresis\"`)"))?;
        let model = at(
            src,
            model,
            &["model"],
            "a model spec string such as \"bingham+hysteresis\"",
        )?;
        let current_limit_a = match top.get("current_limit_a") {
            Some(e) => {
                let limit: f64 = typed(src, e, &["current_limit_a"], "a number of amperes")?;
                let value = current_limit(limit).map_err(|msg| err(e.line, &["current_limit_a"], msg))?;
                Some(At { value, line: e.line })
            }
            None => None,
        };
        let command_timing = match top.get("command_timing") {
            Some(e) => {
                let name: String = typed(src, e, &["command_timing"], "\"after-sample\" or \"at-sample\"")?;
                serde_json::from_value(name.clone().into()).map_err(|_| {
                    let msg = format!(
                        "`{name}` is not a command timing: `after-sample` (a command acts after the sample it is \
                         logged with) or `at-sample` (in force at it)"
                    );
                    err(e.line, &["command_timing"], msg)
                })?
            }
            None => CommandTiming::AfterSample,
        };
        // How the fit's tests shared its loss: a record only, the model runs the same either way.
        if let Some(e) = top.get("weighting") {
            let name: String = typed(src, e, &["weighting"], "\"tests\" or \"samples\"")?;
            if name != "tests" && name != "samples" {
                let msg = format!("`{name}` is not a weighting: expected \"tests\" or \"samples\"");
                return Err(err(e.line, &["weighting"], msg));
            }
        }
        let acquisition_window_periods = match top.get("acquisition_window_periods") {
            Some(e) => {
                let key = ["acquisition_window_periods"];
                let share: f64 = typed(src, e, &key, "a share of the drive period between 0 and 1")?;
                if !(share > 0.0 && share < 1.0) {
                    let msg = format!("value {share} is not a share of the drive period between 0 and 1");
                    return Err(err(e.line, &key, msg));
                }
                Some(share)
            }
            None => None,
        };
        let params_what = "its parameters (`\"params\": {\"te_s\": {\"value\": …}}`)";
        let params_entry = top.get("params").ok_or_else(|| missing("params", params_what))?;
        let Node::Object(params_obj) = &params_entry.value else {
            let msg = format!(
                "expected an object of parameters, found {}",
                params_entry.value.kind()
            );
            return Err(err(params_entry.line, &["params"], msg));
        };
        let names: Vec<&str> = params_obj.entries.iter().map(|e| e.key.as_str()).collect();
        known(params_obj, &names, &["params"], "")?;
        let mut params = Vec::new();
        for p in &params_obj.entries {
            let name = p.key.as_str();
            let Node::Object(obj) = &p.value else {
                let msg = format!(
                    "expected an object such as {{\"value\": 0.01, \"std_err\": null, \"unit\": \"s\"}}, found {}",
                    p.value.kind()
                );
                return Err(err(p.line, &["params", name], msg));
            };
            known(obj, &PARAM_KEYS, &["params", name], "a parameter")?;
            let key = ["params", name, "value"];
            let value = obj
                .get("value")
                .ok_or_else(|| err(p.line, &key, "missing: every parameter has a value".into()))?;
            let value: f64 = typed(src, value, &key, "a number")?;
            let std_err = match obj.get("std_err") {
                Some(e) => {
                    let key = ["params", name, "std_err"];
                    let s: Option<f64> = typed(src, e, &key, "a number or null")?;
                    // A spread is not negative; `fit` writes null where it has none.
                    if let Some(s) = s.filter(|s| *s < 0.0) {
                        let msg =
                            format!("value {s} is negative: a standard error is ≥ 0 (null where unknown)");
                        return Err(err(e.line, &key, msg));
                    }
                    s
                }
                None => None,
            };
            let unit = obj
                .get("unit")
                .map(|e| at(src, e, &["params", name, "unit"], "a unit string"));
            params.push(Param {
                name: name.to_string(),
                line: p.line,
                value,
                std_err,
                unit: unit.transpose()?,
            });
        }
        Ok(Self {
            model,
            current_limit_a,
            command_timing,
            acquisition_window_periods,
            params: At {
                value: params,
                line: params_entry.line,
            },
        })
    }
}

/// A value of `T`, else `expected {want}, found {kind}` at its line.
fn typed<T: serde::de::DeserializeOwned>(
    src: &Source,
    e: &Entry,
    path: &[&str],
    want: &str,
) -> Result<T, InputError> {
    let value = match &e.value {
        Node::Value(v) => serde_json::from_value(v.clone()).ok(),
        Node::Object(_) => None,
    };
    value.ok_or_else(|| {
        let msg = format!("expected {want}, found {}", e.value.kind());
        InputError::field(&src.path, e.line, field(path), msg)
    })
}

/// [`typed`] with its line.
fn at<T: serde::de::DeserializeOwned>(
    src: &Source,
    e: &Entry,
    path: &[&str],
    want: &str,
) -> Result<At<T>, InputError> {
    Ok(At {
        value: typed(src, e, path, want)?,
        line: e.line,
    })
}

/// The driver's saturation: the command is limited to ±limit, so the limit is a positive number of amperes.
pub fn current_limit(limit: f64) -> Result<f64, String> {
    if limit.is_finite() && limit > 0.0 {
        return Ok(limit);
    }
    Err(format!(
        "value {} A: the driver's saturation limits the coil current command to ±current_limit_a, so it must be \
         a positive, finite number of amperes (the paper's driver: 14 A)",
        super::text::short_number(limit)
    ))
}
