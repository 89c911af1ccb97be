//! Why a mechanism calibration could not be made: errors that name the
//! observation (kind and 0-based index) or the parameter.

use parcal_kinematics::mechanism::MechanismError;
use parcal_solver::Status;

use super::observation::ObservationRef;

/// Why [`calibrate_mechanism`](super::calibrate_mechanism) failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MechanismCalibrationError {
    /// The data in memory are not usable as given: a size that does not
    /// match the mechanism, a count beyond its bound, a value that is not
    /// finite, a standard deviation that is not positive.
    #[error("{what}: {reason}")]
    InvalidData {
        /// What is wrong (`parameter diagonal_a`, `options.alpha`).
        what: String,
        /// Why.
        reason: String,
    },
    /// One observation is not usable (a bad value) or cannot be evaluated
    /// (a commanded position the machine cannot reach).
    #[error("{observation}: {reason}")]
    Observation {
        /// The observation.
        observation: ObservationRef,
        /// Why.
        reason: String,
    },
    /// The mechanism's kinematics failed away from any observation (the
    /// canonical frame of the estimate, its gauge freedoms).
    #[error("the {mechanism} kinematics: {source}")]
    Kinematics {
        /// The mechanism.
        mechanism: String,
        /// The cause.
        source: MechanismError,
    },
    /// Neither the data nor the priors determine some unknowns: a gauge
    /// freedom without a prior, or a parameter no observation sees and no
    /// prior holds.
    #[error("not determined: {reason}")]
    NotDetermined {
        /// Which unknowns, and what would determine them.
        reason: String,
    },
    /// An observation failed to evaluate during the iteration (the
    /// parameters went where the machine cannot reach a commanded
    /// position).
    #[error("the solver stopped at iteration {iteration}: {message}")]
    Evaluation {
        /// Linear solves before the failure.
        iteration: usize,
        /// The failure, naming the observation.
        message: String,
    },
    /// The solver could not start.
    #[error("the solver stopped: {status:?}")]
    Solver {
        /// How it ended.
        status: Status,
    },
}

/// Observation `observation` failed, for `reason`.
pub(crate) fn failed(
    observation: ObservationRef,
    reason: impl std::fmt::Display,
) -> MechanismCalibrationError {
    MechanismCalibrationError::Observation {
        observation,
        reason: reason.to_string(),
    }
}
