//! Scenario values replaced by dotted key (`feel.gradient_n_per_m = 900`): the axes of a sweep, `mrfeel run
//! --set`, the overrides of the Python bindings.
//!
//! The scenario's TOML document is edited (`toml_edit`) and read by [`Scenario::parse`], so the scenario's
//! schema checks its overrides: an error is placed where the override was written (a plan's line, a
//! `--set` argument), or, caused elsewhere, at the scenario's own line with the overrides named.

use std::fmt;
use std::path::{Path, PathBuf};

use toml_edit::{DocumentMut, ImDocument, Item, TableLike};

use super::Scenario;
use crate::input::text::line_of;
use crate::input::{InputError, Source};

/// Where an override was written, for its errors.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Origin {
    /// A line of a file (a sweep plan). Relative paths given as values are relative to its directory.
    File {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
    },
    /// A command-line argument or a call (`--set feel.x=1`); relative paths given as values are relative to
    /// the working directory.
    Argument(String),
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Origin::File { path, line } => write!(f, "{}:{line}", path.display()),
            Origin::Argument(a) => f.write_str(a),
        }
    }
}

/// One scenario value replaced (or, with `value: None`, removed) by its dotted key.
#[derive(Debug, Clone, PartialEq)]
pub struct Override {
    /// Dotted key: `feel.gradient_n_per_m`; `fault` (the whole `[[fault]]` list, as an array of tables);
    /// `fault.1.start_s` (a key of the first `[[fault]]`).
    pub key: String,
    /// `None` removes the key (a pilot with given gains made adaptive drops `outer_loop.gain`).
    pub value: Option<toml::Value>,
    /// Where it was written, for its errors.
    pub origin: Origin,
}

impl Override {
    /// `key` set to `value`, written at `origin`.
    pub fn set(key: &str, value: toml::Value, origin: Origin) -> Self {
        Self {
            key: key.to_string(),
            value: Some(value),
            origin,
        }
    }

    /// `KEY=VALUE` from the command line: VALUE is read as a TOML value (`900`, `true`, `"mr"`, `[1, 2]`),
    /// and as a string where it is not one (`device.file=models/x.toml`).
    pub fn parse_argument(arg: &str) -> Result<Self, String> {
        let (key, value) = arg
            .split_once('=')
            .ok_or_else(|| format!("--set {arg}: expected KEY=VALUE, e.g. feel.gradient_n_per_m=900"))?;
        let (key, value) = (key.trim(), value.trim());
        let parsed: Option<toml::Value> = toml::from_str::<toml::Table>(&format!("v = {value}"))
            .ok()
            .and_then(|mut t| t.remove("v"));
        let value = parsed.unwrap_or_else(|| toml::Value::String(value.to_string()));
        Ok(Self::set(key, value, Origin::Argument(format!("--set {arg}"))))
    }
}

/// Keys whose values are paths, read relative to where the override was written (not to the scenario).
const PATH_KEYS: [&str; 5] = [
    "device.file",
    "controller.model",
    "rig.urdf",
    "pilot.model",
    "feel_system.springs",
];

impl Scenario {
    /// The scenario at `path` with `overrides` applied in order, checked as a whole: the one public entry
    /// for a scenario changed by key (sweeps, `--set`, the Python bindings).
    pub fn load_with(path: &Path, overrides: &[Override]) -> Result<Self, InputError> {
        let src = Source::read(path)?;
        Self::parse_with(&src.text, path, overrides)
    }

    /// [`Scenario::load_with`] of a scenario text already read from `path`.
    pub(crate) fn parse_with(text: &str, path: &Path, overrides: &[Override]) -> Result<Self, InputError> {
        if overrides.is_empty() {
            return Self::parse(text, path);
        }
        let edited = edit(text, path, overrides)?;
        Self::parse(&edited.text, path).map_err(|e| edited.place(e, overrides))
    }
}

