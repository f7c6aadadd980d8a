//! The files mrfeel ships, built into the binary so that an installed or moved copy runs from any
//! directory: the rig's URDF, the device, pilot and spring models, the aircraft models, the example
//! scenarios and the JSBSim bridge scripts.
//!
//! A file a scenario names is looked for, in order: relative to the scenario's folder (an absolute path as
//! given); in the data directory (`--data-dir` or `MRFEEL_DATA`); then, for a relative path, among the
//! built-in files by its file name, whose paths (`<built-in>/models/…`) every reader of this crate reads.

use std::path::{Component, Path, PathBuf};
use std::sync::OnceLock;

/// The first component of a built-in file's path.
pub(crate) const ROOT: &str = "<built-in>";

/// The environment variable naming the data directory (the `--data-dir` flag sets the same).
pub(crate) const DATA_ENV: &str = "MRFEEL_DATA";

/// The paper's device (`models/paper-device.toml`).
pub const PAPER_DEVICE: &str = include_str!("../models/paper-device.toml");

/// The paper's Section 4 measurements of that device: (current A, steady force N).
pub const PAPER_POINTS: [(f64, f64); 3] = [(2.2, 10.0), (5.0, 25.0), (14.0, 70.0)];

/// Each built-in file: its path in the repository and its text.
macro_rules! files {
    ($($path:literal),* $(,)?) => { &[$(($path, include_str!(concat!("../", $path)))),*] };
}
const FILES: &[(&str, &str)] = files![
    "models/stick-rig.urdf",
    "models/paper-device.toml",
    "models/pilot-hand.toml",
    "models/pilot-bench-actuator.toml",
    "models/active-stick.toml",
    "models/feel-springs.toml",
    "models/aircraft/c172p.toml",
    "models/aircraft/737.toml",
    "models/aircraft/T37.toml",
    "models/aircraft/f16.toml",
    "models/sidestick.urdf",
    "scenarios/paper-feel-loop.toml",
    "scenarios/paper-fine-corrections.toml",
    "scenarios/response-time.toml",
    "scenarios/compare-feel.toml",
    "scenarios/c172p-pitch-tracking.toml",
    "scenarios/c172p-pullup.toml",
    "scenarios/737-approach.toml",
    "scenarios/T37-pullup.toml",
    "scenarios/f16-pullup.toml",
    "python/jsbsim_bridge.py",
    "python/jsbsim_reference.py",
];

/// Folder of the built-in aircraft models.
const AIRCRAFT_DIR: &str = "models/aircraft";

static DATA_DIR: OnceLock<Option<PathBuf>> = OnceLock::new();

/// Set the data directory (the `--data-dir` flag) for this process, before any file is resolved; without
/// it, `MRFEEL_DATA` is read at the first lookup.
pub fn set_data_dir(dir: Option<PathBuf>) {
    let _ = DATA_DIR.set(dir);
}

/// The data directory, if one is set (`--data-dir`, else `MRFEEL_DATA`; an empty value is none).
pub fn data_dir() -> Option<&'static Path> {
    DATA_DIR
        .get_or_init(|| {
            std::env::var_os(DATA_ENV)
                .filter(|v| !v.is_empty())
                .map(PathBuf::from)
        })
        .as_deref()
}

/// The path of the built-in file at `repo_path` (`models/stick-rig.urdf`).
fn path_of(repo_path: &str) -> PathBuf {
    Path::new(ROOT).join(repo_path)
}

/// The built-in file (repository path, text) whose path is `path` (`<built-in>/models/x`), if it is one.
fn entry(path: &Path) -> Option<&'static (&'static str, &'static str)> {
    let rest = path.strip_prefix(ROOT).ok()?.to_str()?;
    FILES.iter().find(|(p, _)| *p == rest)
}

/// Whether `path` is a built-in file's path.
pub(crate) fn is_builtin(path: &Path) -> bool {
    entry(path).is_some()
}

/// The text of a built-in file's path; `None` for any other path.
pub fn text(path: &Path) -> Option<&'static str> {
    entry(path).map(|(_, t)| *t)
}

