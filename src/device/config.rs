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
    pub path: PathBuf,
}

impl DeviceConfig {
    /// Load a `.toml` device file or a `.json` parameter file written by `mrfeel fit --save`.
    pub fn load(path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let text = std::fs::read_to_string(path).map_err(|e| DeviceError::Io {
            path: path.to_path_buf(),
            msg: e.to_string(),
        })?;
        if path.extension().and_then(|e| e.to_str()) == Some("json") {
            Self::from_json(&text, path, registry)
        } else {
            Self::from_toml(&text, path, registry)
        }
    }

    /// A damper in its initial state, ready to be stepped.
    pub fn damper(&self) -> Damper {
        Damper::new(self.model.clone(), self.params.clone()).expect("parameter count checked on load")
    }

    /// Value of a named parameter.
    pub fn param(&self, name: &str) -> Option<f64> {
        self.model.param_index(name).map(|k| self.params[k])
    }

    pub fn from_toml(text: &str, path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let file: TomlDevice = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| line_of(text, s.start)).unwrap_or(0);
            DeviceError::Parse {
                path: path.to_path_buf(),
                line,
                msg: e.message().to_string(),
            }
        })?;
        let limit = file
            .driver
            .current_limit_a
            .map(|s| s.into_inner())
            .unwrap_or(PAPER_CURRENT_LIMIT_A);
        let spec = ModelSpec::parse(file.model.get_ref()).map_err(|e| DeviceError::Field {
            path: path.to_path_buf(),
            line: line_of(text, file.model.span().start),
            field: "model".into(),
            msg: e.to_string(),
        })?;
        let model = Model::new(&spec, registry, limit).map_err(|e| DeviceError::Field {
            path: path.to_path_buf(),
            line: line_of(text, file.model.span().start),
            field: "model".into(),
            msg: e.to_string(),
        })?;
        let values: BTreeMap<String, (f64, usize)> = file
            .params
            .into_iter()
            .map(|(k, v)| {
                let line = line_of(text, v.span().start);
                (k, (v.into_inner(), line))
            })
            .collect();
        let params = assign_params(&model, &values, path)?;
        let geometry = file.geometry.map(|g| Geometry {
            piston_diameter_m: g.piston_diameter_in * IN_TO_M,
            piston_rod_length_m: g.piston_rod_length_in * IN_TO_M,
            cylinder_id_m: g.cylinder_id_in * IN_TO_M,
            cylinder_od_m: g.cylinder_od_in * IN_TO_M,
            cylinder_length_m: g.cylinder_length_in * IN_TO_M,
            stroke_half_m: g.stroke_half_in * IN_TO_M,
        });
        Ok(Self {
            model: Arc::new(model),
            params,
            supply_limit_a: file.driver.supply_limit_a,
            geometry,
            load_cell_range_n: file.load_cell.map(|l| l.range_n),
            command_timing: CommandTiming::AfterSample,
            path: path.to_path_buf(),
        })
    }

    pub fn from_json(text: &str, path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let file: ParamsFile = serde_json::from_str(text).map_err(|e| DeviceError::Parse {
            path: path.to_path_buf(),
            line: e.line(),
            msg: e.to_string(),
        })?;
        let limit = file.current_limit_a.unwrap_or(PAPER_CURRENT_LIMIT_A);
        let model = Model::from_spec(&file.model, registry, limit).map_err(|e| DeviceError::Field {
            path: path.to_path_buf(),
            line: 0,
            field: "model".into(),
            msg: e.to_string(),
        })?;
        let values: BTreeMap<String, (f64, usize)> =
            file.params.into_iter().map(|(k, v)| (k, (v.value, 0))).collect();
        let params = assign_params(&model, &values, path)?;
        let command_timing = match file.command_timing.as_deref() {
            None => CommandTiming::AfterSample,
            Some(name) => <CommandTiming as clap::ValueEnum>::from_str(name, false).map_err(|_| {
                DeviceError::Field {
                    path: path.to_path_buf(),
                    line: text.find("\"command_timing\"").map_or(0, |o| line_of(text, o)),
                    field: "command_timing".into(),
                    msg: format!(
                        "`{name}` is not a command timing: `after-sample` (a command acts after the sample it \
                         is logged with) or `at-sample` (in force at it)"
                    ),
                }
            })?,
        };
        Ok(Self {
            model: Arc::new(model),
            params,
            supply_limit_a: None,
            geometry: None,
            load_cell_range_n: None,
            command_timing,
            path: path.to_path_buf(),
        })
    }
}

