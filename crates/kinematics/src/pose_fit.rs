//! The least-squares pose of a mechanism's readings: the forward
//! kinematics of a mechanism with more actuators than pose coordinates
//! (a cable robot's redundant lines), whose readings no pose matches
//! exactly once they carry noise.
//!
//! With `g(p, x)` the inverse kinematics, `q` the readings and
//! `G_x = dg/dx`, Gauss–Newton from a start pose `x_0`:
//!
//! ```text
//! x_{k+1} = x_k − (G_xᵀ G_x)⁻¹ G_xᵀ (g(p, x_k) − q),
//! ```
//!
//! minimising `|g(p, x) − q|²`: every reading weighted alike, so the
//! maximum-likelihood pose of readings of one noise, as the calibration
//! weights a sample's readings (one standard deviation for all,
//! `parcal_observe::mechanism::PointSample`). The pose a calibration
//! predicts for a sample and the mechanism's forward kinematics are then
//! one.

use nalgebra::{DMatrix, DVector};

use crate::mechanism::{Mechanism, MechanismError, check_vector};

/// The largest number of Gauss–Newton steps.
const ITERATIONS: usize = 100;
/// Convergence: a step shorter than this (the pose's units, mm).
const TOLERANCE: f64 = 1e-10;

/// The pose whose readings at `params` best match `readings` in least
/// squares (module doc), from `start`. An error at a singular
/// configuration or when the steps do not settle.
pub fn pose_of_readings<M: Mechanism + ?Sized>(
    mechanism: &M,
    params: &[f64],
    readings: &[f64],
    start: &[f64],
) -> Result<DVector<f64>, MechanismError> {
    check_vector(mechanism, "readings", readings, mechanism.actuators().len())?;
    check_vector(
        mechanism,
        "start pose coordinates",
        start,
        mechanism.pose_coordinates().len(),
    )?;
    let q = DVector::from_column_slice(readings);
    least_squares_pose(start, |pose| {
        let misfit = mechanism.inverse(params, pose)? - &q;
        Ok((misfit, mechanism.reading_jacobians(params, pose)?.d_pose))
    })
    .map_err(|error| match error {
        MechanismError::Unreachable { .. } => MechanismError::Unreachable {
            reason: format!(
                "the readings {readings:?} have no least-squares pose: Gauss-Newton did not settle in {ITERATIONS} steps"
            ),
        },
        other => other,
    })
}

/// The pose minimising `|e(x)|²` by Gauss–Newton from `start`, with
/// `residuals(x)` giving `e(x)` and `de/dx`: the one fit behind
/// [`pose_of_readings`], for any residuals of the pose (a fit of other
/// quantities than the readings weights them otherwise; the caller says
/// how by what `e` holds). An error at a singular `de/dx` or when the
/// steps do not settle.
pub fn least_squares_pose(
    start: &[f64],
    residuals: impl Fn(&[f64]) -> Result<(DVector<f64>, DMatrix<f64>), MechanismError>,
) -> Result<DVector<f64>, MechanismError> {
    let mut pose = DVector::from_column_slice(start);
    for _ in 0..ITERATIONS {
        let (misfit, jacobian) = residuals(pose.as_slice())?;
        let step = (jacobian.transpose() * &jacobian)
            .cholesky()
            .map(|normal| -normal.solve(&(jacobian.transpose() * misfit)))
            .filter(|step| step.iter().all(|v| v.is_finite()))
            .ok_or(MechanismError::Singular)?;
        pose += &step;
        if step.norm() < TOLERANCE {
            return Ok(pose);
        }
    }
    Err(MechanismError::Unreachable {
        reason: format!("Gauss-Newton did not settle in {ITERATIONS} steps"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cable::CableRobot;
    use crate::mechanism::design;

    /// With readings no pose matches (each off by a few degrees), the fit
    /// is the least-squares pose: its gradient `G_xᵀ (g(p, x̂) − q)`
    /// vanishes and every small move of the pose raises `|g(p, x) − q|²`.
    #[test]
    fn the_fit_minimises_the_readings_misfit() {
        let robot = CableRobot::typical();
        let p = design(&robot);
        let exact = robot.inverse(p.as_slice(), &[150.0, -90.0, 700.0]).unwrap();
        let readings: Vec<f64> = exact
            .iter()
            .zip([3.0, -2.0, 4.0, -5.0])
            .map(|(q, e)| q + e)
            .collect();
        let pose = pose_of_readings(&robot, p.as_slice(), &readings, &[0.0; 3]).unwrap();
        let q = DVector::from_column_slice(&readings);
        let misfit = |x: &[f64]| (robot.inverse(p.as_slice(), x).unwrap() - &q).norm_squared();
        let g_x = robot
            .reading_jacobians(p.as_slice(), pose.as_slice())
            .unwrap()
            .d_pose;
        let residual = robot.inverse(p.as_slice(), pose.as_slice()).unwrap() - &q;
        let gradient = g_x.transpose() * &residual;
        assert!(
            gradient.amax() < 1e-9 * g_x.amax() * residual.amax(),
            "{gradient}"
        );
        let least = misfit(pose.as_slice());
        // No pose matches them: a combination of the errors stays.
        assert!(least > 1e-3, "{least}");
        for k in 0..3 {
            for step in [-0.01, 0.01] {
                let mut moved = pose.clone();
                moved[k] += step;
                assert!(misfit(moved.as_slice()) > least, "axis {k}, step {step}");
            }
        }
        let error = pose_of_readings(&robot, p.as_slice(), &readings[..3], &[0.0; 3]).unwrap_err();
        assert!(error.to_string().contains("readings"), "{error}");
    }
}
