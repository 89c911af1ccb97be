//! A held-out point sample's rows ([`predict_sample`]).
//!
//! - A point sample whose position `m` was measured: the position its
//!   readings `q` imply, `x̂ = f(p̂, q)`, against `m` (3 rows, mm):
//!
//!   ```text
//!   r = x̂ − m,   G = dx/dp|_q = −G_x⁺ G_p,   D = Σ_m + σ_q² (G_xᵀ G_x)⁻¹,
//!   ```
//!
//!   `x̂` the forward kinematics: for more actuators than coordinates the
//!   maximum-likelihood pose of readings of equal noise `σ_q` (least
//!   squares in the readings, `parcal_kinematics::pose_fit`), `G_x⁺ =
//!   (G_xᵀ G_x)⁻¹ G_xᵀ`; for as many actuators as coordinates, the exact
//!   pose and `−G_x⁻¹ G_p` ([`pose_derivative`]).
//! - A point sample at an unknown pose: its pose is its own unknown, fitted
//!   to its readings; with `A` actuators, `A − 3` combinations of the
//!   readings remain, what no pose change can absorb (the local unknown
//!   projected out, [`super::projection`]): `r = g(p̂, x̂) − q`, `dr/dx = G_x`,
//!   `dr/dp = G_p`, `Σ = σ_q² I`, so `D = σ_q² I`. A delta's (`A = 3`)
//!   has no row: its readings only locate their own pose.
//! - A sample whose actuators' loads were recorded (a cable robot's, its
//!   lines elastic): `g` is then the readings under those loads
//!   (`Mechanism::loaded_readings`, as the calibration weighs the sample),
//!   `G_x` and `G_p` their derivatives, and `x̂` the pose whose loaded
//!   readings are nearest `q` in least squares
//!   ([`least_squares_pose_under_loads`]).

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError, forward_under_loads};
use parcal_observe::mechanism::PointSample;

use super::super::observation::{HeldOut, ObservationRef};
use super::projection::{LocalRows, project_out};
use super::rows::{PredictedRows, widened};

/// How far (mm) the pose of a sample under loads may still move when its
/// search stops ([`least_squares_pose_under_loads`]): far below any
/// measured position's noise.
const LOADED_POSE_TOLERANCE: f64 = 1e-9;
/// The most Gauss-Newton steps [`least_squares_pose_under_loads`] takes.
const LOADED_POSE_STEPS: usize = 20;

/// A point sample's rows (module doc), its readings those under its loads
/// when it recorded them ([`Mechanism::loaded_readings`], as the
/// calibration weighs them); `None` for one at an unknown pose with no
/// redundant reading.
pub(super) fn predict_sample(
    mechanism: &dyn Mechanism,
    params: &[f64],
    observation: ObservationRef,
    sample: &PointSample,
    g: usize,
) -> Result<Option<PredictedRows>, MechanismError> {
    let actuators = mechanism.actuators().len();
    if sample.known_pose.is_none() && actuators <= 3 {
        return Ok(None);
    }
    let start = sample.known_pose.map_or([0.0; 3], |(pose, _)| pose);
    let (pose, predicted, jacobians) = match &sample.loads {
        Some(loads) => {
            let pose = least_squares_pose_under_loads(mechanism, params, sample, loads, &start)?;
            let (predicted, jacobians) =
                mechanism.loaded_readings(params, pose.as_slice(), loads)?;
            (pose, predicted, jacobians)
        }
        None => {
            let pose = mechanism.forward(params, &sample.readings, &start)?;
            let predicted = mechanism.inverse(params, pose.as_slice())?;
            let jacobians = mechanism.reading_jacobians(params, pose.as_slice())?;
            (pose, predicted, jacobians)
        }
    };
    let (g_x, g_p) = (&jacobians.d_pose, &jacobians.d_params);
    let variance = sample.sigma * sample.sigma;
    let rows = match sample.known_pose {
        Some((measured, sigma)) => {
            let (d_params, normal_inverse) = pose_derivative(g_x, g_p)?;
            let mut noise = &normal_inverse * variance;
            for k in 0..3 {
                noise[(k, k)] += sigma[k] * sigma[k];
            }
            PredictedRows {
                observation: HeldOut::Observation(observation),
                residuals: DVector::from_fn(3, |k, _| pose[k] - measured[k]),
                noise,
                d_global: widened(&d_params, g),
                row_observations: Vec::new(),
                mirrored_balls: Vec::new(),
            }
        }
        None => {
            let local = LocalRows {
                residuals: predicted - DVector::from_column_slice(&sample.readings),
                d_local: g_x,
                d_params: g_p,
                noise: DMatrix::identity(actuators, actuators) * variance,
            };
            // J = G_x: a pose its readings do not locate is a singular one.
            project_out(HeldOut::Observation(observation), &local, g)
                .ok_or(MechanismError::Singular)?
        }
    };
    Ok(Some(rows))
}

