//! A ball-touch calibration applied to touches it was not fitted on.
//!
//! The calibrated geometry and actuator scales are held; each contact's
//! tool tip follows by forward kinematics (paper eq. 2) at its leg
//! extensions `s_i q_i` and its residual is its distance to
//! the ball's surface, `|f(q, p) − C| − r` (paper eq. 9, mm). Each ball's
//! centre is fitted on its first `N` contacts with the calibrated radius
//! (the artefact may have moved, or be another one), and its other
//! contacts are predicted. The calibrated centres are not used: their
//! errors are correlated with the parameters' (a rigid motion of the
//! canonical base frame moves both), and calibration.json keeps only their
//! marginal sigmas. Reference touches on one side of a ball, near one
//! circle, fit the centre's mirror image through their plane about as
//! well: the image all its touches fit is then kept and the ball named
//! ([`crate::mirror::located_side`]); enough reference touches, spread
//! over the ball, tell the images apart by themselves.
//!
//! The predicted residual of a contact, to first order, is
//! `δr = G δp − n K ε_ref + ε`, `G = nᵀ J_f − n K B`: `n` its normal, `J_f`
//! its tip's Jacobian on the calibrated parameters `p` (the 33 and, when
//! the calibration identified them, the scales `s_1..s_6`:
//! `dT/ds_i = q_i dT/dl_i`), `K = (AᵀWA)⁻¹AᵀW` the centre fit's gain on
//! the reference contacts (rows `A` their normals, `W` their weights, `B`
//! their `nᵀ J_f`), `ε` the noise (paper eq. 5's radius row, the
//! repeatabilities propagated). Its variance is `G Σ_p Gᵀ + nᵀ Σ_C n + σ²`,
//! `Σ_C = (AᵀWA)⁻¹`. The contacts share the parameters' error, and a
//! ball's contacts its centre's: their covariance is `C = D + U Uᵀ`, `D`
//! the contacts' noise `σ²` and a row of `U` `[G Σ_p^{1/2}, nᵀ Σ_C^{1/2}]`
//! (the second block in its ball's three columns), and `rᵀ C⁻¹ r` gives the
//! verdict ([`crate::prediction`]), each ball's columns eliminated in turn
//! ([`crate::prediction::grouped_statistic`]): neither `U`, with its three
//! columns a ball, nor `C` is formed, and a ball's contacts are found in one
//! pass over the dataset.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix3xX, Matrix6, RowDVector};
use parcal_dataset::{Calibration, Dataset};
use parcal_kinematics::{
    ForwardOptions, Geometry, N_PARAMS, PARAM_NAMES, SCALE_NAMES, Vec3, forward_from_home,
    tip_jacobians,
};
use parcal_observe::{Repeatability, WeightModel, radius_variance};

use crate::CalibrateError;
use crate::instruments::Validation;
use crate::mirror::located_side;
use crate::prediction;
use crate::problem::ActuatorScales;
use crate::sphere_fit::best_fit;

