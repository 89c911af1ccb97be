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
//! - `result`: the result ([`MechanismCalibration`]), its tests and
//!   verdict;
//! - `snooping`: data snooping;
//! - `input`: a dataset read from files as [`MechanismData`];
//! - `hexapod_input`: a hexapod's ball touches as [`MechanismData`]
//!   ([`MechanismData::from_hexapod_touches`]);
//! - `record`: a result as its `calibration.json` record;
//! - `calibrated`: a `calibration.json` record as the numbers that apply
//!   it ([`CalibratedMechanism`]);
//! - `predicted`: held-out observations predicted by a calibration, with
//!   their derivatives (a ball's touches together, its centre projected
//!   out);
//! - `validation`: a calibration judged on held-out data
//!   ([`validate_mechanism`]);
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

use std::time::Instant;

use parcal_solver::IterationRecord;

mod calibrated;
mod checks;
mod compensation;
mod coordinate_problem;
mod correlation;
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

pub use calibrated::CalibratedMechanism;
pub use checks::{ObservationCheck, ObservationChecks};
pub use compensation::{
    Compensation, NAMED_TARGETS, UnreachableTargets, compensate_mechanism, compensate_targets,
};
pub use data::{
    Ball, CentrePrior, MAX_ACTUATORS, MAX_BALLS, MAX_OBSERVATIONS, MAX_POSE_COORDINATES,
    MAX_TIED_BALLS, MAX_TRACKERS, MAX_WARM_START, MIN_ACTUATORS, MIN_POINTS_PER_TRACKER,
    MIN_TOUCHES_PER_BALL, MechanismData, Observations, ParameterPrior, Tracker,
};
pub use error::MechanismCalibrationError;
pub use identifiability::{Identifiability, Undetermined};
pub use mirror::MirroredBall;
pub use observation::{HeldOut, ObservationKind, ObservationRef, number_ranges};
pub use options::{MAX_ITERATIONS, MechanismOptions};
pub use predicted::MAX_HELD_OUT_TOUCHES_PER_BALL;
pub use result::{
    EstimatedBall, EstimatedBody, EstimatedParameter, EstimatedTracker, MechanismCalibration,
    TRIGGER_HEIGHT,
};
pub use touch_start::TouchStart;
pub use validation::{MechanismValidation, ParameterShift, ValidatedRow, validate_mechanism};

/// Calibrates `data` with `options`: validates both, refuses a gauge
/// freedom that no prior holds, fits (with data snooping if asked) and
/// returns the estimate in the canonical frame with its tests, verdict and
/// identifiability. `observer` sees each iteration of each fit, as the
/// hexapod's own [`calibrate`](crate::calibrate) shows them.
pub fn calibrate_mechanism(
    data: &MechanismData,
    options: &MechanismOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<MechanismCalibration, MechanismCalibrationError> {
    let started = Instant::now();
    options.validate()?;
    data.validate()?;
    coordinate_problem::check_observation(data, options)?;
    check_gauge_priors(data)?;
    if options.snoop {
        snooping::snoop(data, options, started, observer)
    } else {
        snooping::calibrate_once(data, options, started, observer)
    }
}

/// Checks `data` as [`calibrate_mechanism`] does before its first step:
/// valid, every gauge freedom held by a prior, and every observation
/// evaluated at the start (the priors' means; each point sample's pose
/// from its readings, each ball's centre from its touches), so that a
/// commanded position the machine cannot reach, readings no pose
/// explains or touches that fit no sphere are named.
pub fn check_mechanism_data(data: &MechanismData) -> Result<(), MechanismCalibrationError> {
    data.validate()?;
    check_gauge_priors(data)?;
    fit::check_start(data)
}

/// Refuses data where some gauge freedom moves only parameters without a
/// prior: nothing would determine it.
fn check_gauge_priors(data: &MechanismData) -> Result<(), MechanismCalibrationError> {
    let mechanism = data.mechanism.as_ref();
    let means: Vec<f64> = data.priors.iter().map(|p| p.mean).collect();
    let freedoms = mechanism.gauge_freedoms(&means).map_err(|source| {
        MechanismCalibrationError::Kinematics {
            mechanism: mechanism.name().to_string(),
            source,
        }
    })?;
    for freedom in freedoms {
        let held = freedom
            .direction
            .iter()
            .zip(&data.priors)
            .any(|(z, prior)| z.abs() > 1e-9 && prior.sigma.is_some());
        if !held {
            let moved: Vec<&str> = freedom
                .direction
                .iter()
                .zip(mechanism.parameters())
                .filter(|(z, _)| z.abs() > 1e-9)
                .map(|(_, p)| p.name.as_str())
                .collect();
            return Err(MechanismCalibrationError::NotDetermined {
                reason: format!(
                    "no measurement sees the {} ({}), and none of its parameters has a prior: give one of them a prior",
                    freedom.name,
                    moved.join(", ")
                ),
            });
        }
    }
    Ok(())
}
