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
use crate::input::params::{current_limit, CommandTiming, Param, ParamsJson};
use crate::input::text::short_number as num;
use crate::input::{InputError, Source};
use crate::units::IN_TO_M;

/// Table 1 geometry of the paper's device, in SI units (converted once from inches on load).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Geometry {
    /// Piston diameter, m.
    pub piston_diameter_m: f64,
    /// Piston rod length, m.
    pub piston_rod_length_m: f64,
    /// Cylinder inner diameter, m.
    pub cylinder_id_m: f64,
    /// Cylinder outer diameter, m.
    pub cylinder_od_m: f64,
    /// Cylinder length, m.
    pub cylinder_length_m: f64,
    /// Half stroke: the piston travels ±`stroke_half_m` from mid-stroke.
    pub stroke_half_m: f64,
}

/// A loaded device: model, parameter values, driver limits, geometry.
#[derive(Debug, Clone)]
pub struct DeviceConfig {
    /// The force model.
    pub model: Arc<Model>,
    /// Its parameter values, in the model's order.
    pub params: Vec<f64>,
    /// The supply's limit, A, above the driver's saturation (the paper's 17 A), where known.
    pub supply_limit_a: Option<f64>,
    /// The device's geometry, where the file gives it.
    pub geometry: Option<Geometry>,
    /// The load cell's range, N, where the file gives it.
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
    /// The file read (named in messages).
    pub path: PathBuf,
}

