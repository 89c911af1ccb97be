//! Kinematics of parallel mechanisms for artefact calibration, after Sato,
//! Shimojima, Furutani and Takamasu, Meas. Sci. Technol. 15 (2004) 1158:
//! the 6-6 Stewart platform (hexapod) in the modules listed first, and
//! every mechanism through one interface (the paragraph after them).
//!
//! - [`Geometry`]: joint centres, tool offset and initial leg lengths;
//!   [`paper`] holds table 2 of the paper.
//! - [`frames`]: the canonical base and platform frames (paper 2.1) and the
//!   conversion of a geometry given in any frame.
//! - [`params`]: the 33 identifiable parameters (paper eq. 3) with their names.
//! - [`inverse`] and [`forward`](mod@forward) kinematics (paper eqs. 1-2).
//! - [`assembly`]: the assembly mode, the branch of the forward kinematics
//!   the machine is in (the platform above its base), and the checks of a
//!   pose against it.
//! - [`joints`]: the angles between the legs and their joints' axes, and
//!   their limits.
//! - [`derivatives`]: the tool tip's derivatives with respect to the 33
//!   parameters and to the actuator values, by implicit differentiation.
//!
//! Every parallel mechanism implements one interface,
//! [`mechanism::Mechanism`]: the hexapod ([`hexapod`], an adapter over the
//! modules above), the linear delta ([`delta`]) and the cable robot
//! ([`cable`]); [`mechanisms`] is the list of them. [`pose_fit`] is the
//! forward kinematics of a mechanism with redundant actuators: the
//! least-squares pose of its readings.
//!
//! Lengths in mm, angles in rad (the delta's tower angles in degrees, as
//! its firmware gives them).
//!
//! ```
//! use parcal_kinematics::{paper, params, rotation_zyx, Pose, ForwardOptions};
//! use nalgebra::Translation3;
//!
//! let canonical = paper::truth().canonicalize()?.geometry;
//! let p = params::to_params(&canonical);
//! assert!((p[0] - 17.253).abs() < 5e-4); // y_b2
//!
//! // Inverse then forward kinematics returns the pose.
//! let pose = Pose::from_parts(Translation3::new(-80.0, 10.0, 250.0), rotation_zyx(0.1, 0.05, -0.02));
//! let q = parcal_kinematics::actuators(&canonical, &pose);
//! let solution = parcal_kinematics::forward_from_home(&canonical, &q, &ForwardOptions::default())?;
//! let error = canonical.tool_tip(&solution.pose) - canonical.tool_tip(&pose);
//! assert!(error.norm() < 1e-9);
//!
//! // d tip / d p (3 x 33) and d tip / d q (3 x 6) at that pose.
//! let jacobians = parcal_kinematics::tip_jacobians(&canonical, &solution);
//! assert_eq!(jacobians.d_params.ncols(), params::N_PARAMS);
//! # Ok::<(), parcal_kinematics::KinematicsError>(())
//! ```

pub mod assembly;
pub mod batch_workspace;
pub mod cable;
pub mod closure;
pub mod delta;
pub mod derivatives;
mod error;
pub mod forward;
pub mod forward_batch;
pub mod frames;
mod geometry;
pub mod hexapod;
pub mod inverse;
pub mod joints;
pub mod lu6;
pub mod mechanism;
pub mod mechanisms;
pub mod params;
pub mod params_jacobian;
pub mod pose_fit;
mod simd;

pub use derivatives::{
    DerivativeAlong, FactoredTipJacobian, SolutionAlong, SolutionJacobian, SolutionRoom,
    TipDerivatives, TipJacobians, tip_jacobians, tip_jacobians_at,
};
pub use error::KinematicsError;
pub use forward::{ForwardOptions, ForwardSolution, forward, forward_from_home};
pub use frames::{Canonical, PriorSigma};
pub use geometry::{Geometry, Pose, Vec3, paper, rotation_zyx};
pub use inverse::{actuators, leg_lengths};
pub use joints::{JointAngles, JointEnd, JointLimits, JointViolation};
pub use params::{N_PARAMS, PARAM_NAMES, ParamCovariance, Params, SCALE_NAMES};
