//! parcal's workflows above one calibration:
//!
//! - [`evaluate`]: what a calibration buys, the accuracy maps before and
//!   after, and in simulation the comparison with the truth;
//! - [`paper`]: the paper study, one simulated dataset of the paper's
//!   scenario calibrated six ways (simulations I-IV, docs/paper-scenario.md section 4).
//!
//! They compute; `parcal-report` writes what they find.
//!
//! ```no_run
//! use parcal_workflows::paper::{PAPER_CASES, PaperStudy};
//! # fn main() -> Result<(), parcal_workflows::WorkflowError> {
//! let study = PaperStudy::simulate(1)?;
//! for (simulation, prior) in PAPER_CASES {
//!     let case = study.calibrate(simulation, prior)?;
//!     println!("{}: {:?}", case.name(), case.run.status);
//! }
//! # Ok(()) }
//! ```

pub mod evaluate;
pub mod paper;

/// Why a workflow stopped.
#[derive(Debug, thiserror::Error)]
pub enum WorkflowError {
    /// The simulation failed.
    #[error(transparent)]
    Simulate(#[from] parcal_simulate::SimulateError),
    /// A calibration could not be set up.
    #[error(transparent)]
    Calibrate(#[from] parcal_calibrate::CalibrateError),
    /// An accuracy map could not be computed.
    #[error("accuracy map: {0}")]
    Accuracy(#[from] parcal_accuracy::AccuracyError),
    /// The simulated dataset has no truth.
    #[error("the simulated dataset has no truth")]
    NoTruth,
    /// The true geometry cannot be put in canonical frames.
    #[error("the true geometry is degenerate: {0}")]
    Truth(#[from] parcal_kinematics::KinematicsError),
}