/// The built-in file whose file name is `name` (`stick-rig.urdf`, `paper-device.toml`).
pub(crate) fn by_file_name(name: &str) -> Option<PathBuf> {
    FILES
        .iter()
        .find(|(p, _)| Path::new(p).file_name().and_then(|n| n.to_str()) == Some(name))
        .map(|(p, _)| path_of(p))
}

/// The file names of the built-in models, rig and scenarios, for messages that list them.
pub(crate) fn file_names() -> Vec<&'static str> {
    FILES
        .iter()
        .filter(|(p, _)| !p.starts_with("python/"))
        .filter_map(|(p, _)| Path::new(p).file_name().and_then(|n| n.to_str()))
        .collect()
}

/// `path` without its leading `..`, `.` and root components: where a file named relative to the
/// repository's layout (`../models/x.toml`) sits in a data directory laid out the same way.
fn within(path: &Path) -> PathBuf {
    path.components()
        .skip_while(|c| !matches!(c, Component::Normal(_)))
        .collect()
}

/// Where a file named `named` in a file in the folder `dir` is ([the module's order](self)). When it is
/// nowhere, the path relative to `dir`, so that the caller's error names the path as written; add
/// [`not_found_hint`] to it.
pub(crate) fn resolve(dir: &Path, named: &Path) -> PathBuf {
    let direct = dir.join(named);
    if direct.starts_with(ROOT) {
        // A built-in file naming another (a built-in scenario's `../models/…`).
        let mut parts: Vec<Component> = Vec::new();
        for c in direct.components() {
            match c {
                Component::ParentDir if parts.len() > 1 => {
                    parts.pop();
                }
                Component::CurDir => {}
                c => parts.push(c),
            }
        }
        let p: PathBuf = parts.into_iter().collect();
        if is_builtin(&p) {
            return p;
        }
    }
    if direct.exists() || is_builtin(&direct) {
        return direct;
    }
    if let Some(data) = data_dir() {
        let inside = within(named);
        let candidates = [
            Some(data.join(&inside)),
            named.file_name().map(|n| data.join("models").join(n)),
            named.file_name().map(|n| data.join(n)),
        ];
        if let Some(p) = candidates.into_iter().flatten().find(|p| p.is_file()) {
            return p;
        }
    }
    if named.is_relative() {
        if let Some(p) = named.file_name().and_then(|n| n.to_str()).and_then(by_file_name) {
            static TOLD: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
            let mut told = TOLD.lock().unwrap_or_else(|e| e.into_inner());
            if !direct.starts_with(ROOT) && !told.contains(&direct) {
                crate::noteln!(
                    "{} not found; using the built-in {}",
                    direct.display(),
                    p.display()
                );
                told.push(direct);
            }
            return p;
        }
    }
    direct
}

/// The scenario a command line names: `path` as given where it exists or has a folder; a bare file name
/// that is not in the working directory is looked for in the data directory, then among the built-in
/// scenarios, in the order a file named inside a scenario is found (the module's order), with a note of the
/// built-in file it uses. Anything else is returned as given, for the reader's error.
pub fn scenario_arg(path: &Path) -> PathBuf {
    let bare = path.parent().is_some_and(|p| p.as_os_str().is_empty());
    let built_in = path.to_str().is_some_and(|name| {
        FILES
            .iter()
            .any(|(p, _)| p.strip_prefix("scenarios/") == Some(name))
    });
    if path.exists() || !bare || !built_in {
        return path.to_path_buf();
    }
    resolve(Path::new(""), path)
}

/// `msg`, an error about the file `path` a scenario names, with [`not_found_hint`] when the file is not there.
pub(crate) fn hint_if_missing(path: &Path, msg: String) -> String {
    if is_builtin(path) || path.exists() {
        msg
    } else {
        format!("{msg}; {}", not_found_hint())
    }
}

