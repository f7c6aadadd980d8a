//! The feel system as one component: from the DAQ sample and the feel law it decides what the rig gets —
//! the MR coil's current command, the active stick's motor force, the spring on the piston joint — for
//! every [`FeelKind`], so that the loop driving it never asks which kind it is.

use super::active::{ActiveStick, RodState};
use super::controller::{ControlOutput, FeelController, Hybrid};
use super::feel::{FeelKind, FeelSystemConfig, Spring, SpringElement};
use crate::sensors::DaqSample;

/// The active stick's motor: its limit and its commands, N on the piston.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motor {
    /// Force limit, N.
    pub max_force_n: f64,
    /// Force commanded at the last DAQ tick (held), N.
    pub cmd_n: f64,
    /// Force applied over the present step (after driver faults), N.
    pub force_n: f64,
}

/// A feel system on the rig: its controller, its spring and its actuators.
#[derive(Debug, Clone)]
pub struct FeelSystem {
    /// The feel loop (law, PID, the controller's model of the damper).
    pub controller: FeelController,
    spring: Option<SpringElement>,
    q_from_aircraft: bool,
    /// Whether the MR damper's coil is driven.
    coil: bool,
    /// The coil current command held between DAQ ticks, A (0 without a coil).
    current_cmd_a: f64,
    /// The active stick's motor.
    pub motor: Option<Motor>,
    /// The modelled active stick (motor, current loop, grip sensor, admittance loop); without it the
    /// motor is an ideal clamped force source commanded at the DAQ's ticks.
    pub stick: Option<ActiveStick>,
}

impl FeelSystem {
    /// The system `config` describes, run by `controller`; `seed` (the scenario's) seeds the modelled
    /// active stick's grip-sensor noise.
    pub fn new(config: &FeelSystemConfig, mut controller: FeelController, seed: u64) -> Self {
        if config.kind == FeelKind::MrSpring {
            controller.hybrid = config.spring.map(|spring| Hybrid {
                spring,
                return_damping_n_s_per_m: config.return_damping_n_s_per_m,
            });
        }
        Self {
            controller,
            spring: config.spring,
            q_from_aircraft: config.q_from_aircraft,
            coil: config.kind.has_coil(),
            current_cmd_a: 0.0,
            motor: (config.kind == FeelKind::Active).then_some(Motor {
                max_force_n: config.motor_max_force_n,
                cmd_n: 0.0,
                force_n: 0.0,
            }),
            stick: config.active_stick.map(|c| ActiveStick::new(c, seed)),
        }
    }

    /// The motor's force for the physics step from `t_s` (after driver faults), N on the piston: the
    /// modelled stick runs its loops over the step on `rod`; the ideal source gives its held command.
    pub(crate) fn step_motor(
        &mut self,
        t_s: f64,
        dt_s: f64,
        rod: &RodState,
        faults: &crate::faults::FaultInjector,
    ) {
        let Some(m) = self.motor.as_mut() else { return };
        m.force_n = match self.stick.as_mut() {
            Some(s) => s.step(t_s, dt_s, &self.controller.law, rod, &faults.schedule),
            None => faults.motor_force_n(t_s, m.cmd_n, m.force_n, m.max_force_n),
        };
    }

    /// One DAQ tick on `sample` at the controller's clock `t_s`: the loop's decision; the coil and motor
    /// commands are held until the next tick. A system without a coil only logs its target; the motor
    /// renders the law by impedance control (pushing with the force the pilot should feel, within its limit).
    pub fn update(&mut self, t_s: f64, sample: &DaqSample, dt_s: f64) -> ControlOutput {
        let out = self.controller.update(t_s, sample, dt_s);
        if let Some(m) = self.motor.as_mut() {
            m.cmd_n = (-out.desired_force_n).clamp(-m.max_force_n, m.max_force_n);
        }
        self.current_cmd_a = if self.coil { out.current_cmd_a } else { 0.0 };
        out
    }

    /// The coil current command held now, A; `None` for a system without a coil.
    pub(crate) fn coil_command_a(&self) -> Option<f64> {
        self.coil.then_some(self.current_cmd_a)
    }

    /// The current command as logged, A (0 without a coil).
    pub fn current_cmd_a(&self) -> f64 {
        self.current_cmd_a
    }

    /// The motor's force over the present step, N (0 without a motor).
    pub(crate) fn motor_force_n(&self) -> f64 {
        self.motor.map_or(0.0, |m| m.force_n)
    }

    /// The spring on the piston joint, if any.
    pub fn spring(&self) -> Option<&SpringElement> {
        self.spring.as_ref()
    }

    /// Energy stored in the spring at `x_m`, J (0 without one).
    pub fn spring_energy_j(&self, x_m: f64) -> f64 {
        self.spring.map_or(0.0, |sp| sp.stored_energy_j(x_m))
    }

    /// The flight's dynamic pressure, Pa: a q-feel spring that follows the aircraft takes it.
    pub fn set_dynamic_pressure(&mut self, qbar_pa: f64) {
        if let (true, Some(sp)) = (self.q_from_aircraft, self.spring.as_mut()) {
            sp.set_dynamic_pressure(qbar_pa);
        }
    }
}
