//! The model being assessed, commanded to the map's targets.

use nalgebra::Translation3;
use parcal_kinematics::{
    Geometry, KinematicsError, PARAM_NAMES, Params, Pose, Vec3, leg_lengths, params,
};

use crate::{AccuracyError, CanonicalTargets};

/// The model's command for one target: the pose that puts the model's tool
/// tip on it and the actuator values of that pose.
#[derive(Debug, Clone)]
pub(crate) struct Command {
    /// Pose of the platform in the canonical base frame (model's belief).
    pub pose: Pose,
    /// Actuator values by the model's inverse kinematics (mm).
    pub q: [f64; 6],
}

/// The canonical geometry of the model's parameters, refusing non-finite
/// values (naming the parameter).
pub(crate) fn model_geometry(model: &Params) -> Result<Geometry, AccuracyError> {
    if let Some(k) = model.iter().position(|v| !v.is_finite()) {
        let what = format!("model parameter {}", PARAM_NAMES[k]);
        return Err(AccuracyError::NonFinite { what });
    }
    Ok(params::from_params(model))
}

/// Commands the model to every target at the map orientation `R_c`:
/// `t = target_c - R_c E_T(p)`, `q = L(pose) - l` (paper eq. 1). A leg of
/// non-positive or non-finite length `l + q` makes the target unreachable,
/// an error naming the grid point.
pub(crate) fn commands(
    model: &Geometry,
    targets: &CanonicalTargets,
) -> Result<Vec<Command>, AccuracyError> {
    let rotation = targets.orientation;
    let offset = rotation * model.tool;
    targets
        .points
        .iter()
        .zip(targets.grid.points())
        .map(|(target, point)| {
            let pose = Pose::from_parts(Translation3::from(target - offset), rotation);
            let lengths = leg_lengths(model, &pose);
            if let Some(i) = lengths.iter().position(|l| !(l.is_finite() && *l > 0.0)) {
                let source = KinematicsError::InfeasibleLeg {
                    leg: i + 1,
                    length: lengths[i],
                };
                return Err(unreachable(&point, source));
            }
            let q = std::array::from_fn(|i| lengths[i] - model.legs[i]);
            Ok(Command { pose, q })
        })
        .collect()
}

/// The error for a grid point the model cannot serve.
pub(crate) fn unreachable(point: &Vec3, source: KinematicsError) -> AccuracyError {
    AccuracyError::Unreachable {
        x: point.x,
        y: point.y,
        source,
    }
}
