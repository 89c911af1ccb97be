//! Observation blocks of artefact calibration, after Sato, Shimojima,
//! Furutani and Takamasu, Meas. Sci. Technol. 15 (2004) 1158: what one
//! touch of a calibration ball says about a hexapod's 33 kinematic
//! parameters `p`, the ball's centre `C_i` and the contact's direction, as a
//! residual with its Jacobian blocks, weighted by the observation covariance;
//! the a priori knowledge as Gaussian priors; and every observation kind of
//! any mechanism ([`mechanism`]).
//!
//! - [`Tip`]: the tool tip `T = f(q, p)` (paper eq. 2) with `J_f = dT/dp`
//!   and `J_q = dT/dq`, the input of every block.
//! - [`RadiusBlock`]: paper eq. (9), `c = r_i − |f(q, p) − C_i|` (1 row;
//!   unknowns `p`, `C_i`).
//! - [`CoordinateBlock`]: paper eq. (10), `c = C_i + r_i u(θ) − f(q, p)`
//!   (3 rows; unknowns `p`, `C_i`, `θ`), with the contact direction charted
//!   by [`DirectionChart`] (tangent coordinates of the exponential map).
//! - [`DistanceBlock`]: a calibrated centre-to-centre distance of two balls
//!   (ball plate, ball bar), `c = L_ab − |C_a − C_b|` (1 row; unknowns the
//!   two centres).
//! - [`PoseBlock`]: a platform pose measured by an instrument, in its
//!   inverse-kinematics form `c_i = |T E_i − B_i| − L_i` (6 rows; unknowns
//!   the joints, leg lengths and scales, the instrument and body frames).
//! - [`PointBlock`]: a tool point measured by an instrument,
//!   `c = F(f(q, p)) − P` (3 rows; unknowns `p`, the instrument frame).
//! - [`frame`]: the instrument and body frames as corrections of a
//!   reference.
//! - [`BlockJacobians`]: the common shape `(residual, d_tip, d_centre,
//!   d_angles)` of both, and its [`BlockJacobians::whiten`].
//! - [`weights`]: the observation covariance `W` of paper eq. (5) from the
//!   actuator, tool and radius repeatabilities, and its whitening
//!   ([`RadiusWhitening`], [`CoordinateWhitening`]).
//! - [`prior`]: paper eq. (7), [`KinematicPrior`] (paper or propagated form)
//!   and [`DiagonalPrior`] for centres and angles.
//!
//! - [`mechanism`]: the observation kinds of any mechanism (a linear delta,
//!   a cable robot, the hexapod) through the `Mechanism` trait: probe
//!   heights, heights measured by hand, part distances, measured points
//!   and quantities, readings at unknown poses, ball touches and the
//!   distances between balls, tracker points and poses.
//!
//! Lengths in mm, angles in rad, everything in the canonical base frame.
//!
//! ```
//! use nalgebra::{Translation3, Vector2};
//! use parcal_kinematics::{ForwardOptions, Pose, Vec3, actuators, forward_from_home, paper, rotation_zyx};
//! use parcal_observe::{
//!     CoordinateBlock, CoordinateWhitening, DirectionChart, Repeatability, Tip, WeightModel,
//!     coordinate_covariance,
//! };
//!
//! // One contact of the design machine, the tip touching a ball of radius 5
//! // from below.
//! let design = paper::design().canonicalize()?.geometry;
//! let pose = Pose::from_parts(Translation3::new(-60.0, 20.0, 300.0), rotation_zyx(0.1, -0.05, 0.02));
//! let q = actuators(&design, &pose);
//! let tip = Tip::at(&design, &forward_from_home(&design, &q, &ForwardOptions::default())?);
//! let u0 = Vec3::new(0.2, 0.1, -1.0).normalize();
//! let centre = tip.position - 5.0 * u0;
//!
//! // Paper eq. (10) at the initial direction: the residual vanishes.
//! let block = CoordinateBlock { radius: 5.0, chart: DirectionChart::new(&u0)? };
//! let raw = block.evaluate(&tip.position, &centre, &Vector2::zeros());
//! assert!(raw.residual.norm() < 1e-12);
//!
//! // Whitened by the covariance of 1 um repeatabilities: d c_w / d p is
//! // about 1000 times d c / d p.
//! let repeatability = Repeatability { actuator: 1e-3, tool: 1e-3, radius: 1e-3 };
//! let w = coordinate_covariance(WeightModel::Propagated, &repeatability, &tip.d_q(), &u0)?;
//! let whitened = raw.whiten(&CoordinateWhitening::from_covariance(&w)?);
//! assert!(whitened.d_params(&tip).norm() > 100.0 * raw.d_params(&tip).norm());
//! # Ok::<(), parcal_observe::ObserveError>(())
//! ```

mod block;
mod chart;
mod coordinates;
mod distance;
mod error;
pub mod frame;
pub mod mechanism;
mod point;
mod pose;
pub mod prior;
mod radius;
#[cfg(test)]
mod test_support;
mod tip;
pub mod weights;

pub use block::{BlockJacobians, CoordinateJacobians, RadiusJacobians};
pub use chart::{DirectionChart, unit_direction};
pub use coordinates::CoordinateBlock;
pub use distance::{DistanceBlock, DistanceJacobians};
pub use error::ObserveError;
pub use frame::FrameCorrection;
pub use point::{PointBlock, PointJacobians, point_covariance};
pub use pose::{PoseBlock, PoseJacobians, pose_covariance};
pub use prior::{AnglePrior, CentrePrior, DiagonalPrior, KinematicPrior};
pub use radius::RadiusBlock;
pub use tip::Tip;
pub use weights::{
    CoordinateWhitening, RadiusWhitening, Repeatability, WeightModel, Whitening,
    coordinate_covariance, radius_variance, tip_covariance,
};
