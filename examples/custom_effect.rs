//! A user-defined effect, end to end: a gas spring, registered next to the builtin vocabulary and composed
//! with the paper's base model as `bingham+gas_spring`, without touching the fitting or diagnosis code.
//!
//! Run with `cargo run --example custom_effect`.
//!
//! Physics: many dampers carry a gas accumulator that makes room for the rod. As the rod enters, the gas is
//! compressed polytropically, `p V^κ = const`; with rod area `A` and gas volume `V0 = A L` at mid-stroke the
//! gas pushes the rod out with `F_gas = F_pre (L / (L + x))^κ` (x positive = extension). The rig has to
//! push against it, so the measured force gains `−F_gas`. κ = 1.4 is the adiabatic exponent of nitrogen
//! (diatomic gas, strokes too fast for heat exchange); a user who knows better makes it a parameter.

use mrfeel::device::{DataStats, Effect, EffectStage, Inputs, Model, ParamSpec, Registry, Stage};

/// Polytropic exponent of nitrogen compressed faster than it exchanges heat (adiabatic, diatomic gas).
pub const KAPPA: f64 = 1.4;

/// The effect: no state, two parameters.
pub struct GasSpring;

const PARAMS: [ParamSpec; 2] = [
    // Parameter names are unique across the model: prefix them with the effect's tag, unit in the name.
    ParamSpec::new(
        "gas_preload_n",
        "N",
        0.0,
        f64::INFINITY,
        "gas force on the rod at mid-stroke",
    ),
    ParamSpec::new(
        "gas_length_m",
        "m",
        1e-3,
        10.0,
        "gas volume at mid-stroke over rod area, V0/A",
    ),
];

impl Effect for GasSpring {
    fn name(&self) -> &'static str {
        "gas_spring"
    }

    fn describe(&self) -> &'static str {
        "Gas accumulator: -F_pre (L/(L + x))^1.4, a preload that stiffens in compression"
    }

    fn stage(&self) -> EffectStage {
        // A force that does not go through the fluid's yield.
        EffectStage::Additive
    }

    fn params(&self) -> &'static [ParamSpec] {
        &PARAMS
    }

    // Starting values from the data's scales, never numbers tuned to one data set.
    fn initial_guess(&self, stats: &DataStats) -> Vec<f64> {
        vec![0.05 * stats.f_rms_n.max(1.0), 10.0 * stats.x_max_m.max(1e-3)]
    }

    fn typical_params(&self, stats: &DataStats) -> Vec<f64> {
        vec![0.2 * stats.f_rms_n.max(1.0), 3.0 * stats.x_max_m.max(1e-3)]
    }

    fn apply(&self, p: &[f64], _s: &[f64], inp: &Inputs, stage: &mut Stage) {
        stage.extra_n -= gas_force_n(p[0], p[1], inp.x_m);
    }

    fn residual_signature(&self) -> &'static str {
        "residual that is a curved function of displacement, steeper in compression, plus an offset"
    }
}

/// Force the compressed gas exerts on the rod at displacement `x_m`, N (pushing towards extension).
pub fn gas_force_n(preload_n: f64, length_m: f64, x_m: f64) -> f64 {
    // The rod cannot displace more gas than there is; keep 1 % of the volume.
    let volume_ratio = (length_m + x_m).max(0.01 * length_m) / length_m;
    preload_n * volume_ratio.powf(-KAPPA)
}

fn main() -> anyhow::Result<()> {
    // The builtin vocabulary plus ours; the fitter and the diagnosis take any `Registry`.
    let mut registry = Registry::builtin();
    registry.register(GasSpring);
    let model = Model::from_spec(
        "bingham+gas_spring",
        &registry,
        mrfeel::device::PAPER_CURRENT_LIMIT_A,
    )?;

    // Base parameters (fc0, fc_gain, c0, Te, Tm) then ours, in `model.param_specs()` order.
    let params = [20.0, 5.0, 300.0, 0.01, 0.02, 40.0, 0.05];
    for (spec, value) in model.param_specs().iter().zip(&params) {
        println!("{:>18} = {value:>8} {}", spec.name, spec.unit);
    }

    // A 20 mm, 0.5 Hz sine at 6 A, sampled at 1 kHz.
    let w = 2.0 * std::f64::consts::PI * 0.5;
    let inputs: Vec<Inputs> = (0..4001)
        .map(|k| {
            let t = k as f64 * 1e-3;
            Inputs {
                t_s: t,
                x_m: 0.02 * (w * t).sin(),
                v_m_s: 0.02 * w * (w * t).cos(),
                a_m_s2: -0.02 * w * w * (w * t).sin(),
                current_cmd_a: 6.0,
            }
        })
        .collect();
    let force = model.simulate(&params, &inputs);
    println!("\n   t_s     x_mm    v_mm_s   force_n");
    for k in (0..inputs.len()).step_by(250) {
        let i = &inputs[k];
        println!(
            "{:6.3} {:8.2} {:9.2} {:9.2}",
            i.t_s,
            i.x_m * 1e3,
            i.v_m_s * 1e3,
            force[k]
        );
    }
    Ok(())
}