/// The scenario's text with the overrides written in, and where they are in it.
struct Edited {
    text: String,
    /// Per override, the lines of its value in `text` (empty for a removed key).
    lines: Vec<std::ops::RangeInclusive<usize>>,
    /// Lines of `text` that are not in the scenario file (keys the overrides added), sorted.
    inserted: Vec<usize>,
}

/// An error at the place the override was written, naming its key.
fn field_err(o: &Override, msg: impl Into<String>) -> InputError {
    match &o.origin {
        Origin::File { path, line } => InputError::field(path, *line, &o.key, msg),
        Origin::Argument(arg) => InputError {
            field: Some(o.key.clone()),
            ..InputError::file(arg, msg)
        },
    }
}

fn edit(text: &str, path: &Path, overrides: &[Override]) -> Result<Edited, InputError> {
    let mut doc: DocumentMut = text.parse().map_err(|e: toml_edit::TomlError| {
        let line = e.span().map_or(1, |s| line_of(text, s.start));
        InputError::line(path, line, e.message().trim())
    })?;
    let mut added = Vec::new();
    for o in overrides {
        let value = o.value.as_ref().map(|v| resolve_path(o, v)).transpose()?;
        let was_there = apply(&mut doc, o, value.as_ref())?;
        added.push(!was_there && o.value.is_some());
    }
    let text = doc.to_string();
    let spans = ImDocument::parse(text.as_str()).map_err(|e| {
        let msg = format!(
            "the scenario with its overrides is not TOML: {}",
            e.message().trim()
        );
        InputError::line(path, 1, msg)
    })?;
    let mut lines = Vec::new();
    let mut inserted = Vec::new();
    for (o, &new) in overrides.iter().zip(&added) {
        let span = find(spans.as_item(), &o.key).and_then(Item::span);
        let range = match span {
            Some(s) => line_of(&text, s.start)..=line_of(&text, s.end.saturating_sub(1).max(s.start)),
            #[allow(clippy::reversed_empty_ranges)]
            None => 1..=0,
        };
        if new {
            inserted.extend(range.clone());
        }
        lines.push(range);
    }
    inserted.sort_unstable();
    Ok(Edited {
        text,
        lines,
        inserted,
    })
}

impl Edited {
    /// An error of the edited scenario, placed: at the override whose line or key it names, else at the
    /// scenario file's own line (lines the overrides added taken out) with the overrides named.
    fn place(&self, mut e: InputError, overrides: &[Override]) -> InputError {
        let Some(line) = e.line else { return e };
        // The last override that wrote the line or the key: it is the value the scenario was given.
        let by_line = overrides
            .iter()
            .zip(&self.lines)
            .rev()
            .find(|(_, r)| r.contains(&line));
        let by_key = || {
            let field = e.field.as_deref()?;
            let within = |o: &&Override| field == o.key || field.starts_with(&format!("{}.", o.key));
            overrides.iter().rev().find(within)
        };
        if let Some(o) = by_line.map(|(o, _)| o).or_else(by_key) {
            return field_err(o, e.msg);
        }
        e.line = Some(line - self.inserted.iter().filter(|&&l| l < line).count());
        let named: Vec<String> = overrides
            .iter()
            .map(|o| match &o.value {
                Some(v) => format!("{} `{}` = {v}", o.origin, o.key),
                None => format!("{} `{}` removed", o.origin, o.key),
            })
            .collect();
        e.msg = format!("{} (with the overrides {})", e.msg, named.join("; "));
        e
    }
}

/// A path value made absolute against the directory of the file it was written in (or the working
/// directory), so that the scenario, which reads paths relative to itself, reads the one meant. A path
/// with no file there is left as written, for the scenario's own search (data directory, built-in files).
fn resolve_path(o: &Override, v: &toml::Value) -> Result<toml::Value, InputError> {
    if !PATH_KEYS.contains(&o.key.as_str()) {
        return Ok(v.clone());
    }
    let toml::Value::String(s) = v else {
        return Ok(v.clone());
    };
    let base = match &o.origin {
        Origin::File { path, .. } => path.parent().unwrap_or(Path::new("")).join(s),
        Origin::Argument(_) => PathBuf::from(s),
    };
    if !base.exists() {
        return Ok(v.clone());
    }
    let abs = std::path::absolute(&base).map_err(|e| field_err(o, format!("{}: {e}", base.display())))?;
    Ok(toml::Value::String(abs.to_string_lossy().into_owned()))
}

