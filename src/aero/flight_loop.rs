//! Pilot-in-the-loop flights on the stick rig. A self-contained loop on [`crate::rig::Rig`] (written
//! before the loop engineer's `sim` landed): the hand is `crate::pilot::Hand` (position task), the
//! pilot's outer loop `crate::pilot::attitude`; the force controller here is a stand-in (feedforward
//! through the yield law + PI, the same semi-active logic as `crate::control::controller`) and the
//! load cell is read without the DAQ model of `crate::sensors`.
//!
//! Per physics step (the rig's rate, 1 kHz):
//! 1. read the rig's true state;
//! 2. when an aircraft frame is due (its rate, 120 Hz — JSBSim's frame): elevator from the stick
//!    (the rig's neutral is the trimmed stick), step the aircraft backend (embedded or live JSBSim),
//!    the pilot's outer loop compares attitude (or load factor) with its command and updates the
//!    stick command; the aircraft's hinge moment gives the **desired feel force** (stick force);
//! 3. the feel controller turns the desired force into a coil current (semi-active: the MR damper can
//!    only resist motion, so it renders the force when the stick moves, or is pushed, the way the force
//!    opposes; otherwise it releases to the minimum current);
//! 4. the hand pushes the grip towards the pilot's stick command; the rig steps.
//!
//! Scenario files (`scenarios/c172p-pitch-tracking.toml`, …) are read by [`FlightScenario::load`].

use std::collections::VecDeque;
use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::backend::{self, AircraftBackend};
use super::{AeroError, AircraftState};
use crate::device::{DeviceConfig, Registry};
use crate::pilot::attitude::{CrossoverPilot, CrossoverPilotConfig, PilotLoop, Schedule};
use crate::pilot::{Hand, HandConfig, Task};
use crate::rig::{BodyPose, LinkVisuals, Rig, RigConfig};

/// Errors of a flight scenario (file, line and field where they come from the file).
#[derive(Debug, thiserror::Error)]
pub enum FlightError {
    #[error("{}: {msg}", path.display())]
    Io { path: PathBuf, msg: String },
    #[error("{}:{line}: `{field}`: {msg}", path.display())]
    Field {
        path: PathBuf,
        line: usize,
        field: String,
        msg: String,
    },
    #[error(transparent)]
    Aero(#[from] AeroError),
    #[error("{0}")]
    Other(String),
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: String,
    #[serde(default)]
    description: String,
    duration_s: f64,
    rig: RigConfig,
    device: DeviceSection,
    aircraft: AircraftSection,
    feel: FeelSection,
    hand: HandSection,
    pilot: PilotSection,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct DeviceSection {
    file: PathBuf,
}

/// `[aircraft]`: which backend, where it is trimmed, its frame rate and the throttle schedule.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AircraftSection {
    /// `"c172p"`, `"737"` (embedded) or `"jsbsim:c172p"`, `"jsbsim:737"` (live JSBSim).
    pub model: String,
    pub airspeed_m_s: f64,
    pub altitude_m: f64,
    /// Aircraft frame rate, Hz (JSBSim's 120 Hz by default).
    #[serde(default = "default_rate")]
    pub rate_hz: f64,
    /// Throttle as a ratio of the trim throttle, `[[t_s, ratio], ...]` (default: trim throughout).
    #[serde(default)]
    pub throttle: Vec<[f64; 2]>,
}

fn default_rate() -> f64 {
    120.0
}

/// `[feel]`: the force controller (stand-in for the loop's PID + feedforward).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FeelSection {
    pub kp_a_per_n: f64,
    pub ki_a_per_n_s: f64,
    pub current_min_a: f64,
    pub current_max_a: f64,
    /// Piston speed below which the stick counts as at rest, m/s.
    pub rest_speed_m_s: f64,
}

