//! The aircraft in the loop: the stick drives the elevator, the aircraft's stick force (from its
//! hinge moment, or its feel computer for powered controls) is the feel target, and the pilot's outer
//! loop on pitch attitude or load factor gives the hand its stick command. A fly-by-wire aircraft
//! ([`crate::aero::FlyByWire`]) has no hinge moment at the stick: the pilot's force on the grip commands
//! its flight control system and the feel target is its designed feel law at the stick's position.
//!
//! Per physics step, when an aircraft frame is due (its own rate, JSBSim's 120 Hz by default):
//! 1. elevator from the stick angle (the rig's neutral is the trimmed stick; the stick-to-elevator link is
//!    mechanical, so it reads the stick itself, not the feel loop's sensors), or for a fly-by-wire aircraft
//!    the FCS command from the stick's own force sensor, the hand's force on the grip (again not the feel
//!    loop's sensors);
//! 2. one aircraft step (embedded Rust model or live JSBSim) with the scheduled throttle;
//! 3. the pilot's outer loop compares attitude (or load factor) with its command and sets the stick
//!    command the hand follows.
//!
//! Between frames the aircraft state, and so the stick force, is held (zero-order hold).

use crate::aero::backend::{self, AircraftBackend};
use crate::aero::{AeroError, AircraftState, FlyByWire, HingeModel};
use crate::pilot::attitude::{CrossoverPilot, CrossoverPilotConfig, PilotLoop, Schedule};
use crate::scenario::{AircraftConfig, OuterLoopConfig, PilotDesign};

/// The aircraft's columns of a results row.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct AeroRow {
    /// Dynamic pressure, Pa.
    pub qbar_pa: f64,
    /// Elevator deflection, rad, positive trailing edge down.
    pub elevator_rad: f64,
    /// Elevator hinge moment, N·m, positive trailing edge down.
    pub hinge_moment_nm: f64,
    /// Pitch attitude, rad.
    pub pitch_rad: f64,
    /// The outer loop's command: pitch (rad, absolute) or load factor (g); NaN for the other loop or none.
    pub pitch_cmd_rad: f64,
    /// Normal load factor, g.
    pub nz_g: f64,
    /// The outer loop's load-factor command, g (NaN for the pitch loop or none).
    pub nz_cmd_g: f64,
    /// Pitch rate, rad/s.
    pub q_rad_s: f64,
    /// Angle of attack, rad.
    pub alpha_rad: f64,
    /// True airspeed, m/s.
    pub airspeed_m_s: f64,
    /// Altitude, m.
    pub altitude_m: f64,
    /// The aircraft's stick force at the grip (pull +), N: the feel target before the linkage.
    pub stick_force_n: f64,
    /// The pilot's stick command, rad relative to trim (NaN without an outer loop).
    pub stick_cmd_rad: f64,
}

/// The crossover pilot adapted to the aircraft at its trim (McRuer): designed on the embedded model of the
/// same aircraft (also when flying JSBSim live, whose linearisation it stands for). `fly_by_wire`: the FCS's
/// command per unit of the pilot's output, for a fly-by-wire aircraft (its embedded model with the FCS).
fn adapted(
    cfg: &AircraftConfig,
    file: &std::path::Path,
    kind: PilotLoop,
    (crossover_rad_s, delay_s, stick_lag_s): (f64, f64, f64),
    fly_by_wire: Option<f64>,
    dt_s: f64,
) -> Result<CrossoverPilotConfig, AeroError> {
    let design = crate::pilot::attitude::CrossoverDesign::new(crossover_rad_s, delay_s);
    let pilot = match fly_by_wire {
        None => {
            let mut ac = crate::aero::Aircraft::load(file)?;
            ac.trim(cfg.airspeed_m_s, cfg.altitude_m)?;
            crate::aero::linear::adapted_pilot(&ac, kind, &design, stick_lag_s)
        }
        Some(command_per_output) => {
            let Some(model) = crate::aero::FbwModel::load(file)? else {
                return Err(AeroError::Refused {
                    what: format!("adapted pilot for `{}`", cfg.model),
                    why: "the adapted pilot is designed on an embedded model ([airframe], [aero_tables], \
                          [fcs]), which this fly-by-wire aircraft's file has not: give the pilot's `gain` (and \
                          `integral_per_s`)"
                        .into(),
                });
            };
            let mut ac = crate::aero::FbwAircraft::new(model);
            ac.trim(cfg.airspeed_m_s, cfg.altitude_m)?;
            let per = command_per_output;
            crate::aero::linear::adapted_fly_by_wire_pilot(&ac, kind, &design, stick_lag_s, per, dt_s)
        }
    };
    pilot.map_err(|e| AeroError::Refused {
        what: format!("adapted pilot for `{}` at ω_c {crossover_rad_s} rad/s", cfg.model),
        why: e.0,
    })
}

