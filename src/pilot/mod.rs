//! The pilot's hand and arm at the grip: a mass–spring–damper arm driven through a first-order
//! neuromuscular activation lag, holding the grip through the palm's compliance.
//!
//! Coordinates are along the grip's path (m, positive = the stick's positive rotation, which pushes the
//! piston towards +x). With `x_h`, `v_h` the hand's position and velocity and `x_g`, `v_g` the grip's:
//! - activation (neuromuscular lag, McRuer–Jex, Hess): `τ a' = u − a`, `u` the central command;
//! - position task: muscle force `F_m = k (a − x_h) + c (a' − v_h)` (the arm's stiffness and damping about
//!   the lagged intended position `a`; `u = x_cmd + z`, `z' = g (x_cmd − x_g)` a slow voluntary correction);
//! - force task: `F_m = a − c v_h` (the lagged force command, the arm's damping);
//! - palm: the force on the grip `F_g = k_g (x_h − x_g) + c_g (v_h − v_g)`;
//! - hand mass: `m v_h' = F_m − F_g`.
//!
//! The parameters live in `models/pilot-hand.toml` with their sources.

pub mod attitude; // flight engineer: McRuer crossover pilot (outer loop on pitch / load factor)
pub mod signal;

pub use signal::Signal;

/// The arm model's parameters (see `models/pilot-hand.toml`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandConfig {
    /// Hand and arm mass at the grip, kg.
    pub mass_kg: f64,
    /// Arm stiffness `k`, N/m.
    pub stiffness_n_per_m: f64,
    /// Arm damping `c`, N·s/m.
    pub damping_n_s_per_m: f64,
    /// Neuromuscular activation lag `τ`, s.
    pub activation_tau_s: f64,
    /// Palm stiffness `k_g`, N/m.
    pub grip_stiffness_n_per_m: f64,
    /// Palm damping `c_g`, N·s/m.
    pub grip_damping_n_s_per_m: f64,
    /// Gain `g` of the slow voluntary position correction, 1/s.
    pub tracking_gain_per_s: f64,
}

/// What the pilot is asked to do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Task {
    /// Follow a grip position (m along the grip path).
    Position,
    /// Apply a grip force (N).
    Force,
}

/// The hand and arm at the grip, stepped with the physics.
#[derive(Debug, Clone)]
pub struct Hand {
    /// The arm model's parameters.
    pub cfg: HandConfig,
    /// Position or force task.
    pub task: Task,
    x_h: f64,
    v_h: f64,
    act: f64,
    act_rate: f64,
    z: f64,
    started: bool,
}

impl Hand {
    /// A hand at rest, gripping from the first step.
    pub fn new(cfg: HandConfig, task: Task) -> Self {
        Self {
            cfg,
            task,
            x_h: 0.0,
            v_h: 0.0,
            act: 0.0,
            act_rate: 0.0,
            z: 0.0,
            started: false,
        }
    }

    /// Hands off the stick: no force; the next [`Hand::step`] grips again from the grip's state then.
    pub(crate) fn release(&mut self) {
        self.started = false;
        self.z = 0.0;
    }

    /// The force the hand applies to the grip now, N (held over the next physics step).
    pub fn grip_force_n(&self, grip_x_m: f64, grip_v_m_s: f64) -> f64 {
        self.cfg.grip_stiffness_n_per_m * (self.x_h - grip_x_m)
            + self.cfg.grip_damping_n_s_per_m * (self.v_h - grip_v_m_s)
    }

