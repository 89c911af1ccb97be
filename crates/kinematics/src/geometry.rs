//! The full geometry of a 6-6 Stewart platform and its poses.
//!
//! Leg `i` joins base joint `B_i` (base frame) to platform joint `E_i`
//! (platform frame); the tool tip `E_T` is fixed in the platform frame.
//! All lengths in mm.

use nalgebra::{Isometry3, Rotation3, Translation3, UnitQuaternion, Vector3};

use crate::KinematicsError;

/// A point or vector in mm.
pub type Vec3 = Vector3<f64>;

/// Pose of the platform frame in the base frame: `x_base = R x_platform + t`.
pub type Pose = Isometry3<f64>;

/// Complete geometry: joint centres, tool offset and initial leg lengths.
#[derive(Debug, Clone, PartialEq)]
pub struct Geometry {
    /// Base joint centres `B_1..B_6` in the base frame.
    pub base: [Vec3; 6],
    /// Platform joint centres `E_1..E_6` in the platform frame.
    pub platform: [Vec3; 6],
    /// Tool tip `E_T` in the platform frame.
    pub tool: Vec3,
    /// Initial leg lengths `l_1..l_6`: leg `i` is `l_i + q_i` long.
    pub legs: [f64; 6],
}

impl Geometry {
    /// Builds a geometry from plain arrays (the dataset's representation).
    pub fn from_arrays(
        base: &[[f64; 3]; 6],
        platform: &[[f64; 3]; 6],
        tool: &[f64; 3],
        legs: &[f64; 6],
    ) -> Self {
        Self {
            base: base.map(Vec3::from),
            platform: platform.map(Vec3::from),
            tool: Vec3::from(*tool),
            legs: *legs,
        }
    }

    /// Refuses NaN or infinite values, naming the offending coordinate.
    pub fn check_finite(&self) -> Result<(), KinematicsError> {
        let joints = |body: &str, joints: &[Vec3; 6]| {
            joints.iter().enumerate().find_map(|(i, p)| {
                (!p.iter().all(|v| v.is_finite())).then(|| format!("{body} joint {}", i + 1))
            })
        };
        let bad = joints("base", &self.base)
            .or_else(|| joints("platform", &self.platform))
            .or_else(|| (!self.tool.iter().all(|v| v.is_finite())).then(|| "tool".to_string()))
            .or_else(|| {
                self.legs
                    .iter()
                    .position(|l| !l.is_finite())
                    .map(|i| format!("leg length l{}", i + 1))
            });
        bad.map_or(Ok(()), |what| Err(KinematicsError::NonFinite { what }))
    }

    /// Tool tip in the base frame at `pose` (paper eq. 2): `T = R E_T + t`.
    pub fn tool_tip(&self, pose: &Pose) -> Vec3 {
        pose.transform_point(&self.tool.into()).coords
    }

    /// A start pose for forward kinematics at actuator values `q`: the
    /// platform parallel to the base, turned about the base z axis by the 2-D
    /// Procrustes angle that best aligns the platform joint pattern with the
    /// base pattern (zero for the symmetric design), its joint centroid above
    /// the base centroid at the height that gives the mean leg length.
    pub fn home_pose(&self, q: &[f64; 6]) -> Pose {
        let centroid = |p: &[Vec3; 6]| p.iter().sum::<Vec3>() / 6.0;
        let (cb, ce) = (centroid(&self.base), centroid(&self.platform));
        let (mut cross, mut dot) = (0.0, 0.0);
        for (b, e) in self.base.iter().zip(&self.platform) {
            let (b, e) = (b - cb, e - ce);
            cross += e.x * b.y - e.y * b.x;
            dot += e.x * b.x + e.y * b.y;
        }
        let rotation = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), cross.atan2(dot));
        let mean_length = (0..6).map(|i| self.legs[i] + q[i]).sum::<f64>() / 6.0;
        let mean_square_offset = (0..6)
            .map(|i| {
                let d = (rotation * (self.platform[i] - ce)) - (self.base[i] - cb);
                d.x * d.x + d.y * d.y
            })
            .sum::<f64>()
            / 6.0;
        let height = (mean_length * mean_length - mean_square_offset)
            .max(0.0)
            .sqrt();
        let t = cb - rotation * ce + Vec3::new(0.0, 0.0, height);
        Pose::from_parts(Translation3::from(t), rotation)
    }
}

/// Orientation `R = Rz(yaw) Ry(pitch) Rx(roll)` about fixed axes (rad).
pub fn rotation_zyx(yaw: f64, pitch: f64, roll: f64) -> UnitQuaternion<f64> {
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_euler_angles(roll, pitch, yaw))
}

/// The geometries of the paper's table 2 (Sato et al. 2004), in the design
/// frame, with the two misprints of E6 corrected (docs/paper-scenario.md section 1).
pub mod paper {
    use super::{Geometry, Vec3};

    /// Design (nominal) geometry of table 2.
    pub fn design() -> Geometry {
        Geometry {
            base: [
                Vec3::new(99.620, -8.716, 0.0),
                Vec3::new(99.620, 8.716, 0.0),
                Vec3::new(-42.262, 90.631, 0.0),
                Vec3::new(-57.358, 81.915, 0.0),
                Vec3::new(-57.358, -81.915, 0.0),
                Vec3::new(-42.262, -90.631, 0.0),
            ],
            platform: [
                Vec3::new(28.679, -40.958, 0.0),
                Vec3::new(28.679, 40.958, 0.0),
                Vec3::new(21.131, 45.315, 0.0),
                Vec3::new(-49.810, 4.358, 0.0),
                Vec3::new(-49.810, -4.358, 0.0),
                Vec3::new(21.131, -45.315, 0.0),
            ],
            tool: Vec3::new(0.0, 0.0, 60.0),
            legs: [235.0; 6],
        }
    }

    /// True geometry of table 2 (the simulated machine).
    pub fn truth() -> Geometry {
        Geometry {
            base: [
                Vec3::new(99.700, -8.633, 0.079),
                Vec3::new(99.604, 8.619, -0.078),
                Vec3::new(-42.154, 90.721, -0.041),
                Vec3::new(-57.499, 81.730, 0.053),
                Vec3::new(-57.449, -81.824, -0.045),
                Vec3::new(-42.202, -90.613, 0.033),
            ],
            platform: [
                Vec3::new(28.695, -41.025, 0.054),
                Vec3::new(28.766, 41.007, 0.036),
                Vec3::new(21.056, 45.307, -0.033),
                Vec3::new(-49.854, 4.441, -0.089),
                Vec3::new(-49.817, -4.418, 0.099),
                Vec3::new(21.155, -45.311, -0.067),
            ],
            tool: Vec3::new(0.099, 0.053, 60.411),
            legs: [234.934, 235.046, 235.124, 235.003, 235.069, 234.931],
        }
    }
}