/// The pilot's outer loop.
struct Outer {
    pilot: CrossoverPilot,
    kind: PilotLoop,
    command: Schedule,
}

/// How the stick reaches the aircraft.
enum Controls {
    /// A mechanical link to the elevator; the stick force from the hinge moment (or a feel computer).
    Hinge(HingeModel),
    /// The stick's position commands the FCS; the stick force is the designed feel law.
    FlyByWire(FlyByWire),
}

/// An aircraft stepped in lock-step with the rig.
pub struct Flight {
    backend: Box<dyn AircraftBackend>,
    /// The aircraft's mrfeel model file ([`backend::model_file`]).
    model_file: std::path::PathBuf,
    controls: Controls,
    /// The trimmed state the flight starts from.
    pub trim: AircraftState,
    /// Stick angle of the trim (aircraft convention), rad: the rig's neutral.
    pub trim_stick_rad: f64,
    dt_s: f64,
    ticks: u64,
    next_t_s: f64,
    state: AircraftState,
    throttle: Schedule,
    outer: Option<Outer>,
    stick_cmd_rad: f64,
}

impl Flight {
    /// Open the backend, trim it, and build the outer loop with the rig's stick limits. With
    /// `force_task` the outer loop commands the hand's force on the grip (N): only on a fly-by-wire
    /// aircraft, within its grip force limits.
    pub fn open(
        cfg: &AircraftConfig,
        outer: Option<&OuterLoopConfig>,
        stick_limits_rad: (f64, f64),
        force_task: bool,
    ) -> Result<Self, AeroError> {
        let mut backend = backend::open(&cfg.model)?;
        let model_file = backend::model_file(cfg.model.strip_prefix("jsbsim:").unwrap_or(&cfg.model))?;
        let dt_s = 1.0 / cfg.rate_hz;
        let trim = backend.trim(cfg.airspeed_m_s, cfg.altitude_m, dt_s)?;
        let controls = match (backend.hinge(), backend.fly_by_wire()) {
            (_, Some(f)) => Controls::FlyByWire(f.clone()),
            (Some(h), None) => Controls::Hinge(h.clone()),
            (None, None) => {
                return Err(AeroError::Refused {
                    what: format!("aircraft `{}`", cfg.model),
                    why: "neither a hinge model nor a fly-by-wire stick".into(),
                })
            }
        };
        // The fly-by-wire stick's neutral is its trim: the FCS holds the trim itself.
        let trim_stick_rad = match &controls {
            Controls::Hinge(h) => h.stick_from_elevator_rad(trim.elevator_rad),
            Controls::FlyByWire(_) => 0.0,
        };
        let refuse = |why: &str| AeroError::Refused {
            what: format!("the outer loop on `{}`", cfg.model),
            why: why.into(),
        };
        let limits = match (&controls, force_task) {
            (Controls::FlyByWire(f), true) => (-f.max_push_n, f.max_pull_n),
            (Controls::Hinge(_), true) => return Err(refuse(
                "a force task (`pilot.task = \"force\"`) flies only a fly-by-wire aircraft, whose stick is \
                     commanded by force; a mechanical stick is flown by position",
            )),
            (_, false) => stick_limits_rad,
        };
        let outer = match outer {
            Some(o) => {
                let cfg = match (o.pilot, &controls) {
                    (PilotDesign::Given(c), _) => c,
                    (
                        PilotDesign::Adapted {
                            crossover_rad_s,
                            delay_s,
                            stick_lag_s,
                        },
                        controls,
                    ) => {
                        // a fly-by-wire FCS's command per unit of the pilot's output: a force on the grip
                        // beyond the breakout, or the stick's angle through the designed law
                        let fly_by_wire = match controls {
                            Controls::FlyByWire(f) if force_task => Some(1.0 / f.full_command_force_n()),
                            Controls::FlyByWire(f) => Some(1.0 / f.full_command_stick_rad),
                            Controls::Hinge(_) => None,
                        };
                        let design = (crossover_rad_s, delay_s, stick_lag_s);
                        adapted(cfg, &model_file, o.loop_kind, design, fly_by_wire, dt_s)?
                    }
                };
                Some(Outer {
                    pilot: CrossoverPilot::new(
                        CrossoverPilotConfig {
                            stick_min_rad: limits.0,
                            stick_max_rad: limits.1,
                            ..cfg
                        },
                        dt_s,
                    ),
                    kind: o.loop_kind,
                    command: o.command.clone(),
                })
            }
            None => None,
        };
        Ok(Self {
            backend,
            model_file,
            controls,
            trim,
            trim_stick_rad,
            dt_s,
            ticks: 0,
            next_t_s: 0.0,
            state: trim,
            throttle: cfg.throttle.clone(),
            outer,
            stick_cmd_rad: 0.0,
        })
    }