/// The item at a dotted key (`fault.1.start_s`: the first `[[fault]]`'s `start_s`).
fn find<'a>(root: &'a Item, key: &str) -> Option<&'a Item> {
    let mut cur = root;
    for part in key.split('.') {
        cur = match (cur, part.parse::<usize>()) {
            (Item::ArrayOfTables(_), Ok(k)) if k >= 1 => cur.get(k - 1)?,
            _ => cur.get(part)?,
        };
    }
    Some(cur)
}

/// Write one override into the document; `true` if the key was there before.
fn apply(doc: &mut DocumentMut, o: &Override, value: Option<&toml::Value>) -> Result<bool, InputError> {
    let parts: Vec<&str> = o.key.split('.').collect();
    if parts.iter().any(|p| p.is_empty()) {
        let msg = "not a dotted key (an empty part): write `table.key`, e.g. `feel.gradient_n_per_m`";
        return Err(field_err(o, msg));
    }
    let (last, path) = parts.split_last().expect("split gives at least one part");
    let mut table: &mut dyn TableLike = doc.as_table_mut();
    for (i, part) in path.iter().enumerate() {
        let here = parts[..=i].join(".");
        if !table.contains_key(part) {
            if value.is_none() {
                return Ok(false);
            }
            let mut t = toml_edit::Table::new();
            t.set_implicit(true);
            table.insert(part, Item::Table(t));
        }
        table = match table.get_mut(part).expect("inserted above") {
            Item::ArrayOfTables(aot) => {
                let n = aot.len();
                let k = parts[i + 1].parse::<usize>().ok().filter(|k| (1..=n).contains(k));
                let k = k.ok_or_else(|| {
                    let msg = format!(
                        "`{here}` is a list of {n} tables: name one by its number, `{here}.1` to `{here}.{n}`"
                    );
                    field_err(o, msg)
                })?;
                let t = aot.get_mut(k - 1).expect("index checked");
                return match &parts[i + 2..] {
                    [key] => set_in(t, o, key, value),
                    _ => Err(field_err(
                        o,
                        format!("write `{here}.{k}.key`: its keys are values"),
                    )),
                };
            }
            other => match other.as_table_like_mut() {
                Some(t) => t,
                None => return Err(field_err(o, format!("`{here}` is a value, not a table"))),
            },
        };
    }
    set_in(table, o, last, value)
}

fn set_in(
    table: &mut dyn TableLike,
    o: &Override,
    key: &str,
    value: Option<&toml::Value>,
) -> Result<bool, InputError> {
    let Some(value) = value else {
        return Ok(table.remove(key).is_some());
    };
    let new_item = match (key, value) {
        // The whole `[[fault]]` list: an array of tables, written as tables (`[]`: none).
        ("fault", toml::Value::Array(items)) if items.iter().all(toml::Value::is_table) => {
            let mut aot = toml_edit::ArrayOfTables::new();
            for t in items {
                if let toml_edit::Value::InlineTable(it) = to_edit(t) {
                    aot.push(it.into_table());
                }
            }
            if aot.is_empty() {
                return Ok(table.remove(key).is_some());
            }
            Item::ArrayOfTables(aot)
        }
        _ => Item::Value(to_edit(value)),
    };
    match table.get_mut(key) {
        Some(Item::Value(old)) if new_item.is_value() => {
            let decor = old.decor().clone();
            *old = new_item.into_value().expect("checked a value");
            *old.decor_mut() = decor;
            Ok(true)
        }
        Some(Item::Table(_)) | Some(Item::ArrayOfTables(_)) if key != "fault" => Err(field_err(
            o,
            format!("`{}` is a table: set one of its keys (`{}.key`)", o.key, o.key),
        )),
        Some(old) => {
            *old = new_item;
            Ok(true)
        }
        None => {
            table.insert(key, new_item);
            Ok(false)
        }
    }
}

