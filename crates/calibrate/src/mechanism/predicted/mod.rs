//! Each held-out observation predicted by a calibration: its residual
//! rows `r` (observation's units), their own noise covariance `D_i`, and
//! their derivative `G_i = dr/dθ` with respect to the calibration's
//! global block `θ = (p, h)` (the parameters, then the trigger height),
//! through the [`Mechanism`](parcal_kinematics::mechanism::Mechanism)
//! trait's analytic derivatives. A point sample at an unknown pose, a
//! ball, a tracker has local unknowns of its own (a pose, a centre, a
//! frame), projected out of its rows.
//!
//! With reference observations `N` (`parcal validate --reference N`),
//! each ball's centre is located by its first `N` touches alone, each
//! tracker's frame (and the body its poses see) by its first `N` points
//! and poses, and the others are predicted from them: `r' = r_o − J_o K
//! r_r`, `K` the local unknowns' weighted fit on the reference rows, each
//! row named by the observation it predicts, the fit's error in their
//! noise (`projection`). A sample's pose is located by its
//! own readings: reference observations are refused beside samples.
//!
//! The pieces, each importing only those above it:
//!
//! - `rows`: the predicted rows of one observation, or of observations
//!   predicted together ([`PredictedRows`]);
//! - `projection`: local unknowns projected out of rows, or located by
//!   reference rows and the others predicted from them;
//! - `sample`: a point sample's rows, at a measured or an unknown pose;
//! - `ball_sets`: the balls predicted together (a ball, or balls tied by
//!   held-out distances) and the bound on their rows;
//! - `balls`: a set of balls' rows, their touches and distances, the
//!   centres taken out;
//! - `tracker_reference`: the observations that locate a held-out
//!   tracker's frame;
//! - `posed_tracker`: a tracker's rows with poses, its frame and the body
//!   located by Gauss-Newton, and their unit;
//! - `tracker`: a tracker's rows of points;
//! - `predict`: every held-out observation predicted, in the order of the
//!   kinds ([`predict()`]).

mod ball_sets;
mod balls;
mod posed_tracker;
mod predict;
mod projection;
mod rows;
mod sample;
#[cfg(test)]
mod simulated;
mod tracker;
mod tracker_reference;

pub use ball_sets::MAX_HELD_OUT_TOUCHES_PER_BALL;
pub(crate) use posed_tracker::tracker_unit;
pub(crate) use predict::predict;
pub(crate) use rows::PredictedRows;
pub(crate) use sample::pose_derivative;
