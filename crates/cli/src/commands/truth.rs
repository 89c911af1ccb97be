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

/// The truth of a simulated hexapod `dataset` (none for a real one) as the
/// `parameters` of a calibration through the common path: the true
/// machine's 33 canonical parameters, then its actuators' scales when
/// there are more than 33 (the scales unknown).
pub fn hexapod(dataset: &Dataset, parameters: usize) -> anyhow::Result<Option<Vec<f64>>> {
    let Some(truth) = TrueMachine::of(dataset) else {
        return Ok(None);
    };
    let truth = truth.context("truth.json: the true geometry is degenerate")?;
    let scales = dataset.truth.as_ref().and_then(|t| t.actuator_scale);
    let scales = scales.filter(|_| parameters > N_PARAMS);
    let values = truth.params.iter().copied();
    Ok(Some(values.chain(scales.into_iter().flatten()).collect()))
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
