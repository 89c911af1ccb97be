//! Forward kinematics: actuator values -> pose, by Newton's method on the six
//! pose unknowns of the closure equations (paper eq. 1, see [`crate::closure`]).

use nalgebra::{UnitQuaternion, Vector3, Vector6};

use crate::{Geometry, KinematicsError, Pose, closure::Legs, lu6::Lu6};

/// Controls of the Newton iteration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ForwardOptions {
    /// Converged when every leg closure residual is below this (mm).
    pub tolerance: f64,
    /// Newton steps before giving up.
    pub max_iterations: usize,
}

impl Default for ForwardOptions {
    fn default() -> Self {
        Self {
            tolerance: 1e-10,
            max_iterations: 30,
        }
    }
}

/// A converged forward kinematics.
#[derive(Debug, Clone)]
pub struct ForwardSolution {
    /// Pose of the platform frame in the base frame.
    pub pose: Pose,
    /// The legs at that pose (reused by the derivatives).
    pub legs: Legs,
    /// Newton steps taken.
    pub iterations: usize,
}

/// Applies a pose increment `(dt, w)`: `t <- t + dt`, `R <- exp([w]x) R`.
pub fn step(pose: &Pose, delta: &Vector6<f64>, scale: f64) -> Pose {
    let mut next = *pose;
    next.translation.vector += scale * delta.fixed_rows::<3>(0);
    let w: Vector3<f64> = scale * delta.fixed_rows::<3>(3);
    next.rotation = UnitQuaternion::from_scaled_axis(w) * pose.rotation;
    next.rotation.renormalize_fast();
    next
}

/// Forward kinematics from `start`: the pose at which every leg has length
/// `l_i + q_i` (paper eq. 1), to within `options.tolerance` mm.
///
/// Newton's method with step halving when a full step does not reduce the
/// largest closure residual. Errors: a non-finite or infeasible
/// (`l_i + q_i <= 0`) actuator value, a singular closure Jacobian, or no
/// convergence within `options.max_iterations` steps.
pub fn forward(
    geometry: &Geometry,
    q: &[f64; 6],
    start: &Pose,
    options: &ForwardOptions,
) -> Result<ForwardSolution, KinematicsError> {
    for (i, value) in q.iter().enumerate() {
        let length = geometry.legs[i] + value;
        if !length.is_finite() {
            let what = format!("actuator value q{}", i + 1);
            return Err(KinematicsError::NonFinite { what });
        }
        if length <= 0.0 {
            return Err(KinematicsError::InfeasibleLeg { leg: i + 1, length });
        }
    }
    let mut pose = *start;
    let mut legs = Legs::at(geometry, &pose);
    let mut residual = legs.residual(geometry, q);
    let mut largest = residual.amax();
    for iterations in 0..=options.max_iterations {
        if largest < options.tolerance {
            return Ok(ForwardSolution {
                pose,
                legs,
                iterations,
            });
        }
        if iterations == options.max_iterations {
            break;
        }
        let delta = Lu6::factor(&legs.pose_jacobian())?.solve(&-residual);
        let mut scale = 1.0;
        loop {
            let candidate = step(&pose, &delta, scale);
            let candidate_legs = Legs::at(geometry, &candidate);
            let candidate_residual = candidate_legs.residual(geometry, q);
            let candidate_largest = candidate_residual.amax();
            if candidate_largest < largest || scale < 1e-3 {
                (pose, legs, residual, largest) = (
                    candidate,
                    candidate_legs,
                    candidate_residual,
                    candidate_largest,
                );
                break;
            }
            scale *= 0.5;
        }
        if !largest.is_finite() {
            break;
        }
    }
    Err(KinematicsError::NotConverged {
        iterations: options.max_iterations,
        residual: largest,
    })
}

/// Forward kinematics from the geometry's home pose ([`Geometry::home_pose`]).
pub fn forward_from_home(
    geometry: &Geometry,
    q: &[f64; 6],
    options: &ForwardOptions,
) -> Result<ForwardSolution, KinematicsError> {
    forward(geometry, q, &geometry.home_pose(q), options)
}
