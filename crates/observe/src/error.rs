//! Errors of the observation blocks, weights and priors: values with context.

use parcal_kinematics::KinematicsError;

/// What can go wrong while building an observation block, a weight or a prior.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ObserveError {
    /// The kinematics underneath failed (forward kinematics, derivatives,
    /// canonicalisation).
    #[error(transparent)]
    Kinematics(#[from] KinematicsError),
    /// A direction (chart reference, contact normal) is zero or not finite.
    #[error("the {what} is not a usable direction (length {length:e})")]
    DegenerateDirection {
        /// Which direction.
        what: &'static str,
        /// Its length.
        length: f64,
    },
    /// A standard deviation is negative, NaN or infinite (or zero where a
    /// prior needs it positive).
    #[error("the {what} {value:e} mm is not a valid standard deviation ({expected})")]
    InvalidSigma {
        /// Which standard deviation.
        what: &'static str,
        /// Its value.
        value: f64,
        /// What is accepted.
        expected: &'static str,
    },
    /// A covariance is not symmetric positive definite, so it has no
    /// Cholesky factor, no inverse and no whitening.
    #[error("the {what} is not symmetric positive definite")]
    NotPositiveDefinite {
        /// Which covariance.
        what: &'static str,
    },
}

/// Accepts a finite standard deviation, positive or (when `zero_allowed`)
/// zero.
pub(crate) fn check_sigma(
    what: &'static str,
    value: f64,
    zero_allowed: bool,
) -> Result<f64, ObserveError> {
    let valid = value.is_finite() && (value > 0.0 || (zero_allowed && value == 0.0));
    if valid {
        Ok(value)
    } else {
        let expected = if zero_allowed {
            "a finite number >= 0"
        } else {
            "a finite number > 0"
        };
        Err(ObserveError::InvalidSigma {
            what,
            value,
            expected,
        })
    }
}