impl DeviceConfig {
    /// Load a `.toml` device file or a `.json` parameter file written by `mrfeel fit --save`, told apart
    /// by the extension in any case, or where there is none of the two (a pipe: `--params <(…)`) by the
    /// text: a JSON object opens with `{`, which no TOML document does.
    pub fn load(path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let text = crate::input::text::read_text(path).map_err(|msg| InputError::file(path, msg))?;
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
    pub(crate) fn from_model(model: Model, params: Vec<f64>, path: PathBuf) -> Self {
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
    pub(crate) fn viscous_damper(&self, c0_n_s_per_m: f64) -> Damper {
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

    /// Read a device file's text (`models/*.toml`).
    pub fn from_toml(text: &str, path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let src = Source::new(path, text);
        let file: TomlDevice = src.toml()?;
        let limit = match &file.driver.current_limit_a {
            Some(v) => current_limit(*v.get_ref()).map_err(|m| src.err(v, "driver.current_limit_a", m))?,
            None => PAPER_CURRENT_LIMIT_A,
        };
        let supply_limit_a = (file.driver.supply_limit_a.as_ref())
            .map(|v| {
                let field = "driver.supply_limit_a";
                let supply = positive(v, "A", &src, field)?;
                if supply < limit {
                    let msg = format!(
                        "value {} A is below the driver's saturation current_limit_a = {} A: the driver \
                         saturates at a current the supply can give (the paper's 14 A from a 17 A \
                         supply), so the supply's limit is at least the saturation",
                        num(supply),
                        num(limit)
                    );
                    return Err(src.err(v, field, msg));
                }
                Ok(supply)
            })
            .transpose()?;
        // Effect files the spec names (`bingham+drag.toml`) are read relative to this file.
        let mut registry = registry.clone();
        let model_err = |e: DeviceError| DeviceError::from(src.err(&file.model, "model", e.to_string()));
        let spec_text = super::formula::resolve_spec(file.model.get_ref(), &mut registry, path.parent())
            .map_err(model_err)?;
        let model = ModelSpec::parse(&spec_text)
            .and_then(|spec| Model::new(&spec, &registry, limit))
            .map_err(model_err)?;
        let params_line = src.line_of(file.params.span().start);
        let values: Vec<Param> = file
            .params
            .get_ref()
            .iter()
            .map(|(name, v)| Param {
                name: name.clone(),
                line: src.line_of(v.span().start),
                value: *v.get_ref(),
                std_err: None,
                unit: None,
            })
            .collect();
        let params = assign_params(&model, &values, path, params_line)?;
        let geometry = file.geometry.as_ref().map(|g| g.check(&src)).transpose()?;
        let load_cell_range_n = (file.load_cell.as_ref())
            .map(|l| positive(&l.range_n, "N", &src, "load_cell.range_n"))
            .transpose()?;
        Ok(Self {
            supply_limit_a,
            geometry,
            load_cell_range_n,
            ..Self::from_model(model, params, path.to_path_buf())
        })
    }

    /// Read a `PARAMS.json` (`ParamsJson`: the model, its parameters and what the fit recorded beside
    /// them), its parameters checked against the model: every error names its line and key.
    pub fn from_json(text: &str, path: &Path, registry: &Registry) -> Result<Self, DeviceError> {
        let file = ParamsJson::parse(&Source::new(path, text))?;
        let limit = file.current_limit_a.map_or(PAPER_CURRENT_LIMIT_A, |l| l.value);
        let model = Model::from_spec(&file.model.value, registry, limit)
            .map_err(|e| InputError::field(path, file.model.line, "model", e.to_string()))?;
        let params = assign_params(&model, &file.params.value, path, file.params.line)?;
        let std_errs = model
            .param_specs()
            .iter()
            .map(|spec| {
                file.params
                    .value
                    .iter()
                    .find(|p| p.name == spec.name)
                    .and_then(|p| p.std_err)
            })
            .collect();
        Ok(Self {
            std_errs,
            command_timing: file.command_timing,
            acquisition_window_periods: file.acquisition_window_periods,
            ..Self::from_model(model, params, path.to_path_buf())
        })
    }
}

/// A value that must be a positive, finite number of `unit`.
fn positive(v: &toml::Spanned<f64>, unit: &str, src: &Source, field: &str) -> Result<f64, InputError> {
    let x = *v.get_ref();
    if x.is_finite() && x > 0.0 {
        return Ok(x);
    }
    let msg = format!("value {} {unit}: must be a positive, finite number", num(x));
    Err(src.err(v, field, msg))
}

/// Match named values to the model's parameters: every parameter present (or one whose absence has a
/// meaning, [`ParamSpec::absent`](super::ParamSpec::absent)), no unknown name, in the parameter's unit
/// where a unit is given, inside bounds, and a usable force ([`check_force`]). A missing parameter is
/// reported at `section_line`, the line of the table or object that lacks it.
fn assign_params(
    model: &Model,
    values: &[Param],
    path: &Path,
    section_line: usize,
) -> Result<Vec<f64>, InputError> {
    let specs = model.param_specs();
    for p in values {
        let Some(k) = model.param_index(&p.name) else {
            let names: Vec<&str> = specs.iter().map(|p| p.name).collect();
            let msg = format!(
                "unknown parameter for model `{}`; its parameters are: {}",
                model.name(),
                names.join(", ")
            );
            return Err(InputError::field(path, p.line, &p.name, msg));
        };
        let spec = &specs[k];
        if let Some(unit) = p.unit.as_ref().filter(|u| u.value != spec.unit) {
            let msg = format!(
                "unit \"{}\" is not the parameter's: {} is in \"{}\" (values are read in that unit only; convert \
                 the value)",
                unit.value, p.name, spec.unit
            );
            return Err(InputError::field(
                path,
                unit.line,
                format!("{}.unit", p.name),
                msg,
            ));
        }
    }
    let mut out = Vec::with_capacity(model.n_params());
    for spec in specs {
        let (v, line) = match (values.iter().find(|p| p.name == spec.name), spec.absent) {
            (Some(p), _) => (p.value, p.line),
            (None, Some(v)) => (v, section_line),
            (None, None) => {
                let msg = format!("missing parameter ({}, {})", spec.unit, spec.doc);
                return Err(InputError::field(path, section_line, spec.name, msg));
            }
        };
        if !v.is_finite() || v < spec.lower || v > spec.upper {
            let (v, lo, hi, unit) = (num(v), spec.lower, spec.upper, spec.unit);
            let msg = format!("value {v} outside the allowed range [{lo}, {hi}] {unit}");
            return Err(InputError::field(path, line, spec.name, msg));
        }
        out.push(v);
    }
    check_force(model, &out, values, path, section_line)?;
    Ok(out)
}

/// Refuse parameters with which the model's force is not a usable number anywhere a damper works
/// ([`Model::unusable_force`]): name the parameter that makes it so (the one whose return to zero, or its
/// nearest bound, gives a usable force), or every parameter when no single one does.
fn check_force(
    model: &Model,
    params: &[f64],
    values: &[Param],
    path: &Path,
    section_line: usize,
) -> Result<(), InputError> {
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
            let line = values
                .iter()
                .find(|p| p.name == spec.name)
                .map_or(section_line, |p| p.line);
            let (v, unit) = (num(params[k]), spec.unit);
            let msg = format!("value {v} {unit} gives {at}; correct the value or refit");
            return Err(InputError::field(path, line, spec.name, msg));
        }
    }
    let all: Vec<String> = specs
        .iter()
        .zip(params)
        .map(|(s, v)| format!("{} = {}", s.name, num(*v)))
        .collect();
    let msg = format!(
        "these parameters ({}) give {at}; correct them or refit",
        all.join(", ")
    );
    Err(InputError::field(path, section_line, "params", msg))
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
    fn check(&self, src: &Source) -> Result<Geometry, InputError> {
        let len = |v: &toml::Spanned<f64>, name: &str| positive(v, "in", src, &format!("geometry.{name}"));
        let piston = len(&self.piston_diameter_in, "piston_diameter_in")?;
        let rod = len(&self.piston_rod_length_in, "piston_rod_length_in")?;
        let id = len(&self.cylinder_id_in, "cylinder_id_in")?;
        let od = len(&self.cylinder_od_in, "cylinder_od_in")?;
        let cyl_len = len(&self.cylinder_length_in, "cylinder_length_in")?;
        let stroke = len(&self.stroke_half_in, "stroke_half_in")?;
        for (clash, v, name, why) in [
            (
                piston > id,
                &self.piston_diameter_in,
                "piston_diameter_in",
                format!("value {piston} in is larger than the cylinder's bore, cylinder_id_in = {id} in"),
            ),
            (
                id >= od,
                &self.cylinder_id_in,
                "cylinder_id_in",
                format!("value {id} in is not smaller than the cylinder's outside diameter, cylinder_od_in = {od} in"),
            ),
            (
                2.0 * stroke > cyl_len,
                &self.stroke_half_in,
                "stroke_half_in",
                format!(
                    "value {stroke} in: the full stroke, 2 × {stroke} in, is longer than the cylinder, \
                     cylinder_length_in = {cyl_len} in"
                ),
            ),
        ] {
            if clash {
                return Err(src.err(v, &format!("geometry.{name}"), why));
            }
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
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct ParamsFile {
    /// The model's spec (`bingham+hysteresis`).
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
    /// Each parameter's value (and standard error), by name.
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
            params,
            ..Self::default()
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

    /// A saved parameter file reads back as the numbers written, to the bit (serde_json's
    /// `float_roundtrip`: its fast parser reads 3991.6813567412532 as 3991.681356741253).
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

    /// A negative standard error is refused at its line.
    #[test]
    fn a_negative_standard_error_is_refused_at_its_line() {
        let registry = Registry::builtin();
        let text = "{\"model\": \"bingham\",\n \"params\": {\n  \"fc0_n\": {\"value\": 1.0,\n   \"std_err\": -0.5}\n}}";
        match DeviceConfig::from_json(text, Path::new("p.json"), &registry) {
            Err(DeviceError::Input(e)) => {
                assert_eq!((e.line, e.field.as_deref()), (Some(4), Some("fc0_n.std_err")));
                assert!(e.msg.contains("negative"), "{e}");
            }
            other => panic!("{other:?}"),
        }
    }

    /// Text after the JSON object is the file's fault at its line, not the last key's before it.
    #[test]
    fn text_after_the_object_names_no_key() {
        let registry = Registry::builtin();
        let text =
            "{\"model\": \"bingham\",\n \"params\": {\"te_s\": {\"value\": 0.01, \"unit\": \"s\"}}}\nx\n";
        match DeviceConfig::from_json(text, Path::new("p.json"), &registry) {
            Err(DeviceError::Input(e)) => {
                assert_eq!((e.line, e.field.as_deref()), (Some(3), None));
                assert!(e.msg.contains("trailing characters"), "{e}");
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
            DeviceError::Input(e) => e.line.expect("a line"),
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
            DeviceError::Input(e) => assert_eq!((e.line, e.field.as_deref()), (Some(2), Some("fc0_n"))),
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
            Err(DeviceError::Input(e)) => {
                assert_eq!(e.field.as_deref(), Some("hyst_x_yield_m"));
                assert!(e.msg.contains("missing"), "{e}");
            }
            other => panic!("a file without the yield displacement: {other:?}"),
        }
    }
}
