//! A target: the tool tip's position and the platform's orientation in the
//! design frame.

use nalgebra::{Rotation3, Translation3, UnitQuaternion};
use parcal_kinematics::{Pose, Vec3, rotation_zyx};

use crate::Refusal;

/// A tool-tip position (mm) and a platform orientation
/// `R = Rz(yaw) Ry(pitch) Rx(roll)` (rad, fixed axes), in the design frame:
/// a row `x,y,z,roll,pitch,yaw` of targets.csv.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Tool tip (mm).
    pub position: Vec3,
    /// Rotation about x (rad).
    pub roll: f64,
    /// Rotation about y (rad).
    pub pitch: f64,
    /// Rotation about z (rad).
    pub yaw: f64,
}

impl Target {
    /// The CSV columns of a target.
    pub const COLUMNS: [&'static str; 6] = ["x", "y", "z", "roll", "pitch", "yaw"];

    /// From a row `x,y,z,roll,pitch,yaw`.
    pub fn from_row(row: &[f64; 6]) -> Self {
        Self {
            position: Vec3::new(row[0], row[1], row[2]),
            roll: row[3],
            pitch: row[4],
            yaw: row[5],
        }
    }

    /// The row `x,y,z,roll,pitch,yaw`.
    pub fn row(&self) -> [f64; 6] {
        let p = self.position;
        [p.x, p.y, p.z, self.roll, self.pitch, self.yaw]
    }

    /// `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub fn rotation(&self) -> UnitQuaternion<f64> {
        rotation_zyx(self.yaw, self.pitch, self.roll)
    }

    /// The platform pose that puts `tool` (platform frame) on the target:
    /// `t = position - R tool`.
    pub fn pose(&self, tool: &Vec3) -> Pose {
        let rotation = self.rotation();
        Pose::from_parts(
            Translation3::from(self.position - rotation * tool),
            rotation,
        )
    }

    /// The target a pose reaches with `tool`: its tip and its angles
    /// (`Rotation3::euler_angles`, pitch in [-pi/2, pi/2]).
    pub fn of_pose(pose: &Pose, tool: &Vec3) -> Self {
        let rotation: Rotation3<f64> = pose.rotation.to_rotation_matrix();
        let (roll, pitch, yaw) = rotation.euler_angles();
        Self {
            position: pose.transform_point(&(*tool).into()).coords,
            roll,
            pitch,
            yaw,
        }
    }

    /// Refuses a NaN or infinite value.
    pub(crate) fn check(&self) -> Result<(), Refusal> {
        match self.row().iter().position(|v| !v.is_finite()) {
            Some(k) => Err(Refusal::NonFinite {
                what: Self::COLUMNS[k],
            }),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_gives_back_its_target() {
        let target = Target {
            position: Vec3::new(12.0, -30.0, 410.0),
            roll: 0.1,
            pitch: -0.2,
            yaw: 0.3,
        };
        let tool = Vec3::new(1.0, 2.0, 60.0);
        let pose = target.pose(&tool);
        assert!((pose.transform_point(&tool.into()).coords - target.position).norm() < 1e-12);
        let back = Target::of_pose(&pose, &tool);
        for (a, b) in back.row().iter().zip(target.row()) {
            assert!((a - b).abs() < 1e-12, "{back:?} vs {target:?}");
        }
        // R = Rz(yaw) Ry(pitch) Rx(roll) about fixed axes.
        let expected = Rotation3::from_axis_angle(&Vec3::z_axis(), 0.3)
            * Rotation3::from_axis_angle(&Vec3::y_axis(), -0.2)
            * Rotation3::from_axis_angle(&Vec3::x_axis(), 0.1);
        assert!(
            (target.rotation().to_rotation_matrix().matrix() - expected.matrix()).norm() < 1e-14
        );
    }
}