/// Applies the ball-touch `calibration` to the touches of `dataset` (module
/// doc).
pub fn validate_touches(
    dataset: &Dataset,
    calibration: &Calibration,
    reference: Option<usize>,
) -> Result<Validation, CalibrateError> {
    crate::validate(dataset)?;
    crate::validate::same_unit(dataset, calibration.actuator_unit())?;
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
    // The calibrated parameters the touches depend on: the 33, then the
    // scales if identified.
    let scale_columns = names
        .iter()
        .position(|name| *name == SCALE_NAMES[0])
        .filter(|&k| {
            names
                .get(k..k + 6)
                .is_some_and(|found| found == SCALE_NAMES)
        });
    let columns: Vec<usize> = (0..N_PARAMS)
        .chain(scale_columns.into_iter().flat_map(|k| k..k + 6))
        .collect();
    let m = columns.len();
    let covariance = DMatrix::from_fn(m, m, |i, j| calibration.covariance[columns[i]][columns[j]]);
    let c = &calibration.canonical;
    let geometry =
        Geometry::from_arrays(&c.base_joints, &c.platform_joints, &c.tool, &c.leg_lengths);
    let machine = &dataset.machine.repeatability;
    let forward = ForwardOptions::default();
    let measurements = &dataset.measurements;
    let scales = ActuatorScales {
        values: calibration.calibrated_scales(),
        column: None,
    };
    // Each ball's rows in dataset order (measurements.csv's ball column,
    // checked by the dataset's reader against the artefacts).
    let mut rows_by_ball = vec![Vec::new(); dataset.artefacts.balls.len()];
    for (row, &ball) in measurements.ball.iter().enumerate() {
        rows_by_ball[ball as usize].push(row);
    }
    let Some(n_ref) = reference else {
        return Err(refuse(
            "a ball-touch validation fits each ball's centre on its first touches: give their number (at least 4)".into(),
        ));
    };
    let covariance_root = prediction::square_root(&covariance);
    // Each predicted contact: its residual, its noise variance and its row
    // of U (module doc): `m` values in the parameters' columns (`global`,
    // row by row) and three in its ball's (`local`); each ball's first
    // predicted contact (`starts`).
    let (mut residuals, mut noises) = (Vec::new(), Vec::new());
    let (mut global, mut local, mut starts) = (Vec::<f64>::new(), Vec::<Vec3>::new(), Vec::new());
    let mut mirrored_balls = Vec::new();
    for (k, ball) in dataset.artefacts.balls.iter().enumerate() {
        let rows = &rows_by_ball[k];
        let mut tips = Vec::with_capacity(rows.len());
        for &row in rows {
            let extensions = scales.extensions(&measurements.q[row]);
            let solution = forward_from_home(&geometry, &extensions, &forward)
                .map_err(|source| CalibrateError::ForwardKinematics { row, source })?;
            let jacobians = tip_jacobians(&geometry, &solution);
            // dT/dp on the calibrated parameters; dT/dq per unit of the
            // reading, J_q diag(s).
            let q = &measurements.q[row];
            let d_params = Matrix3xX::from_fn(m, |a, k| match k {
                _ if k < N_PARAMS => jacobians.d_params[(a, k)],
                _ => jacobians.d_q[(a, k - N_PARAMS)] * q[k - N_PARAMS],
            });
            let d_q = jacobians.d_q * Matrix6::from_diagonal(&scales.values.into());
            tips.push((row, (d_params, d_q), geometry.tool_tip(&solution.pose)));
        }
        if rows.len() <= n_ref {
            return Err(refuse(format!(
                "ball {:?} has {} contacts: none is left to predict after the {n_ref} reference contacts",
                ball.id,
                rows.len()
            )));
        }
        let points: Vec<Vec3> = tips[..n_ref].iter().map(|(.., tip)| *tip).collect();
        let fit = best_fit(&points, ball.radius).map_err(|e| {
            refuse(format!(
                "the first {n_ref} touches of ball {:?} do not locate its centre: {e} (more reference touches may)",
                ball.id
            ))
        })?;
        let all: Vec<Vec3> = tips.iter().map(|(.., tip)| *tip).collect();
        let (fit, mirror) = located_side(fit, &points, &all, ball.radius);
        if mirror {
            mirrored_balls.push(ball.id.clone());
        }
        let centre = fit.centre;
        // The centre fit linearised: A (normals), W, B (nᵀ J_f).
        let mut information = Matrix3::zeros();
        let mut weighted = Vec::with_capacity(n_ref);
        for (row, (d_params, d_q), tip) in &tips[..n_ref] {
            let normal = (tip - centre).normalize();
            let variance = contact_variance(machine, ball.radius_sigma, d_q, &normal, *row)?;
            information += normal * normal.transpose() / variance;
            weighted.push((normal / variance, normal.transpose() * d_params));
        }
        let centre_covariance = information.try_inverse().ok_or_else(|| {
            refuse(format!(
                "the reference contacts of ball {:?} do not determine its centre",
                ball.id
            ))
        })?;
        let centre_root = Matrix3::from_column_slice(
            prediction::square_root(&DMatrix::from_column_slice(
                3,
                3,
                centre_covariance.as_slice(),
            ))
            .as_slice(),
        );
        // K B: the centre's first-order response to the parameters (3 x m).
        let response = weighted.iter().fold(Matrix3xX::zeros(m), |sum, (a, b)| {
            sum + centre_covariance * a * b
        });
        starts.push(residuals.len());
        for (row, (d_params, d_q), tip) in &tips[n_ref.min(tips.len())..] {
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
            let gain: RowDVector<f64> = normal.transpose() * (d_params - &response);
            global.extend((gain * &covariance_root).iter());
            local.push(centre_root.transpose() * normal);
            residuals.push(distance - ball.radius);
            noises.push(contact_variance(
                machine,
                ball.radius_sigma,
                d_q,
                &normal,
                *row,
            )?);
        }
    }
    let mut v = DMatrix::from_row_slice(residuals.len(), m, &global);
    let sigmas = (noises.iter().zip(v.row_iter()).zip(&local))
        .map(|((noise, g), b)| (noise + g.norm_squared() + b.norm_squared()).sqrt())
        .collect();
    // Whitened by the contacts' noise.
    let scale: Vec<f64> = noises.iter().map(|v| 1.0 / v.sqrt()).collect();
    let z = DVector::from_iterator(
        residuals.len(),
        residuals.iter().zip(&scale).map(|(r, s)| r * s),
    );
    for ((mut row, b), s) in v.row_iter_mut().zip(&mut local).zip(&scale) {
        row *= *s;
        *b *= *s;
    }
    Ok(Validation {
        poses: 0,
        points: 0,
        contacts: residuals.len(),
        reference: n_ref,
        refitted: vec!["ball centres".into()],
        selection: Vec::new(),
        statistic: prediction::grouped_statistic(&z, &v, &local, &starts),
        calibration_test: calibration
            .global_test
            .as_ref()
            .map(|t| (t.cost, t.redundancy)),
        residuals,
        predicted_sigmas: sigmas,
        explanations: Vec::new(),
        mirrored_balls,
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
