//! Joint angles: how far each leg leans away from the axes of its joints.
//!
//! A spherical or universal joint turns only so far from its neutral
//! direction, its axis. With the leg direction `n_i` (unit, from base
//! joint `B_i` to platform joint `R E_i + t`, [`crate::closure::Legs`]),
//! the base joint's axis `a_i` (base frame) and the platform joint's axis
//! `b_i` (platform frame, along the leg's direction from base to platform
//! at the joint's neutral position: for both ends the frame's `+z` when
//! the platform sits above its base), the joint angles are
//!
//! ```text
//! θ_i^base     = ∠(n_i, a_i),
//! θ_i^platform = ∠(n_i, R b_i),
//! ```
//!
//! each `atan2(|n × a|, n · a)` (accurate near 0 and π). A pose is within
//! the limits when every `θ_i^base ≤ θ_max^base` and every
//! `θ_i^platform ≤ θ_max^platform`.

use crate::closure::Legs;
use crate::{Geometry, Pose, Vec3};

/// Which end of a leg a joint is on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointEnd {
    /// The base joint `B_i`.
    Base,
    /// The platform joint `E_i`.
    Platform,
}

impl JointEnd {
    /// `base` or `platform`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Base => "base",
            Self::Platform => "platform",
        }
    }
}

/// The largest angles between each leg and its joints' axes (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct JointLimits {
    /// Largest base joint angle (rad); `None`: unlimited.
    pub base: Option<f64>,
    /// Largest platform joint angle (rad); `None`: unlimited.
    pub platform: Option<f64>,
    /// Unit axis `a_i` of each base joint (base frame).
    pub base_axes: [Vec3; 6],
    /// Unit axis `b_i` of each platform joint (platform frame).
    pub platform_axes: [Vec3; 6],
}

/// A joint beyond its limit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointViolation {
    /// The leg (0-based).
    pub leg: usize,
    /// Which joint of the leg.
    pub end: JointEnd,
    /// Its angle (rad).
    pub angle: f64,
    /// Its limit (rad).
    pub limit: f64,
}

impl std::fmt::Display for JointViolation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "the {} joint of leg {} is at {:.2} degrees, beyond its limit of {:.2}",
            self.end.name(),
            self.leg + 1,
            self.angle.to_degrees(),
            self.limit.to_degrees()
        )
    }
}

/// The angles of the base and the platform joints of every leg at a pose
/// (rad, module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointAngles {
    /// `θ_i^base`.
    pub base: [f64; 6],
    /// `θ_i^platform`.
    pub platform: [f64; 6],
}

/// The angle between two vectors, `atan2(|a × b|, a · b)`.
fn angle(a: &Vec3, b: &Vec3) -> f64 {
    a.cross(b).norm().atan2(a.dot(b))
}

impl JointLimits {
    /// Limits with every axis along `+z` of its frame (the base and the
    /// platform normals of a design whose frames have `z` up).
    pub fn along_normals(base: Option<f64>, platform: Option<f64>) -> Self {
        Self {
            base,
            platform,
            base_axes: [Vec3::z(); 6],
            platform_axes: [Vec3::z(); 6],
        }
    }

    /// The joint angles of `geometry` at `pose` about these axes.
    pub fn angles(&self, geometry: &Geometry, pose: &Pose) -> JointAngles {
        let legs = Legs::at(geometry, pose);
        JointAngles {
            base: std::array::from_fn(|i| angle(&legs.direction[i], &self.base_axes[i])),
            platform: std::array::from_fn(|i| {
                angle(&legs.direction[i], &(legs.rotation * self.platform_axes[i]))
            }),
        }
    }

    /// The first joint (by leg, base before platform) of `geometry` at
    /// `pose` beyond its limit; `None` when every joint is within.
    pub fn violation(&self, geometry: &Geometry, pose: &Pose) -> Option<JointViolation> {
        let angles = self.angles(geometry, pose);
        (0..6).find_map(|leg| {
            [
                (JointEnd::Base, self.base, angles.base[leg]),
                (JointEnd::Platform, self.platform, angles.platform[leg]),
            ]
            .into_iter()
            .find_map(|(end, limit, angle)| {
                let limit = limit?;
                (angle > limit).then_some(JointViolation {
                    leg,
                    end,
                    angle,
                    limit,
                })
            })
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{paper, rotation_zyx};
    use nalgebra::Translation3;

    #[test]
    fn a_vertical_leg_is_at_zero_and_a_tilted_one_at_its_lean() {
        // One leg straight up from the origin to (0, 0, 40), one from
        // (-30, 0, 0) to (10, 0, 40): 45 degrees from vertical.
        let mut geometry = paper::design();
        geometry.base[0] = Vec3::zeros();
        geometry.platform[0] = Vec3::zeros();
        geometry.base[1] = Vec3::new(-30.0, 0.0, 0.0);
        geometry.platform[1] = Vec3::new(10.0, 0.0, 0.0);
        let pose = Pose::from_parts(
            Translation3::new(0.0, 0.0, 40.0),
            rotation_zyx(0.0, 0.0, 0.0),
        );
        let limits = JointLimits::along_normals(None, None);
        let angles = limits.angles(&geometry, &pose);
        assert!(angles.base[0].abs() < 1e-15 && angles.platform[0].abs() < 1e-15);
        let lean = std::f64::consts::FRAC_PI_4;
        assert!((angles.base[1] - lean).abs() < 1e-14, "{}", angles.base[1]);
        // Rolling the platform by 0.1 rad tilts its axes: the vertical
        // leg's platform joint turns by 0.1, its base joint not at all.
        let rolled = Pose::from_parts(
            Translation3::new(0.0, 0.0, 40.0),
            rotation_zyx(0.0, 0.0, 0.1),
        );
        let angles = limits.angles(&geometry, &rolled);
        assert!(angles.base[0].abs() < 1e-15);
        assert!((angles.platform[0] - 0.1).abs() < 1e-14);
    }

    #[test]
    fn the_first_joint_beyond_its_limit_is_named() {
        let geometry = paper::design();
        let pose = Pose::from_parts(
            Translation3::new(0.0, 0.0, 250.0),
            rotation_zyx(0.0, 0.3, 0.0),
        );
        let open = JointLimits::along_normals(Some(1.5), Some(1.5));
        assert_eq!(open.violation(&geometry, &pose), None);
        let angles = open.angles(&geometry, &pose);
        let largest = angles.platform.iter().copied().fold(0.0, f64::max);
        let tight = JointLimits::along_normals(None, Some(largest - 1e-9));
        let v = tight.violation(&geometry, &pose).unwrap();
        assert_eq!(v.end, JointEnd::Platform);
        assert_eq!(v.angle, largest);
        assert!(v.to_string().contains(&format!("leg {}", v.leg + 1)), "{v}");
    }
}
