//! The damper as a feel controller believes it (a device file or a fitted `PARAMS.json`, not necessarily
//! the plant): an observer of the model's internal states and the inverse that gives the coil current for
//! a wanted force.
//!
//! The inverse asks the model itself ([`Model::eval`]) for the force at a candidate current with the lags
//! settled and solves for the current by Illinois regula falsi. States (hysteresis, heating) advance on the
//! measured motion and the commanded currents, never the plant's; holding uses the fully yielded force.

use std::sync::Arc;

use super::bingham;
use super::config::DeviceConfig;
use super::effect::{Inputs, Step};
use super::model::{Base, Model};
use super::DeviceError;

/// A controller's model of the damper, with its observer; see the module documentation.
#[derive(Debug, Clone)]
pub struct ForceInverse {
    model: Arc<Model>,
    params: Vec<f64>,
    /// Predicted state (layout of [`Model::init_state`]); empty until the first sample.
    state: Vec<f64>,
    /// The state predicted one lag ahead (`te + tm`) at the sample's velocity: where the force the
    /// command asks for arrives. Empty until the first sample.
    ahead: Vec<f64>,
    /// The previous sample's inputs, with the command that was held after it.
    last: Option<Inputs>,
    /// The command most recently sent to the driver, A.
    last_cmd_a: f64,
}

/// Iterations of the regula falsi beyond which the bracket's midpoint is taken (a yield map that is not
/// monotone in the current; never reached by the built-in effects).
const MAX_ITERATIONS: usize = 40;

impl ForceInverse {
    /// The inverse of a loaded device (its model and parameters), observer at rest. The inverse settles
    /// the Bingham base's two lags at a candidate current; a model on another base (`spencer`, whose force
    /// follows its own filtered-command and Bouc–Wen states) is refused.
    pub fn new(device: &DeviceConfig) -> Result<Self, DeviceError> {
        if device.model.base() != Base::Bingham {
            let why = format!(
                "the feel controller's inverse needs a `{}` base model ({}); give the controller a \
                 bingham-based model or set `controller.feedforward = false`",
                Base::Bingham.name(),
                device.path.display()
            );
            return Err(DeviceError::bad_spec(device.model.name(), why));
        }
        Ok(Self {
            model: device.model.clone(),
            params: device.params.clone(),
            state: Vec::new(),
            ahead: Vec::new(),
            last: None,
            last_cmd_a: 0.0,
        })
    }

    /// The coil (Eq. 3) and fluid (Eq. 4) time constants, s: the force a command asks for arrives through
    /// them.
    pub(crate) fn lags_s(&self) -> (f64, f64) {
        (self.params[bingham::TE], self.params[bingham::TM])
    }

    /// Record the command sent to the driver after this sample (held until the next).
    pub(crate) fn commanded(&mut self, current_a: f64) {
        self.last_cmd_a = current_a;
    }

    /// Advance the predicted state to a new sensor sample (time, position, filtered velocity). Models
    /// without effect states have nothing to predict: the call does nothing.
    pub(crate) fn observe(&mut self, t_s: f64, x_m: f64, v_m_s: f64) {
        if !self.model.has_effect_states() {
            return;
        }
        let inp = Inputs {
            t_s,
            x_m,
            v_m_s,
            current_cmd_a: self.last_cmd_a,
            ..Inputs::default()
        };
        match self.last {
            None => self.state = self.model.init_state(&self.params, &inp),
            Some(prev) => {
                let dt_s = t_s - prev.t_s;
                if dt_s > 0.0 {
                    let prev = Inputs {
                        current_cmd_a: self.last_cmd_a,
                        ..prev
                    };
                    // The filtered velocity, trapezoidal: the laser's position is too noisy to difference
                    // at a pre-yield displacement's scale.
                    let step = Step {
                        dt_s,
                        dx_m: 0.5 * (prev.v_m_s + v_m_s) * dt_s,
                    };
                    self.model.step(&self.params, &mut self.state, &prev, step);
                }
            }
        }
        self.last = Some(inp);
        // One lag ahead at this velocity: a command sent now acts through the coil and fluid lags.
        let (te_s, tm_s) = self.lags_s();
        let h = te_s + tm_s;
        self.ahead.clone_from(&self.state);
        if h > 0.0 {
            let step = Step {
                dt_s: h,
                dx_m: v_m_s * h,
            };
            self.model.step(&self.params, &mut self.ahead, &inp, step);
        }
    }