    /// The backend's label (`"c172p"`, `"jsbsim:c172p"`).
    pub fn label(&self) -> &str {
        self.backend.label()
    }

    /// The aircraft's mrfeel model file (`models/aircraft/<name>.toml`, a JSBSim folder's `mrfeel.toml`).
    pub fn model_file(&self) -> &std::path::Path {
        &self.model_file
    }

    /// The aircraft model's parameters marked `[EST]` (estimates without a source).
    pub fn estimates(&self) -> &[String] {
        self.backend.estimates()
    }

    /// Whether the pilot's outer loop sets the stick command.
    pub(crate) fn has_outer_loop(&self) -> bool {
        self.outer.is_some()
    }

    /// The pilot's stick command now, rad relative to trim.
    pub fn stick_cmd_rad(&self) -> f64 {
        self.stick_cmd_rad
    }

    /// The aircraft's stick force now (pull +), N at the grip.
    pub fn stick_force_n(&self) -> f64 {
        self.state.stick_force_n
    }

    /// Round trips of a live co-simulation: (count, mean µs, max µs).
    pub fn round_trip_us(&self) -> Option<(u64, f64, f64)> {
        self.backend.round_trip_us()
    }

    /// The outer loop's commands at `t_s`: (pitch rad absolute, load factor g), NaN where not flown.
    fn commands(&self, t_s: f64) -> (f64, f64) {
        match &self.outer {
            Some(o) => match o.kind {
                PilotLoop::Pitch => (self.trim.theta_rad + o.command.value(t_s), f64::NAN),
                PilotLoop::LoadFactor => (f64::NAN, o.command.value(t_s)),
            },
            None => (f64::NAN, f64::NAN),
        }
    }

    /// Advance the aircraft if a frame is due at `t_s`, with the rig's stick angle (rad, relative to the
    /// trimmed stick) and the hand's force on the grip (N, pull +: a fly-by-wire stick's force sensor).
    pub fn update(&mut self, t_s: f64, stick_angle_rad: f64, grip_force_n: f64) -> Result<(), AeroError> {
        if t_s + 1e-9 < self.next_t_s {
            return Ok(());
        }
        let throttle = self.throttle.value(t_s);
        self.state = match &self.controls {
            Controls::Hinge(h) => {
                let elevator = h.elevator_from_stick_rad(self.trim_stick_rad + stick_angle_rad);
                self.backend.step(elevator, throttle)?
            }
            Controls::FlyByWire(f) => {
                let mut s = self.backend.step_command(f.command(grip_force_n), throttle)?;
                s.stick_force_n = f.stick_force_n(stick_angle_rad);
                s
            }
        };
        let (pitch_cmd, nz_cmd) = self.commands(t_s);
        if let Some(o) = self.outer.as_mut() {
            let err = match o.kind {
                PilotLoop::Pitch => pitch_cmd - self.state.theta_rad,
                PilotLoop::LoadFactor => nz_cmd - self.state.nz_g,
            };
            self.stick_cmd_rad = o.pilot.step(err);
        }
        self.ticks += 1;
        self.next_t_s = self.ticks as f64 * self.dt_s;
        Ok(())
    }

    /// The aircraft's columns at `t_s`.
    pub fn row(&self, t_s: f64) -> AeroRow {
        let s = &self.state;
        let (pitch_cmd_rad, nz_cmd_g) = self.commands(t_s);
        AeroRow {
            qbar_pa: s.qbar_pa,
            elevator_rad: s.elevator_rad,
            hinge_moment_nm: s.hinge_moment_nm,
            pitch_rad: s.theta_rad,
            pitch_cmd_rad,
            nz_g: s.nz_g,
            nz_cmd_g,
            q_rad_s: s.q_rad_s,
            alpha_rad: s.alpha_rad,
            airspeed_m_s: s.airspeed_m_s,
            altitude_m: s.altitude_m,
            stick_force_n: s.stick_force_n,
            stick_cmd_rad: if self.outer.is_some() {
                self.stick_cmd_rad
            } else {
                f64::NAN
            },
        }
    }
}

