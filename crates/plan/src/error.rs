//! Why a plan could not be made, written or read.

use parcal_accuracy::AccuracyError;
use parcal_dataset::DatasetError;
use parcal_kinematics::KinematicsError;
use parcal_observe::ObserveError;

/// Why a plan could not be made, written or read.
#[derive(Debug, thiserror::Error)]
pub enum DesignError {
    /// Options that make no sense.
    #[error("invalid options: {0}")]
    Options(String),
    /// machine.json has no stroke: every pose would look reachable.
    #[error("machine.json has no \"stroke\": [min, max] of the actuator readings; a plan needs it")]
    NoStroke,
    /// No candidate is feasible.
    #[error(
        "no candidate touch is feasible: every one puts the platform below the base (the other assembly mode), has an actuator reading outside the stroke {stroke:?}, is near a singularity or has a joint beyond machine.json's joint_limits"
    )]
    EmptyPool {
        /// The stroke.
        stroke: [f64; 2],
    },
    /// The per-ball capacity cannot hold the budget.
    #[error(
        "--per-ball {per_ball} cannot hold {contacts} contacts on the balls the machine reaches"
    )]
    Capacity {
        /// The capacity.
        per_ball: usize,
        /// The budget.
        contacts: usize,
    },
    /// A candidate touch's covariance (the propagated repeatabilities) is
    /// not positive definite.
    #[error("a candidate touch's covariance is not positive definite (all repeatabilities zero?)")]
    TouchCovariance,
    /// The predicted information is not positive definite.
    #[error("the predicted information matrix is not positive definite")]
    Singular,
    /// The design geometry does not define the canonical frames.
    #[error("the design geometry is degenerate: {0}")]
    Design(KinematicsError),
    /// A candidate's tip derivatives do not exist.
    #[error("a candidate pose: {0}")]
    Kinematics(KinematicsError),
    /// The machine's repeatabilities.
    #[error("machine.json repeatability: {0}")]
    Observe(ObserveError),
    /// The accuracy map's targets.
    #[error("the accuracy map: {0}")]
    Accuracy(AccuracyError),
    /// plan.json records another plan.csv's checksum than its plan.csv's.
    #[error(
        "{} and {} are not of the same plan: {} records the checksum {recorded} of the plan, {} has {actual} (written by two runs, or one interrupted between the two); plan again",
        csv.display(), summary.display(), summary.display(), csv.display()
    )]
    MismatchedPair {
        /// plan.csv.
        csv: std::path::PathBuf,
        /// plan.json.
        summary: std::path::PathBuf,
        /// The checksum plan.json records.
        recorded: String,
        /// plan.csv's.
        actual: String,
    },
    /// Writing the plan.
    #[error(transparent)]
    Dataset(#[from] DatasetError),
}