    /// The force against the motion, N, that the damper gives in direction `dir` (±1) at `speed_m_s` and
    /// displacement `x_m`, with the lags settled at `current_a`: on the observed state, or with
    /// `yielded` fully yielded in direction `dir`.
    pub(crate) fn force_n(&self, current_a: f64, dir: f64, speed_m_s: f64, x_m: f64, yielded: bool) -> f64 {
        let inp = Inputs {
            t_s: self.last.map_or(0.0, |l| l.t_s),
            x_m,
            v_m_s: dir * speed_m_s,
            current_cmd_a: current_a,
            ..Inputs::default()
        };
        let observed = if yielded { &self.state } else { &self.ahead };
        let mut s = if observed.is_empty() {
            self.model.init_state(&self.params, &inp)
        } else {
            observed.clone()
        };
        bingham::init_states(&mut s, current_a, self.model.current_limit_a);
        let stage = if yielded {
            self.model.eval_yielded(&self.params, &s, &inp, dir)
        } else {
            self.model.eval(&self.params, &s, &inp)
        };
        dir * stage.force_n(inp.v_m_s)
    }

    /// The coil current, A (≥ 0), for a force magnitude `force_n` against motion in direction `dir` at
    /// `speed_m_s` and `x_m` (see [`ForceInverse::force_n`] for `yielded`). Beyond the driver's
    /// saturation the force is extrapolated along the chord from 0 to the limit, so a feedback can see
    /// how far out of reach the force is; 0 where no current raises the force (a current that would only
    /// add to a force on the wrong side).
    pub(crate) fn current_a(&self, force_n: f64, dir: f64, speed_m_s: f64, x_m: f64, yielded: bool) -> f64 {
        let dir = if dir < 0.0 { -1.0 } else { 1.0 };
        let g = |i: f64| self.force_n(i, dir, speed_m_s, x_m, yielded) - force_n;
        let limit = self.model.current_limit_a;
        let (g0, g1) = (g(0.0), g(limit));
        if g0 >= 0.0 || g1 <= g0 {
            return 0.0;
        }
        let chord = limit * (-g0) / (g1 - g0);
        if g1 <= 0.0 {
            return chord;
        }
        // Illinois regula falsi on [0, limit]: g(a) < 0 < g(b).
        let (mut a, mut b, mut ga, mut gb) = (0.0, limit, g0, g1);
        let mut side = 0i8;
        for _ in 0..MAX_ITERATIONS {
            let c = (a * gb - b * ga) / (gb - ga);
            let gc = g(c);
            if gc == 0.0 || (b - a) <= 1e-12 * limit || gc.abs() <= 1e-12 * force_n.abs().max(1.0) {
                return c;
            }
            if gc < 0.0 {
                (a, ga) = (c, gc);
                if side == -1 {
                    gb *= 0.5;
                }
                side = -1;
            } else {
                (b, gb) = (c, gc);
                if side == 1 {
                    ga *= 0.5;
                }
                side = 1;
            }
        }
        0.5 * (a + b)
    }

    /// The static inverse: the current whose fully yielded force at rest is `force_n` against a push in
    /// direction `dir`, at `x_m`, A.
    pub(crate) fn holding_current_a(&self, force_n: f64, dir: f64, x_m: f64) -> f64 {
        self.current_a(force_n, dir, 0.0, x_m, true)
    }

