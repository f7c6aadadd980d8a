//! One full rig step (rapier multibody + loop closure + MR damper device model) against baselines
//! measured in the same run: the same rig with the device replaced by nothing (the bare rapier step), and
//! rapier's own floor, one step of a world holding a single free body (no joint, no collider), which is what
//! any rig built on rapier's pipeline pays per step before it has a linkage.
//!
//! `cargo bench --bench rig`

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion};
use mrfeel::device::{DeviceConfig, Registry};
use mrfeel::rig::{Rig, RigConfig};

fn rig(fc0_n: f64, gain: f64, c0: f64) -> Rig {
    let text = format!(
        "model = \"bingham\"\n[params]\nfc0_n = {fc0_n}\nfc_gain_n_per_a = {gain}\nc0_n_s_per_m = {c0}\nte_s = 0.01\ntm_s = 0.02\n"
    );
    let damper = DeviceConfig::from_toml(&text, Path::new("bench.toml"), &Registry::builtin())
        .unwrap()
        .damper();
    let urdf = Path::new(env!("CARGO_MANIFEST_DIR")).join("models/stick-rig.urdf");
    Rig::new(&RigConfig::new(urdf), damper).unwrap()
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("rig_step_1khz");
    // A 1 Hz cosine push keeps the linkage moving (sliding, reversing, sticking) as in a scenario.
    let hand = |k: u64| 15.0 * (2.0 * std::f64::consts::PI * k as f64 * 1e-3).cos();
    {
        let mut r = rig(3.0, 5.0, 300.0);
        let mut k = 0u64;
        g.bench_function("full_step_with_mr_damper", |b| {
            b.iter(|| {
                r.step(black_box(hand(k)), black_box(1.0));
                k += 1;
                black_box(r.state().load_cell_n)
            })
        });
    }
    {
        // Zero yield, zero damping: the rig step with the damper's constraints inactive.
        let mut r = rig(0.0, 0.0, 0.0);
        let mut k = 0u64;
        g.bench_function("rig_step_without_damper_forces", |b| {
            b.iter(|| {
                r.step(black_box(0.2 * hand(k)), black_box(0.0));
                k += 1;
                black_box(r.state().load_cell_n)
            })
        });
    }
    {
        // Baseline: the bare rapier step of the same multibody and loop closure (no device, no bookkeeping).
        let mut r = rig(3.0, 5.0, 300.0);
        g.bench_function("baseline_rapier_step_only", |b| b.iter(|| r.step_rapier_only()));
    }
    {
        // Floor: rapier's pipeline for one free body, with the rig's integration settings.
        use rapier3d::prelude::{PhysicsWorld, RigidBodyBuilder};
        let cfg = RigConfig::new("unused.urdf");
        let mut w = PhysicsWorld::new();
        w.integration_parameters.dt = (1.0 / cfg.physics_hz) as f32;
        w.integration_parameters.num_solver_iterations = cfg.solver_iterations;
        w.integration_parameters.num_internal_pgs_iterations = cfg.pgs_iterations;
        w.integration_parameters.max_ccd_substeps = 0;
        let body = RigidBodyBuilder::dynamic().can_sleep(false).additional_mass(1.0);
        let h = w.bodies.insert(body);
        g.bench_function("floor_rapier_one_free_body", |b| {
            b.iter(|| {
                w.step();
                black_box(w.bodies[h].translation().z)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
