//! Inverse kinematics: pose -> leg lengths -> actuator values.

use crate::{Geometry, Pose, closure::Legs};

/// Leg lengths `L_i = |R E_i + t - B_i|` at `pose` (paper eq. 1), mm.
pub fn leg_lengths(geometry: &Geometry, pose: &Pose) -> [f64; 6] {
    Legs::at(geometry, pose).length
}

/// Actuator values `q_i = L_i - l_i` that put the platform at `pose`, mm.
pub fn actuators(geometry: &Geometry, pose: &Pose) -> [f64; 6] {
    let lengths = leg_lengths(geometry, pose);
    std::array::from_fn(|i| lengths[i] - geometry.legs[i])
}
