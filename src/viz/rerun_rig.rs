//! Rerun recording of a stick-rig run: the rig's bodies in 3D with the forces on them as arrows (1 mm per
//! newton), time series of the run's signals (`SERIES`, `AIRCRAFT_SERIES`), and a default blueprint with
//! the 3D rig beside the plots. Entity layout: `docs/explanation/feel-loop.md`. It takes plain data ([`Sample`], poses,
//! visuals), not the simulation's types.
#![warn(missing_docs)]

use std::path::Path;

use rerun::blueprint::{
    Blueprint, BlueprintActivation, ContainerLike, Horizontal, Spatial3DView, TimePanel, TimeSeriesView,
    Vertical,
};
use rerun::{RecordingStream, RecordingStreamResult, TimeColumn};

use crate::rig::{BodyPose, LinkVisuals, VisualShape};

/// Metres of arrow per newton of force.
const ARROW_M_PER_N: f32 = 1e-3;

/// Where the aircraft shape sits beside the stick, m (rig frame: x aft, z up).
const AIRCRAFT_AT_M: [f32; 3] = [0.0, 0.6, 0.3];

/// A recording that could not be made.
#[derive(Debug, thiserror::Error)]
pub enum VizError {
    #[error("rerun: {0}")]
    /// The Rerun SDK failed.
    Rerun(String),
    /// No viewer could be started.
    #[error(
        "could not spawn a Rerun viewer ({0}); install one with `pip install rerun-sdk==0.36.3` (then `rerun` is on PATH) or `cargo install rerun-cli --version 0.36.3 --locked`, or write a file with --rerun out.rrd and open it later"
    )]
    Spawn(String),
}

fn err(e: impl std::fmt::Display) -> VizError {
    VizError::Rerun(e.to_string())
}

/// A recording stream that writes `path`.
pub fn to_file(path: &Path) -> Result<RecordingStream, VizError> {
    rerun::RecordingStreamBuilder::new("mrfeel")
        .save(path)
        .map_err(err)
}

/// A recording stream into a freshly spawned viewer on gRPC port `port` (one already listening there is
/// reused); fails with a clear message if none is installed.
pub fn spawn_on_port(port: u16) -> Result<RecordingStream, VizError> {
    let found = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("rerun").is_file()));
    if !found {
        return Err(VizError::Spawn("no `rerun` executable on PATH".into()));
    }
    let opts = rerun::SpawnOptions {
        port,
        ..Default::default()
    };
    rerun::RecordingStreamBuilder::new("mrfeel")
        .spawn_opts(&opts)
        .map_err(|e| VizError::Spawn(e.to_string()))
}

/// The time series of a recording, one entity path each.
pub(crate) const SERIES: [&str; 10] = [
    "signals/force/desired",
    "signals/force/load_cell",
    "signals/force/load_cell_true",
    "signals/force/damper",
    "signals/current/command",
    "signals/stroke/piston_x",
    "signals/pilot/force",
    "signals/stick/angle",
    "signals/energy/dissipated",
    "signals/faults/mask",
];
/// The aircraft's time series.
pub(crate) const AIRCRAFT_SERIES: [&str; 9] = [
    "signals/aircraft/pitch",
    "signals/aircraft/pitch_cmd",
    "signals/aircraft/nz",
    "signals/aircraft/nz_cmd",
    "signals/aircraft/elevator",
    "signals/aircraft/hinge_moment",
    "signals/aircraft/qbar",
    "signals/aircraft/stick_force",
    "signals/aircraft/stick_cmd",
];
/// Where the arrows' forces are in [`Sample::series`]: true load cell, damper, pilot's hand (N).
const LOAD_CELL_TRUE: usize = 2;
const DAMPER: usize = 3;
const PILOT: usize = 6;

/// One physics step as a recording shows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    /// Time since the run's start, s.
    pub t_s: f64,
    /// The values of `SERIES`, in order (SI units as the paths say).
    pub series: [f64; 10],
    /// The values of `AIRCRAFT_SERIES`, in order, when the run flies (the first is the pitch, rad).
    pub aircraft: Option<[f64; 9]>,
}

