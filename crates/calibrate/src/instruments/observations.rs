//! The poses and points on a global block: what an instrument calibration
//! ([`crate::instruments::run`]) and a calibration of ball touches with
//! poses and points ([`crate::mixed`]) share. The groups the data add to
//! the global block (`groups`), its start (`initial_block`) and their
//! priors (`group_priors`); the model of the rows and the rows whitened
//! (`model_and_rows`) and their residuals (`residuals`).

use nalgebra::{DMatrix, DVector};
use parcal_dataset::Dataset;
use parcal_kinematics::{ForwardOptions, Geometry, Vec3};

use crate::CalibrateError;
use crate::instruments::model::{InstrumentModel, ModelValues};
use crate::instruments::rows::InstrumentRows;
use crate::instruments::start::frame_start;
use crate::layout::{ParameterGroup, ParameterLayout};

/// The model of `dataset`'s poses and points on the global block `layout`
/// (which holds their [`groups`]) and their rows, weighed at the initial
/// block `initial`: the instrument frames start from the design
/// (`canonical`, [`frame_start`]).
pub(crate) fn model_and_rows<'a>(
    dataset: &'a Dataset,
    canonical: &Geometry,
    layout: ParameterLayout,
    initial: &DVector<f64>,
) -> Result<(InstrumentModel, InstrumentRows<'a>), CalibrateError> {
    let machine = &dataset.machine;
    let tracker = &dataset.tracker;
    let forward = ForwardOptions::default();
    let start = frame_start(tracker, canonical, &machine.actuator.scale, &forward)?;
    let model = InstrumentModel {
        layout,
        sessions: tracker.sessions.clone(),
        tracker_references: start.trackers,
        body_reference: start.body,
        fixed_scales: machine.actuator.scale,
        fixed_tool: canonical.tool,
    };
    let mut rows = InstrumentRows::new(tracker, start.point_poses, forward);
    rows.whiten(&model, &model.values(initial), &machine.repeatability)?;
    Ok((model, rows))
}

/// Each pose's leg-length residuals `|T E_i − B_i| − L_i` and each
/// point's residual `F(T) − P` at `values` (mm).
pub(crate) fn residuals(
    rows: &InstrumentRows<'_>,
    model: &InstrumentModel,
    values: &ModelValues,
) -> Result<(Vec<[f64; 6]>, Vec<Vec3>), CalibrateError> {
    let tracker = rows.tracker;
    let legs = (0..tracker.poses.len())
        .map(|j| {
            rows.pose(model, values, j)
                .map(|b| std::array::from_fn(|i| b.residual[i]))
        })
        .collect::<Result<_, _>>()?;
    let points = (0..tracker.points.len())
        .map(|j| rows.point(model, values, j).map(|r| r.block.residual))
        .collect::<Result<_, _>>()?;
    Ok((legs, points))
}

/// The groups the data determines besides the kinematic parameters and
/// the balls: the scales when machine.json gives their sigmas (for touches
/// too); with poses or points, one instrument frame per session, the body
/// frame when there are poses, for every later session with poses a body
/// origin and a body rotation, and for every later session leg offsets,
/// when the session model has them.
pub(crate) fn groups(dataset: &Dataset) -> Vec<ParameterGroup> {
    let machine = &dataset.machine;
    let tracker = &dataset.tracker;
    let model = &machine.session_model;
    let with_poses = |session: usize| tracker.poses.session.iter().any(|&s| s as usize == session);
    let mut groups = Vec::new();
    if machine.actuator.scale_sigma.is_some() {
        groups.push(ParameterGroup::ActuatorScales);
    }
    if tracker.is_empty() {
        return groups;
    }
    for session in 0..tracker.sessions.len() {
        groups.push(ParameterGroup::TrackerFrame { session });
    }
    if !tracker.poses.is_empty() {
        groups.push(ParameterGroup::BodyFrame);
    }
    for session in 1..tracker.sessions.len() {
        if model.body_origin_sigma.is_some() && with_poses(session) {
            groups.push(ParameterGroup::BodyOrigin { session });
        }
        if model.body_rotation_sigma.is_some() && with_poses(session) {
            groups.push(ParameterGroup::BodyRotation { session });
        }
        if model.leg_offset_sigma.is_some() {
            groups.push(ParameterGroup::LegOffsets { session });
        }
    }
    groups
}

/// The design's parameters (those of the layout) and scales, every
/// correction and offset zero.
pub(crate) fn initial_block(
    layout: &ParameterLayout,
    design: &parcal_kinematics::Params,
    scales: &[f64; 6],
) -> DVector<f64> {
    let mut g = DVector::zeros(layout.size());
    let n = layout.kinematic().len();
    g.rows_mut(0, n).copy_from(&design.rows(0, n));
    if let Some(r) = layout.range(ParameterGroup::ActuatorScales) {
        g.rows_mut(r.start, 6).copy_from_slice(scales);
    }
    g
}

/// Writes the priors of the instrument groups of `layout` into a prior's
/// `mean` and `information`: the scales about their design values
/// (machine.json's `scale_sigma`), the later sessions' body origins, body
/// rotations and leg offsets about zero (`session_model`); none on the
/// frames (the other groups' entries are left as they are).
pub(crate) fn group_priors(
    dataset: &Dataset,
    layout: &ParameterLayout,
    mean: &mut DVector<f64>,
    information: &mut DMatrix<f64>,
) {
    let machine = &dataset.machine;
    let mut diagonal = |start: usize, means: &[f64], sigmas: &[f64]| {
        for (k, (m, s)) in means.iter().zip(sigmas).enumerate() {
            mean[start + k] = *m;
            information[(start + k, start + k)] = 1.0 / (s * s);
        }
    };
    for (group, range) in layout.groups() {
        match *group {
            ParameterGroup::ActuatorScales => {
                let sigmas = machine.actuator.scale_sigma.unwrap_or([f64::INFINITY; 6]);
                diagonal(range.start, &machine.actuator.scale, &sigmas);
            }
            ParameterGroup::BodyOrigin { .. } => {
                let sigma = machine
                    .session_model
                    .body_origin_sigma
                    .unwrap_or(f64::INFINITY);
                diagonal(range.start, &[0.0; 3], &[sigma; 3]);
            }
            ParameterGroup::BodyRotation { .. } => {
                let sigma = machine
                    .session_model
                    .body_rotation_sigma
                    .unwrap_or(f64::INFINITY);
                diagonal(range.start, &[0.0; 3], &[sigma; 3]);
            }
            ParameterGroup::LegOffsets { .. } => {
                let sigma = machine
                    .session_model
                    .leg_offset_sigma
                    .unwrap_or(f64::INFINITY);
                diagonal(range.start, &[0.0; 6], &[sigma; 6]);
            }
            _ => {}
        }
    }
}

/// The RMS of `values`, or `None` without any.
pub(crate) fn rms(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (n, sum) = values.fold((0usize, 0.0), |(n, s), v| (n + 1, s + v * v));
    (n > 0).then(|| (sum / n as f64).sqrt())
}