/// `[hand]`: the pilot's arm model file (`models/pilot-hand.toml`, read by `crate::scenario::load_hand`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HandSection {
    pub file: PathBuf,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct PilotSection {
    #[serde(rename = "loop")]
    loop_: PilotLoop,
    gain: f64,
    #[serde(default)]
    lead_s: f64,
    #[serde(default)]
    lag_s: f64,
    delay_s: f64,
    #[serde(default)]
    integral_per_s: f64,
    /// `[[t_s, value], ...]`: pitch in degrees relative to trim, or load factor in g.
    command: Vec<[f64; 2]>,
}

/// A validated flight scenario.
#[derive(Debug, Clone)]
pub struct FlightScenario {
    pub path: PathBuf,
    pub name: String,
    pub description: String,
    pub duration_s: f64,
    pub rig: RigConfig,
    pub device_path: PathBuf,
    pub aircraft: AircraftSection,
    pub feel: FeelSection,
    pub hand: HandConfig,
    pub pilot_loop: PilotLoop,
    pub pilot: CrossoverPilotConfig,
    /// Command in the loop's unit: pitch in **rad** relative to trim (converted from the file's
    /// degrees), or load factor in g.
    pub command: Schedule,
    pub throttle: Schedule,
}

struct Ctx<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Ctx<'_> {
    /// Line of `key = ` in the file (first occurrence at the start of a line), 0 if not found.
    fn line(&self, key: &str) -> usize {
        let leaf = key.rsplit('.').next().unwrap_or(key);
        self.text
            .lines()
            .position(|l| {
                let l = l.trim_start();
                l.starts_with(leaf) && l[leaf.len()..].trim_start().starts_with('=')
            })
            .map_or(0, |i| i + 1)
    }

    fn err(&self, key: &str, msg: String) -> FlightError {
        FlightError::Field {
            path: self.path.to_path_buf(),
            line: self.line(key),
            field: key.to_string(),
            msg,
        }
    }

    fn range(&self, key: &str, v: f64, lo: f64, hi: f64, unit: &str) -> Result<f64, FlightError> {
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(v)
        } else {
            Err(self.err(
                key,
                format!("value {v} outside the allowed range [{lo}, {hi}] {unit}"),
            ))
        }
    }

    fn schedule(
        &self,
        key: &str,
        pts: &[[f64; 2]],
        lo: f64,
        hi: f64,
        unit: &str,
    ) -> Result<Schedule, FlightError> {
        if pts.is_empty() {
            return Err(self.err(key, "needs at least one [t_s, value] point".into()));
        }
        for (i, p) in pts.iter().enumerate() {
            self.range(key, p[1], lo, hi, unit)?;
            if !p[0].is_finite() || (i > 0 && p[0] <= pts[i - 1][0]) {
                return Err(self.err(key, format!("point {i}: times must be finite and increasing")));
            }
        }
        Ok(Schedule {
            points: pts.iter().map(|p| (p[0], p[1])).collect(),
        })
    }
}

impl FlightScenario {
    pub fn load(path: &Path) -> Result<Self, FlightError> {
        let text = std::fs::read_to_string(path).map_err(|e| FlightError::Io {
            path: path.to_path_buf(),
            msg: e.to_string(),
        })?;
        Self::parse(&text, path)
    }

