//! Corrected poses for closed controllers.
//!
//! A closed controller (PI, Symetrie) computes its actuator commands from
//! its own nominal model, the design geometry: leg `i` of length
//! `l_i^d + s_i^d q_i`. Sent the pose `P'`, it commands `q = IK_d(P')`. For
//! the machine to reach the target it must command the calibrated model's
//! `q` ([`crate::compensate`](fn@crate::compensate)), so the pose to send is the nominal forward
//! kinematics of those commands, `P' = FK_d(q)`: the corrected pose, given
//! as a target row (the design tool's tip and the platform's angles).

use parcal_kinematics::{ForwardOptions, forward};

use crate::error::row_by_row;
use crate::{AppliedModel, ApplyError, Command, Refusal, Target};

/// The pose to send to a controller using the nominal model for it to
/// command `command`: forward kinematics of the design geometry at leg
/// lengths `l_i^d + s_i^d q_i`, started from the calibrated model's pose.
pub fn corrected_pose(model: &AppliedModel, command: &Command) -> Result<Target, Refusal> {
    let q_mm: [f64; 6] = std::array::from_fn(|i| model.design_scale[i] * command.q[i]);
    let solution = forward(
        &model.design,
        &q_mm,
        &command.pose,
        &ForwardOptions::default(),
    )
    .map_err(Refusal::NominalForward)?;
    Ok(Target::of_pose(&solution.pose, &model.design.tool))
}

/// [`corrected_pose`] of every command; an error names the row (1-based).
pub fn corrected_poses(
    model: &AppliedModel,
    commands: &[Command],
) -> Result<Vec<Target>, ApplyError> {
    row_by_row(commands, |c| corrected_pose(model, c))
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::command;
    use crate::tests::paper_model;
    use parcal_kinematics::{Vec3, leg_lengths};

    #[test]
    fn the_nominal_model_commands_the_calibrated_readings_at_the_corrected_pose() {
        let mut scaled = paper_model();
        scaled.design_scale = [1.0, 1.002, 0.998, 1.0, 1.001, 0.999];
        for (k, (x, roll)) in [(0.0, 0.0), (60.0, 0.1), (-80.0, -0.15)]
            .into_iter()
            .enumerate()
        {
            let model = if k == 0 {
                paper_model()
            } else {
                scaled.clone()
            };
            let target = Target {
                position: Vec3::new(x, 40.0 - 30.0 * k as f64, 380.0 + 20.0 * k as f64),
                roll,
                pitch: 0.05 * k as f64,
                yaw: -0.1,
            };
            let c = command(&model, &target).unwrap();
            let corrected = corrected_pose(&model, &c).unwrap();
            let lengths = leg_lengths(&model.design, &corrected.pose(&model.design.tool));
            for i in 0..6 {
                let q = (lengths[i] - model.design.legs[i]) / model.design_scale[i];
                assert!(
                    (q - c.q[i]).abs() < 1e-9,
                    "target {k}, leg {i}: {q} vs {}",
                    c.q[i]
                );
            }
            if k == 0 {
                // The truth differs from the design by tenths of a mm: so
                // do the corrections.
                let shift = (corrected.position - target.position).norm();
                assert!(shift > 1e-3 && shift < 5.0, "{shift}");
            }
        }
    }
}
