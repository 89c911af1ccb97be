//! The accuracy the calibration predicts at commanded targets, after the
//! user's rigid registration (the registered map of parcal-accuracy's
//! `predicted`, at any targets and orientations).
//!
//! At each command's pose, mapped back into the canonical frames
//! (`P_c = M_b^-1 P M_p`, `M_b`, `M_p` the placement), the tip Jacobian
//! `J_k = dT/dp` (3 x 33, fixed readings, docs/formulation.md section 5)
//! propagates the posterior covariance `Σ_p`; the rigid-motion directions of
//! the target cloud are removed (`parcal_accuracy::remove_rigid_motions`),
//! and the value at target `k` is `sqrt(trace(J_k Σ_p J_kᵀ))` (mm). The
//! uncertainty of calibrated actuator scales is not included.

use nalgebra::{Rotation3, SMatrix, Translation3, UnitQuaternion};
use parcal_accuracy::{RigidMotion, remove_rigid_motions};
use parcal_kinematics::{Pose, Vec3, tip_jacobians_at};
use rayon::prelude::*;

use crate::{AppliedModel, ApplyError, Command};

fn isometry(motion: &RigidMotion) -> Pose {
    Pose::from_parts(
        Translation3::from(motion.translation),
        UnitQuaternion::from_rotation_matrix(&Rotation3::from(motion.rotation)),
    )
}

/// The predicted registered tip error at each command (module doc), mm.
/// Errors: no covariance in the calibration, a singular pose (naming the
/// row), fewer than three or collinear targets.
pub fn predicted_registered(
    model: &AppliedModel,
    commands: &[Command],
) -> Result<Vec<f64>, ApplyError> {
    let covariance = model.covariance.as_ref().ok_or_else(|| {
        ApplyError::Missing(
            "calibration.json has no covariance of the 33 kinematic parameters to predict the accuracy (none was computed, or the calibration left some out: the tool of poses alone)"
                .into(),
        )
    })?;
    let (base_inverse, platform) = (
        isometry(&model.placement.base).inverse(),
        isometry(&model.placement.platform),
    );
    // Each command's tip and Jacobian on the threads, written in place; the
    // first row that fails, on any number of threads, is named.
    let n = commands.len();
    let (mut points, mut jacobians) = (vec![Vec3::zeros(); n], vec![SMatrix::zeros(); n]);
    let failed = (points.par_iter_mut().zip(&mut jacobians).zip(commands))
        .enumerate()
        .filter_map(|(k, ((point, jacobian), command))| {
            let pose_c = base_inverse * command.pose * platform;
            match tip_jacobians_at(&model.canonical, &pose_c) {
                Ok(tip) => {
                    *point = model.canonical.tool_tip(&pose_c);
                    *jacobian = tip.d_params;
                    None
                }
                Err(e) => Some((k, e)),
            }
        })
        .min_by_key(|&(k, _)| k);
    if let Some((k, e)) = failed {
        return Err(ApplyError::Prediction(format!("row {}: {e}", k + 1)));
    }
    remove_rigid_motions(&points, &mut jacobians)
        .map_err(|e| ApplyError::Prediction(e.to_string()))?;
    Ok(jacobians
        .par_iter()
        .map(|j| (j * covariance).component_mul(j).sum().max(0.0).sqrt())
        .collect())
}

/// RMS of a set of values.
pub fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// The residuals after the best rigid motion of `achieved` onto `targets`
/// (what a user's registration leaves), as distances (mm).
pub fn registered_errors(achieved: &[Vec3], targets: &[Vec3]) -> Result<Vec<f64>, ApplyError> {
    parcal_accuracy::kabsch::registered_residuals(achieved, targets)
        .map(|(residuals, _)| residuals.iter().map(|r| r.norm()).collect())
        .map_err(|e| ApplyError::Prediction(e.to_string()))
}