    /// Advance the hand over `dt_s` with the command `cmd` (m or N by task) and the grip state at the start
    /// of the step; returns the grip force to apply over this step.
    pub fn step(&mut self, cmd: f64, grip_x_m: f64, grip_v_m_s: f64, dt_s: f64) -> f64 {
        let c = self.cfg;
        if !self.started {
            // Start relaxed at the grip, the activation settled on the first command.
            // A force task pre-loads the palm so the first force is the command (no start-up transient).
            self.x_h = match self.task {
                Task::Position => grip_x_m,
                Task::Force => grip_x_m + cmd / c.grip_stiffness_n_per_m,
            };
            self.v_h = grip_v_m_s;
            self.act = cmd;
            self.started = true;
        }
        let f_grip = self.grip_force_n(grip_x_m, grip_v_m_s);
        let u = match self.task {
            Task::Position => {
                self.z += c.tracking_gain_per_s * (cmd - grip_x_m) * dt_s;
                cmd + self.z
            }
            Task::Force => cmd,
        };
        // Exact first-order activation over the step.
        let a0 = self.act;
        self.act = u + (a0 - u) * (-dt_s / c.activation_tau_s).exp();
        self.act_rate = (self.act - a0) / dt_s;
        let f_muscle = match self.task {
            Task::Position => {
                c.stiffness_n_per_m * (self.act - self.x_h) + c.damping_n_s_per_m * (self.act_rate - self.v_h)
            }
            Task::Force => self.act - c.damping_n_s_per_m * self.v_h,
        };
        // Semi-implicit Euler for the hand mass.
        self.v_h += dt_s * (f_muscle - f_grip) / c.mass_kg;
        self.x_h += dt_s * self.v_h;
        f_grip
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> HandConfig {
        HandConfig {
            mass_kg: 1.5,
            stiffness_n_per_m: 1200.0,
            damping_n_s_per_m: 30.0,
            activation_tau_s: 0.1,
            grip_stiffness_n_per_m: 20000.0,
            grip_damping_n_s_per_m: 60.0,
            tracking_gain_per_s: 0.0,
        }
    }

    /// Grip held fixed (a rigid wall): a position step of 1 cm settles to the arm stiffness times the
    /// offset in series with the palm: F = 0.01 · (k k_g / (k + k_g)).
    #[test]
    fn position_step_against_a_wall_settles_to_series_stiffness_force() {
        let mut h = Hand::new(cfg(), Task::Position);
        let dt = 1e-3;
        let mut f = 0.0;
        h.step(0.0, 0.0, 0.0, dt);
        for _ in 0..3000 {
            f = h.step(0.01, 0.0, 0.0, dt);
        }
        let k_series = 1200.0 * 20000.0 / (1200.0 + 20000.0);
        assert!((f - 0.01 * k_series).abs() < 0.01 * 0.01 * k_series, "force {f}");
    }

    /// The neuromuscular lag: a force step against a wall reaches 63 % after ≈ τ (plus the palm's fast
    /// mode), not instantly.
    #[test]
    fn force_step_rises_with_the_activation_time_constant() {
        let mut h = Hand::new(cfg(), Task::Force);
        let dt = 1e-4;
        h.step(0.0, 0.0, 0.0, dt);
        let mut t63 = None;
        for k in 1..20000 {
            let f = h.step(20.0, 0.0, 0.0, dt);
            if t63.is_none() && f >= 0.632 * 20.0 {
                t63 = Some(k as f64 * dt);
            }
        }
        let t63 = t63.unwrap();
        assert!((t63 - 0.1).abs() < 0.02, "t63 {t63}");
    }

    /// A free grip (no resistance): the hand follows a slow sine with little error.
    #[test]
    fn position_task_follows_a_slow_command_when_unloaded() {
        let mut h = Hand::new(cfg(), Task::Position);
        let dt = 1e-3;
        let s = Signal::Sine {
            offset: 0.0,
            amplitude: 0.05,
            frequency_hz: 0.2,
        };
        let mut worst: f64 = 0.0;
        for k in 0..10000 {
            let t = k as f64 * dt;
            // The grip moves with the hand (massless stick): pass the hand's own state.
            let (x, v) = (h.x_h, h.v_h);
            h.step(s.value(t), x, v, dt);
            if t > 2.0 {
                // Lag ≈ τ·ω·A = 0.1·1.26·0.05 ≈ 6 mm at most.
                worst = worst.max((h.x_h - s.value(t)).abs());
            }
        }
        assert!(worst < 0.008, "worst tracking error {worst} m");
    }
}
