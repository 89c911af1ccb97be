//! A ball-touch calibration applied to touches it was not fitted on.
//!
//! The calibrated geometry is held; each contact's tool tip follows by
//! forward kinematics (paper eq. 2) and its residual is its distance to
//! the ball's surface, `|f(q, p) − C| − r` (paper eq. 9, mm). Each ball's
//! centre is fitted on its first `N` contacts with the calibrated radius
//! (the artefact may have moved, or be another one), and its other
//! contacts are predicted. The calibrated centres are not used: their
//! errors are correlated with the parameters' (a rigid motion of the
//! canonical base frame moves both), and calibration.json keeps only their
//! marginal sigmas. Reference touches on one side of a ball, nearly in
//! one plane, fit the centre's mirror image through that plane about as
//! well (`crate::mirror`): give enough of them, spread over the ball.
//!
//! The predicted residual of a contact, to first order, is
//! `δr = G δp − n K ε_ref + ε`, `G = nᵀ J_f − n K B`: `n` its normal, `J_f`
//! its tip's parameter Jacobian, `K = (AᵀWA)⁻¹AᵀW` the centre fit's gain on
//! the reference contacts (rows `A` their normals, `W` their weights, `B`
//! their `nᵀ J_f`), `ε` the noise (paper eq. 5's radius row, the
//! repeatabilities propagated). Its variance is `G Σ_p Gᵀ + nᵀ Σ_C n + σ²`,
//! `Σ_C = (AᵀWA)⁻¹`.

use nalgebra::{Matrix3, SMatrix};
use parcal_dataset::{Calibration, Dataset};
use parcal_kinematics::{
    ForwardOptions, Geometry, N_PARAMS, PARAM_NAMES, Vec3, forward_from_home, tip_jacobians,
};
use parcal_observe::{Repeatability, WeightModel, radius_variance};

use crate::CalibrateError;
use crate::instruments::Validation;
use crate::sphere_fit::best_fit;

/// Applies the ball-touch `calibration` to the touches of `dataset` (module
/// doc).
pub fn validate_touches(
    dataset: &Dataset,
    calibration: &Calibration,
    reference: Option<usize>,
) -> Result<Validation, CalibrateError> {
    crate::validate(dataset)?;
    let refuse = |reason: String| CalibrateError::Calibration { reason };
    let names = &calibration.parameters.names;
    if names.len() < N_PARAMS || names[..N_PARAMS] != PARAM_NAMES {
        return Err(refuse(
            "its parameters are not the 33 kinematic parameters of a ball-touch calibration".into(),
        ));
    }
    if calibration.covariance.len() != names.len() {
        return Err(refuse(
            "it has no covariance (the calibration did not converge)".into(),
        ));
    }
    let covariance =
        SMatrix::<f64, N_PARAMS, N_PARAMS>::from_fn(|i, j| calibration.covariance[i][j]);
    let c = &calibration.canonical;
    let geometry =
        Geometry::from_arrays(&c.base_joints, &c.platform_joints, &c.tool, &c.leg_lengths);
    let machine = &dataset.machine.repeatability;
    let forward = ForwardOptions::default();
    let measurements = &dataset.measurements;
    let Some(n_ref) = reference else {
        return Err(refuse(
            "a ball-touch validation fits each ball's centre on its first touches: give their number (at least 4)".into(),
        ));
    };
    let (mut residuals, mut sigmas) = (Vec::new(), Vec::new());
    for (k, ball) in dataset.artefacts.balls.iter().enumerate() {
        let rows: Vec<usize> = (0..measurements.len())
            .filter(|&row| measurements.ball[row] as usize == k)
            .collect();
        let mut tips = Vec::with_capacity(rows.len());
        for &row in &rows {
            let solution = forward_from_home(&geometry, &measurements.q[row], &forward)
                .map_err(|source| CalibrateError::ForwardKinematics { row, source })?;
            tips.push((
                row,
                tip_jacobians(&geometry, &solution),
                geometry.tool_tip(&solution.pose),
            ));
        }
        if rows.len() <= n_ref {
            return Err(refuse(format!(
                "ball {:?} has {} contacts: none is left to predict after the {n_ref} reference contacts",
                ball.id,
                rows.len()
            )));
        }
        let points: Vec<Vec3> = tips[..n_ref].iter().map(|(.., tip)| *tip).collect();
        let centre_fit_error = |source| CalibrateError::CentreFit {
            ball: ball.id.clone(),
            source,
        };
        let centre = best_fit(&points, ball.radius)
            .map_err(centre_fit_error)?
            .centre;
        // The centre fit linearised: A (normals), W, B (nᵀ J_f).
        let mut information = Matrix3::zeros();
        let mut weighted = Vec::with_capacity(n_ref);
        for (row, jacobians, tip) in &tips[..n_ref] {
            let normal = (tip - centre).normalize();
            let variance =
                contact_variance(machine, ball.radius_sigma, &jacobians.d_q, &normal, *row)?;
            information += normal * normal.transpose() / variance;
            weighted.push((normal / variance, normal.transpose() * jacobians.d_params));
        }
        let centre_covariance = information.try_inverse().ok_or_else(|| {
            refuse(format!(
                "the reference contacts of ball {:?} do not determine its centre",
                ball.id
            ))
        })?;
        // K B: the centre's first-order response to the parameters (3 x 33).
        let response: SMatrix<f64, 3, N_PARAMS> = weighted
            .iter()
            .map(|(a, b)| centre_covariance * a * b)
            .sum();
        for (row, jacobians, tip) in &tips[n_ref.min(tips.len())..] {
            let offset = tip - centre;
            let distance = offset.norm();
            if distance == 0.0 {
                return Err(CalibrateError::InvalidDataset {
                    row: Some(*row),
                    field: "q".into(),
                    message: "the tool tip is at the ball's centre".into(),
                });
            }
            let normal = offset / distance;
            let d_params = normal.transpose() * (jacobians.d_params - response);
            let noise =
                contact_variance(machine, ball.radius_sigma, &jacobians.d_q, &normal, *row)?;
            let variance = noise
                + (d_params * covariance * d_params.transpose())[0]
                + normal.dot(&(centre_covariance * normal));
            residuals.push(distance - ball.radius);
            sigmas.push(variance.sqrt());
        }
    }
    Ok(Validation {
        poses: 0,
        points: 0,
        contacts: residuals.len(),
        reference: n_ref,
        refitted: vec!["ball centres".into()],
        selection: Vec::new(),
        residuals,
        predicted_sigmas: sigmas,
    })
}

/// The variance of a contact's radius row (mm²): the repeatabilities
/// propagated (paper eq. 5).
fn contact_variance(
    machine: &parcal_dataset::Repeatability,
    radius_sigma: f64,
    d_q: &nalgebra::Matrix3x6<f64>,
    normal: &Vec3,
    row: usize,
) -> Result<f64, CalibrateError> {
    let repeatability = Repeatability {
        actuator: machine.actuator,
        tool: machine.tool,
        radius: radius_sigma,
    };
    radius_variance(WeightModel::Propagated, &repeatability, d_q, normal)
        .map_err(|source| CalibrateError::Observation { row, source })
}
