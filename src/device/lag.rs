//! First-order lags of the paper's Eq. (3) (coil, `Te = L/R`) and Eq. (4) (fluid, `Tm`), cascaded as in
//! Eq. (6), integrated exactly for a command held constant over the step (zero-order hold).
//!
//! Exact integration means the result does not depend on the step size for a piecewise-constant command:
//! one step of 10 ms equals ten steps of 1 ms to rounding, and no step size is unstable.

/// Advance the cascade `u -> 1/(Te s + 1) -> i -> 1/(Tm s + 1) -> h` by `dt_s` with `u` held constant.
///
/// `i` is the coil current (Eq. 3, the RL circuit), `h` the fluid's effective excitation expressed in
/// amperes (Eq. 4). Returns the new `(i, h)`. Time constants of zero are allowed (no lag).
pub(crate) fn advance_two_lags(i: f64, h: f64, u: f64, te_s: f64, tm_s: f64, dt_s: f64) -> (f64, f64) {
    advance_two_lags_in(i, h, u, te_s, tm_s, dt_s, &mut DecayMemo::default())
}

/// The decays `exp(-dt/Te)` and `exp(-dt/Tm)` of the last few `(dt, Te, Tm)` asked, exactly as computed.
/// A simulation steps on a clock whose step lengths take a handful of values (an even clock's `t[k+1] −
/// t[k]` differ in their last bits), so one integration keeps a memo and spends an exponential only on a
/// step length it has not met: the same numbers as computing each, without two exponentials per sample.
#[derive(Debug, Default, Clone)]
pub(crate) struct DecayMemo {
    keys: [(u64, u64, u64); MEMO],
    values: [(f64, f64); MEMO],
    len: usize,
    next: usize,
}

/// Step lengths a [`DecayMemo`] remembers.
const MEMO: usize = 4;

impl DecayMemo {
    fn decays(&mut self, dt_s: f64, te_s: f64, tm_s: f64) -> (f64, f64) {
        let key = (dt_s.to_bits(), te_s.to_bits(), tm_s.to_bits());
        if let Some(k) = self.keys[..self.len].iter().position(|&k| k == key) {
            return self.values[k];
        }
        let v = (decay(dt_s, te_s), decay(dt_s, tm_s));
        self.keys[self.next] = key;
        self.values[self.next] = v;
        self.next = (self.next + 1) % MEMO;
        self.len = (self.len + 1).min(MEMO);
        v
    }
}

/// [`advance_two_lags`] with the decays from `memo`.
pub(crate) fn advance_two_lags_in(
    i: f64,
    h: f64,
    u: f64,
    te_s: f64,
    tm_s: f64,
    dt_s: f64,
    memo: &mut DecayMemo,
) -> (f64, f64) {
    if i == u && h == u {
        // Settled (exactly, as the states become after ~36 time constants in floating point): the general
        // formula gives `u` too, without two exponentials.
        return (u, u);
    }
    let (ee, em) = memo.decays(dt_s, te_s, tm_s);
    let e0 = i - u; // coil error, decays as exp(-t/Te)
    let g0 = h - u; // fluid error
    let i1 = u + e0 * ee;
    // g' = (e0 exp(-t/Te) - g) / Tm  =>  g(t) = C exp(-t/Te) + (g0 - C) exp(-t/Tm), C = e0 Te / (Te - Tm)
    let scale = te_s.max(tm_s);
    let h1 = if scale <= 0.0 {
        u
    } else if (te_s - tm_s).abs() <= 1e-9 * scale {
        // Repeated pole: g(t) = (g0 + e0 t / T) exp(-t/T)
        u + (g0 + e0 * dt_s / scale) * em
    } else {
        let c = e0 * te_s / (te_s - tm_s);
        u + c * ee + (g0 - c) * em
    };
    (i1, h1)
}

/// `exp(-dt/T)`, with `T = 0` meaning an instantaneous response.
fn decay(dt_s: f64, t_s: f64) -> f64 {
    if t_s <= 0.0 {
        0.0
    } else {
        (-dt_s / t_s).exp()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn step_size_does_not_change_the_exact_solution() {
        let (te, tm) = (0.012, 0.030);
        let (mut i1, mut h1) = (0.0, 0.0);
        for _ in 0..100 {
            (i1, h1) = advance_two_lags(i1, h1, 5.0, te, tm, 0.0005);
        }
        let (i2, h2) = advance_two_lags(0.0, 0.0, 5.0, te, tm, 0.05);
        assert!((i1 - i2).abs() < 1e-12 && (h1 - h2).abs() < 1e-12);
    }

    #[test]
    fn cascade_matches_a_fine_euler_integration() {
        // Independent check: explicit Euler with a tiny step converges to the same curve.
        let (te, tm, u) = (0.010, 0.025, 3.0);
        let (mut i, mut h) = (0.0, 0.0);
        let dt = 1e-7;
        let n = (0.04 / dt) as usize;
        for _ in 0..n {
            let di = (u - i) / te;
            let dh = (i - h) / tm;
            i += di * dt;
            h += dh * dt;
        }
        let (_, he) = advance_two_lags(0.0, 0.0, u, te, tm, n as f64 * dt);
        assert!((h - he).abs() < 1e-5 * u, "euler {h} exact {he}");
    }

    #[test]
    fn equal_time_constants_are_continuous() {
        let step = |te, tm| advance_two_lags(0.0, 0.0, 1.0, te, tm, 0.02).1;
        let (a, b) = (step(0.01, 0.01), step(0.01, 0.010001));
        assert!((a - b).abs() < 1e-4);
        // Repeated pole closed form: 1 - (1 + t/T) e^{-t/T}
        let expect = 1.0 - (1.0 + 2.0) * (-2.0f64).exp();
        assert!((a - expect).abs() < 1e-12);
    }
}
