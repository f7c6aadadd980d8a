//! Rerun recording of a flight: the rig's links (URDF shapes posed over time), a simple aircraft shape
//! beside the stick rotated by the pitch attitude, and the flight's time series.

use std::path::Path;

use rerun::{RecordingStream, TimeColumn};

use super::flight_loop::{FlightError, FlightResults, FlightRow};
use crate::viz::rerun_rig::{log_link_poses, log_link_visuals};

fn err(e: impl std::fmt::Display) -> FlightError {
    FlightError::Other(format!("rerun: {e}"))
}

/// Where the aircraft shape sits (beside the stick, m, rig frame: x aft, z up).
const AIRCRAFT_AT_M: [f32; 3] = [0.0, 0.6, 0.3];

/// Write a recording of the flight to `path` (.rrd).
pub fn write(res: &FlightResults, path: &Path) -> Result<(), FlightError> {
    let rec = rerun::RecordingStreamBuilder::new("mrfeel")
        .save(path)
        .map_err(err)?;
    log(&rec, res)?;
    rec.flush_blocking().map_err(err)?;
    Ok(())
}

pub fn log(rec: &RecordingStream, res: &FlightResults) -> Result<(), FlightError> {
    let times: Vec<f64> = res.rows.iter().map(|r| r.t_s).collect();
    type Col = (&'static str, fn(&FlightRow) -> f64);
    let cols: [Col; 12] = [
        ("series/force/desired_grip", |r| r.desired_force_n),
        ("series/force/load_cell_grip", |r| r.load_cell_grip_n),
        ("series/force/hand", |r| r.hand_force_n),
        ("series/current", |r| r.current_a),
        ("series/stick/angle", |r| r.stick_angle_rad),
        ("series/stick/command", |r| r.stick_cmd_rad),
        ("series/aircraft/pitch", |r| r.pitch_rad),
        ("series/aircraft/pitch_cmd", |r| r.pitch_cmd_rad),
        ("series/aircraft/nz", |r| r.nz_g),
        ("series/aircraft/elevator", |r| r.elevator_rad),
        ("series/aircraft/hinge_moment", |r| r.hinge_moment_nm),
        ("series/aircraft/qbar", |r| r.qbar_pa),
    ];
    // Decimate the series to 100 Hz (the viewer does not need every physics step).
    let every = (res.rows.len() / (times.last().copied().unwrap_or(1.0).max(1e-3) * 100.0) as usize).max(1);
    let t: Vec<f64> = times.iter().step_by(every).copied().collect();
    for (p, f) in cols {
        let v: Vec<f64> = res.rows.iter().step_by(every).map(f).collect();
        rec.send_columns(
            p,
            [TimeColumn::new_duration_secs("time", t.iter().copied())],
            rerun::Scalars::new(v).columns_of_unit_batches().map_err(err)?,
        )
        .map_err(err)?;
    }
    log_link_visuals(rec, "world/rig", &res.visuals).map_err(err)?;
    // Aircraft: fuselage, wing and tailplane boxes, nose towards −x (forward), 1:20 scale.
    rec.log_static(
        "world/aircraft/shape",
        &rerun::Boxes3D::from_centers_and_sizes(
            [
                [0.0, 0.0, 0.0],
                [-0.05, 0.0, 0.02],
                [0.18, 0.0, 0.02],
                [0.19, 0.0, 0.06],
            ],
            [
                [0.45, 0.06, 0.06],
                [0.08, 0.55, 0.01],
                [0.05, 0.18, 0.01],
                [0.05, 0.01, 0.08],
            ],
        ),
    )
    .map_err(err)?;
    let dt = if res.rows.len() > 1 {
        res.rows[1].t_s - res.rows[0].t_s
    } else {
        1.0
    };
    for (t, poses) in &res.frames {
        rec.set_duration_secs("time", *t);
        log_link_poses(rec, "world/rig", poses).map_err(err)?;
        let k = ((t / dt).round() as usize).min(res.rows.len().saturating_sub(1));
        if let Some(r) = res.rows.get(k) {
            // Nose-up pitch θ rotates the nose (−x) towards +z: a rotation by θ about +y.
            let h = (r.pitch_rad * 0.5) as f32;
            rec.log(
                "world/aircraft",
                &rerun::Transform3D::from_translation_rotation(
                    AIRCRAFT_AT_M,
                    rerun::Quaternion::from_xyzw([0.0, h.sin(), 0.0, h.cos()]),
                ),
            )
            .map_err(err)?;
        }
    }
    Ok(())
}