/// Log one run whose samples and frames are all in memory ([`RunLogger`]).
pub(crate) fn log_run(
    rec: &RecordingStream,
    visuals: &[LinkVisuals],
    flight: bool,
    samples: &[Sample],
    frames: &[(f64, Vec<BodyPose>)],
) -> Result<(), VizError> {
    let mut log = RunLogger::new(rec, visuals, flight)?;
    let dt = if samples.len() > 1 {
        samples[1].t_s - samples[0].t_s
    } else {
        1.0
    };
    let mut frames = frames.iter().peekable();
    for (k, sample) in samples.iter().enumerate() {
        // Each frame before the sample of its step, as a run hands them over.
        while let Some((t, poses)) =
            frames.next_if(|(t, _)| ((t / dt).round() as usize).min(samples.len() - 1) <= k)
        {
            log.frame(*t, poses);
        }
        log.sample(sample)?;
    }
    log.finish()
}

/// The layout a recording opens with: the 3D rig and its force arrows on the left; on the right the
/// forces, the coil current and the stick (and with an aircraft its pitch and load factor) over time.
pub(crate) fn blueprint(flight: bool) -> Blueprint {
    let mut plots: Vec<ContainerLike> = vec![
        TimeSeriesView::new("force (N)")
            .with_origin("/signals/force")
            .into(),
        TimeSeriesView::new("coil current (A)")
            .with_origin("/signals/current")
            .into(),
        TimeSeriesView::new("pilot force (N), stick angle (rad)")
            .with_contents(["+ /signals/pilot/**", "+ /signals/stick/**"])
            .into(),
    ];
    if flight {
        plots.push(
            TimeSeriesView::new("aircraft")
                .with_contents([
                    "+ /signals/aircraft/pitch",
                    "+ /signals/aircraft/pitch_cmd",
                    "+ /signals/aircraft/nz",
                    "+ /signals/aircraft/nz_cmd",
                ])
                .into(),
        );
    }
    let rig = Spatial3DView::new("rig").with_origin("/").with_contents([
        "+ /rig/**",
        "+ /forces/**",
        "+ /aircraft/**",
    ]);
    let columns: [ContainerLike; 2] = [rig.into(), Vertical::new(plots).into()];
    Blueprint::new(Horizontal::new(columns).with_column_shares([0.45, 0.55]))
        .with_time_panel(TimePanel::new().with_timeline("time"))
}

/// Rows logged per batch of time series: memory is bounded by the batch, not the run's length.
const ROWS_PER_BATCH: usize = 4096;

/// A run's recording made as the run goes: the blueprint, up axis and static shapes at the start, each
/// frame's poses with the force arrows of its step's sample, and the time series in batches of
/// `ROWS_PER_BATCH` samples, so that memory does not grow with the run.
pub struct RunLogger<'a> {
    rec: &'a RecordingStream,
    aero: bool,
    grip: Option<(String, [f64; 3])>,
    batch: Vec<Sample>,
    /// A frame waiting for the row of its step (the arrows show that row's forces).
    pending: Option<(f64, Vec<BodyPose>)>,
}

impl<'a> RunLogger<'a> {
    /// Start the recording of a run on the rig of `visuals`, with an aircraft where `flight`.
    pub fn new(rec: &'a RecordingStream, visuals: &[LinkVisuals], flight: bool) -> Result<Self, VizError> {
        blueprint(flight)
            .send(rec, BlueprintActivation::default())
            .map_err(err)?;
        rec.log_static("/", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())
            .map_err(err)?;
        log_shapes(rec, visuals, flight)?;
        Ok(Self {
            rec,
            aero: flight,
            grip: grip_of(visuals),
            batch: Vec::with_capacity(ROWS_PER_BATCH),
            pending: None,
        })
    }

    /// The poses of a drawing frame at time `t`, logged with the next row.
    pub fn frame(&mut self, t: f64, poses: &[BodyPose]) {
        self.pending = Some((t, poses.to_vec()));
    }

    /// One physics step's sample (with the arrows of a frame waiting for it).
    pub fn sample(&mut self, sample: &Sample) -> Result<(), VizError> {
        if let Some((t, poses)) = self.pending.take() {
            log_frame(self.rec, t, &poses, sample, self.grip.as_ref())?;
        }
        self.batch.push(*sample);
        if self.batch.len() == ROWS_PER_BATCH {
            self.send_batch()?;
        }
        Ok(())
    }

