//! The calibrated machine.json, in the design frame, so that it can be the
//! design of the next calibration.

use parcal_dataset::{Actuator, Calibration, GeometryRecord, Machine};

use crate::{AppliedModel, ApplyError};

/// The calibrated machine: the placed calibrated geometry
/// ([`crate::place`]) and the calibrated scales, with the design's unit,
/// priors, repeatability, session model and stroke (what the calibration
/// started from); `actuator.scale_sigma` keeps the design's a-priori sigma
/// of the scales (absent: the scales are taken as known, as before).
pub fn calibrated_machine(
    record: &Calibration,
    model: &AppliedModel,
) -> Result<Machine, ApplyError> {
    let design = record
        .design
        .as_ref()
        .ok_or_else(|| ApplyError::Missing("calibration.json has no `design`".to_string()))?;
    let g = &model.calibrated;
    Ok(Machine {
        geometry: GeometryRecord {
            base_joints: g.base.map(Into::into),
            platform_joints: g.platform.map(Into::into),
            tool: g.tool.into(),
            leg_lengths: g.legs,
        },
        actuator: Actuator {
            unit: model.unit.clone(),
            scale: model.scale,
            scale_sigma: design.actuator.scale_sigma,
        },
        ..design.clone()
    })
}
