//! Each held-out observation predicted by a calibration: its residual
//! rows `r` (observation's units), their own noise covariance `D_i`, and
//! their derivative `G_i = dr/dθ` with respect to the calibration's
//! global block `θ = (p, h)` (the parameters, then the trigger height),
//! through the [`Mechanism`] trait's analytic derivatives.
//!
//! - A probe height, a part distance, a measured point: the observation
//!   kind's own rows ([`parcal_observe::mechanism`]) at `θ̂` and the
//!   controller's configured parameters `p_c`, un-whitened (`r = σ r_w`,
//!   `G = σ dr_w/dθ`, `D = σ²`).
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
//!   pose and `−G_x⁻¹ G_p`.
//! - A point sample at an unknown pose: its pose is its own unknown, fitted
//!   to its readings; with `A` actuators, `A − 3` combinations of the
//!   readings remain, `N_⊥ᵀ (g(p̂, x̂) − q)`, `N_⊥` an orthonormal basis of
//!   the left nullspace of `G_x` (what no pose change can absorb):
//!   `G = N_⊥ᵀ G_p`, `D = σ_q² I`. A delta's (`A = 3`) has no row: its
//!   readings only locate its own pose.
//! - A touch of a ball is refused: its ball's centre is an unknown of its
//!   own, which held-out touches would have to locate first.

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};
use parcal_observe::mechanism::{PointSample, Rows};

use super::data::Observations;
use super::error::MechanismCalibrationError;
use super::observation::{ObservationKind, ObservationRef};

/// The predicted rows of one held-out observation (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct PredictedRows {
    /// The observation.
    pub observation: ObservationRef,
    /// `r`, its residual rows in the observation's units.
    pub residuals: DVector<f64>,
    /// `D_i`, their own noise covariance.
    pub noise: DMatrix<f64>,
    /// `G_i = dr/dθ` (rows × the global block).
    pub d_global: DMatrix<f64>,
}

/// Every observation of `observations` predicted at the global block
/// `global` (`p̂` then, with probes, `ĥ`) with the controller's
/// `configured` parameters (module doc), in the order of the kinds, each
/// kind's in its order; samples at an unknown pose of a mechanism of 3
/// actuators give none; touches of balls are refused (module doc).
pub fn predict(
    mechanism: &dyn Mechanism,
    global: &DVector<f64>,
    configured: &[f64],
    observations: &Observations,
) -> Result<Vec<PredictedRows>, MechanismCalibrationError> {
    let n = mechanism.parameters().len();
    let g = global.len();
    let params = &global.as_slice()[..n];
    let at = |kind, index| ObservationRef { kind, index };
    let failed = |observation, error: MechanismError| MechanismCalibrationError::Observation {
        observation,
        reason: error.to_string(),
    };
    if !observations.touches.is_empty() {
        return Err(MechanismCalibrationError::Observation {
            observation: at(ObservationKind::Touch, 0),
            reason: "held-out touches of balls are not predicted (each ball's centre is an unknown of its own): validate on probe heights, part distances, measured positions or samples".to_string(),
        });
    }
    let mut predicted = Vec::new();
    for (k, probe) in observations.probes.iter().enumerate() {
        let id = at(ObservationKind::Probe, k);
        let trigger =
            global
                .get(n)
                .copied()
                .ok_or_else(|| MechanismCalibrationError::InvalidData {
                    what: "trigger height".to_string(),
                    reason:
                        "probe heights need one, and neither the calibration nor the data give it"
                            .to_string(),
                })?;
        let evaluated = probe
            .evaluate(mechanism, params, configured, trigger)
            .map_err(|e| failed(id, e))?;
        let mut rows = unwhitened(id, &evaluated.rows, &[probe.sigma], g);
        rows.d_global[(0, n)] = evaluated.d_trigger_height * probe.sigma;
        predicted.push(rows);
    }
    for (k, distance) in observations.distances.iter().enumerate() {
        let id = at(ObservationKind::Distance, k);
        let rows = distance
            .evaluate(mechanism, params, configured)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &[distance.sigma], g));
    }
    for (k, point) in observations.points.iter().enumerate() {
        let id = at(ObservationKind::Point, k);
        let rows = point
            .evaluate(mechanism, params, configured)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &point.sigma, g));
    }
    for (k, quantity) in observations.quantities.iter().enumerate() {
        let id = at(ObservationKind::Quantity, k);
        let rows = quantity
            .evaluate(mechanism, params)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &[quantity.sigma], g));
    }
    for (k, sample) in observations.samples.iter().enumerate() {
        let id = at(ObservationKind::Sample, k);
        if let Some(rows) =
            predict_sample(mechanism, params, id, sample, g).map_err(|e| failed(id, e))?
        {
            predicted.push(rows);
        }
    }
    Ok(predicted)
}

