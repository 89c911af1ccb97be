//! Commands run on a machine: the loop of docs/apply.md closed in
//! simulation.
//!
//! Actuator readings `q` (in the actuators' unit) set leg `i` to
//! `l_i + s_i q_i` (`s_i` the machine's true scale); forward kinematics of
//! the machine's true geometry (docs/formulation.md section 4, from its home
//! pose) gives the pose it reaches, and its tool tip where the tool goes.

use parcal_kinematics::{ForwardOptions, Geometry, Pose, forward_from_home};

use crate::SimulateError;

/// The poses `geometry` (the true machine, in its design frame) reaches at
/// each row of readings `commands`, with true scales `scale` (mm per unit).
/// Errors name the row (1-based) whose forward kinematics failed.
pub fn execute(
    geometry: &Geometry,
    scale: &[f64; 6],
    commands: &[[f64; 6]],
) -> Result<Vec<Pose>, SimulateError> {
    let options = ForwardOptions::default();
    commands
        .iter()
        .enumerate()
        .map(|(k, q)| {
            let q_mm: [f64; 6] = std::array::from_fn(|i| scale[i] * q[i]);
            forward_from_home(geometry, &q_mm, &options)
                .map(|solution| solution.pose)
                .map_err(|e| SimulateError::Command {
                    row: k + 1,
                    reason: e.to_string(),
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion};
    use parcal_kinematics::{leg_lengths, paper};

    #[test]
    fn a_machine_reaches_the_pose_its_own_inverse_kinematics_commands() {
        let truth = paper::truth();
        let scale = [1.0, 1.001, 0.999, 2.0, 0.5, 1.0];
        let poses = [
            Pose::from_parts(
                Translation3::new(10.0, -20.0, 330.0),
                UnitQuaternion::identity(),
            ),
            Pose::from_parts(
                Translation3::new(-40.0, 30.0, 360.0),
                UnitQuaternion::from_euler_angles(0.1, -0.1, 0.2),
            ),
        ];
        let commands: Vec<[f64; 6]> = poses
            .iter()
            .map(|p| {
                let lengths = leg_lengths(&truth, p);
                std::array::from_fn(|i| (lengths[i] - truth.legs[i]) / scale[i])
            })
            .collect();
        let reached = execute(&truth, &scale, &commands).unwrap();
        for (a, b) in reached.iter().zip(&poses) {
            assert!((a.translation.vector - b.translation.vector).norm() < 1e-9);
            assert!(a.rotation.angle_to(&b.rotation) < 1e-11);
        }
        let error = execute(&truth, &scale, &[commands[0], [-1e4; 6]]).unwrap_err();
        assert!(error.to_string().starts_with("command row 2: "), "{error}");
    }
}