/// The pose whose readings under `loads` are nearest `sample`'s in least
/// squares, `min_x |q_F(p, x) − q|²` (the pose the calibration fits
/// them with): Gauss-Newton steps `δx = −(G_xᵀ G_x)⁻¹ G_xᵀ (q_F − q)`,
/// `G_x` the loaded readings' derivative, from the forward kinematics
/// under loads ([`forward_under_loads`], which weighs the readings by the
/// rigid lines' derivative instead); an error if it does not settle.
fn least_squares_pose_under_loads(
    mechanism: &dyn Mechanism,
    params: &[f64],
    sample: &PointSample,
    loads: &[f64],
    start: &[f64],
) -> Result<DVector<f64>, MechanismError> {
    let q = DVector::from_column_slice(&sample.readings);
    let mut pose = forward_under_loads(
        mechanism,
        params,
        &sample.readings,
        loads,
        start,
        LOADED_POSE_TOLERANCE,
    )?;
    for _ in 0..LOADED_POSE_STEPS {
        let (loaded, jacobians) = mechanism.loaded_readings(params, pose.as_slice(), loads)?;
        let g_x = &jacobians.d_pose;
        let step = (g_x.transpose() * g_x)
            .lu()
            .solve(&(g_x.transpose() * (loaded - &q)))
            .ok_or(MechanismError::Singular)?;
        pose = mechanism.retract(pose.as_slice(), (-&step).as_slice());
        if step.norm() < LOADED_POSE_TOLERANCE {
            return Ok(pose);
        }
    }
    Err(MechanismError::Unreachable {
        reason: format!(
            "the least-squares pose under loads {loads:?} did not settle in {LOADED_POSE_STEPS} steps"
        ),
    })
}

/// `dx/dp|_q = −G_x⁺ G_p` of the readings' least-squares pose (module
/// doc), and `(G_xᵀ G_x)⁻¹`; an error at a singular configuration.
pub fn pose_derivative(
    g_x: &DMatrix<f64>,
    g_p: &DMatrix<f64>,
) -> Result<(DMatrix<f64>, DMatrix<f64>), MechanismError> {
    let normal_inverse = (g_x.transpose() * g_x)
        .try_inverse()
        .filter(|m| m.iter().all(|v| v.is_finite()))
        .ok_or(MechanismError::Singular)?;
    let d_params = -(&normal_inverse * g_x.transpose() * g_p);
    Ok((d_params, normal_inverse))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::observation::ObservationKind;
    use parcal_kinematics::cable::{CableRobot, Elasticity};
    use parcal_kinematics::mechanism::{design, prior_sigma};

    /// `G_i = dr/dθ` of a cable robot's samples (four lines: the
    /// least-squares pose) against central differences of the predicted
    /// residuals, for a measured position and an unknown one; of rigid
    /// lines, and of elastic lines under loads other than the zeroing
    /// ones (the readings and pose under loads).
    #[test]
    fn sample_derivatives_match_central_differences() {
        check_sample_derivatives(CableRobot::typical(), None);
        let zero_loads = vec![14.0, 13.0, 15.0, 12.0];
        let elastic = CableRobot::typical()
            .with_elasticity(Elasticity::typical(vec![0, 1, 2, 3], zero_loads))
            .unwrap();
        check_sample_derivatives(elastic, Some(vec![9.0, 21.0, 11.0, 30.0]));
    }

    fn check_sample_derivatives(robot: CableRobot, loads: Option<Vec<f64>>) {
        let mut params = design(&robot);
        for (k, value) in params.iter_mut().enumerate() {
            *value += 0.3 * ((k as f64) * 1.7).sin();
        }
        let pose = [120.0, -80.0, 400.0];
        let readings: Vec<f64> = match &loads {
            Some(loads) => {
                robot
                    .loaded_readings(params.as_slice(), &pose, loads)
                    .unwrap()
                    .0
            }
            None => robot.inverse(params.as_slice(), &pose).unwrap(),
        }
        .iter()
        .copied()
        .collect();
        let known = PointSample {
            readings: readings.clone(),
            sigma: 1.0,
            known_pose: Some(([121.0, -79.5, 400.2], [0.1; 3])),
            loads: loads.clone(),
        };
        let unknown = PointSample {
            readings,
            sigma: 1.0,
            known_pose: None,
            loads,
        };
        let n = params.len();
        let id = ObservationRef {
            kind: ObservationKind::Sample,
            index: 0,
        };
        let steps = prior_sigma(&robot) * 1e-4;
        for sample in [&known, &unknown] {
            let at = |p: &DVector<f64>| {
                predict_sample(&robot, p.as_slice(), id, sample, n)
                    .unwrap()
                    .unwrap()
            };
            let analytic = at(&params).d_global;
            for k in 0..n {
                let (mut plus, mut minus) = (params.clone(), params.clone());
                plus[k] += steps[k];
                minus[k] -= steps[k];
                let column = (at(&plus).residuals - at(&minus).residuals) / (2.0 * steps[k]);
                let error = (&column - analytic.column(k)).amax();
                assert!(
                    error < 1e-6 * analytic.amax(),
                    "column {k}: {error:e} against {:e}",
                    analytic.amax()
                );
            }
        }
        // The unknown pose leaves one combination of the four readings.
        assert_eq!(at_rows(&robot, &params, &unknown), 1);
    }

    fn at_rows(robot: &CableRobot, params: &DVector<f64>, sample: &PointSample) -> usize {
        let id = ObservationRef {
            kind: ObservationKind::Sample,
            index: 0,
        };
        predict_sample(robot, params.as_slice(), id, sample, params.len())
            .unwrap()
            .unwrap()
            .residuals
            .len()
    }
}
