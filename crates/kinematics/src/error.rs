//! Errors of the kinematics: values with context, never NaN.

/// What can go wrong with a geometry or a kinematic computation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KinematicsError {
    /// Two joints of the same body coincide (within 1e-9 mm).
    #[error("{body} joints {first} and {second} coincide")]
    CoincidentJoints {
        /// `base` or `platform`.
        body: &'static str,
        /// The first joint (1-based).
        first: usize,
        /// The second joint (1-based).
        second: usize,
    },
    /// The three joints that define a canonical frame are (nearly) collinear.
    #[error(
        "{body} joints 1, 2 and 3 are collinear (sine of their angle {sine:.3e}): they cannot define the canonical frame"
    )]
    CollinearFrameJoints {
        /// `base` or `platform`.
        body: &'static str,
        /// The sine of the angle at joint 1.
        sine: f64,
    },
    /// A coordinate of the geometry is NaN or infinite.
    #[error("{what} is not a finite number")]
    NonFinite {
        /// The coordinate.
        what: String,
    },
    /// Leg `leg` (1-based) would need a non-positive length `l + q`.
    #[error("leg {leg} is infeasible: l + q = {length:.6} mm is not positive")]
    InfeasibleLeg {
        /// The leg (1-based).
        leg: usize,
        /// Its length `l + q` (mm).
        length: f64,
    },
    /// The closure Jacobian is singular at the pose (a singular configuration).
    #[error("the closure Jacobian is singular at this pose (singular configuration)")]
    SingularJacobian,
    /// Newton's method did not bring the leg closure residual under tolerance.
    #[error(
        "forward kinematics did not converge in {iterations} iterations (largest leg closure residual {residual:.3e} mm)"
    )]
    NotConverged {
        /// Newton steps taken.
        iterations: usize,
        /// The largest leg closure residual left (mm).
        residual: f64,
    },
}
