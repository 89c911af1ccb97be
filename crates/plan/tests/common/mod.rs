//! What the mechanism planner's tests share.

use nalgebra::{DMatrix, DVector};
use parcal_calibrate::mechanism::MechanismData;

/// The prior covariance of a delta's parameters and its trigger height,
/// diagonal, built from `data` independently of the planner: the dense
/// reference the planner's picks are checked against.
pub fn dense_prior(data: &MechanismData) -> DMatrix<f64> {
    let mut variances: Vec<f64> = data
        .priors
        .iter()
        .map(|p| p.sigma.unwrap().powi(2))
        .collect();
    variances.push(data.trigger_height.sigma.unwrap().powi(2));
    DMatrix::from_diagonal(&DVector::from_vec(variances))
}
