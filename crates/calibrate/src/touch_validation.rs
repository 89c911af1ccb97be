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
//! pass over the dataset. The balls are predicted on the threads, in pieces
//! put together in their order: the same bits on any number of threads.

use nalgebra::{DMatrix, DVector, Matrix3, Matrix3xX, Matrix6, RowDVector};
use parcal_dataset::{Ball, Calibration, Dataset, Measurements};
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
use rayon::prelude::*;

/// Applies the ball-touch `calibration` to the touches of `dataset` (module
/// doc).
pub fn validate_touches(
    dataset: &Dataset,
    calibration: &Calibration,
    reference: Option<usize>,
) -> Result<Validation, CalibrateError> {
    crate::validate(dataset)?;
    crate::validate::same_unit(dataset, calibration.actuator_unit())?;
    let names = &calibration.parameters.names;
    if names.len() < N_PARAMS || names[..N_PARAMS] != PARAM_NAMES {
        return Err(refused(
            "its parameters are not the 33 kinematic parameters of a ball-touch calibration".into(),
        ));
    }
    if calibration.covariance.len() != names.len() {
        return Err(refused(
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
        return Err(refused(
            "a ball-touch validation fits each ball's centre on its first touches: give their number (at least 4)".into(),
        ));
    };
    let predictor = BallPredictor {
        measurements,
        geometry: &geometry,
        scales: &scales,
        forward: &forward,
        machine,
        covariance_root: prediction::square_root(&covariance),
        reference: n_ref,
    };
    // Pieces of balls on the threads, each predicted on its own, then put
    // one after another in their order: the same bits on any number of
    // threads, the first error in the balls' order.
    let balls = &dataset.artefacts.balls;
    let pieces: Vec<_> = (balls.par_chunks(BALL_PIECE))
        .zip(rows_by_ball.par_chunks(BALL_PIECE))
        .map(|(balls, rows)| {
            let mut piece = PredictedContacts::default();
            for (ball, rows) in balls.iter().zip(rows) {
                predictor.predict(ball, rows, &mut piece)?;
            }
            Ok::<_, CalibrateError>(piece)
        })
        .collect();
    let pieces = pieces.into_iter().collect::<Result<Vec<_>, _>>()?;
    // U's parameter columns filled piece by piece, each piece's rows let go
    // once copied.
    let mut v = DMatrix::zeros(pieces.iter().map(|p| p.residuals.len()).sum(), m);
    let mut predicted = PredictedContacts::default();
    for piece in pieces {
        let first = predicted.residuals.len();
        for (i, row) in piece.global.chunks_exact(m).enumerate() {
            v.row_mut(first + i).copy_from_slice(row);
        }
        predicted.append(piece);
    }
    let PredictedContacts {
        residuals,
        noises,
        mut local,
        starts,
        mirrored_balls,
        ..
    } = predicted;
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

/// The balls [`validate_touches`] predicts at a time on a thread.
const BALL_PIECE: usize = 256;

/// A calibration refused, for `reason`.
fn refused(reason: String) -> CalibrateError {
    CalibrateError::Calibration { reason }
}

/// The predicted contacts of balls one after another (module doc).
#[derive(Default)]
struct PredictedContacts {
    /// Each contact's residual (mm).
    residuals: Vec<f64>,
    /// Its noise variance (mm²).
    noises: Vec<f64>,
    /// Its row of `U` in the parameters' columns, row after row.
    global: Vec<f64>,
    /// Its row of `U` in its ball's three columns.
    local: Vec<Vec3>,
    /// Each ball's first contact.
    starts: Vec<usize>,
    /// The balls kept at their mirror image.
    mirrored_balls: Vec<String>,
}

impl PredictedContacts {
    /// `other`'s balls after these, but for their rows of `U` in the
    /// parameters' columns, which [`validate_touches`] copies itself (and
    /// lets go of here).
    fn append(&mut self, other: Self) {
        let offset = self.residuals.len();
        self.starts
            .extend(other.starts.iter().map(|start| offset + start));
        self.residuals.extend(other.residuals);
        self.noises.extend(other.noises);
        self.local.extend(other.local);
        self.mirrored_balls.extend(other.mirrored_balls);
    }
}

/// What a ball's prediction takes of the calibration and the dataset.
struct BallPredictor<'a> {
    /// The dataset's readings.
    measurements: &'a Measurements,
    /// The calibrated geometry.
    geometry: &'a Geometry,
    /// The calibrated actuator scales.
    scales: &'a ActuatorScales,
    /// The forward kinematics' options.
    forward: &'a ForwardOptions,
    /// The machine's repeatabilities.
    machine: &'a parcal_dataset::Repeatability,
    /// `Σ_p^{1/2}` of the calibrated parameters.
    covariance_root: DMatrix<f64>,
    /// The reference contacts `N` of each ball.
    reference: usize,
}

impl BallPredictor<'_> {
    /// The contacts `rows` of `ball` predicted, into `out` (module doc);
    /// an error names the ball or the row that cannot be predicted.
    fn predict(
        &self,
        ball: &Ball,
        rows: &[usize],
        out: &mut PredictedContacts,
    ) -> Result<(), CalibrateError> {
        let (m, n_ref) = (self.covariance_root.nrows(), self.reference);
        let mut tips = Vec::with_capacity(rows.len());
        for &row in rows {
            let extensions = self.scales.extensions(&self.measurements.q[row]);
            let solution = forward_from_home(self.geometry, &extensions, self.forward)
                .map_err(|source| CalibrateError::ForwardKinematics { row, source })?;
            let jacobians = tip_jacobians(self.geometry, &solution);
            // dT/dp on the calibrated parameters; dT/dq per unit of the
            // reading, J_q diag(s).
            let q = &self.measurements.q[row];
            let d_params = Matrix3xX::from_fn(m, |a, k| match k {
                _ if k < N_PARAMS => jacobians.d_params[(a, k)],
                _ => jacobians.d_q[(a, k - N_PARAMS)] * q[k - N_PARAMS],
            });
            let d_q = jacobians.d_q * Matrix6::from_diagonal(&self.scales.values.into());
            tips.push((row, (d_params, d_q), self.geometry.tool_tip(&solution.pose)));
        }
        if rows.len() <= n_ref {
            return Err(refused(format!(
                "ball {:?} has {} contacts: none is left to predict after the {n_ref} reference contacts",
                ball.id,
                rows.len()
            )));
        }
        let points: Vec<Vec3> = tips[..n_ref].iter().map(|(.., tip)| *tip).collect();
        let fit = best_fit(&points, ball.radius).map_err(|e| {
        refused(format!(
            "the first {n_ref} touches of ball {:?} do not locate its centre: {e} (more reference touches may)",
            ball.id
        ))
    })?;
        let all: Vec<Vec3> = tips.iter().map(|(.., tip)| *tip).collect();
        let (fit, mirror) = located_side(fit, &points, &all, ball.radius);
        if mirror {
            out.mirrored_balls.push(ball.id.clone());
        }
        let centre = fit.centre;
        // The centre fit linearised: A (normals), W, B (nᵀ J_f).
        let mut information = Matrix3::zeros();
        let mut weighted = Vec::with_capacity(n_ref);
        for (row, (d_params, d_q), tip) in &tips[..n_ref] {
            let normal = (tip - centre).normalize();
            let variance = contact_variance(self.machine, ball.radius_sigma, d_q, &normal, *row)?;
            information += normal * normal.transpose() / variance;
            weighted.push((normal / variance, normal.transpose() * d_params));
        }
        let centre_covariance = information.try_inverse().ok_or_else(|| {
            refused(format!(
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
        out.starts.push(out.residuals.len());
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
            out.global.extend((gain * &self.covariance_root).iter());
            out.local.push(centre_root.transpose() * normal);
            out.residuals.push(distance - ball.radius);
            out.noises.push(contact_variance(
                self.machine,
                ball.radius_sigma,
                d_q,
                &normal,
                *row,
            )?);
        }
        Ok(())
    }
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