    fn send_batch(&mut self) -> Result<(), VizError> {
        if self.batch.is_empty() {
            return Ok(());
        }
        let rows = std::mem::take(&mut self.batch);
        let times = || TimeColumn::new_duration_secs("time", rows.iter().map(|r| r.t_s));
        for (k, path) in SERIES.into_iter().enumerate() {
            self.send(path, times(), rows.iter().map(|r| r.series[k]).collect())?;
        }
        if self.aero {
            for (k, path) in AIRCRAFT_SERIES.into_iter().enumerate() {
                let v = rows
                    .iter()
                    .map(|r| r.aircraft.map_or(f64::NAN, |a| a[k]))
                    .collect();
                self.send(path, times(), v)?;
            }
        }
        self.batch = rows;
        self.batch.clear();
        Ok(())
    }

    fn send(&self, path: &str, time: TimeColumn, values: Vec<f64>) -> Result<(), VizError> {
        self.rec
            .send_columns(
                path,
                [time],
                rerun::Scalars::new(values)
                    .columns_of_unit_batches()
                    .map_err(err)?,
            )
            .map_err(err)
    }

    /// Log what is left and wait until the recording has it all.
    pub fn finish(mut self) -> Result<(), VizError> {
        self.send_batch()?;
        self.rec.flush_blocking().map_err(err)
    }
}

/// A rigid transform from a translation, m, and a rotation quaternion `[x, y, z, w]`.
fn transform(translation_m: [f64; 3], rotation_xyzw: [f64; 4]) -> rerun::Transform3D {
    rerun::Transform3D::from_translation_rotation(
        f32s(translation_m),
        rerun::Quaternion::from_xyzw(f32s(rotation_xyzw)),
    )
}

/// Each link's visual shapes, static, under `rig/<link>/visual_<k>`, posed in the link's frame (the
/// link's own transform is logged over time by [`log_link_poses`]).
fn log_link_visuals(rec: &RecordingStream, visuals: &[LinkVisuals]) -> RecordingStreamResult<()> {
    for link in visuals {
        for (k, v) in link.visuals.iter().enumerate() {
            let path = format!("rig/{}/visual_{k}", link.name);
            rec.log_static(path.as_str(), &transform(v.translation_m, v.rotation_xyzw))?;
            match &v.shape {
                VisualShape::Box { size_m } => {
                    rec.log_static(path.as_str(), &rerun::Boxes3D::from_sizes([f32s(*size_m)]))?
                }
                VisualShape::Cylinder { radius_m, length_m }
                | VisualShape::Capsule { radius_m, length_m } => rec.log_static(
                    path.as_str(),
                    &rerun::Cylinders3D::from_lengths_and_radii([*length_m as f32], [*radius_m as f32]),
                )?,
                VisualShape::Sphere { radius_m } => rec.log_static(
                    path.as_str(),
                    &rerun::Ellipsoids3D::from_radii([*radius_m as f32]),
                )?,
                VisualShape::Mesh { .. } => {}
            }
        }
    }
    Ok(())
}

/// The links' world poses at the recording's current time, under `rig/<link>`.
fn log_link_poses(rec: &RecordingStream, poses: &[BodyPose]) -> RecordingStreamResult<()> {
    for p in poses {
        rec.log(
            format!("rig/{}", p.name),
            &transform(p.translation_m, p.rotation_xyzw),
        )?;
    }
    Ok(())
}

