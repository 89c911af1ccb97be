//! The records of a measuring session's nuisance (`truth.json`,
//! `calibration.json`): the instrument's frame, the platform body frame and
//! the legs' zero offsets.

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};
use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::check::Check;
use crate::error::Result;
use crate::shape;

/// A rigid transformation `x_to = R x_from + t`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameRecord {
    /// `t` (mm).
    #[serde(deserialize_with = "shape::point")]
    pub translation: Point3,
    /// `R` as a unit quaternion `[x, y, z, w]`.
    pub rotation: [f64; 4],
}

impl FrameRecord {
    /// The identity.
    pub const IDENTITY: Self = Self {
        translation: [0.0; 3],
        rotation: [0.0, 0.0, 0.0, 1.0],
    };

    /// The record of `isometry` (its quaternion as it is).
    pub fn of(isometry: &Isometry3<f64>) -> Self {
        let q = isometry.rotation.coords;
        Self {
            translation: isometry.translation.vector.into(),
            rotation: [q.x, q.y, q.z, q.w],
        }
    }

    /// The rigid motion it records (its quaternion normalised).
    pub fn isometry(&self) -> Isometry3<f64> {
        let [x, y, z, w] = self.rotation;
        Isometry3::from_parts(
            Translation3::from(Vector3::from(self.translation)),
            UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
        )
    }

    pub(crate) fn validate(&self, check: Check, field: &str) -> Result<()> {
        check.point(format_args!("{field}.translation"), &self.translation)?;
        check.values(format_args!("{field}.rotation"), &self.rotation)?;
        let norm = self.rotation.iter().map(|v| v * v).sum::<f64>().sqrt();
        if (norm - 1.0).abs() > 1e-6 {
            return Err(check.error(
                format!("{field}.rotation"),
                format!("a unit quaternion is expected, its norm is {norm}"),
            ));
        }
        Ok(())
    }
}

/// One session's nuisance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SessionRecord {
    /// The session's label (poses.csv, points.csv).
    pub label: String,
    /// The base frame in the instrument frame: `x_instrument = R x_base + t`.
    pub tracker_frame: FrameRecord,
    /// The platform body frame in the platform frame: `x_platform = R x_body
    /// + t` (poses: the marker body; identity for points).
    pub body_frame: FrameRecord,
    /// The legs' zero offsets (mm): leg `i` is `l_i + o_i + s_i q_i` long.
    #[serde(deserialize_with = "shape::legs")]
    pub leg_offsets: [f64; 6],
}

impl SessionRecord {
    pub(crate) fn validate(&self, check: Check, field: &str) -> Result<()> {
        self.tracker_frame
            .validate(check, &format!("{field}.tracker_frame"))?;
        self.body_frame
            .validate(check, &format!("{field}.body_frame"))?;
        check.lengths(format_args!("{field}.leg_offsets"), &self.leg_offsets)
    }
}
