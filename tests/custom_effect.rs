//! The worked example of a user-defined effect (`examples/custom_effect.rs`) composes with the base model
//! through a `Registry` and produces the force its physics says.

#[allow(dead_code)]
#[path = "../examples/custom_effect.rs"]
mod example;

use example::{gas_force_n, GasSpring};
use mrfeel::device::{Inputs, Model, Registry, PAPER_CURRENT_LIMIT_A};

const BASE: [f64; 5] = [20.0, 5.0, 300.0, 0.01, 0.02];

fn model() -> Model {
    let mut r = Registry::builtin();
    r.register(GasSpring);
    Model::from_spec("bingham+gas_spring+hysteresis", &r, PAPER_CURRENT_LIMIT_A).expect("model builds")
}

#[test]
fn user_effect_is_unknown_until_registered() {
    assert!(Model::from_spec("bingham+gas_spring", &Registry::builtin(), PAPER_CURRENT_LIMIT_A).is_err());
    // Base five, the gas spring's two, then the built-in hysteresis (yield displacement, knee velocity, knee
    // shape, gamma share).
    assert_eq!(model().n_params(), 5 + 2 + 4);
}

#[test]
fn gas_spring_force_at_rest_follows_the_adiabatic_law() {
    let m = model();
    let (preload, length) = (40.0, 0.05);
    let mut p = BASE.to_vec();
    p.extend([preload, length, 1e-4, 0.0, 0.0, 0.0]);
    for x in [-0.02, 0.0, 0.02] {
        let rest = [Inputs {
            t_s: 0.0,
            x_m: x,
            v_m_s: 0.0,
            a_m_s2: 0.0,
            current_cmd_a: 5.0,
        }];
        let f = m.simulate(&p, &rest)[0];
        // Independent of the example's helper: p V^1.4 = const on V = A (L + x).
        let expect = -preload * (length / (length + x)).powf(1.4);
        assert!((f - expect).abs() < 1e-9, "at x = {x}: {f} N vs {expect} N");
    }
    // Stiffer in compression than in extension, and the preload at mid-stroke.
    let d = 0.02;
    let stiff_in = gas_force_n(preload, length, -d) - preload;
    let stiff_out = preload - gas_force_n(preload, length, d);
    assert!(stiff_in > stiff_out * 1.5, "{stiff_in} vs {stiff_out}");
}

#[test]
fn gas_spring_adds_to_the_base_force_while_moving() {
    let m = model();
    let mut with = BASE.to_vec();
    with.extend([40.0, 0.05, 1e-4, 0.0, 0.0, 0.0]);
    let mut without = with.clone();
    without[5] = 0.0;
    let inputs: Vec<Inputs> = (0..2000)
        .map(|k| {
            let t = k as f64 * 1e-3;
            Inputs {
                t_s: t,
                x_m: 0.01 * t.sin(),
                v_m_s: 0.01 * t.cos(),
                a_m_s2: -0.01 * t.sin(),
                current_cmd_a: 4.0,
            }
        })
        .collect();
    let a = m.simulate(&with, &inputs);
    let b = m.simulate(&without, &inputs);
    for ((fa, fb), i) in a.iter().zip(&b).zip(&inputs) {
        let expect = -40.0 * (0.05 / (0.05 + i.x_m)).powf(1.4);
        assert!((fa - fb - expect).abs() < 1e-9);
    }
}