    pub fn parse(text: &str, path: &Path) -> Result<Self, FlightError> {
        let f: File = toml::from_str(text).map_err(|e| {
            let line = e.span().map_or(0, |s| super::line_of(text, s.start));
            FlightError::Field {
                path: path.to_path_buf(),
                line,
                field: "(file)".into(),
                msg: e.message().to_string(),
            }
        })?;
        let c = Ctx { path, text };
        let dir = path.parent().unwrap_or(Path::new("."));
        let mut rig = f.rig.clone();
        rig.urdf = dir.join(&rig.urdf);
        c.range("rig.physics_hz", rig.physics_hz, 100.0, 100_000.0, "Hz")?;
        let duration_s = c.range("duration_s", f.duration_s, 0.01, 3600.0, "s")?;
        let a = &f.aircraft;
        c.range("aircraft.airspeed_m_s", a.airspeed_m_s, 10.0, 300.0, "m/s")?;
        c.range("aircraft.altitude_m", a.altitude_m, 0.0, 11_000.0, "m")?;
        c.range(
            "aircraft.rate_hz",
            a.rate_hz,
            10.0,
            rig.physics_hz,
            "Hz (at most rig.physics_hz)",
        )?;
        let throttle = if a.throttle.is_empty() {
            Schedule {
                points: vec![(0.0, 1.0)],
            }
        } else {
            c.schedule(
                "aircraft.throttle",
                &a.throttle,
                0.0,
                3.0,
                "(ratio of trim throttle)",
            )?
        };
        let k = f.feel;
        c.range("feel.kp_a_per_n", k.kp_a_per_n, 0.0, 10.0, "A/N")?;
        c.range("feel.ki_a_per_n_s", k.ki_a_per_n_s, 0.0, 1000.0, "A/(N·s)")?;
        c.range("feel.current_min_a", k.current_min_a, 0.0, 14.0, "A")?;
        c.range(
            "feel.current_max_a",
            k.current_max_a,
            k.current_min_a,
            14.0,
            "A (at least current_min_a)",
        )?;
        c.range("feel.rest_speed_m_s", k.rest_speed_m_s, 0.0, 1.0, "m/s")?;
        let hand = crate::scenario::load_hand(&dir.join(&f.hand.file))
            .map_err(|e| c.err("hand.file", e.to_string()))?;
        let p = &f.pilot;
        c.range("pilot.gain", p.gain, 0.0, 100.0, "stick rad per rad (or per g)")?;
        c.range("pilot.lead_s", p.lead_s, 0.0, 10.0, "s")?;
        c.range("pilot.lag_s", p.lag_s, 0.0, 100.0, "s")?;
        c.range("pilot.delay_s", p.delay_s, 0.0, 1.0, "s")?;
        c.range(
            "pilot.integral_per_s",
            p.integral_per_s,
            0.0,
            100.0,
            "stick rad per (unit·s)",
        )?;
        let command = match p.loop_ {
            PilotLoop::Pitch => {
                let s = c.schedule("pilot.command", &p.command, -30.0, 30.0, "deg")?;
                Schedule {
                    points: s.points.iter().map(|&(t, v)| (t, v.to_radians())).collect(),
                }
            }
            PilotLoop::LoadFactor => c.schedule("pilot.command", &p.command, -1.0, 4.0, "g")?,
        };
        Ok(Self {
            path: path.to_path_buf(),
            name: f.name.clone(),
            description: f.description.clone(),
            duration_s,
            rig,
            device_path: dir.join(&f.device.file),
            aircraft: a.clone(),
            feel: k,
            hand,
            pilot_loop: p.loop_,
            pilot: CrossoverPilotConfig {
                gain: p.gain,
                lead_s: p.lead_s,
                lag_s: p.lag_s,
                delay_s: p.delay_s,
                integral_per_s: p.integral_per_s,
                stick_min_rad: f64::NEG_INFINITY,
                stick_max_rad: f64::INFINITY,
            },
            command,
            throttle,
        })
    }

    /// The same scenario flown by another aircraft backend (`"jsbsim:c172p"`).
    pub fn with_aircraft_model(&self, model: &str) -> Self {
        let mut s = self.clone();
        s.aircraft.model = model.to_string();
        s
    }
}

/// One physics step of a flight (state at the start of the step, what was applied over it).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct FlightRow {
    pub t_s: f64,
    /// Rig stick angle, rad (+ aft), relative to the trimmed stick.
    pub stick_angle_rad: f64,
    pub stick_rate_rad_s: f64,
    pub piston_x_m: f64,
    pub piston_v_m_s: f64,
    /// True load-cell force on the piston, N (+x), and its equivalent at the grip (× gearing / lever).
    pub load_cell_n: f64,
    pub load_cell_grip_n: f64,
    /// Desired feel force at the grip (the aircraft's stick force, + pull), N, and on the piston.
    pub desired_force_n: f64,
    pub desired_load_cell_n: f64,
    /// Whether the damper can provide the desired force now (it resists the stick's motion or push).
    pub providable: bool,
    pub current_a: f64,
    pub hand_force_n: f64,
    /// The pilot's stick command, rad relative to trim.
    pub stick_cmd_rad: f64,
    pub qbar_pa: f64,
    pub elevator_rad: f64,
    pub hinge_moment_nm: f64,
    pub pitch_rad: f64,
    pub pitch_cmd_rad: f64,
    pub nz_g: f64,
    pub nz_cmd_g: f64,
    pub q_rad_s: f64,
    pub alpha_rad: f64,
    pub airspeed_m_s: f64,
    pub altitude_m: f64,
}

