//! Thermal drift: the dissipated power heats the fluid (`dE/dt = P − E/τ`, from ambient at each test's
//! start) and the yield force falls as `Fy · max(0, 1 − E/E_th)`; integrated exactly for a power held over
//! a step. Physics and sources: `docs/explanation/damper-models.md`.

use super::*;

/// Yield force falling with dissipated heat, see the module documentation.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct ThermalDrift;

/// Indices of the parameters in the effect's slice.
pub(crate) const ENERGY: usize = 0;
/// Index of the cooling time constant `thermal_tau_s`.
pub const TAU: usize = 1;

const PARAMS: [ParamSpec; 2] = [
    ParamSpec::new(
        "thermal_energy_j",
        "J",
        // 1 mJ: a heat capacity far below any damper's (grams of fluid hold ~1 J/K); no upper limit (no drift).
        1e-3,
        f64::INFINITY,
        "heat above ambient that would remove the yield force at the linear rate, C_th/α",
    ),
    ParamSpec::new(
        "thermal_tau_s",
        "s",
        // Estimates: a damper body of grams to kilograms cools to ambient in seconds to hours, not faster than
        // 1 s; below that the "drift" would be a velocity effect, not a thermal one.
        1.0,
        1e6,
        "cooling time constant R_th·C_th",
    ),
];

/// Relative yield force at stored heat `e_j`.
pub(crate) fn yield_factor(e_j: f64, energy_j: f64) -> f64 {
    (1.0 - e_j.max(0.0) / energy_j).max(0.0)
}

/// Exact step of `dE/dt = P − E/τ` with `P` held over `dt`.
pub(crate) fn heat_step(e_j: f64, power_w: f64, tau_s: f64, dt_s: f64) -> f64 {
    let steady = power_w * tau_s;
    steady + (e_j - steady) * (-dt_s / tau_s).exp()
}

impl Effect for ThermalDrift {
    effect_constants!(
        "thermal_drift",
        YieldScale,
        "Yield force falling as dissipated energy heats the fluid: stored heat dE/dt = P - E/tau from the \
         dissipated power P, yield scaled by 1 - E/E_th (lumped thermal model, Gordaninejad & Breese 1999), \
         starting at ambient at each test's first sample.",
        "residual that drifts with time within each test (and with cumulative dissipated energy): the measured \
         force amplitude falls cycle after cycle, faster at high current and speed, and a model without it is \
         too weak early and too strong late in every test",
    );

    // Guess: heat for a full loss 20× the energy dissipated in the longest test (a drift of a few %),
    // cooling over three test durations. Typical: 2.5× and one duration, the yield force falling by about
    // a quarter over the longest test.
    scaled_guesses!(s => vec![20.0 * s.energy_j, 3.0 * s.duration_s], vec![2.5 * s.energy_j, s.duration_s]);

    fn n_states(&self) -> usize {
        1
    }

    fn init_states(&self, _p: &[f64], s: &mut [f64], _inp: &Inputs, _stage: &Stage) {
        s[0] = 0.0;
    }

    fn apply(&self, p: &[f64], s: &[f64], _inp: &Inputs, stage: &mut Stage) {
        let k = yield_factor(s[0], p[ENERGY]);
        stage.yield_n *= k;
        stage.yield_field_n *= k;
    }

