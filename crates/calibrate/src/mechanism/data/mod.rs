//! A mechanism calibration's data in memory: the mechanism, the parameters
//! its controller ran with, the priors, the observations; and their
//! validation, which names the observation (kind, 0-based index) or the
//! parameter at fault.
//!
//! The pieces, each importing only those above it:
//!
//! - `limits`: what a calibration accepts (the most and fewest of each);
//! - `tracker`, `ball`: an instrument at one placement, a calibrated ball;
//! - `observations`: the observations by kind ([`Observations`]);
//! - `repeats`: observations given twice ([`Repeat`]);
//! - `mechanism_data`: the data ([`MechanismData`]) and their priors
//!   ([`ParameterPrior`]), built from a mechanism's design;
//! - `value_checks`: the checks every kind's values share;
//! - `ball_checks`, `tracker_checks`: the balls' and the trackers' checks;
//! - `validate`: the data checked before any work
//!   ([`MechanismData::validate`]).

mod ball;
mod ball_checks;
mod limits;
mod mechanism_data;
mod observations;
mod repeats;
mod tracker;
mod tracker_checks;
mod validate;
mod value_checks;

pub use ball::{Ball, CentrePrior};
pub use limits::{
    MAX_ACTUATORS, MAX_BALLS, MAX_OBSERVATIONS, MAX_POSE_COORDINATES, MAX_TIED_BALLS, MAX_TRACKERS,
    MAX_WARM_START, MIN_ACTUATORS, MIN_POINTS_PER_TRACKER, MIN_TOUCHES_PER_BALL,
};
pub use mechanism_data::{MechanismData, ParameterPrior};
pub use observations::Observations;
pub use repeats::Repeat;
pub use tracker::Tracker;