impl FlightRow {
    pub const COLUMNS: &'static str = "t_s,stick_angle_rad,stick_rate_rad_s,piston_x_m,piston_v_m_s,load_cell_n,load_cell_grip_n,desired_force_n,desired_load_cell_n,providable,current_a,hand_force_n,stick_cmd_rad,qbar_pa,elevator_rad,hinge_moment_nm,pitch_rad,pitch_cmd_rad,nz_g,nz_cmd_g,q_rad_s,alpha_rad,airspeed_m_s,altitude_m";

    fn csv(&self) -> String {
        let v = [
            self.t_s,
            self.stick_angle_rad,
            self.stick_rate_rad_s,
            self.piston_x_m,
            self.piston_v_m_s,
            self.load_cell_n,
            self.load_cell_grip_n,
            self.desired_force_n,
            self.desired_load_cell_n,
            f64::from(u8::from(self.providable)),
            self.current_a,
            self.hand_force_n,
            self.stick_cmd_rad,
            self.qbar_pa,
            self.elevator_rad,
            self.hinge_moment_nm,
            self.pitch_rad,
            self.pitch_cmd_rad,
            self.nz_g,
            self.nz_cmd_g,
            self.q_rad_s,
            self.alpha_rad,
            self.airspeed_m_s,
            self.altitude_m,
        ];
        v.iter().map(|x| format!("{x:.9e}")).collect::<Vec<_>>().join(",")
    }
}

/// A finished flight.
pub struct FlightResults {
    pub scenario: String,
    pub aircraft: String,
    pub trim: AircraftState,
    /// Stick angle of the trim (aircraft convention), rad: the rig's neutral.
    pub trim_stick_rad: f64,
    pub rows: Vec<FlightRow>,
    /// Rig poses at the aircraft rate, for drawing.
    pub frames: Vec<(f64, Vec<BodyPose>)>,
    pub visuals: Vec<LinkVisuals>,
    /// Live JSBSim: (requests, mean µs, max µs) of the step round trips; `None` for embedded.
    pub round_trip_us: Option<(u64, f64, f64)>,
    /// Largest yield force the device gives at full current, N on the piston (the feel's ceiling).
    pub max_yield_n: f64,
}

impl FlightResults {
    /// Write the rows as CSV (one `#` header line naming the scenario and the aircraft).
    pub fn write_csv(&self, path: &Path) -> Result<(), FlightError> {
        let io = |e: std::io::Error| FlightError::Io {
            path: path.to_path_buf(),
            msg: e.to_string(),
        };
        let mut w = std::io::BufWriter::new(std::fs::File::create(path).map_err(io)?);
        writeln!(
            w,
            "# mrfeel flight `{}`, aircraft `{}`, trim {:.3} m/s at {:.1} m, trim stick {:.6} rad",
            self.scenario, self.aircraft, self.trim.airspeed_m_s, self.trim.altitude_m, self.trim_stick_rad
        )
        .map_err(io)?;
        writeln!(w, "{}", FlightRow::COLUMNS).map_err(io)?;
        for r in &self.rows {
            writeln!(w, "{}", r.csv()).map_err(io)?;
        }
        w.flush().map_err(io)
    }
}

