//! The pilot's outer loop: McRuer's quasi-linear tracking pilot on pitch attitude or load factor,
//! `Y_p(s) = K_p e^{-τ_e s} (T_L s + 1) / (T_I s + 1)` plus a slow trimming integral, whose output is a
//! stick angle (rad, + aft) relative to trim, the hand model's position command. [`CrossoverPilotConfig::adapted`]
//! fits it to the controlled element by the crossover model (`docs/explanation/pilot.md`).

use nalgebra::Complex;
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
    /// Lower stick command limit, rad relative to trim.
    pub stick_min_rad: f64,
    /// Upper stick command limit, rad relative to trim.
    pub stick_max_rad: f64,
}

/// What the pilot adapts with (the crossover model's parameters, see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CrossoverDesign {
    /// ω_c: where the pilot puts the open loop's unit gain, rad/s.
    pub crossover_rad_s: f64,
    /// τ_e: the pilot's effective delay realised by `CrossoverPilot`, s. Lags modelled elsewhere in
    /// the loop (the hand's activation) belong in the controlled element, not here.
    pub delay_s: f64,
    /// Corner of the trimming integral as a fraction of ω_c (`K_i = ratio ω_c K_p`); 0 for none.
    pub integral_corner_ratio: f64,
    /// Largest phase the lead or lag supplies at ω_c, rad (in [0, 1.5]).
    pub max_equalisation_phase_rad: f64,
}

impl CrossoverDesign {
    /// ω_c and τ_e with the defaults: the trimming integral a decade below crossover, lead or lag
    /// phase up to atan 3 = 71.6° at ω_c (a lead time constant at most 3/ω_c, an integral corner at
    /// most 3 ω_c).
    pub fn new(crossover_rad_s: f64, delay_s: f64) -> Self {
        Self {
            crossover_rad_s,
            delay_s,
            integral_corner_ratio: 0.1,
            max_equalisation_phase_rad: 3f64.atan(),
        }
    }

    /// Phase margin of the ideal crossover model, `π/2 − ω_c τ_e`, rad.
    pub(crate) fn ideal_phase_margin_rad(&self) -> f64 {
        std::f64::consts::FRAC_PI_2 - self.crossover_rad_s * self.delay_s
    }
}

/// A crossover design that cannot be made (bad parameters or controlled element).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("crossover pilot design: {0}")]
pub struct CrossoverDesignError(pub String);

impl CrossoverPilotConfig {
    /// McRuer's adapted pilot for the controlled element `yc` (stick rad → output, complex frequency
    /// response `Y_c(jω)`, ω in rad/s) at crossover `omega_c_rad_s` with delay `delay_s`; the defaults of
    /// [`CrossoverDesign::new`]. Stick limits are left open (±∞): the caller sets the rig's.
    pub fn adapted(
        yc: impl Fn(f64) -> Complex<f64>,
        omega_c_rad_s: f64,
        delay_s: f64,
    ) -> Result<Self, CrossoverDesignError> {
        Self::adapted_with(yc, &CrossoverDesign::new(omega_c_rad_s, delay_s))
    }