/// What to do about a file a scenario names that is not found.
pub(crate) fn not_found_hint() -> String {
    format!(
        "a relative path is read beside the file that names it, then in the data directory (--data-dir or \
         {DATA_ENV}{}); give a path that exists, set the data directory to a folder that holds the file, or \
         name a built-in file ({})",
        match data_dir() {
            Some(d) => format!(", now {}", d.display()),
            None => ", not set".into(),
        },
        file_names().join(", ")
    )
}

/// Names of the built-in aircraft models (`737`, `c172p`), and of those in the data directory's
/// `models/aircraft/` or `aircraft/`, sorted.
pub(crate) fn aircraft_names() -> Vec<String> {
    let mut names: Vec<String> = FILES
        .iter()
        .filter_map(|(p, _)| {
            p.strip_prefix(AIRCRAFT_DIR)?
                .strip_prefix('/')?
                .strip_suffix(".toml")
        })
        .map(str::to_string)
        .collect();
    for dir in data_aircraft_dirs() {
        if let Ok(rd) = std::fs::read_dir(dir) {
            names.extend(
                rd.filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("toml"))
                    .filter_map(|p| p.file_stem().and_then(|s| s.to_str()).map(str::to_string)),
            );
        }
    }
    names.sort();
    names.dedup();
    names
}

fn data_aircraft_dirs() -> Vec<PathBuf> {
    data_dir()
        .map(|d| vec![d.join(AIRCRAFT_DIR), d.join("aircraft")])
        .unwrap_or_default()
}

/// The file of the aircraft model `name` (checked to be a plain name by the caller): the data directory's
/// `models/aircraft/<name>.toml` or `aircraft/<name>.toml`, else the built-in one; `None` if neither has it.
pub fn aircraft(name: &str) -> Option<PathBuf> {
    let file = format!("{name}.toml");
    data_aircraft_dirs()
        .into_iter()
        .map(|d| d.join(&file))
        .find(|p| p.is_file())
        .or_else(|| {
            let p = format!("{AIRCRAFT_DIR}/{file}");
            FILES.iter().any(|(q, _)| *q == p).then(|| path_of(&p))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one reader of input files reads a built-in file's path as that file (cargo runs unit tests in
    /// the package's folder), and refuses a path under the built-in root that names no built-in file.
    #[test]
    fn built_in_files_read_as_the_repository_files() {
        for (p, _) in FILES {
            let built_in = crate::input::text::read_text(&path_of(p)).unwrap();
            assert_eq!(built_in, std::fs::read_to_string(p).unwrap(), "{p}");
        }
        assert!(crate::input::text::read_text(Path::new("<built-in>/models/nothing.toml")).is_err());
    }

    /// A relative path that does not exist falls back to the built-in file of its name; one that exists is
    /// kept; a name no built-in file has stays as written (for the caller's error).
    #[test]
    fn missing_relative_paths_fall_back_by_file_name() {
        let nowhere = std::env::temp_dir().join(format!("mrfeel-builtin-{}", std::process::id()));
        let p = resolve(&nowhere, Path::new("../models/paper-device.toml"));
        assert_eq!(p, Path::new("<built-in>/models/paper-device.toml"));
        assert!(text(&p).unwrap().contains("[geometry]"));
        let p = resolve(&nowhere, Path::new("my-device.toml"));
        assert_eq!(p, nowhere.join("my-device.toml"));
        let here = Path::new("scenarios");
        let p = resolve(here, Path::new("../models/stick-rig.urdf"));
        assert_eq!(p, here.join("../models/stick-rig.urdf"));
        // An absolute path is never replaced.
        let abs = nowhere.join("paper-device.toml");
        assert_eq!(resolve(Path::new("."), &abs), abs);
    }

    #[test]
    fn aircraft_are_found_by_name() {
        assert_eq!(
            aircraft("c172p").unwrap(),
            Path::new("<built-in>/models/aircraft/c172p.toml")
        );
        assert!(aircraft("c17").is_none());
        let names = aircraft_names();
        assert!(names.contains(&"737".to_string()) && names.contains(&"c172p".to_string()));
    }
}