/// Fly a scenario on the rig; `progress` gets the fraction done.
pub fn fly(scn: &FlightScenario, mut progress: impl FnMut(f64)) -> Result<FlightResults, FlightError> {
    let device = DeviceConfig::load(&scn.device_path, &Registry::builtin())
        .map_err(|e| FlightError::Other(format!("{}: {e}", scn.device_path.display())))?;
    let mut rig = Rig::new(&scn.rig, device.damper()).map_err(|e| FlightError::Other(e.to_string()))?;
    let mut ac: Box<dyn AircraftBackend> = backend::open(&scn.aircraft.model)?;
    let dt = rig.dt_s();
    let ac_dt = 1.0 / scn.aircraft.rate_hz;
    let trim = ac.trim(scn.aircraft.airspeed_m_s, scn.aircraft.altitude_m, ac_dt)?;
    let hinge = ac.hinge().clone();
    let trim_stick = hinge.stick_from_elevator_rad(trim.elevator_rad);
    let (smin, smax) = rig.stick_limits_rad();
    let pilot_cfg = CrossoverPilotConfig {
        stick_min_rad: smin,
        stick_max_rad: smax,
        ..scn.pilot
    };
    let mut pilot = CrossoverPilot::new(pilot_cfg, ac_dt);
    let mut hand = Hand::new(scn.hand, Task::Position);
    let fc0 = device.param("fc0_n").unwrap_or(0.0);
    let fc_gain = device.param("fc_gain_n_per_a").unwrap_or(0.0);
    let c0 = device.param("c0_n_s_per_m").unwrap_or(0.0);
    if fc_gain <= 0.0 {
        return Err(FlightError::Other(format!(
            "{}: the feel controller needs a device with `fc_gain_n_per_a` > 0",
            scn.device_path.display()
        )));
    }
    let max_yield_n = fc0 + fc_gain * scn.feel.current_max_a;
    let lever = rig.grip_lever_m();
    let n = (scn.duration_s / dt).round() as usize;
    let mut rows = Vec::with_capacity(n);
    let mut frames = Vec::new();
    let frame_every = ((1.0 / (30.0 * dt)).round() as usize).max(1);
    let mut s_ac = trim;
    let mut next_ac_t = 0.0;
    let mut ac_ticks: u64 = 0;
    let mut stick_cmd = 0.0;
    let mut integral_a = 0.0;
    let report_every = (n / 200).max(1);
    // Recent load-cell readings for the direction of the hand's push at rest (a few ms).
    let mut lc_hist: VecDeque<f64> = VecDeque::new();
    for k in 0..n {
        let t = k as f64 * dt;
        let s = rig.state();
        let (pitch_cmd, nz_cmd) = match scn.pilot_loop {
            PilotLoop::Pitch => (trim.theta_rad + scn.command.value(t), f64::NAN),
            PilotLoop::LoadFactor => (f64::NAN, scn.command.value(t)),
        };
        if t + 1e-9 >= next_ac_t {
            let elevator = hinge.elevator_from_stick_rad(trim_stick + s.stick_angle_rad);
            s_ac = ac.step(elevator, scn.throttle.value(t))?;
            let err = match scn.pilot_loop {
                PilotLoop::Pitch => pitch_cmd - s_ac.theta_rad,
                PilotLoop::LoadFactor => nz_cmd - s_ac.nz_g,
            };
            stick_cmd = pilot.step(err);
            ac_ticks += 1;
            next_ac_t = ac_ticks as f64 * ac_dt;
        }
        // Desired force: grip → piston by virtual work at the present linkage angle.
        let gearing = rig
            .linkage()
            .gearing_m_per_rad(s.stick_angle_rad)
            .unwrap_or(rig.gearing_m_per_rad());
        let desired_grip = s_ac.stick_force_n;
        let desired_piston = desired_grip * lever / gearing;
        lc_hist.push_back(s.load_cell_n);
        if lc_hist.len() > 5 {
            lc_hist.pop_front();
        }
        let push = lc_hist.iter().sum::<f64>() / lc_hist.len() as f64;
        let moving = s.piston_v_m_s.abs() > scn.feel.rest_speed_m_s;
        // Semi-active: the fluid force opposes the piston's motion (or, at rest, the push on it).
        let resist_dir = if moving {
            s.piston_v_m_s.signum()
        } else {
            push.signum()
        };
        let providable = desired_piston * resist_dir > 0.0;
        // --- Force controller (stand-in for the loop's PID + feedforward) ---
        let current = if providable {
            let target_yield = (desired_piston.abs() - c0 * s.piston_v_m_s.abs()).max(0.0);
            let ff = (target_yield - fc0) / fc_gain;
            if moving {
                let e = desired_piston.abs() - s.load_cell_n.abs();
                integral_a = (integral_a + scn.feel.ki_a_per_n_s * e * dt)
                    .clamp(-scn.feel.current_max_a, scn.feel.current_max_a);
                ff + scn.feel.kp_a_per_n * e + integral_a
            } else {
                ff + integral_a
            }
        } else {
            integral_a = 0.0;
            scn.feel.current_min_a
        }
        .clamp(scn.feel.current_min_a, scn.feel.current_max_a);
        let grip_x = lever * s.stick_angle_rad;
        let grip_v = lever * s.stick_rate_rad_s;
        let f_hand = hand.step(lever * stick_cmd, grip_x, grip_v, dt);
        rows.push(FlightRow {
            t_s: t,
            stick_angle_rad: s.stick_angle_rad,
            stick_rate_rad_s: s.stick_rate_rad_s,
            piston_x_m: s.piston_x_m,
            piston_v_m_s: s.piston_v_m_s,
            load_cell_n: s.load_cell_n,
            load_cell_grip_n: s.load_cell_n * gearing / lever,
            desired_force_n: desired_grip,
            desired_load_cell_n: desired_piston,
            providable,
            current_a: current,
            hand_force_n: f_hand,
            stick_cmd_rad: stick_cmd,
            qbar_pa: s_ac.qbar_pa,
            elevator_rad: s_ac.elevator_rad,
            hinge_moment_nm: s_ac.hinge_moment_nm,
            pitch_rad: s_ac.theta_rad,
            pitch_cmd_rad: pitch_cmd,
            nz_g: s_ac.nz_g,
            nz_cmd_g: nz_cmd,
            q_rad_s: s_ac.q_rad_s,
            alpha_rad: s_ac.alpha_rad,
            airspeed_m_s: s_ac.airspeed_m_s,
            altitude_m: s_ac.altitude_m,
        });
        if k % frame_every == 0 {
            frames.push((t, rig.poses()));
        }
        rig.step(f_hand, current);
        if k % report_every == 0 {
            progress(k as f64 / n as f64);
        }
    }
    progress(1.0);
    let round_trip_us = ac.round_trip_us();
    Ok(FlightResults {
        scenario: scn.name.clone(),
        aircraft: ac.label().to_string(),
        trim,
        trim_stick_rad: trim_stick,
        rows,
        frames,
        visuals: rig.visuals().to_vec(),
        round_trip_us,
        max_yield_n,
    })
}

