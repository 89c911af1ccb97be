//! True accuracy maps (simulation only): where the true machine puts its
//! tool tip when the model commands it to the targets (docs/paper-scenario.md section 5).
//!
//! The model computes the actuator values `q_k` of each target; forward
//! kinematics of the TRUE geometry (in its own canonical frames) at `q_k`,
//! started from the model's pose, gives the true tip `f(q_k, p_true)`. The
//! absolute map is `|f(q_k, p_true) - target_c|`; the registered map is the
//! residual after the best rigid motion (Kabsch, proper rotation, no scale)
//! of all true tips onto the targets.

use parcal_kinematics::{ForwardOptions, Geometry, KinematicsError, Params, Vec3, forward};

use crate::kabsch::registered_residuals;
use crate::model::{commands, model_geometry};
use crate::{AccuracyError, AccuracyMap, CanonicalTargets, MapGrid};

/// The true error map of a model with canonical parameters `model` on
/// `grid`, for a machine whose true geometry in its own canonical frames is
/// `truth_canonical`; targets and orientation are mapped into the canonical
/// frames by the `design` geometry's transforms ([`CanonicalTargets`]).
/// Values in mm.
///
/// Errors: an invalid grid or design, a non-finite model or truth, a target
/// the model cannot reach, forward kinematics of the truth failing at a grid
/// point (both naming the point).
pub fn true_error(
    design: &Geometry,
    model: &Params,
    truth_canonical: &Geometry,
    grid: &MapGrid,
) -> Result<AccuracyMap, AccuracyError> {
    true_error_at(
        &CanonicalTargets::new(design, grid)?,
        model,
        truth_canonical,
    )
}

/// [`true_error`] at targets already mapped into the canonical frames (by
/// whichever geometry's transforms, see [`CanonicalTargets::new`]): the
/// model is commanded to `targets` and the true tips are compared with them.
pub fn true_error_at(
    targets: &CanonicalTargets,
    model: &Params,
    truth_canonical: &Geometry,
) -> Result<AccuracyMap, AccuracyError> {
    let tips = true_tips(targets, model, truth_canonical)?;
    let absolute = tips
        .iter()
        .zip(&targets.points)
        .map(|(tip, target)| (tip - target).norm())
        .collect();
    let (residuals, _) = registered_residuals(&tips, &targets.points)?;
    Ok(AccuracyMap {
        grid: targets.grid.clone(),
        absolute,
        registered: residuals.iter().map(|r| r.norm()).collect(),
    })
}

/// The error map of a parameter error `error`: [`true_error`] of the model
/// `model` on a machine whose parameters are `model − error` (canonical,
/// paper eq. 3), so that `error` plays the part of the model's parameter
/// error. What an error of the parameters (e.g. the shift an undetected
/// blunder makes) does to the tool tip; its registered map is, to first
/// order, `|(P J)_k error|` ([`crate::registered_jacobians`]).
pub fn parameter_error(
    design: &Geometry,
    model: &Params,
    error: &Params,
    grid: &MapGrid,
) -> Result<AccuracyMap, AccuracyError> {
    let machine = model_geometry(&(model - error))?;
    true_error(design, model, &machine, grid)
}

/// The true tips `f(q_k, p_true)` (canonical base frame of the truth, mm)
/// at the actuator values the model commands for each target, in map order.
pub fn true_tips(
    targets: &CanonicalTargets,
    model: &Params,
    truth_canonical: &Geometry,
) -> Result<Vec<Vec3>, AccuracyError> {
    let geometry = model_geometry(model)?;
    if let Err(error) = truth_canonical.check_finite() {
        let what = match error {
            KinematicsError::NonFinite { what } => format!("true {what}"),
            other => other.to_string(),
        };
        return Err(AccuracyError::NonFinite { what });
    }
    let options = ForwardOptions::default();
    commands(&geometry, targets)?
        .iter()
        .zip(targets.grid.points())
        .map(|(command, point)| {
            forward(truth_canonical, &command.q, &command.pose, &options)
                .map(|solution| truth_canonical.tool_tip(&solution.pose))
                .map_err(|source| AccuracyError::TrueForward {
                    x: point.x,
                    y: point.y,
                    source,
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::{paper, params};

    #[test]
    fn a_model_equal_to_the_truth_has_no_error() {
        // The model is the truth itself (in the truth's canonical frames):
        // the truth's tip lands exactly where the model puts it, on target_c.
        let truth = paper::truth().canonicalize().unwrap().geometry;
        let model = params::to_params(&truth);
        let map = true_error(&paper::design(), &model, &truth, &MapGrid::paper()).unwrap();
        assert_eq!(map.absolute.len(), 441);
        let (absolute, registered) = (map.absolute_summary(), map.registered_summary());
        println!("model = truth: absolute {absolute}, registered {registered}");
        assert!(absolute.max < 1e-9, "absolute max {:e} mm", absolute.max);
        assert!(
            registered.max < 1e-9,
            "registered max {:e} mm",
            registered.max
        );
    }

    #[test]
    fn a_parameter_error_maps_as_its_registered_jacobians() {
        // A small error along every parameter: the map is linear in it.
        let design = paper::design();
        let model = params::to_params(&design.canonicalize().unwrap().geometry);
        let error = Params::from_fn(|k, _| 1e-4 * ((k % 7) as f64 - 3.0));
        let grid = MapGrid::square(100.0, 50.0, 400.0);
        let map = parameter_error(&design, &model, &error, &grid).unwrap();
        let targets = CanonicalTargets::new(&design, &grid).unwrap();
        let jacobians = crate::registered_jacobians(&targets, &model).unwrap();
        let mut worst: f64 = 0.0;
        for (value, j) in map.registered.iter().zip(&jacobians) {
            worst = worst.max((value - (j * error).norm()).abs());
        }
        let rms = map.registered_summary().rms;
        println!("registered RMS {rms:.3e} mm, linear within {worst:.1e} mm");
        // Second order in an error of 1e-4 (mm, rad) over lengths of 1e2.
        assert!(rms > 1e-4 && worst < 1e-3 * rms, "{worst:e} of {rms:e}");
        let zero = parameter_error(&design, &model, &Params::zeros(), &grid).unwrap();
        assert!(zero.registered_summary().max < 1e-9);
    }

    #[test]
    fn a_failing_true_forward_kinematics_names_the_grid_point() {
        // True leg 3 so short that l + q <= 0 at every commanded q.
        let design = paper::design();
        let model = params::to_params(&design.canonicalize().unwrap().geometry);
        let mut truth = paper::truth().canonicalize().unwrap().geometry;
        truth.legs[2] = -1000.0;
        let error = true_error(&design, &model, &truth, &MapGrid::paper()).unwrap_err();
        let message = error.to_string();
        assert!(
            message.starts_with("grid point (x = -100 mm, y = -100 mm): forward kinematics of the true geometry failed: leg 3 is infeasible"),
            "{message}"
        );
        truth.tool.y = f64::INFINITY;
        let error = true_error(&design, &model, &truth, &MapGrid::paper()).unwrap_err();
        assert_eq!(error.to_string(), "true tool is not a finite number");
    }
}
