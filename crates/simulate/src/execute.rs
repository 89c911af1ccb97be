//! Commands run on a machine: the loop of docs/apply.md closed in
//! simulation.
//!
//! Actuator readings `q` (in the actuators' unit) set leg `i` to
//! `l_i + s_i q_i` (`s_i` the machine's true scale); forward kinematics of
//! the machine's true geometry (docs/formulation.md section 4, from its home
//! pose: the machine's assembly mode, `parcal_kinematics::assembly`) gives
//! the pose it reaches, and its tool tip where the tool goes. A machine
//! cannot run a reading outside its stroke, nor reach a pose with a joint
//! beyond its limits: such a row is refused, naming the leg.

use parcal_kinematics::{ForwardOptions, Geometry, JointLimits, Pose, forward_from_home};

use crate::SimulateError;

/// What the machine's actuators and joints allow (machine.json's `stroke`
/// and `joint_limits`).
#[derive(Debug, Clone, Copy, Default)]
pub struct MachineLimits<'a> {
    /// The range `[min, max]` of every reading (actuators' unit), if given.
    pub stroke: Option<[f64; 2]>,
    /// The largest joint angles, if given.
    pub joint_limits: Option<&'a JointLimits>,
}

/// The poses `geometry` (the true machine, in its design frame) reaches at
/// each row of readings `commands`, with true scales `scale` (mm per unit)
/// and the machine's `limits`. Errors name the row (1-based) with a reading
/// outside the stroke (and its leg), whose forward kinematics failed, or
/// whose pose has a joint beyond its limit (and its leg).
pub fn execute(
    geometry: &Geometry,
    scale: &[f64; 6],
    limits: MachineLimits,
    commands: &[[f64; 6]],
) -> Result<Vec<Pose>, SimulateError> {
    let options = ForwardOptions::default();
    commands
        .iter()
        .enumerate()
        .map(|(k, q)| {
            let refused = |reason: String| SimulateError::Command { row: k + 1, reason };
            if let Some([min, max]) = limits.stroke
                && let Some(i) = q.iter().position(|q| !(min..=max).contains(q))
            {
                return Err(refused(format!(
                    "q{} = {} is outside the stroke [{min}, {max}] of machine.json: the machine cannot run it",
                    i + 1,
                    q[i]
                )));
            }
            let q_mm: [f64; 6] = std::array::from_fn(|i| scale[i] * q[i]);
            let pose = forward_from_home(geometry, &q_mm, &options)
                .map_err(|e| refused(e.to_string()))?
                .pose;
            match limits.joint_limits.and_then(|l| l.violation(geometry, &pose)) {
                Some(violation) => Err(refused(format!(
                    "at the pose these readings reach, {violation} (machine.json's joint_limits)"
                ))),
                None => Ok(pose),
            }
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
        let free = MachineLimits::default();
        let reached = execute(&truth, &scale, free, &commands).unwrap();
        for (a, b) in reached.iter().zip(&poses) {
            assert!((a.translation.vector - b.translation.vector).norm() < 1e-9);
            assert!(a.rotation.angle_to(&b.rotation) < 1e-11);
        }
        let error = execute(&truth, &scale, free, &[commands[0], [-1e4; 6]]).unwrap_err();
        assert!(error.to_string().starts_with("command row 2: "), "{error}");
    }

    #[test]
    fn readings_outside_the_stroke_and_joints_beyond_their_limits_are_refused() {
        let truth = paper::truth();
        let scale = [1.0; 6];
        let pose = Pose::from_parts(
            Translation3::new(0.0, 0.0, 330.0),
            UnitQuaternion::from_euler_angles(0.0, 0.2, 0.0),
        );
        let lengths = leg_lengths(&truth, &pose);
        let q: [f64; 6] = std::array::from_fn(|i| lengths[i] - truth.legs[i]);
        let (low, high) = q
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let top = q.iter().position(|&v| v == high).unwrap();
        // A stroke that ends just below the largest reading refuses it,
        // naming its leg; one that holds every reading runs it.
        let mut limits = MachineLimits {
            stroke: Some([low - 1.0, high - 1e-6]),
            joint_limits: None,
        };
        let message = execute(&truth, &scale, limits, &[q])
            .unwrap_err()
            .to_string();
        assert!(
            message.starts_with(&format!("command row 1: q{} = ", top + 1))
                && message.contains("is outside the stroke"),
            "{message}"
        );
        limits.stroke = Some([low - 1.0, high + 1.0]);
        assert!(execute(&truth, &scale, limits, &[q]).is_ok());
        // A platform joint limit just below the pose's largest angle.
        let open = JointLimits::along_normals(None, Some(1.5));
        let angles = open.angles(&truth, &pose).platform;
        let largest = angles.iter().copied().fold(0.0, f64::max);
        let tight = JointLimits::along_normals(None, Some(largest - 1e-6));
        limits.joint_limits = Some(&tight);
        let message = execute(&truth, &scale, limits, &[q])
            .unwrap_err()
            .to_string();
        assert!(message.contains("the platform joint of leg"), "{message}");
    }
}