    /// Virtual viscous damping: the current whose yield force exceeds the zero-current one by
    /// `c_n_s_per_m · speed_m_s`, at `x_m`, A.
    pub(crate) fn damping_current_a(&self, c_n_s_per_m: f64, speed_m_s: f64, x_m: f64) -> f64 {
        let at_zero = self.force_n(0.0, 1.0, 0.0, x_m, true);
        self.holding_current_a(at_zero + c_n_s_per_m * speed_m_s, 1.0, x_m)
    }
}

impl DeviceConfig {
    /// The largest force the damper gives fully yielded at rest with `current_a` settled in the coil, N:
    /// the ceiling of the feel it can render at that current (none for a model the inverse refuses).
    pub fn yield_force_n(&self, current_a: f64) -> Option<f64> {
        ForceInverse::new(self)
            .ok()
            .map(|inv| inv.force_n(current_a, 1.0, 0.0, 0.0, true))
    }

    /// The force the damper holds at rest at mid-stroke with `current_a` settled, fully yielded one way, N:
    /// the ceiling of the feel it can render. [`DeviceConfig::yield_force_n`] where the inverse applies;
    /// another base (`spencer`) from its own states after a long stroke that way.
    pub(crate) fn ceiling_force_n(&self, current_a: f64) -> f64 {
        self.yield_force_n(current_a).unwrap_or_else(|| {
            let inp = Inputs {
                v_m_s: f64::MIN_POSITIVE,
                current_cmd_a: current_a,
                ..Inputs::default()
            };
            let s = self.model.init_state(&self.params, &inp);
            self.model.eval(&self.params, &s, &inp).force_n(0.0)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::Registry;

    fn device(spec: &str, extra: &str) -> DeviceConfig {
        let text = format!(
            "model = \"{spec}\"\n[params]\nfc0_n = 2.0\nfc_gain_n_per_a = 5.0\nc0_n_s_per_m = 100.0\n\
             te_s = 0.01\ntm_s = 0.02\n{extra}"
        );
        DeviceConfig::from_toml(&text, std::path::Path::new("test.toml"), &Registry::builtin()).unwrap()
    }

    /// Eq. (2) at steady state, solved by hand: F = fc0 + gain·i + C0·v.
    #[test]
    fn bingham_inverse_is_the_static_eq_2_solved_for_the_current() {
        let inv = ForceInverse::new(&device("bingham", "")).unwrap();
        // 40 N at 0.05 m/s: (40 − 2 − 5)/5 = 6.6 A.
        let i = inv.current_a(40.0, 1.0, 0.05, 0.0, false);
        assert!((i - 6.6).abs() < 1e-9, "{i}");
        // Held at rest: (30 − 2)/5 = 5.6 A, either direction.
        assert!((inv.current_a(30.0, -1.0, 0.0, 0.0, true) - 5.6).abs() < 1e-9);
        // Below the zero-current force: 0 A. Beyond the 14 A saturation: extrapolated, (100 − 2)/5.
        assert_eq!(inv.current_a(1.0, 1.0, 0.0, 0.0, true), 0.0);
        assert!((inv.current_a(100.0, 1.0, 0.0, 0.0, true) - 19.6).abs() < 1e-9);
    }

    /// A saturating yield map is inverted to where the forward model gives the force back, inside the
    /// force it reaches at 14 A (2 + 5·4·tanh(3.5) + 100·0.02 = 23.96 N).
    #[test]
    fn saturating_inverse_gives_the_force_back_through_the_forward_model() {
        let inv = ForceInverse::new(&device("bingham+magnetic_saturation", "sat_current_a = 4.0\n")).unwrap();
        // 12 N at 0.02 m/s, solved by hand: 12 − 2 − 2 = 20 tanh(i/4), i = 4 atanh(0.4).
        let i = inv.current_a(12.0, 1.0, 0.02, 0.0, false);
        assert!((i - 4.0 * 0.4f64.atanh()).abs() < 1e-9, "{i}");
        for f in [5.0, 12.0, 20.0, 23.5] {
            let i = inv.current_a(f, 1.0, 0.02, 0.0, false);
            assert!(i > 0.0 && i < 14.0, "{f} N: {i} A");
            let back = inv.force_n(i, 1.0, 0.02, 0.0, false);
            assert!((back - f).abs() < 1e-6 * f, "{f} N -> {i} A -> {back} N");
        }
    }

    /// With a viscous pre-yield branch the damper below `v_y` gives `Fy·v/v_y`: the observer, driven by a
    /// slow steady motion, predicts that branch, and the inverse asks for `v_y/v` times the Bingham current.
    #[test]
    fn observed_hysteresis_state_raises_the_current_on_the_slow_pre_yield_branch() {
        let d = device(
            "bingham+hysteresis",
            "hyst_x_yield_m = 1e-4\nhyst_v_yield_m_s = 0.01\n",
        );
        let mut inv = ForceInverse::new(&d).unwrap();
        let v = 0.005; // half of v_y: z → 0.5
        for k in 0..400 {
            let t = k as f64 * 1e-3;
            inv.observe(t, v * t, v);
            inv.commanded(3.0);
        }
        // Yield wanted: 20 − C0 v = 19.5 N; on z = ½ the yield force must be 39 N: (39 − 2)/5 = 7.4 A.
        let i = inv.current_a(20.0, 1.0, v, 0.0, false);
        assert!((i - 7.4).abs() < 1e-3, "{i}");
        // Bingham alone would ask (19.5 − 2)/5 = 3.5 A.
        let bingham = ForceInverse::new(&device("bingham", "")).unwrap();
        assert!((bingham.current_a(20.0, 1.0, v, 0.0, false) - 3.5).abs() < 1e-9);
    }

    /// The inverse settles the Bingham lags: a Spencer model is refused with what to do instead, not
    /// inverted on parameters of another layout.
    #[test]
    fn a_spencer_model_is_refused_by_the_inverse() {
        let m = Model::from_spec("spencer", &Registry::builtin(), 14.0).unwrap();
        let d = DeviceConfig::from_model(m, super::super::spencer::SPENCER_1997.to_vec(), "s.json".into());
        let e = ForceInverse::new(&d).unwrap_err().to_string();
        assert!(
            e.contains("spencer") && e.contains("s.json") && e.contains("feedforward = false"),
            "{e}"
        );
        assert_eq!(d.yield_force_n(14.0), None);
    }

    /// The ceiling of a Spencer model is its own yielded force at rest, `c1/(c0+c1)·α(i)·z_max` plus the
    /// accumulator spring `k1·(0 − x0)` (the force with the k0 spring relaxed), growing with the current.
    #[test]
    fn a_spencer_ceiling_is_its_yielded_force_at_rest() {
        use super::super::spencer;
        let m = Model::from_spec("spencer", &Registry::builtin(), 14.0).unwrap();
        let p = spencer::SPENCER_1997.to_vec();
        let d = DeviceConfig::from_model(m, p.clone(), "s.json".into());
        let by_hand = |i: f64| {
            use spencer::{ALPHA_A, ALPHA_B, C0A, C0B, C1A, C1B, K1, X0};
            let (alpha, c0, c1) = (
                p[ALPHA_A] + p[ALPHA_B] * i,
                p[C0A] + p[C0B] * i,
                p[C1A] + p[C1B] * i,
            );
            c1 / (c0 + c1) * alpha * spencer::z_scale(&p) + p[K1] * (0.0 - p[X0])
        };
        for i in [0.0, 5.0, 14.0] {
            let got = d.ceiling_force_n(i);
            assert!(
                (got - by_hand(i)).abs() <= 1e-9 * by_hand(i).abs().max(1.0),
                "{i} A: {got} vs {}",
                by_hand(i)
            );
        }
        assert!(d.ceiling_force_n(14.0) > d.ceiling_force_n(0.0));
    }
}
