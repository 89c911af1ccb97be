//! Calibration from instrument measurements: platform poses (motion
//! capture, photogrammetry) and tool points (laser tracker), in sessions,
//! with actuators that read in their own unit.
//!
//! - [`model`]: the global block (kinematic parameters, actuator scales,
//!   each session's instrument frame, the body frame, each later session's
//!   body origin and leg offsets) and what it means;
//! - [`start`]: the initial frames (hand–eye for poses, Kabsch for points);
//! - [`rows`]: every measured row as whitened residual rows;
//! - [`problem`]: the solver's problem (a global block only);
//! - [`run`]: the instrument stage of [`crate::calibrate`] (poses and
//!   points alone), calibration.json's machine and sessions;
//! - [`result`]: what a calibration's poses and points give besides the
//!   global block, with or without ball touches;
//! - [`validate`]: a calibration applied to data it was not fitted on
//!   (k-fold cross-validation: [`crate::cross_validation`]).
//!
//! The gauge: the kinematic parameters live in the canonical frames
//! (`parcal_kinematics::frames`); an instrument sees the base frame only
//! through its session's frame `F_k`, and measured poses see the platform
//! frame through the body frame `B`, so both frames are unknowns and the
//! canonical frames fix the gauge. Points do not see the body frame and
//! poses do not see the tool: neither is then in the layout (poses alone
//! hold the design's tool, not calibrated). docs/formulation.md says which
//! parameters each kind of data determines.

pub mod model;
pub mod observations;
pub mod problem;
pub mod result;
pub mod rows;
pub mod run;
pub mod start;
pub mod validate;

pub use crate::error::InstrumentTable;
pub use model::{InstrumentModel, ModelValues};
pub use result::{InstrumentResult, ParameterInformation};
pub use run::{InstrumentSetup, setup};
pub use validate::{
    Calibrated, CalibratedSession, Explanation, SessionGroup, Validation, validate_calibration,
};
