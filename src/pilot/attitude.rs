//! The pilot's outer loop: a compensatory tracking pilot on pitch attitude or load factor that moves
//! the stick through the hand.
//!
//! McRuer's quasi-linear pilot (McRuer, D. T. and Jex, H. R., "A Review of Quasi-Linear Pilot Models",
//! IEEE Trans. Human Factors in Electronics HFE-8(3), 231–249, 1967, Eq. for the "precision model"):
//!
//! ```text
//! Y_p(s) = K_p e^{-τ_e s} (T_L s + 1) / (T_I s + 1)
//! ```
//!
//! with the effective time delay τ_e ≈ 0.2–0.3 s (transport delay plus the high-frequency neuromuscular
//! lag; McRuer & Jex report 0.2–0.4 s, decreasing with the task's demand), the lead T_L and lag T_I
//! chosen by the pilot so that the open loop `Y_p Y_c` looks like `ω_c e^{-τ_e s} / s` around the
//! crossover ω_c (the *crossover model*; for an attitude-type plant `K/s` a pure gain, for `K/s²` a lead).
//! Pitch-attitude crossover frequencies of 2–4 rad/s are typical of fighter/transport tracking tasks
//! (McRuer, Graham, Krendel, Reisener, AFFDL-TR-65-15, 1965). Here, in addition, a slow integral of
//! the error (`K_i ∫ e`), the pilot's own low-frequency trimming, removes the steady error a pure gain
//! leaves against the phugoid; it is small (its corner `K_i/K_p` well below ω_c).
//!
//! The output is a **stick angle** (rad, + aft) relative to the trimmed stick — the hand model's
//! position command. Error signs: a pitch (or load factor) below its command asks for a pull.

use serde::Deserialize;

/// What the pilot closes the loop on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PilotLoop {
    /// Pitch attitude θ (command in degrees relative to the trim attitude).
    Pitch,
    /// Load factor n_z (command in g).
    LoadFactor,
}

/// Parameters of the crossover pilot.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossoverPilotConfig {
    /// K_p, stick rad per rad of pitch error (pitch loop) or per g (load-factor loop).
    pub gain: f64,
    /// Lead time constant T_L, s (0: none).
    pub lead_s: f64,
    /// Lag time constant T_I, s (0: none).
    pub lag_s: f64,
    /// Effective time delay τ_e, s.
    pub delay_s: f64,
    /// Integral (trim) gain K_i, stick rad per (error unit · s).
    pub integral_per_s: f64,
    /// Stick command limits, rad relative to trim.
    pub stick_min_rad: f64,
    pub stick_max_rad: f64,
}

/// The pilot, stepped at a fixed rate `dt_s`.
#[derive(Debug, Clone)]
pub struct CrossoverPilot {
    cfg: CrossoverPilotConfig,
    dt_s: f64,
    delay: std::collections::VecDeque<f64>,
    /// Previous delayed error, and the lag filter's state `x' = (e − x)/T_I`.
    e_prev: f64,
    y_prev: f64,
    integral: f64,
    started: bool,
}

impl CrossoverPilot {
    pub fn new(cfg: CrossoverPilotConfig, dt_s: f64) -> Self {
        let n = (cfg.delay_s / dt_s).round() as usize;
        Self {
            cfg,
            dt_s,
            delay: std::iter::repeat_n(0.0, n).collect(),
            e_prev: 0.0,
            y_prev: 0.0,
            integral: 0.0,
            started: false,
        }
    }

    pub fn config(&self) -> &CrossoverPilotConfig {
        &self.cfg
    }

    /// Effective delay as realised (a whole number of steps), s.
    pub fn realised_delay_s(&self) -> f64 {
        self.delay.len() as f64 * self.dt_s
    }