/// An observation kind's whitened `rows` back in its units (`σ` per row),
/// its derivative placed in the first columns of `g`.
fn unwhitened(observation: ObservationRef, rows: &Rows, sigma: &[f64], g: usize) -> PredictedRows {
    let m = rows.residual.len();
    let n = rows.d_params.ncols();
    let mut d_global = DMatrix::zeros(m, g);
    for i in 0..m {
        for j in 0..n {
            d_global[(i, j)] = rows.d_params[(i, j)] * sigma[i];
        }
    }
    PredictedRows {
        observation,
        residuals: DVector::from_fn(m, |i, _| rows.residual[i] * sigma[i]),
        noise: DMatrix::from_fn(m, m, |i, j| if i == j { sigma[i] * sigma[i] } else { 0.0 }),
        d_global,
    }
}

/// A point sample's rows (module doc); `None` for one at an unknown pose
/// with no redundant reading.
fn predict_sample(
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
    let pose = mechanism.forward(params, &sample.readings, &start)?;
    let jacobians = mechanism.reading_jacobians(params, pose.as_slice())?;
    let (g_x, g_p) = (&jacobians.d_pose, &jacobians.d_params);
    let (d_params, normal_inverse) = pose_derivative(g_x, g_p)?;
    let variance = sample.sigma * sample.sigma;
    let rows = match sample.known_pose {
        Some((measured, sigma)) => {
            let mut noise = &normal_inverse * variance;
            for k in 0..3 {
                noise[(k, k)] += sigma[k] * sigma[k];
            }
            PredictedRows {
                observation,
                residuals: DVector::from_fn(3, |k, _| pose[k] - measured[k]),
                noise,
                d_global: widened(&d_params, g),
            }
        }
        None => {
            let basis = left_nullspace(g_x, &normal_inverse);
            let predicted = mechanism.inverse(params, pose.as_slice())?;
            let misfit = predicted - DVector::from_column_slice(&sample.readings);
            let m = basis.ncols();
            PredictedRows {
                observation,
                residuals: basis.transpose() * misfit,
                noise: DMatrix::identity(m, m) * variance,
                d_global: widened(&(basis.transpose() * g_p), g),
            }
        }
    };
    Ok(Some(rows))
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

/// `d_params` with zero columns appended up to `g`.
fn widened(d_params: &DMatrix<f64>, g: usize) -> DMatrix<f64> {
    let mut wide = DMatrix::zeros(d_params.nrows(), g);
    wide.columns_mut(0, d_params.ncols()).copy_from(d_params);
    wide
}

/// An orthonormal basis of the left nullspace of `g_x` (`A × 3`): the
/// eigenvectors of eigenvalue 1 of the residual projector
/// `I − G_x (G_xᵀ G_x)⁻¹ G_xᵀ` (its others are 0).
fn left_nullspace(g_x: &DMatrix<f64>, normal_inverse: &DMatrix<f64>) -> DMatrix<f64> {
    let a = g_x.nrows();
    let projector = DMatrix::identity(a, a) - g_x * normal_inverse * g_x.transpose();
    let eigen = ((&projector + projector.transpose()) * 0.5).symmetric_eigen();
    let kept: Vec<usize> = (0..a).filter(|&k| eigen.eigenvalues[k] > 0.5).collect();
    DMatrix::from_fn(a, kept.len(), |i, j| eigen.eigenvectors[(i, kept[j])])
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::cable::CableRobot;
    use parcal_kinematics::mechanism::{design, prior_sigma};

    /// `G_i = dr/dθ` of a cable robot's samples (four lines: the
    /// least-squares pose) against central differences of the predicted
    /// residuals, for a measured position and an unknown one.
    #[test]
    fn sample_derivatives_match_central_differences() {
        let robot = CableRobot::typical();
        let mut params = design(&robot);
        for (k, value) in params.iter_mut().enumerate() {
            *value += 0.3 * ((k as f64) * 1.7).sin();
        }
        let pose = [120.0, -80.0, 400.0];
        let readings: Vec<f64> = robot
            .inverse(params.as_slice(), &pose)
            .unwrap()
            .iter()
            .copied()
            .collect();
        let known = PointSample {
            readings: readings.clone(),
            sigma: 1.0,
            known_pose: Some(([121.0, -79.5, 400.2], [0.1; 3])),
            loads: None,
        };
        let unknown = PointSample {
            readings,
            sigma: 1.0,
            known_pose: None,
            loads: None,
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
