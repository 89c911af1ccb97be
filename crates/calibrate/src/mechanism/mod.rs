//! One calibration for any mechanism through the
//! [`Mechanism`](parcal_kinematics::mechanism::Mechanism) trait: for one
//! whose pose is a position `(x, y, z)` (a linear delta, a cable robot),
//! probe heights, part distances, measured points, readings at unknown
//! poses and touches of calibrated balls at unknown centres
//! ([`parcal_observe::mechanism`]); for any other (the hexapod), touches at
//! the actuators' readings; for both, calibrated distances between the
//! balls. The builder's tolerances are the priors, by
//! the method of Sato et al. (2004) the hexapod's own calibration follows.
//!
//! The stages, each importing only those above it (private but
//! [`frame`] and [`identifiability`]; their results are re-exported here):
//!
//! - `observation`: the observations' names (kind and index);
//! - `error`: what can go wrong, naming the observation or parameter;
//! - `tied`: where the balls that calibrated distances tie together have
//!   their unknowns in the global block;
//! - `data`: the data in memory ([`MechanismData`]) and their validation;
//! - `options`: loss, snooping, level, iteration limit
//!   ([`MechanismOptions`]);
//! - `problem`: the solver's problem (global block: parameters, the
//!   trigger height, the tied balls' centres and uncertain radii; local
//!   blocks: the poses of point samples, the centres of the other balls
//!   and their uncertain radii);
//! - `fit`: one solve, redundancy numbers, normalised residuals;
//! - [`frame`]: the estimate and covariance in the canonical frame (the
//!   gauge projected out);
//! - [`identifiability`]: what the data determine and what only the priors
//!   do;
//! - `calibrate`: the entry ([`calibrate_mechanism`]): the data checked,
//!   fitted once or with data snooping;
//! - `result`: the result ([`MechanismCalibration`]), its tests and
//!   verdict;
//! - `snooping`: data snooping;
//! - `input`: a dataset read from files as [`MechanismData`];
//! - `hexapod_input`: a hexapod's ball touches as [`MechanismData`]
//!   ([`MechanismData::from_hexapod_touches`]);
//! - `record`: a result as its `calibration.json` record;
//! - `calibrated`: a `calibration.json` record as the numbers that apply
//!   it ([`CalibratedMechanism`]);
//! - `calibrated_machine`: a record as the `machine.json` of the next
//!   calibration ([`calibrated_machine`]);
//! - `predicted`: held-out observations predicted by a calibration, with
//!   their derivatives (a ball's touches together, its centre projected
//!   out);
//! - `validation`: a calibration judged on held-out data
//!   ([`validate_mechanism`]);
//! - `cross_validation`: each fold of the data judged by the calibration
//!   of the others ([`cross_validate_mechanism`]);
//! - `compensation`: the actuator commands that reach target positions
//!   ([`compensate_mechanism`]).
//!
//! ```
//! use std::sync::Arc;
//! use parcal_calibrate::mechanism::{
//!     MechanismData, MechanismOptions, Observations, calibrate_mechanism,
//! };
//! use parcal_kinematics::delta::{LinearDelta, probe_rings};
//! use parcal_kinematics::mechanism::design;
//! use parcal_observe::mechanism::ProbeHeight;
//!
//! // A printer exactly as configured, probed on three rings: every probe
//! // triggers at the commanded height 0.7 mm, the trigger height.
//! let delta = LinearDelta::typical();
//! let configured: Vec<f64> = design(&delta).iter().copied().collect();
//! let probes = probe_rings(100.0, 3, 8)
//!     .into_iter()
//!     .map(|[x, y]| ProbeHeight { commanded: [x, y, 0.7], sigma: 0.01 })
//!     .collect();
//! let observations = Observations { probes, ..Default::default() };
//! let data = MechanismData::new(Arc::new(delta), configured, observations)
//!     .with_trigger_height(0.7, Some(0.05));
//! let calibration = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {})?;
//! assert!(calibration.verdict.accepted, "{:?}", calibration.reasons);
//! let radius = calibration.parameter("radius").unwrap();
//! assert!((radius.value - 135.0).abs() < 1e-6);
//! # Ok::<(), parcal_calibrate::mechanism::MechanismCalibrationError>(())
//! ```

mod calibrate;
mod calibrated;
mod calibrated_machine;
mod checks;
mod compensation;
mod coordinate_problem;
mod correlation;
mod cross_validation;
mod data;
mod error;
mod fit;
pub mod frame;
mod hexapod_input;
pub mod identifiability;
mod input;
mod mirror;
mod observation;
mod options;
mod predicted;
pub mod prior;
mod problem;
mod problem_rows;
mod reaches;
mod record;
mod result;
mod snooping;
mod tied;
mod touch_jacobian;
mod touch_start;
mod touched_ball;
mod trackers;
mod validation;
mod warm_start;

pub use calibrate::{calibrate_mechanism, check_mechanism_data};
pub use calibrated::CalibratedMechanism;
pub use calibrated_machine::calibrated_machine;
pub use checks::{ObservationCheck, ObservationChecks};
pub use compensation::{
    Compensation, NAMED_TARGETS, UnreachableTargets, compensate_mechanism, compensate_targets,
};
pub use cross_validation::cross_validate_mechanism;
pub use data::{
    Ball, CentrePrior, MAX_ACTUATORS, MAX_BALLS, MAX_OBSERVATIONS, MAX_POSE_COORDINATES,
    MAX_TIED_BALLS, MAX_TRACKERS, MAX_WARM_START, MIN_ACTUATORS, MIN_POINTS_PER_TRACKER,
    MIN_TOUCHES_PER_BALL, MechanismData, Observations, ParameterPrior, Repeat, Tracker,
};
pub use error::MechanismCalibrationError;
pub use identifiability::{Identifiability, Undetermined};
pub use mirror::MirroredBall;
pub use observation::{HeldOut, ObservationKind, ObservationRef, number_ranges};
pub use options::{MAX_ITERATIONS, MechanismOptions};
pub use predicted::MAX_HELD_OUT_TOUCHES_PER_BALL;
pub use result::{
    EstimatedBall, EstimatedBody, EstimatedParameter, EstimatedTracker, MechanismCalibration,
    TRIGGER_HEIGHT, repeat_warnings,
};
pub use touch_start::TouchStart;
pub use validation::{MechanismValidation, ParameterShift, ValidatedRow, validate_mechanism};