    fn advance(&self, p: &[f64], s: &mut [f64], inp: &Inputs, stage: &Stage, _force_n: f64, step: Step) {
        let v = inp.v_m_s;
        let power = ((stage.yield_n * stage.direction + stage.damping_n_s_per_m * v) * v).max(0.0);
        s[0] = heat_step(s[0], power, p[TAU], step.dt_s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::effects::testkit::*;

    /// Peak |F| per cycle of a sine.
    fn cycle_peaks(f: &[f64], samples_per_cycle: usize) -> Vec<f64> {
        f.chunks(samples_per_cycle)
            .map(|c| c.iter().fold(0.0f64, |m, x| m.max(x.abs())))
            .collect()
    }

    #[test]
    fn yield_falls_monotonically_as_energy_is_dissipated() {
        let m = model("bingham+thermal_drift");
        let mut p = params(&m, &[("thermal_energy_j", 200.0), ("thermal_tau_s", 1e6)]);
        p[2] = 0.0;
        let inputs = triangle(0.01, 0.05, 10.0, 1e-3, 16.0);
        let f = m.simulate(&p, &inputs);
        let peaks = cycle_peaks(&f, 800);
        assert!(peaks.windows(2).all(|w| w[1] < w[0]), "not falling: {peaks:?}");
        // Without cooling, E = ∫ Fy(E) |v| dt, so dE/ds = Fy0 (1 - E/E_th) along the path s:
        // E(s) = E_th (1 - e^{-Fy0 s / E_th}), and the yield force is Fy0 e^{-Fy0 s / E_th}.
        let fy0 = BASE[0] + BASE[1] * 10.0;
        let s_path = 0.05 * inputs.last().expect("samples").t_s;
        let expect = fy0 * (-fy0 * s_path / 200.0).exp();
        let last = f.last().expect("samples").abs();
        assert!(
            (last - expect).abs() < 0.01 * fy0,
            "after {s_path} m of travel: {last} N vs {expect} N"
        );
    }

    #[test]
    fn recovers_by_cooling_at_zero_velocity() {
        let m = model("bingham+thermal_drift");
        let mut p = params(&m, &[("thermal_energy_j", 50.0), ("thermal_tau_s", 5.0)]);
        p[2] = 0.0;
        let mut inputs = triangle(0.01, 0.05, 10.0, 1e-3, 4.0);
        // Hold still for 3τ, then move again for one sample.
        let t_end = inputs.last().expect("samples").t_s;
        let at = |t_s: f64, v_m_s: f64| Inputs {
            t_s,
            v_m_s,
            current_cmd_a: 10.0,
            ..Inputs::default()
        };
        inputs.extend((1..=15000).map(|k| at(t_end + k as f64 * 1e-3, 0.0)));
        inputs.push(at(t_end + 15.001, 0.05));
        let f = m.simulate(&p, &inputs);
        let fy0 = BASE[0] + BASE[1] * 10.0;
        let heated = f[3999].abs();
        let cooled = *f.last().expect("samples");
        assert!(heated < 0.9 * fy0, "no drift while moving: {heated}");
        // The heat decays as e^{-t/τ}: after 3τ 5 % of the loss remains.
        let loss_expect = (fy0 - heated) * (-3.0f64).exp();
        assert!(
            ((fy0 - cooled) - loss_expect).abs() < 0.02 * fy0,
            "{cooled} N after cooling"
        );
    }

    #[test]
    fn each_test_starts_at_ambient() {
        let m = model("bingham+thermal_drift");
        let p = params(&m, &[("thermal_energy_j", 50.0), ("thermal_tau_s", 100.0)]);
        let inputs = sine(0.01, 1.0, 10.0, 1e-3, 5.0);
        let a = m.simulate(&p, &inputs);
        let b = m.simulate(&p, &inputs);
        assert_eq!(a, b, "a second test must not inherit the first one's heat");
        let base = model("bingham").simulate(&BASE, &inputs);
        assert_eq!(a[0], base[0], "the first sample sees no heat");
    }

    #[test]
    fn heat_step_is_exact_at_any_step_size() {
        let (p, tau) = (12.0, 7.0);
        let mut e = 0.0;
        for _ in 0..1000 {
            e = heat_step(e, p, tau, 0.01);
        }
        let coarse = heat_step(0.0, p, tau, 10.0);
        assert!((e - coarse).abs() < 1e-9 * coarse);
        assert!((coarse - p * tau * (1.0 - (-10.0f64 / tau).exp())).abs() < 1e-9);
        assert!(yield_factor(1e9, 1.0) == 0.0 && yield_factor(0.0, 1.0) == 1.0);
    }
}
