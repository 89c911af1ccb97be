//! Artefact calibration with a priori knowledge (Sato et al., Meas. Sci.
//! Technol. 15 (2004) 1158, docs/paper-scenario.md section 4): from a dataset to the
//! identified kinematic parameters, ball centres and contact angles with
//! their uncertainties, and a verdict on the priors.
//!
//! - [`setup`]: the initial estimates, weights and priors of a dataset;
//! - [`problem`]: the observation blocks as the solver's problem;
//! - [`calibrate`] ([`CalibrationRun`]): one calibration of any hexapod
//!   dataset: ball touches (with poses and points beside them, if any), or
//!   poses and points alone;
//! - [`conflict`]: prior-data conflict tests;
//! - [`fit`]: each ball's goodness of fit;
//! - [`instruments`]: measured poses and points: the instrument stage,
//!   their result ([`instruments::InstrumentResult`]), validation;
//! - [`cross_validation`]: k-fold cross-validation of poses and points;
//! - [`layout`]: the global block, named groups of parameters;
//! - [`mechanism`]: the calibration of any mechanism (a linear delta, a
//!   cable robot, the hexapod's ball touches and tracker data) through the
//!   `Mechanism` trait ([`mechanism::calibrate_mechanism`]);
//! - [`mirror`]: a ball on the wrong side of its contacts;
//! - [`mixed`]: ball touches with measured poses and points;
//! - [`verdict`]: the global test and the verdict of a run;
//! - [`observation`]: an observation by its place in the dataset;
//! - [`hypothesis`]: the tests' shared terms: levels, critical values,
//!   minimal detectable biases;
//! - [`reliability`]: redundancy numbers, normalised residuals, variance
//!   components;
//! - [`snooping`]: data snooping, the blunders found and removed;
//! - [`external`]: external reliability, the parameters' shift by an
//!   undetected blunder;
//! - [`systematic`]: tests of systematic errors (which common error
//!   explains a rejection);
//! - [`robust`]: a robust loss, the observations it down-weights;
//! - [`sphere_fit`]: initial ball centres;
//! - [`validate_touches`]: a ball-touch calibration applied to other
//!   touches;
//! - [`prediction`]: the test of a validation's residuals against their
//!   predicted covariance;
//! - [`bounds`]: the bounds of the counts a user gives.
//!
//! The public modules hold what a caller builds, reads or tests: the
//! stages a benchmark or another solver drives ([`setup`], [`problem`]),
//! and the types of results and their tests, which `parcal_report`
//! presents. The run's internals (its loop, the systematic effects'
//! passes, the dataset's checks) are private. Result types are
//! `#[non_exhaustive]`: they grow without breaking a caller.
//!
//! [`calibrate`] validates its dataset first ([`validate`]), so data built
//! in memory fails with a [`CalibrateError`] rather than a panic. Errors
//! name measurement rows (0-based), balls and dataset fields, never files:
//! the caller that read the files adds them ([`CalibrateError::row`]).
//! The `parcal` crate re-exports this crate with the others it needs.
//!
//! ```no_run
//! use parcal_calibrate::{CalibrationOptions, Simulation, calibrate};
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let dataset = parcal_dataset::Dataset::read("data/paper-seed1".as_ref())?;
//! let run = calibrate(&dataset, &CalibrationOptions::simulation(Simulation::IV), &mut |_| {})?;
//! println!("{:?} after {} iterations", run.status, run.iterations());
//! # Ok(()) }
//! ```

pub mod bounds;
pub mod conflict;
pub mod cross_validation;
mod effect;
mod error;
pub mod external;
pub mod fit;
pub mod hypothesis;
pub mod instruments;
pub mod layout;
pub mod mechanism;
pub mod mirror;
pub mod mixed;
pub mod observation;
mod options;
pub mod prediction;
pub mod problem;
pub mod reliability;
pub mod robust;
mod run;
mod run_away;
pub mod setup;
pub mod snooping;
pub mod sphere_fit;
pub mod systematic;
mod touch_validation;
mod validate;
pub mod verdict;

pub use error::{CalibrateError, InstrumentTable};
pub use options::{
    CalibrationOptions, Observation, PriorMode, ROBUST_ITERATIONS, RadiusModel, Simulation,
};
pub use parcal_kinematics::ParamCovariance;
pub use parcal_observe::WeightModel;
pub use parcal_solver::{CAUCHY_K, HUBER_K, IterationRecord, Loss, Method};
pub use run::{CalibratedBalls, CalibrationRun, calibrate};
pub use run_away::RunAway;
pub use touch_validation::validate_touches;
pub use validate::{MIN_CONTACTS_PER_BALL, validate};