    /// [`Self::adapted`] with every design parameter given.
    pub(crate) fn adapted_with(
        yc: impl Fn(f64) -> Complex<f64>,
        d: &CrossoverDesign,
    ) -> Result<Self, CrossoverDesignError> {
        let require =
            |ok: bool, msg: &dyn Fn() -> String| ok.then_some(()).ok_or_else(|| CrossoverDesignError(msg()));
        let (w, tau) = (d.crossover_rad_s, d.delay_s);
        require(w.is_finite() && w > 0.0, &|| {
            format!("crossover frequency {w} rad/s must be positive and finite")
        })?;
        require(tau.is_finite() && tau >= 0.0, &|| {
            format!("delay {tau} s must be finite and >= 0")
        })?;
        require(d.ideal_phase_margin_rad() > 0.0, &|| {
            format!(
                "ω_c τ_e = {:.3} rad >= π/2: the crossover model has no phase margin (lower ω_c or τ_e)",
                w * tau
            )
        })?;
        let (ratio, cap) = (d.integral_corner_ratio, d.max_equalisation_phase_rad);
        require((0.0..1.0).contains(&ratio), &|| {
            format!("integral corner ratio {ratio} outside [0, 1)")
        })?;
        require((0.0..=1.5).contains(&cap), &|| {
            format!("max equalisation phase {cap} rad outside [0, 1.5]")
        })?;
        let y0 = yc(w);
        require(y0.norm().is_finite() && y0.norm() > 0.0, &|| {
            format!("the controlled element's response at {w} rad/s is zero or not finite ({y0})")
        })?;
        // Y_p(jω_c) must be ω_c e^{−jω_cτ} / (jω_c Y_c(jω_c)): the equaliser supplies the phase
        // −90° − arg Y_c (delay aside), a lead when positive, a lag (as an integral) when negative;
        // within ±5° the pilot is a pure gain.
        let pi = std::f64::consts::PI;
        let mut phi = -std::f64::consts::FRAC_PI_2 - y0.arg();
        if phi <= -pi {
            phi += 2.0 * pi;
        } else if phi > pi {
            phi -= 2.0 * pi;
        }
        let trim_integral = d.integral_corner_ratio * w;
        let dead_band = 5f64.to_radians();
        let (lead_s, integral_corner) = if phi > dead_band {
            (phi.min(cap).tan() / w, trim_integral)
        } else if phi < -dead_band {
            (0.0, (w * (-phi).min(cap).tan()).max(trim_integral))
        } else {
            (0.0, trim_integral)
        };
        let unit = Self {
            gain: 1.0,
            lead_s,
            lag_s: 0.0,
            delay_s: d.delay_s,
            integral_per_s: integral_corner,
            stick_min_rad: f64::NEG_INFINITY,
            stick_max_rad: f64::INFINITY,
        };
        let l = unit.describing_function(w) * y0;
        // the open loop (delay aside) must lag by 0..180 deg at crossover: otherwise the stick acts
        // the wrong way (sign of the gearing) or the element is beyond what the pilot can equalise
        let phase = (unit.describing_function(w) * Complex::from_polar(1.0, w * d.delay_s) * y0).arg();
        require(phase < 0.0 && phase > -std::f64::consts::PI, &|| {
            format!(
                "the equalised open loop's phase at {w} rad/s is {:.0} deg (delay aside); the crossover model needs -180..0 deg (a positive stick gain): check the sign of the controlled element",
                phase.to_degrees()
            )
        })?;
        let gain = 1.0 / l.norm();
        Ok(Self {
            gain,
            integral_per_s: gain * unit.integral_per_s,
            ..unit
        })
    }

    /// The pilot's describing function `Y_p(jω) = e^{−jωτ} [K (T_L jω + 1)/(T_I jω + 1) + K_i/(jω)]`
    /// (stick rad per unit error), as `CrossoverPilot` realises it (its delay rounded to whole
    /// steps aside).
    pub fn describing_function(&self, omega_rad_s: f64) -> Complex<f64> {
        let jw = Complex::new(0.0, omega_rad_s);
        let lead_lag = (jw * self.lead_s + 1.0) / (jw * self.lag_s + 1.0);
        let integral = if self.integral_per_s != 0.0 {
            Complex::new(self.integral_per_s, 0.0) / jw
        } else {
            Complex::new(0.0, 0.0)
        };
        (lead_lag * self.gain + integral) * Complex::from_polar(1.0, -omega_rad_s * self.delay_s)
    }
}

/// The pilot, stepped at a fixed rate `dt_s`.
#[derive(Debug, Clone)]
pub(crate) struct CrossoverPilot {
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
    /// A pilot of `cfg` stepped every `dt_s`, its delay rounded to whole steps.
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

