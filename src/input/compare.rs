//! The comparison scenario file (`scenarios/compare-*.toml`): its schema, read into a
//! [`CompareScenario`] with the files it names loaded.

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use super::{InputError, Source};
use crate::compare::{
    feel_kinds, main_task, ActiveSection, CompareError, CompareScenario, FaultTest, FeelKind, Limits,
    TargetLaw, TaskSection,
};
use crate::control::feel::{CentringSpring, FeelSprings};
use crate::scenario::Scenario;

type S<T> = Spanned<T>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    #[serde(default, rename = "description")]
    _description: String,
    seed: u64,
    systems: S<Vec<String>>,
    base: S<PathBuf>,
    device: DeviceFile,
    springs: SpringsFile,
    target: TargetFile,
    task: TaskFile,
    limits: LimitsFile,
    fault_test: FaultTestFile,
    active: Option<ActiveFile>,
    #[serde(default)]
    fault: Vec<super::faults::FaultTable>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceFile {
    coil_resistance_ohm: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SpringsFile {
    file: S<PathBuf>,
    damping_n_s_per_m: S<f64>,
    qbar_pa: S<f64>,
    hybrid_k_n_per_m: S<f64>,
    hybrid_return_damping_n_s_per_m: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TargetFile {
    breakout_n: S<f64>,
    gradient_n_per_m: S<f64>,
    max_force_n: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TaskFile {
    sweep_amplitude_rad: S<f64>,
    sweep_frequency_hz: S<f64>,
    sweep_cycles: S<i64>,
    release_angle_rad: S<f64>,
    release_ramp_s: S<f64>,
    release_hold_s: S<f64>,
    release_observe_s: S<f64>,
    recentre_band_rad: S<f64>,
    breakout_ramp_n_per_s: S<f64>,
    breakout_duration_s: S<f64>,
    breakout_threshold_rad: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LimitsFile {
    part23_stick_pitch_temporary_lbf: S<f64>,
    pitch_prolonged_lbf: S<f64>,
    part25_pitch_one_hand_lbf: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FaultTestFile {
    start_s: S<f64>,
    end_s: S<f64>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ActiveFile {
    /// An active-stick file (`models/active-stick.toml`): the modelled stick.
    model: Option<S<PathBuf>>,
    /// The ideal force source's limit and friction (without `model`).
    max_force_n: Option<S<f64>>,
    damping_n_s_per_m: Option<S<f64>>,
    /// The rig's physics rate for the active stick's runs, Hz (default: the base scenario's).
    physics_hz: Option<S<f64>>,
}

impl CompareScenario {
    /// Read and check a comparison scenario and the files it names.
    pub fn load(path: &Path) -> Result<Self, CompareError> {
        Self::parse(&Source::read(path)?.text, path)
    }

    /// Check a comparison scenario's text; `path` places its errors and its relative paths.
    pub fn parse(text: &str, path: &Path) -> Result<Self, CompareError> {
        let src = Source::new(path, text);
        let f: File = src.toml()?;
        let dir = path.parent().unwrap_or(Path::new("."));
        let no_active = "`active` needs an `[active]` section (model, or max_force_n and damping_n_s_per_m)";
        let systems = if f.systems.get_ref().is_empty() {
            Err(format!(
                "no feel system listed; name at least one of: {}",
                FeelKind::names()
            ))
        } else {
            let names: Vec<&str> = f.systems.get_ref().iter().map(String::as_str).collect();
            feel_kinds(&names).and_then(|k| match f.active {
                None if k.contains(&FeelKind::Active) => Err(no_active.to_string()),
                _ => Ok(k),
            })
        }
        .map_err(|msg| src.err(&f.systems, "systems", msg))?;
        let named = |at: &S<PathBuf>, field: &str, e: &dyn std::fmt::Display| {
            let p = crate::builtin::resolve(dir, at.get_ref());
            src.err(at, field, crate::builtin::hint_if_missing(&p, e.to_string()))
        };
        let base_path = crate::builtin::resolve(dir, f.base.get_ref());
        let base = Scenario::load(&base_path).map_err(|e| named(&f.base, "base", &e))?;
        let devices = crate::sim::Devices::load(&base)?;
        let coil_resistance_ohm = within!(src, f.device.coil_resistance_ohm, 0.0..=1000.0, "Ω")?;
        let springs_path = crate::builtin::resolve(dir, f.springs.file.get_ref());
        let springs =
            FeelSprings::load(&springs_path).map_err(|e| named(&f.springs.file, "springs.file", &e))?;
        let spring_damping_n_s_per_m = within!(src, f.springs.damping_n_s_per_m, 0.0..=1e5, "N·s/m")?;
        let qbar_pa = within!(src, f.springs.qbar_pa, 0.0..=1e6, "Pa")?;
        let hybrid_k_n_per_m = within!(src, f.springs.hybrid_k_n_per_m, 0.0..=1e6, "N/m")?;
        let hybrid_return_damping_n_s_per_m =
            within!(src, f.springs.hybrid_return_damping_n_s_per_m, 0.0..=1e5, "N·s/m")?;
        let target = TargetLaw {
            breakout_n: within!(src, f.target.breakout_n, 0.0..=250.0, "N")?,
            gradient_n_per_m: within!(src, f.target.gradient_n_per_m, 0.0..=1e6, "N/m")?,
            max_force_n: within!(src, f.target.max_force_n, 0.0..=250.0, "N")?,
        };
        let task = TaskSection {
            sweep_amplitude_rad: within!(src, f.task.sweep_amplitude_rad, 0.0..=1.0, "rad")?,
            sweep_frequency_hz: within!(src, f.task.sweep_frequency_hz, 0.01..=20.0, "Hz")?,
            sweep_cycles: src
                .within_int(&f.task.sweep_cycles, "task.sweep_cycles", 2..=100)
                .map_err(|e| InputError {
                    msg: format!("{} (the first cycle is a run-in)", e.msg),
                    ..e
                })? as usize,
            release_angle_rad: within!(src, f.task.release_angle_rad, -1.0..=1.0, "rad")?,
            release_ramp_s: within!(src, f.task.release_ramp_s, 0.01..=60.0, "s")?,
            release_hold_s: within!(src, f.task.release_hold_s, 0.0..=60.0, "s")?,
            release_observe_s: within!(src, f.task.release_observe_s, 0.1..=60.0, "s")?,
            recentre_band_rad: within!(src, f.task.recentre_band_rad, 1e-5..=0.5, "rad")?,
            breakout_ramp_n_per_s: within!(src, f.task.breakout_ramp_n_per_s, 0.1..=1000.0, "N/s")?,
            breakout_duration_s: within!(src, f.task.breakout_duration_s, 0.1..=60.0, "s")?,
            breakout_threshold_rad: within!(src, f.task.breakout_threshold_rad, 1e-5..=0.5, "rad")?,
        };
        let limits = Limits {
            part23_stick_pitch_temporary_lbf: within!(
                src,
                f.limits.part23_stick_pitch_temporary_lbf,
                0.0..=500.0,
                "lbf"
            )?,
            pitch_prolonged_lbf: within!(src, f.limits.pitch_prolonged_lbf, 0.0..=500.0, "lbf")?,
            part25_pitch_one_hand_lbf: within!(src, f.limits.part25_pitch_one_hand_lbf, 0.0..=500.0, "lbf")?,
        };
        let task_s = main_task(&task).duration_s();
        let (start, end) = (&f.fault_test.start_s, &f.fault_test.end_s);
        if let Some((key, msg)) =
            super::faults::window_error(*start.get_ref(), *end.get_ref(), task_s, "task")
        {
            let at = if key == "start_s" { start } else { end };
            return Err(src.err(at, &format!("fault_test.{key}"), msg).into());
        }
        let active = f
            .active
            .as_ref()
            .map(|a| active(&src, a, &f.systems))
            .transpose()?;
        let faults = super::faults::schedule(&src, &f.fault, task_s)?;
        Ok(Self {
            path: path.to_path_buf(),
            name: f.name,
            seed: f.seed,
            systems,
            rig: base.rig.clone(),
            devices,
            coil_resistance_ohm,
            springs,
            springs_path,
            spring_damping_n_s_per_m,
            qbar_pa,
            hybrid_spring: CentringSpring {
                k_n_per_m: hybrid_k_n_per_m,
            },
            hybrid_return_damping_n_s_per_m,
            target,
            base,
            task,
            limits,
            fault_test: FaultTest {
                start_s: *start.get_ref(),
                end_s: *end.get_ref(),
            },
            active,
            faults,
        })
    }
}

/// `[active]`: the modelled stick of an active-stick file (`model`), or an ideal force source with
/// `max_force_n` and `damping_n_s_per_m` (whose absence is named at `systems`).
fn active(src: &Source, a: &ActiveFile, systems: &S<Vec<String>>) -> Result<ActiveSection, InputError> {
    let physics_hz = a
        .physics_hz
        .as_ref()
        .map(|v| src.within(v, "active.physics_hz", 100.0..=100_000.0, "Hz"))
        .transpose()?;
    let Some(p) = &a.model else {
        let need = |v: &Option<S<f64>>, key: &str, hi: f64, unit: &str| {
            let field = format!("active.{key}");
            let v = v
                .as_ref()
                .ok_or_else(|| src.err(systems, &field, "required without `active.model`"))?;
            src.within(v, &field, 0.0..=hi, unit)
        };
        return Ok(ActiveSection {
            max_force_n: need(&a.max_force_n, "max_force_n", 1e4, "N")?,
            damping_n_s_per_m: need(&a.damping_n_s_per_m, "damping_n_s_per_m", 1e5, "N·s/m")?,
            model: None,
            physics_hz,
        });
    };
    let ideal = [
        ("max_force_n", &a.max_force_n),
        ("damping_n_s_per_m", &a.damping_n_s_per_m),
    ];
    if let Some((key, Some(v))) = ideal.into_iter().find(|(_, v)| v.is_some()) {
        let msg = "not used with `active.model` (the motor file gives the force limit and the friction)";
        return Err(src.err(v, &format!("active.{key}"), msg));
    }
    let (_, m) = src.load_named(p, "active.model", crate::control::active::ActiveStickConfig::load)?;
    Ok(ActiveSection {
        max_force_n: m.max_force_n(),
        damping_n_s_per_m: m.rod_damping_n_s_per_m(),
        model: Some(m),
        physics_hz,
    })
}