/// `mrfeel fly`: fly a flight scenario on the rig and write the rows.
#[derive(clap::Args, Debug, Clone)]
pub struct FlyArgs {
    /// Flight scenario (`scenarios/c172p-pitch-tracking.toml`, ...).
    pub scenario: PathBuf,
    /// Override the scenario's aircraft backend (`c172p`, `jsbsim:c172p`, ...).
    #[arg(long)]
    pub aircraft: Option<String>,
    /// Output CSV (columns in `FlightRow::COLUMNS`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Rerun recording (.rrd): the rig's links and the aircraft's attitude beside them.
    #[arg(long)]
    pub rerun: Option<PathBuf>,
}

pub fn run_cli(a: FlyArgs) -> anyhow::Result<()> {
    let mut scn = FlightScenario::load(&a.scenario)?;
    if let Some(m) = &a.aircraft {
        scn = scn.with_aircraft_model(m);
    }
    let bar = indicatif::ProgressBar::new(1000);
    if !std::io::IsTerminal::is_terminal(&std::io::stderr()) {
        bar.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let res = fly(&scn, |f| bar.set_position((f * 1000.0) as u64))?;
    bar.finish_and_clear();
    let m = FlightMetrics::of(&res, &scn);
    println!("{}", m.summary());
    if let Some(out) = &a.out {
        res.write_csv(out)?;
        println!("wrote {}", out.display());
    }
    if let Some(rrd) = &a.rerun {
        super::flight_rerun::write(&res, rrd)?;
        println!("wrote {}", rrd.display());
    }
    Ok(())
}

/// Figures of merit of a flight (what the tests assert and `mrfeel fly` prints).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FlightMetrics {
    /// RMS of (command − response) from the first command to the end: rad (pitch) or g (load factor).
    pub tracking_rms: f64,
    /// Largest |command change| in the schedule, same unit (scale of the task).
    pub command_span: f64,
    /// Correlation of the desired force with the hinge moment (1: the feel follows the air load).
    pub desired_vs_hinge_corr: f64,
    /// Where the damper can provide the desired force and is not saturated (moving): RMS of
    /// (load cell − desired) at the grip, N, RMS of the desired force there, N, and the fraction of
    /// the flight in that condition.
    pub follow_rms_n: f64,
    pub follow_desired_rms_n: f64,
    pub follow_fraction: f64,
    /// Peak |desired force| at the grip, N, and the device's ceiling there, N.
    pub desired_peak_n: f64,
    pub round_trip_us: Option<(u64, f64, f64)>,
}

