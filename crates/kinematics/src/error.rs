//! Errors of the kinematics: values with context, never NaN.

/// What can go wrong with a geometry or a kinematic computation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum KinematicsError {
    /// Two joints of the same body coincide (within 1e-9 mm).
    #[error("{body} joints {first} and {second} coincide")]
    CoincidentJoints {
        body: &'static str,
        first: usize,
        second: usize,
    },
    /// The three joints that define a canonical frame are (nearly) collinear.
    #[error(
        "{body} joints 1, 2 and 3 are collinear (sine of their angle {sine:.3e}): they cannot define the canonical frame"
    )]
    CollinearFrameJoints { body: &'static str, sine: f64 },
    /// A coordinate of the geometry is NaN or infinite.
    #[error("{what} is not a finite number")]
    NonFinite { what: String },
    /// Leg `leg` (1-based) would need a non-positive length `l + q`.
    #[error("leg {leg} is infeasible: l + q = {length:.6} mm is not positive")]
    InfeasibleLeg { leg: usize, length: f64 },
    /// The closure Jacobian is singular at the pose (a singular configuration).
    #[error("the closure Jacobian is singular at this pose (singular configuration)")]
    SingularJacobian,
    /// Newton's method did not bring the leg closure residual under tolerance.
    #[error(
        "forward kinematics did not converge in {iterations} iterations (largest leg closure residual {residual:.3e} mm)"
    )]
    NotConverged { iterations: usize, residual: f64 },
}