    /// The pilot's parameters.
    pub fn config(&self) -> &CrossoverPilotConfig {
        &self.cfg
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

/// A pursuit pilot (McRuer & Krendel 1974: a pilot who sees the command, not only the error, adds a
/// feedforward `Y_ff ≈ 1/Y_c`): the crossover pilot's output on the error plus `feedforward × command`,
/// both through the delay τ. For a load-factor task the feedforward is the aircraft's stick per g
/// (`Aircraft::stick_per_g_rad`); with 0 it is the compensatory `CrossoverPilot`.
#[derive(Debug, Clone)]
pub struct PursuitPilot {
    pilot: CrossoverPilot,
    feedforward: f64,
    delay: std::collections::VecDeque<f64>,
}

impl PursuitPilot {
    /// `feedforward`: stick rad per unit of command (rad or g) relative to trim.
    pub fn new(cfg: CrossoverPilotConfig, feedforward: f64, dt_s: f64) -> Self {
        let pilot = CrossoverPilot::new(cfg, dt_s);
        let n = pilot.delay.len();
        Self {
            pilot,
            feedforward,
            delay: std::iter::repeat_n(0.0, n).collect(),
        }
    }

    /// One step. `error`: command − measured now (rad or g), for the compensatory loop;
    /// `command_ahead`: the command relative to trim that the feedforward acts on: the present
    /// command (pursuit) or the command `preview` seconds ahead (precognitive, a known schedule; a
    /// preview equal to the pilot's delay plus the hand's lag cancels them). Returns the stick angle
    /// command relative to trim, rad (+ aft), within the stick limits.
    pub fn step(&mut self, error: f64, command_ahead: f64) -> f64 {
        self.delay.push_back(command_ahead);
        let c = self.delay.pop_front().unwrap_or(command_ahead);
        let cfg = *self.pilot.config();
        (self.pilot.step(error) + self.feedforward * c).clamp(cfg.stick_min_rad, cfg.stick_max_rad)
    }
}

/// A piecewise-linear command schedule `[[t_s, value], ...]` (held before the first and after the last
/// point).
#[derive(Debug, Clone, PartialEq)]
pub struct Schedule {
    /// `(t_s, value)` points, in time order.
    pub points: Vec<(f64, f64)>,
}

impl Schedule {
    /// The value at `t_s`.
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

    /// Crossover frequency of an open loop `L(jω)`: the first ω in `[lo, hi]` (rad/s) where `|L|` falls
    /// through 1, from a log-spaced scan (200 points per decade) refined by bisection; `None` if it
    /// does not cross there.
    fn crossover_frequency(open_loop: impl Fn(f64) -> Complex<f64>, lo: f64, hi: f64) -> Option<f64> {
        let n = ((hi / lo).log10() * 200.0).ceil().max(1.0) as usize;
        let g = |w: f64| open_loop(w).norm().ln();
        let mut w0 = lo;
        for k in 1..=n {
            let w1 = lo * (hi / lo).powf(k as f64 / n as f64);
            if g(w0) >= 0.0 && g(w1) < 0.0 {
                let (mut a, mut b) = (w0, w1);
                for _ in 0..60 {
                    let m = (a * b).sqrt();
                    if g(m) >= 0.0 {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                return Some((a * b).sqrt());
            }
            w0 = w1;
        }
        None
    }

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

    fn design(w: f64, tau: f64) -> CrossoverDesign {
        CrossoverDesign {
            integral_corner_ratio: 0.0,
            ..CrossoverDesign::new(w, tau)
        }
    }

    /// Slope of |L(jω)| in decades per decade at ω.
    fn slope(l: impl Fn(f64) -> Complex<f64>, w: f64) -> f64 {
        let r: f64 = 1.01;
        (l(w * r).norm().ln() - l(w / r).norm().ln()) / (2.0 * r.ln())
    }

    fn open_loop(p: CrossoverPilotConfig, yc: impl Fn(f64) -> Complex<f64>) -> impl Fn(f64) -> Complex<f64> {
        move |w| p.describing_function(w) * yc(w)
    }

    /// Y_c = K/s (attitude-type): the crossover model is a pure gain K_p = ω_c/K (McRuer & Krendel).
    #[test]
    fn integrator_element_gets_a_pure_gain_of_crossover_over_k() {
        let yc = |w: f64| Complex::new(4.0, 0.0) / Complex::new(0.0, w);
        let p = CrossoverPilotConfig::adapted_with(yc, &design(3.0, 0.2)).unwrap();
        assert_eq!((p.lead_s, p.lag_s, p.integral_per_s), (0.0, 0.0, 0.0));
        assert!((p.gain - 3.0 / 4.0).abs() < 1e-12, "{}", p.gain);
        let wx = crossover_frequency(open_loop(p, yc), 0.1, 100.0).unwrap();
        assert!((wx / 3.0 - 1.0).abs() < 1e-6, "{wx}");
    }

    /// Y_c = K/s² (acceleration-type): the pilot adds lead; it would need 90°, the default cap
    /// (atan 3) gives T_L = 3/ω_c and K_p = ω_c²/(K √(1 + 9)).
    #[test]
    fn double_integrator_gets_a_lead_and_the_analytic_gain() {
        let yc = |w: f64| Complex::new(2.0, 0.0) / (Complex::new(0.0, w) * Complex::new(0.0, w));
        let p = CrossoverPilotConfig::adapted_with(yc, &design(2.0, 0.2)).unwrap();
        assert!((p.lead_s - 1.5).abs() < 1e-9 && p.lag_s == 0.0, "{p:?}");
        assert!((p.gain - 4.0 / (2.0 * 10f64.sqrt())).abs() < 1e-9, "{}", p.gain);
        let l = open_loop(p, yc);
        assert!((l(2.0).norm() - 1.0).abs() < 1e-9);
        assert!((slope(&l, 2.0) + 1.1).abs() < 0.02, "slope {}", slope(&l, 2.0));
    }

    /// Y_c = K (position-type): the pilot integrates: K_p (1 + ω_i/s) with ω_i = 3 ω_c (−71.6° at
    /// ω_c, the default cap of the −90° asked for) and K_p = 1/(K √(1 + 9)); no steady error.
    #[test]
    fn gain_element_gets_an_integrating_pilot() {
        let yc = |_w: f64| Complex::new(0.5, 0.0);
        let p = CrossoverPilotConfig::adapted_with(yc, &design(2.5, 0.2)).unwrap();
        assert!(p.lag_s == 0.0 && p.lead_s == 0.0, "{p:?}");
        assert!((p.gain - 1.0 / (0.5 * 10f64.sqrt())).abs() < 1e-9, "{}", p.gain);
        assert!((p.integral_per_s / p.gain - 7.5).abs() < 1e-9, "{p:?}");
        let l = open_loop(p, yc);
        assert!((l(2.5).norm() - 1.0).abs() < 1e-9);
        assert!(l(0.01).norm() > 100.0, "integrator at low frequency");
    }

    /// A first-order element K/(T s + 1): the pilot's integral corner cancels the pole (ω_i = 1/T),
    /// so the open loop is exactly the crossover model ω_c e^{−sτ}/s: slope −1 around ω_c and phase
    /// margin π/2 − ω_c τ.
    #[test]
    fn first_order_element_open_loop_is_the_crossover_model() {
        for t in [0.2, 0.5, 2.0] {
            let yc = move |w: f64| Complex::new(3.0, 0.0) / Complex::new(1.0, w * t);
            let d = CrossoverDesign::new(3.0, 0.15);
            let p = CrossoverPilotConfig::adapted_with(yc, &d).unwrap();
            assert!(
                (p.integral_per_s / p.gain * t - 1.0).abs() < 1e-9,
                "T = {t}: {p:?}"
            );
            let l = open_loop(p, yc);
            let wx = crossover_frequency(&l, 0.3, 30.0).unwrap();
            assert!((wx / 3.0 - 1.0).abs() < 1e-6, "T = {t}: crossover {wx}");
            for w in [0.3, 3.0, 30.0] {
                assert!(
                    (slope(&l, w) + 1.0).abs() < 1e-3,
                    "T = {t}: slope {} at {w}",
                    slope(&l, w)
                );
            }
            let pm =
                std::f64::consts::PI + (l(3.0) * Complex::from_polar(1.0, 3.0 * 0.15)).arg() - 3.0 * 0.15;
            assert!(
                (pm - d.ideal_phase_margin_rad()).abs() < 1e-9,
                "T = {t}: phase margin {pm}"
            );
        }
    }

    /// Closing the discrete pilot around K/s² with the adapted lead: a step command settles (the
    /// crossover design is stable with the delay), where a pure gain would not.
    #[test]
    fn adapted_pilot_tracks_a_step_on_a_double_integrator() {
        let k = 2.0;
        let yc = move |w: f64| Complex::new(k, 0.0) / (Complex::new(0.0, w) * Complex::new(0.0, w));
        let p = CrossoverPilotConfig::adapted(yc, 2.0, 0.2).unwrap();
        let dt = 0.005;
        let mut pilot = CrossoverPilot::new(p, dt);
        let (mut x, mut v) = (0.0_f64, 0.0_f64);
        let mut late = 0.0_f64;
        for i in 0..4000 {
            let u = pilot.step(1.0 - x);
            v += k * u * dt;
            x += v * dt;
            if i > 3000 {
                late = late.max((1.0 - x).abs());
            }
        }
        assert!(late < 0.02, "residual error {late}");
    }

    #[test]
    fn impossible_designs_are_errors() {
        let yc = |w: f64| Complex::new(1.0, 0.0) / Complex::new(0.0, w);
        // ω_c τ = 1.6 > π/2: no phase margin left
        assert!(CrossoverPilotConfig::adapted(yc, 4.0, 0.4).is_err());
        // a stick that works the wrong way round
        let reversed = |w: f64| Complex::new(-1.0, 0.0) / Complex::new(0.0, w);
        let e = CrossoverPilotConfig::adapted(reversed, 2.0, 0.2).unwrap_err();
        assert!(e.to_string().contains("sign"), "{e}");
        assert!(CrossoverPilotConfig::adapted(|_| Complex::new(0.0, 0.0), 2.0, 0.2).is_err());
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