/// Stick force against load factor for a flight, with what it is judged by: the flown samples (every
/// tenth row), the steady pull-up of the embedded model at the trim (or a fly-by-wire stick's designed
/// law), and the boundaries `F = F/g (n − 1)` of the allowed stick force per g of the aircraft's basis
/// (MIL-F-8785C Level 1, or the 14 CFR 23 / 25 limits; [`crate::aero::FeelAssessment`]), read from the
/// model file the flight flew. `None` without an aircraft.
pub fn stick_force_per_g_chart(res: &super::Results) -> Result<Option<crate::viz::plot::Chart>, AeroError> {
    let Some(f) = &res.flight else { return Ok(None) };
    let file = &f.model_file;
    let flown = |force: fn(&super::Row, &AeroRow) -> f64| -> Vec<(f64, f64)> {
        let rows = res.rows.iter().step_by(10);
        rows.filter_map(|r| r.aero.map(|a| (a.nz_g, force(r, &a))))
            .collect()
    };
    let (v, h) = (f.trim.airspeed_m_s, f.trim.altitude_m);
    // The file read once: a fly-by-wire stick's design, or an aircraft model.
    let src = crate::input::Source::read(file)?;
    if crate::input::aircraft::is_fly_by_wire(&src.text) {
        // The hand's force on the grip, which the stick's force sensor hands to the FCS.
        let fbw = FlyByWire::from_toml(&src.text, file)?;
        let designed = format!(
            "designed: {:.1} N breakout + {:.1} N/g",
            fbw.breakout_n, fbw.stick_force_per_g_n
        );
        return Ok(Some(per_g_chart(
            format!(
                "{} (fly-by-wire): stick force vs load factor, trim {v:.0} m/s at {h:.0} m",
                f.aircraft
            ),
            (
                "flown: the hand's force (the FCS's input)",
                flown(|r, _| r.pilot_force_n),
            ),
            fbw.limit_load_factor,
            (designed, &|n| Some(fbw.designed_force_n(n))),
            "MIL-F-8785C Level 1",
            fbw.level1_per_g_n(),
        )));
    }
    let model = crate::aero::AircraftModel::from_toml(&src.text, file)?;
    let a = crate::aero::Aircraft::new(std::sync::Arc::new(model));
    let assess = crate::aero::FeelAssessment::assess(&a, v, h)?;
    Ok(Some(per_g_chart(
        format!(
            "{}: stick force vs load factor, trim {v:.0} m/s at {h:.0} m",
            f.aircraft
        ),
        ("flown", flown(|_, a| a.stick_force_n)),
        assess.limit_load_factor,
        ("steady pull-up (embedded model)".into(), &|n| {
            a.pull_up_stick_force_n(v, h, n).ok()
        }),
        assess.basis.part.label(),
        assess.allowed_per_g_n,
    )))
}

/// The chart of [`stick_force_per_g_chart`]: the flown points, a reference `curve` of the load factor (up
/// to where it has none), and the `basis`'s bounds `(lo, hi)` in N/g, from 1 g to near the most flown.
fn per_g_chart(
    title: String,
    (flown_name, flown): (&str, Vec<(f64, f64)>),
    limit_load_factor: f64,
    (curve_name, curve): (String, &dyn Fn(f64) -> Option<f64>),
    basis: &str,
    (lo, hi): (f64, f64),
) -> crate::viz::plot::Chart {
    use crate::viz::plot::{Chart, Series};
    let nz_flown = flown.iter().map(|p| p.0).fold(1.0, f64::max);
    let n_top = (nz_flown + 0.5).max(2.0).min(limit_load_factor);
    let ns: Vec<f64> = (0..=20).map(|k| 1.0 + (n_top - 1.0) * k as f64 / 20.0).collect();
    // a condition past the stall or the elevator stop has no steady pull-up: the curve stops there
    let along = ns.iter().map_while(|&n| curve(n).map(|f| (n, f))).collect();
    let bound = |which: &str, per_g: f64| {
        Series::dashed(
            format!("{basis}: {which} {per_g:.1} N/g"),
            ns.iter().map(|&n| (n, per_g * (n - 1.0))).collect(),
        )
    };
    Chart::new(
        title,
        "load factor n_z (g)",
        "stick force at the grip (N, pull +)",
    )
    .with(Series::points(flown_name, flown))
    .with(Series::line(curve_name, along))
    .with(bound("minimum", lo))
    .with(bound("maximum", hi))
}
