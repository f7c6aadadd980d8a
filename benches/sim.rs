//! One full closed-loop step (rig multibody + MR damper, sensors and DAQ, feel controller with PID, pilot
//! hand) against a baseline in the same run: the rig step alone with the same kind of input. Plus the whole
//! `paper-feel-loop` scenario (12 s of 1 kHz physics) as it ships and, as its baseline, with the rig built
//! the slow way (fixed links not fused, all five loop-pin rows: `fuse_fixed_links = false`,
//! `planar_loop_rows = false`). And the loop on a plant with hysteresis whose controller believes
//! `bingham+hysteresis` (the stateful inverse: an observer and a state predicted one lag ahead at every DAQ
//! tick) against the same loop with the Bingham controller (a stateless inverse).
//!
//! Real-time factor: criterion's throughput is set in **simulated seconds** (`elem` = 1 s of simulated
//! time), so `thrpt: N elem/s` reads directly as "N× faster than real time" for every benchmark here.
//! Target (issue 4): the whole scenario ≥ 100× on one core.
//!
//! The aircraft alone: the embedded fly-by-wire F-16 with its FCS against the embedded c172p.
//!
//! `cargo bench --bench sim`

use std::hint::black_box;
use std::path::Path;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use mrfeel::device::{DeviceConfig, Registry};
use mrfeel::scenario::Scenario;
use mrfeel::sim::{self, Devices, Loop, Plant, RunOptions};

fn bench(c: &mut Criterion) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/paper-feel-loop.toml");
    let (scn, device, _) = sim::load(&path).unwrap();
    let dt_s = 1.0 / scn.physics_rate_hz();
    let mut g = c.benchmark_group("sim_step_1khz");
    // Throughput of one step: 1 ms simulated. Criterion counts whole elements, so 1000 steps are timed as
    // one iteration of 1 simulated second.
    let steps_per_iter = (1.0 / dt_s).round() as u64;
    g.throughput(Throughput::Elements(1));
    {
        let mut lp = Loop::new(&scn, &device, sim::build_rig(&scn, &device.plant).unwrap()).unwrap();
        g.bench_function("full_loop_1000_steps", |b| {
            b.iter(|| {
                for _ in 0..steps_per_iter {
                    black_box(lp.step().unwrap().load_cell_true_n);
                }
            })
        });
    }
    {
        // Baseline: the rig step alone, driven by a 0.25 Hz push so it moves as in the scenario.
        let mut rig = sim::build_rig(&scn, &device.plant).unwrap();
        let mut k = 0u64;
        g.bench_function("baseline_rig_1000_steps_only", |b| {
            b.iter(|| {
                for _ in 0..steps_per_iter {
                    let f = 8.0 * (2.0 * std::f64::consts::PI * 0.25 * k as f64 * dt_s).sin();
                    Plant::step(&mut rig, black_box(f), black_box(4.0));
                    k += 1;
                    black_box(Plant::state(&rig).load_cell_n);
                }
            })
        });
    }
    // The paper's damper with `mrfeel mts`'s default hidden hysteresis.
    let text = std::fs::read_to_string(&device.plant.path)
        .unwrap()
        .replacen("model = \"bingham\"", "model = \"bingham+hysteresis\"", 1)
        .replacen(
            "[params]\n",
            "[params]\nhyst_x_yield_m = 2.54e-4\nhyst_v_yield_m_s = 0.016\n",
            1,
        );
    let hysteresis = DeviceConfig::from_toml(&text, &device.plant.path, &Registry::builtin()).unwrap();
    for (name, controller) in [
        (
            "hysteresis_plant_baseline_bingham_controller_1000_steps",
            &device.plant,
        ),
        ("hysteresis_plant_stateful_inverse_1000_steps", &hysteresis),
    ] {
        let devices = Devices {
            plant: hysteresis.clone(),
            controller: controller.clone(),
            controller_is_plant: false,
        };
        let mut lp = Loop::new(&scn, &devices, sim::build_rig(&scn, &hysteresis).unwrap()).unwrap();
        g.bench_function(name, |b| {
            b.iter(|| {
                for _ in 0..steps_per_iter {
                    black_box(lp.step().unwrap().load_cell_true_n);
                }
            })
        });
    }
    g.finish();

    let mut g = c.benchmark_group("scenario");
    g.sample_size(10);
    g.throughput(Throughput::Elements(scn.duration_s.round() as u64));
    let whole = |scn: &Scenario| {
        let rig = sim::build_rig(scn, &device.plant).unwrap();
        sim::run(scn, &device, rig, RunOptions::default(), |_| {})
            .unwrap()
            .rows
            .len()
    };
    g.bench_function("paper_feel_loop_12s_at_1khz", |b| {
        b.iter(|| black_box(whole(&scn)))
    });
    let mut slow = scn.clone();
    slow.rig.fuse_fixed_links = false;
    slow.rig.planar_loop_rows = false;
    g.bench_function("baseline_unfused_full_loop_rows_12s", |b| {
        b.iter(|| black_box(whole(&slow)))
    });
    g.finish();
}

/// The aircraft alone, one simulated second at 120 Hz: the embedded fly-by-wire F-16 (tables, FCS) against
/// the embedded c172p (linear coefficients) as its baseline, each from its trim with the stick held.
fn bench_aircraft(c: &mut Criterion) {
    use mrfeel::aero::{Aircraft, AircraftModel, FbwAircraft, FbwModel};
    let dt = 1.0 / 120.0;
    let mut g = c.benchmark_group("aircraft_120hz");
    g.throughput(Throughput::Elements(1));
    let path = AircraftModel::builtin_path("f16");
    let mut f16 = FbwAircraft::new(FbwModel::load(&path).unwrap().unwrap());
    let trim = f16.trim(200.0, 3000.0).unwrap();
    g.bench_function("f16_embedded_with_fcs_1s", |b| {
        b.iter(|| {
            let mut a = f16.clone();
            for _ in 0..120 {
                black_box(a.step(-0.1, trim.throttle, dt));
            }
        })
    });
    let mut c172p = Aircraft::load(&AircraftModel::builtin_path("c172p")).unwrap();
    let trim = c172p.trim(50.0, 1000.0).unwrap();
    g.bench_function("c172p_embedded_1s (baseline)", |b| {
        b.iter(|| {
            let mut a = c172p.clone();
            for _ in 0..120 {
                black_box(a.step(trim.elevator_rad - 0.01, trim.throttle, dt));
            }
        })
    });
    g.finish();
}

criterion_group!(benches, bench, bench_aircraft);
criterion_main!(benches);
