//! Forward kinematics: actuator values -> pose, by Newton's method on the six
//! pose unknowns of the closure equations (paper eq. 1, see [`crate::closure`]).

use nalgebra::{Quaternion, UnitQuaternion, Vector6};

use crate::{Geometry, KinematicsError, Pose, closure::Legs, lu6::Lu6};

/// A Newton step at most this long (mm and rad, largest component) ends the
/// iteration without evaluating the legs again. Newton's method converges
/// quadratically: after a step `d` the closure residual is
/// `1/2 d^T H d`, with the closure's second derivatives `|H|` below
/// `1/L_i` (translation) and the joint radius `|E_i|` (rotation), i.e.
/// below 1e-13 mm for any mechanism smaller than 1 m, far below the
/// tolerance. The legs and the closure factorisation at the step's start
/// then serve the derivatives: they differ from those at the solution by
/// `O(step)`, about 1e-8 relative, far below what the derivatives are
/// checked to (1e-6). A warm-started calibration iteration thus costs one
/// evaluation of the legs and one LU per contact.
pub const SHORT_STEP: f64 = 1e-8;

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
#[derive(Debug, Clone, Default)]
pub struct ForwardSolution {
    /// Pose of the platform frame in the base frame.
    pub pose: Pose,
    /// The legs at `pose`, or at the start of a last Newton step shorter
    /// than [`SHORT_STEP`] (reused by the derivatives).
    pub legs: Legs,
    /// LU of the closure Jacobian `A` where `legs` are.
    pub factor: Lu6,
    /// Newton steps taken.
    pub iterations: usize,
}

/// Applies a pose increment `(dt, w)` scaled by `scale`: `t <- t + dt`,
/// `R <- rot(w) R`, with `rot(w)` the rotation of the unit quaternion
/// `(1, w/2) / |(1, w/2)|` (the Cayley retraction: `exp([w]x)` to first
/// order, angle `2 atan(|w|/2)`). Newton's method needs only the first
/// order; this costs one square root instead of a sine and a cosine.
pub fn step(pose: &Pose, delta: &Vector6<f64>, scale: f64) -> Pose {
    let mut next = *pose;
    next.translation.vector += scale * delta.fixed_rows::<3>(0);
    let half = 0.5 * scale * delta.fixed_rows::<3>(3);
    let turn = Quaternion::new(1.0, half.x, half.y, half.z);
    next.rotation = UnitQuaternion::new_normalize(turn * pose.rotation.into_inner());
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
    let mut solution = ForwardSolution {
        pose: *start,
        ..ForwardSolution::default()
    };
    forward_in_place(geometry, q, options, &mut solution)?;
    Ok(solution)
}

/// [`forward`] from `solution.pose`, overwriting `solution` (unspecified
/// after an error): the calibration's per-contact path (one contact, a
/// machine without AVX2, and the rare cases of [`crate::forward_batch`]), which
/// moves neither the legs nor the factorisation by value.
pub fn forward_in_place(
    geometry: &Geometry,
    q: &[f64; 6],
    options: &ForwardOptions,
    solution: &mut ForwardSolution,
) -> Result<(), KinematicsError> {
    check_actuators(geometry, q)?;
    let ForwardSolution {
        pose,
        legs,
        factor,
        iterations,
    } = solution;
    legs.evaluate(geometry, pose);
    let mut residual = legs.residual(geometry, q);
    let mut largest = residual.amax();
    for step_count in 0..=options.max_iterations {
        *iterations = step_count;
        if largest < options.tolerance {
            legs.factor_into(factor)?;
            return Ok(());
        }
        if step_count == options.max_iterations {
            break;
        }
        legs.factor_into(factor)?;
        let delta = factor.solve(&-residual);
        if delta.amax() <= SHORT_STEP {
            *pose = step(pose, &delta, 1.0);
            *iterations = step_count + 1;
            return Ok(());
        }
        // Step halving; the legs are evaluated in place at each candidate
        // (the factorisation of the step's start is no longer needed).
        let start = *pose;
        let mut scale = 1.0;
        loop {
            *pose = step(&start, &delta, scale);
            legs.evaluate(geometry, pose);
            residual = legs.residual(geometry, q);
            let candidate_largest = residual.amax();
            if candidate_largest < largest || scale < 1e-3 {
                largest = candidate_largest;
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

/// Refuses a non-finite actuator value or one that makes a leg
/// infeasible (`l_i + q_i <= 0`).
pub(crate) fn check_actuators(geometry: &Geometry, q: &[f64; 6]) -> Result<(), KinematicsError> {
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
    Ok(())
}

/// Forward kinematics from the geometry's home pose ([`Geometry::home_pose`]).
pub fn forward_from_home(
    geometry: &Geometry,
    q: &[f64; 6],
    options: &ForwardOptions,
) -> Result<ForwardSolution, KinematicsError> {
    forward(geometry, q, &geometry.home_pose(q), options)
}