/// A `toml` value as a `toml_edit` one.
fn to_edit(v: &toml::Value) -> toml_edit::Value {
    match v {
        toml::Value::String(s) => s.as_str().into(),
        toml::Value::Integer(i) => (*i).into(),
        toml::Value::Float(x) => (*x).into(),
        toml::Value::Boolean(b) => (*b).into(),
        toml::Value::Datetime(d) => d.to_string().parse().unwrap_or_else(|_| d.to_string().into()),
        toml::Value::Array(a) => toml_edit::Value::Array(a.iter().map(to_edit).collect()),
        toml::Value::Table(t) => {
            let mut it = toml_edit::InlineTable::new();
            for (k, v) in t {
                it.insert(k.as_str(), to_edit(v));
            }
            toml_edit::Value::InlineTable(it)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn base() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/c172p-pitch-tracking.toml")
    }

    fn at(line: usize) -> Origin {
        Origin::File {
            path: PathBuf::from("plan.toml"),
            line,
        }
    }

    #[test]
    fn overrides_change_only_their_keys() {
        let plain = Scenario::load(&base()).unwrap();
        let ov = [
            Override::set("aircraft.airspeed_m_s", toml::Value::Float(60.0), at(3)),
            Override::set("controller.kp_a_per_n", toml::Value::Float(0.25), at(4)),
            Override::set("daq.sample_rate_hz", toml::Value::Integer(500), at(5)),
        ];
        let s = Scenario::load_with(&base(), &ov).unwrap();
        assert_eq!(s.aircraft.as_ref().unwrap().airspeed_m_s, 60.0);
        assert_eq!(s.controller.gains.kp, 0.25);
        assert_eq!(s.sensors.daq.sample_rate_hz, 500.0);
        let mut back = s.clone();
        back.aircraft.as_mut().unwrap().airspeed_m_s = 50.0;
        back.controller.gains.kp = 0.1;
        back.sensors.daq.sample_rate_hz = 1000.0;
        assert_eq!(back, plain, "nothing else changed");
    }

    #[test]
    fn an_unknown_key_or_a_value_out_of_range_is_refused_at_the_plan_line() {
        for (key, value, line, want) in [
            ("feel.gradient_n_per_mm", 900.0.into(), 7, "unknown field"),
            (
                "aircraft.airspeed_m_s",
                5.0.into(),
                9,
                "value 5 outside the allowed range [10, 300]",
            ),
            ("controller.kp_a_per_n", "high".into(), 2, "invalid type"),
        ] {
            let e = Scenario::load_with(&base(), &[Override::set(key, value, at(line))]).unwrap_err();
            let want = format!("plan.toml:{line}: field `{key}`: {want}");
            assert!(e.to_string().starts_with(&want), "{e}");
        }
    }

    #[test]
    fn an_error_caused_elsewhere_names_the_scenario_line_and_the_override() {
        // A physics rate below the DAQ's: the error is at the scenario's own `daq.sample_rate_hz` line.
        let text = std::fs::read_to_string(base()).unwrap();
        let daq_line = text
            .lines()
            .position(|l| l.starts_with("sample_rate_hz"))
            .unwrap()
            + 1;
        // A key added before it (the aircraft's throttle, absent in the file) must not move that line.
        let ov = [
            Override::set(
                "aircraft.throttle",
                toml::Value::Array(vec![toml::Value::Array(vec![0.0.into(), 1.0.into()])]),
                at(3),
            ),
            Override::set("rig.physics_hz", 500.0.into(), at(4)),
        ];
        let e = Scenario::load_with(&base(), &ov).unwrap_err().to_string();
        let want = format!(
            "{}:{daq_line}: field `daq.sample_rate_hz`: value 1000 outside",
            base().display()
        );
        assert!(e.starts_with(&want), "{e}\nwanted {want}");
        assert!(e.contains("plan.toml:4 `rig.physics_hz` = 500"), "{e}");
    }

    #[test]
    fn removed_keys_and_set_arguments() {
        // The given-gain pilot made adaptive: its gains removed, the crossover model's keys set.
        let removed = ["gain", "lead_s", "lag_s", "integral_per_s"].map(|k| Override {
            key: format!("outer_loop.{k}"),
            value: None,
            origin: at(1),
        });
        let set = ["outer_loop.crossover_rad_s=1.5", "outer_loop.stick_lag_s = 1"];
        let ov: Vec<_> = removed
            .into_iter()
            .chain(set.map(|a| Override::parse_argument(a).unwrap()))
            .collect();
        let s = Scenario::load_with(&base(), &ov).unwrap();
        assert!(matches!(
            s.outer_loop.unwrap().pilot,
            super::super::PilotDesign::Adapted { crossover_rad_s, stick_lag_s, .. } if crossover_rad_s == 1.5 && stick_lag_s == 1.0
        ));
        // A bare word is a string; a path is relative to the working directory.
        let dev = Override::parse_argument("device.file=models/paper-device.toml").unwrap();
        assert_eq!(
            dev.value,
            Some(toml::Value::String("models/paper-device.toml".into()))
        );
        assert!(Override::parse_argument("no-equals").is_err());
        let e = Scenario::load_with(&base(), &[Override::parse_argument("feel.law=springy").unwrap()])
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--set feel.law=springy: field `feel.law`: `springy` is not one of"),
            "{e}"
        );
    }

    #[test]
    fn a_path_is_read_beside_the_override_or_else_as_the_scenario_reads_its_own() {
        let dev = |origin: Origin| {
            let o = Override::set("device.file", "paper-device.toml".into(), origin);
            Scenario::load_with(&base(), &[o]).map(|s| s.device_path)
        };
        // Beside the plan: that file, whatever the built-ins hold.
        let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("models");
        let beside = dev(Origin::File {
            path: models.join("plan.toml"),
            line: 3,
        })
        .unwrap();
        assert_eq!(
            beside,
            std::path::absolute(models.join("paper-device.toml")).unwrap()
        );
        // No such file beside the plan: the built-in of that name, as the scenario would find it.
        let elsewhere = dev(Origin::File {
            path: models.join("no-such-folder/plan.toml"),
            line: 3,
        })
        .unwrap();
        assert!(crate::builtin::is_builtin(&elsewhere), "{}", elsewhere.display());
    }

    #[test]
    fn a_fault_list_is_set_whole_or_by_number() {
        let fault = |start: f64| {
            let mut t = toml::Table::new();
            t.insert("kind".into(), "coil_open".into());
            t.insert("start_s".into(), start.into());
            t.insert("end_s".into(), 4.0.into());
            toml::Value::Table(t)
        };
        let one = Override::set("fault", toml::Value::Array(vec![fault(2.0)]), at(1));
        assert_eq!(
            Scenario::load_with(&base(), &[one]).unwrap().faults.faults.len(),
            1
        );
        let two = [
            Override::set("fault", toml::Value::Array(vec![fault(2.0), fault(3.0)]), at(1)),
            Override::set("fault.2.start_s", 3.5.into(), at(2)),
        ];
        let s = Scenario::load_with(&base(), &two).unwrap();
        assert_eq!(s.faults.faults[1].start_s, 3.5);
        let late = Override::set("fault", toml::Value::Array(vec![fault(5.0)]), at(6));
        let e = Scenario::load_with(&base(), &[late]).unwrap_err().to_string();
        assert!(e.starts_with("plan.toml:6: field `fault`"), "{e}");
    }
}
