//! The checks of a correlation of the parameters' priors
//! ([`super::prior`]): what makes a matrix a correlation matrix.

use nalgebra::DMatrix;
use parcal_kinematics::mechanism::Mechanism;

use super::error::MechanismCalibrationError;

/// How far a correlation matrix may be from symmetric, or its diagonal
/// from 1: rounding of a matrix computed in floating point.
const CORRELATION_ROUNDING: f64 = 1e-12;

/// Refuses a correlation matrix that is not `n × n` for the `n`
/// parameters, not finite, not symmetric, without a unit diagonal, with an
/// entry beyond ±1, or not positive definite over the parameters with a
/// prior (`has_prior`, one per parameter); the first fault names the
/// parameters.
pub(crate) fn check_correlation(
    mechanism: &dyn Mechanism,
    has_prior: &[bool],
    correlation: &DMatrix<f64>,
) -> Result<(), MechanismCalibrationError> {
    let parameters = mechanism.parameters();
    let n = parameters.len();
    let invalid = |reason: String| {
        Err(MechanismCalibrationError::InvalidData {
            what: "prior correlation".to_string(),
            reason,
        })
    };
    if correlation.shape() != (n, n) {
        let (rows, columns) = correlation.shape();
        return invalid(format!(
            "{rows} x {columns} for the {n} parameters of the {}",
            mechanism.name()
        ));
    }
    let name = |k: usize| parameters[k].name.as_str();
    for j in 0..n {
        for k in 0..n {
            let c = correlation[(j, k)];
            let fault = if !c.is_finite() {
                Some("is not finite")
            } else if (c - correlation[(k, j)]).abs() > CORRELATION_ROUNDING {
                Some("differs from its transpose's")
            } else if j == k && (c - 1.0).abs() > CORRELATION_ROUNDING {
                Some("is not 1 on the diagonal")
            } else if c.abs() > 1.0 + CORRELATION_ROUNDING {
                Some("is beyond ±1")
            } else {
                None
            };
            if let Some(fault) = fault {
                return invalid(format!(
                    "its entry {c} of {} and {} {fault}",
                    name(j),
                    name(k)
                ));
            }
        }
    }
    let with: Vec<usize> = (0..n).filter(|&k| has_prior[k]).collect();
    let sub = correlation.select_rows(&with).select_columns(&with);
    if sub.cholesky().is_none() {
        return invalid(
            "it is not positive definite over the parameters with a prior (some combination of them would have no uncertainty)"
                .to_string(),
        );
    }
    Ok(())
}