    /// One step with the present error (command − measured, rad or g); returns the stick angle
    /// command relative to trim, rad (+ aft).
    pub fn step(&mut self, error: f64) -> f64 {
        let c = self.cfg;
        // e^{-τ s}: the pilot acts on what was perceived τ ago.
        self.delay.push_back(error);
        let e = self.delay.pop_front().unwrap_or(error);
        if !self.started {
            self.e_prev = e;
            self.y_prev = e;
            self.started = true;
        }
        // K (T_L s + 1)/(T_I s + 1) = K [T_L/T_I + (1 − T_L/T_I)/(T_I s + 1)]: the lag part
        // integrated exactly over the step (zero-order hold on e). Without a lag (T_I = 0), a
        // backward-difference lead K (e + T_L ė). (A bilinear pure lead would put a pole at z = −1.)
        let h = self.dt_s;
        let y = if c.lag_s > 0.0 {
            let r = c.lead_s / c.lag_s;
            self.y_prev = e + (self.y_prev - e) * (-h / c.lag_s).exp();
            c.gain * (r * e + (1.0 - r) * self.y_prev)
        } else {
            c.gain * (e + c.lead_s * (e - self.e_prev) / h)
        };
        self.e_prev = e;
        let raw = y + self.integral;
        let out = raw.clamp(c.stick_min_rad, c.stick_max_rad);
        // Conditional integration: stop trimming while the stick command is saturated the same way.
        let saturated = (raw > c.stick_max_rad && e > 0.0) || (raw < c.stick_min_rad && e < 0.0);
        if !saturated {
            self.integral += c.integral_per_s * e * h;
        }
        out
    }
}

/// A piecewise-linear command schedule `[[t_s, value], ...]` (held before the first and after the last
/// point).
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    pub points: Vec<(f64, f64)>,
}

impl Schedule {
    pub fn value(&self, t_s: f64) -> f64 {
        let p = &self.points;
        match p.iter().position(|&(t, _)| t > t_s) {
            None => p.last().map_or(0.0, |q| q.1),
            Some(0) => p[0].1,
            Some(i) => {
                let (t0, v0) = p[i - 1];
                let (t1, v1) = p[i];
                v0 + (v1 - v0) * (t_s - t0) / (t1 - t0)
            }
        }
    }

    /// Time of the first change of value (the first command), s.
    pub fn first_change_s(&self) -> f64 {
        let p = &self.points;
        p.windows(2)
            .find(|w| w[1].1 != w[0].1)
            .map_or(f64::INFINITY, |w| w[0].0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cfg() -> CrossoverPilotConfig {
        CrossoverPilotConfig {
            gain: 2.0,
            lead_s: 0.5,
            lag_s: 0.0,
            delay_s: 0.25,
            integral_per_s: 0.0,
            stick_min_rad: -1.0,
            stick_max_rad: 1.0,
        }
    }

    /// The pilot does not react before the effective delay; then the lead kicks the output above the
    /// static gain, and for a held error it settles to the static gain K·e.
    #[test]
    fn step_error_acts_after_the_delay_and_settles_to_the_static_gain() {
        let dt = 0.01;
        let mut p = CrossoverPilot::new(cfg(), dt);
        let mut out = Vec::new();
        p.step(0.0);
        for _ in 0..200 {
            out.push(p.step(0.1));
        }
        // The step entered at sample index 0 of `out`; it comes out after 25 samples.
        assert!(
            out[..24].iter().all(|y| y.abs() < 1e-12),
            "acted before the delay"
        );
        assert!(out[25].abs() > 0.2, "lead kick expected, got {}", out[25]);
        assert!(
            (out[199] - 0.2).abs() < 1e-9,
            "static gain K·e = 0.2, got {}",
            out[199]
        );
    }

    /// A pure delay of 0.25 s in a unity loop around an integrator `ω_c/s` has a phase margin of
    /// `π/2 − ω_c τ`: with ω_c = 2 rad/s the loop tracks a step without sustained oscillation
    /// (McRuer's crossover model is stable for ω_c τ < π/2).
    #[test]
    fn crossover_model_around_an_integrator_tracks_a_step() {
        let dt = 0.005;
        let c = CrossoverPilotConfig {
            gain: 2.0,
            lead_s: 0.0,
            lag_s: 0.0,
            delay_s: 0.25,
            ..cfg()
        };
        let mut p = CrossoverPilot::new(c, dt);
        let mut x: f64 = 0.0;
        let mut late: f64 = 0.0;
        for k in 0..2000 {
            let u = p.step(1.0 - x);
            x += u * dt; // plant 1/s
            if k > 1200 {
                late = late.max((1.0 - x).abs());
            }
        }
        assert!(late < 0.01, "residual error {late}");
    }

    #[test]
    fn schedule_interpolates_and_holds() {
        let s = Schedule {
            points: vec![(0.0, 0.0), (2.0, 0.0), (3.0, 5.0), (6.0, 5.0)],
        };
        assert_eq!(s.value(-1.0), 0.0);
        assert_eq!(s.value(2.5), 2.5);
        assert_eq!(s.value(10.0), 5.0);
        assert_eq!(s.first_change_s(), 2.0);
    }
}
