//! A simulation's truth in the terms of a calibration through the common
//! path: the values `parcal calibrate` and `parcal report --dataset` set
//! beside the estimates.

use std::path::Path;

use anyhow::Context;
use parcal::calibration::mechanism::MechanismData;
use parcal::dataset::mechanism::MechanismDataset;
use parcal::dataset::{Dataset, FrameRecord};
use parcal::kinematics::N_PARAMS;
use parcal::workflows::evaluate::TrueMachine;

/// The truth of a simulated hexapod `dataset` (none for a real one) in the
/// terms of a calibration through the common path of `parameters`
/// parameters and the trackers `trackers` (by label): the true machine's
/// 33 canonical parameters, then its actuators' scales when there are
/// more than 33 (the scales unknown); each tracker's true frame from the
/// true canonical base frame, its session's `tracker_frame` (from
/// machine.json's base frame) composed with the canonical frame's map.
pub fn hexapod(
    dataset: &Dataset,
    parameters: usize,
    trackers: &[&str],
) -> anyhow::Result<Option<MechanismTrue>> {
    let (Some(truth), Some(record)) = (TrueMachine::of(dataset), dataset.truth.as_ref()) else {
        return Ok(None);
    };
    let truth = truth.context("truth.json: the true geometry is degenerate")?;
    let scales = record.actuator_scale.filter(|_| parameters > N_PARAMS);
    let values = truth.params.iter().copied();
    let to_input = truth.base_from_input.inverse();
    let frames = (trackers.iter())
        .map(|label| {
            let session = record.sessions.iter().find(|s| s.label == *label)?;
            Some(FrameRecord::of(
                &(session.tracker_frame.isometry() * to_input),
            ))
        })
        .collect();
    Ok(Some(MechanismTrue {
        values: values.chain(scales.into_iter().flatten()).collect(),
        frames,
    }))
}

/// A simulated mechanism's truth in the terms of its calibration.
pub struct MechanismTrue {
    /// One value per unknown of the global block the record reports
    /// ([`MechanismData::true_values`]).
    pub values: Vec<f64>,
    /// Each tracker's true frame from the canonical frame, as the record's
    /// ([`MechanismData::true_tracker_frames`]).
    pub frames: Vec<Option<FrameRecord>>,
}

/// The truth of the simulated machine of `dataset` (read from `path`, its
/// data `data`) in the terms of its calibration, when it has a
/// truth.json.
pub fn mechanism(
    path: &Path,
    dataset: &MechanismDataset,
    data: &MechanismData,
) -> anyhow::Result<Option<MechanismTrue>> {
    let Some(truth) = &dataset.truth else {
        return Ok(None);
    };
    let failed = |error| anyhow::anyhow!("{}: truth.json: {error}", path.display());
    let values = data.true_values(truth).map_err(failed)?;
    let frames = data.true_tracker_frames(truth).map_err(failed)?;
    Ok(Some(MechanismTrue {
        values,
        frames: (frames.iter())
            .map(|frame| frame.as_ref().map(FrameRecord::of))
            .collect(),
    }))
}