impl FlightMetrics {
    pub fn of(res: &FlightResults, scn: &FlightScenario) -> Self {
        let t0 = scn.command.first_change_s();
        let tracked: Vec<f64> = res
            .rows
            .iter()
            .filter(|r| r.t_s >= t0)
            .map(|r| match scn.pilot_loop {
                PilotLoop::Pitch => r.pitch_cmd_rad - r.pitch_rad,
                PilotLoop::LoadFactor => r.nz_cmd_g - r.nz_g,
            })
            .collect();
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len().max(1) as f64).sqrt();
        let vals: Vec<f64> = scn.command.points.iter().map(|p| p.1).collect();
        let span = vals.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
            - vals.iter().cloned().fold(f64::INFINITY, f64::min);
        let d: Vec<f64> = res.rows.iter().map(|r| r.desired_force_n).collect();
        let h: Vec<f64> = res.rows.iter().map(|r| r.hinge_moment_nm).collect();
        let rest = scn.feel.rest_speed_m_s;
        let ceiling = res.max_yield_n;
        let follow: Vec<(f64, f64)> = res
            .rows
            .iter()
            .filter(|r| {
                r.providable
                    && r.piston_v_m_s.abs() > 2.0 * rest
                    && r.desired_load_cell_n.abs() < 0.9 * ceiling
            })
            .map(|r| (r.load_cell_grip_n - r.desired_force_n, r.desired_force_n))
            .collect();
        let e: Vec<f64> = follow.iter().map(|p| p.0).collect();
        let dd: Vec<f64> = follow.iter().map(|p| p.1).collect();
        Self {
            tracking_rms: rms(&tracked),
            command_span: span,
            desired_vs_hinge_corr: correlation(&d, &h),
            follow_rms_n: rms(&e),
            follow_desired_rms_n: rms(&dd),
            follow_fraction: follow.len() as f64 / res.rows.len().max(1) as f64,
            desired_peak_n: d.iter().fold(0.0, |m: f64, x| m.max(x.abs())),
            round_trip_us: res.round_trip_us,
        }
    }

    pub fn summary(&self) -> String {
        let mut s = format!(
            "tracking RMS {:.4} (command span {:.4}); desired-force/hinge correlation {:.5}; load cell vs desired where providable: RMS {:.2} N of {:.2} N over {:.1} % of the flight; peak desired {:.1} N",
            self.tracking_rms,
            self.command_span,
            self.desired_vs_hinge_corr,
            self.follow_rms_n,
            self.follow_desired_rms_n,
            100.0 * self.follow_fraction,
            self.desired_peak_n
        );
        if let Some((n, mean, max)) = self.round_trip_us {
            s += &format!("; JSBSim round trip: {n} steps, mean {mean:.1} µs, max {max:.1} µs");
        }
        s
    }
}

/// Pearson correlation coefficient.
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len().min(b.len()) as f64;
    let ma = a.iter().sum::<f64>() / n;
    let mb = b.iter().sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}