/// Match named values to the model's parameters: every parameter present (or one whose absence has a
/// meaning, [`ParamSpec::absent`]), no unknown name, inside bounds.
fn assign_params(
    model: &Model,
    values: &BTreeMap<String, (f64, usize)>,
    path: &Path,
) -> Result<Vec<f64>, DeviceError> {
    for (name, (_, line)) in values {
        if model.param_index(name).is_none() {
            return Err(DeviceError::Field {
                path: path.to_path_buf(),
                line: *line,
                field: name.clone(),
                msg: format!(
                    "unknown parameter for model `{}`; its parameters are: {}",
                    model.name(),
                    model
                        .param_specs()
                        .iter()
                        .map(|p| p.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
            });
        }
    }
    let mut out = Vec::with_capacity(model.n_params());
    for spec in model.param_specs() {
        let absent = spec.absent.map(|v| (v, 0));
        let Some((v, line)) = values.get(spec.name).or(absent.as_ref()) else {
            return Err(DeviceError::Field {
                path: path.to_path_buf(),
                line: 0,
                field: spec.name.to_string(),
                msg: format!("missing parameter ({}, {})", spec.unit, spec.doc),
            });
        };
        if !v.is_finite() || *v < spec.lower || *v > spec.upper {
            return Err(DeviceError::Field {
                path: path.to_path_buf(),
                line: *line,
                field: spec.name.to_string(),
                msg: format!(
                    "value {v} outside the allowed range [{}, {}] {}",
                    spec.lower, spec.upper, spec.unit
                ),
            });
        }
        out.push(*v);
    }
    Ok(out)
}

/// 1-based line of a byte offset.
pub(crate) fn line_of(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlDevice {
    model: toml::Spanned<String>,
    #[serde(default)]
    driver: TomlDriver,
    params: BTreeMap<String, toml::Spanned<f64>>,
    geometry: Option<TomlGeometry>,
    load_cell: Option<TomlLoadCell>,
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct TomlDriver {
    current_limit_a: Option<toml::Spanned<f64>>,
    supply_limit_a: Option<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlGeometry {
    piston_diameter_in: f64,
    piston_rod_length_in: f64,
    cylinder_id_in: f64,
    cylinder_od_in: f64,
    cylinder_length_in: f64,
    stroke_half_in: f64,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TomlLoadCell {
    range_n: f64,
}

/// `PARAMS.json` as written by `mrfeel fit --save` and read by `mrfeel validate --params`.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct ParamsFile {
    pub model: String,
    /// Driver saturation the model was fitted with, A.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub current_limit_a: Option<f64>,
    /// When the fitted data's logged current commands took effect, `after-sample` or `at-sample`
    /// ([`CommandTiming`]); absent in files saved before session 11, which were all read after their sample.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub command_timing: Option<String>,
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
            params,
        }
    }

    /// Refuse, before any work, a path to save parameters to that would not be read back as such:
    /// [`ParamsFile::write`] writes JSON, and [`DeviceConfig::load`] reads a file by its extension (a `.toml`
    /// as a device file, which JSON is not).
    pub fn check_path(flag: &str, path: &Path) -> Result<(), String> {
        if path.extension().and_then(|e| e.to_str()) == Some("json") {
            Ok(())
        } else {
            Err(format!(
                "{flag} {}: parameters are saved as JSON and read back by the file's extension; name the file \
                 *.json (nothing was run)",
                path.display()
            ))
        }
    }

    /// Write as pretty JSON with a final newline (what `fit --save` and `mts --save-device` write).
    pub fn write(&self, path: &Path) -> std::io::Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(std::io::Error::other)?;
        std::fs::write(path, text + "\n")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A parameter file saved before `hysteresis` had its shape parameters (`fit --save` until session 8)
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