/// The static shapes of a run: the links' visuals and, when it flies, the airframe.
fn log_shapes(rec: &RecordingStream, visuals: &[LinkVisuals], flight: bool) -> Result<(), VizError> {
    log_link_visuals(rec, visuals).map_err(err)?;
    if flight {
        // Airframe: fuselage, wing, tailplane and fin boxes, nose towards −x (forward), 1:20 scale.
        rec.log_static(
            "aircraft/shape",
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
    }
    Ok(())
}

/// One drawing frame at time `t`: the links' poses; the forces of `row` (its step's sample) as arrows: the
/// load cell's and the damper's at the piston along x, the pilot's hand at the grip along its path; and
/// the aircraft's attitude.
fn log_frame(
    rec: &RecordingStream,
    t: f64,
    poses: &[BodyPose],
    row: &Sample,
    grip: Option<&(String, [f64; 3])>,
) -> Result<(), VizError> {
    rec.set_duration_secs("time", t);
    log_link_poses(rec, poses).map_err(err)?;
    if let Some(piston) = poses.iter().find(|p| p.name == "piston") {
        let at = [f32s(piston.translation_m)];
        for (path, f_n) in [
            ("forces/load_cell", row.series[LOAD_CELL_TRUE]),
            ("forces/damper", -row.series[DAMPER]),
        ] {
            let along_x = [[(f_n * f64::from(ARROW_M_PER_N)) as f32, 0.0, 0.0]];
            rec.log(path, &rerun::Arrows3D::from_vectors(along_x).with_origins(at))
                .map_err(err)?;
        }
    }
    if let Some((link, offset)) = grip {
        if let Some(pose) = poses.iter().find(|p| &p.name == link) {
            // The grip path is the link's local +x at the grip (a pull moves the grip aft).
            let (origin, dir) = in_world(
                pose,
                *offset,
                [row.series[PILOT] * f64::from(ARROW_M_PER_N), 0.0, 0.0],
            );
            rec.log(
                "forces/hand",
                &rerun::Arrows3D::from_vectors([f32s(dir)]).with_origins([f32s(origin)]),
            )
            .map_err(err)?;
        }
    }
    if let Some(a) = row.aircraft {
        // Nose-up pitch θ turns the nose (−x) towards +z: a rotation by θ about +y.
        let h = (a[0] * 0.5) as f32;
        rec.log(
            "aircraft",
            &rerun::Transform3D::from_translation_rotation(
                AIRCRAFT_AT_M,
                rerun::Quaternion::from_xyzw([0.0, h.sin(), 0.0, h.cos()]),
            ),
        )
        .map_err(err)?;
    }
    Ok(())
}

/// The link carrying the URDF visual named `grip` and that visual's origin in the link's frame.
fn grip_of(visuals: &[LinkVisuals]) -> Option<(String, [f64; 3])> {
    visuals.iter().find_map(|l| {
        l.visuals
            .iter()
            .find(|v| v.name.as_deref() == Some("grip"))
            .map(|v| (l.name.clone(), v.translation_m))
    })
}

/// The point `local` of a link's frame, and the vector `along` in it, in the world at the link's `pose`.
fn in_world(pose: &BodyPose, local: [f64; 3], along: [f64; 3]) -> ([f64; 3], [f64; 3]) {
    use nalgebra::{Quaternion, UnitQuaternion, Vector3};
    let [x, y, z, w] = pose.rotation_xyzw;
    let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
    let at = Vector3::from(pose.translation_m) + q * Vector3::from(local);
    (at.into(), (q * Vector3::from(along)).into())
}

fn f32s<const N: usize>(a: [f64; N]) -> [f32; N] {
    a.map(|v| v as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A stick tilted aft by θ (about +y) carries its grip 0.40 m up the stick to (0.4 sin θ, 0, 0.4 cos θ),
    /// and the grip path (local +x) to (cos θ, 0, −sin θ): the hand arrow starts at the grip and points
    /// along the path the grip moves on.
    #[test]
    fn the_grip_and_its_path_follow_the_stick() {
        let th: f64 = 0.3;
        let pose = BodyPose {
            name: "stick".into(),
            translation_m: [0.1, 0.0, 0.0],
            rotation_xyzw: [0.0, (th / 2.0).sin(), 0.0, (th / 2.0).cos()],
        };
        let (at, dir) = in_world(&pose, [0.0, 0.0, 0.4], [1.0, 0.0, 0.0]);
        let want_at = [0.1 + 0.4 * th.sin(), 0.0, 0.4 * th.cos()];
        let want_dir = [th.cos(), 0.0, -th.sin()];
        for i in 0..3 {
            assert!((at[i] - want_at[i]).abs() < 1e-12, "{at:?}");
            assert!((dir[i] - want_dir[i]).abs() < 1e-12, "{dir:?}");
        }
    }
}
