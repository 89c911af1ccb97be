//! The calibrated geometry placed in the design frame.
//!
//! A calibration identifies the geometry in its canonical frames
//! (docs/formulation.md section 2): base frame on B1, B2, B3, platform frame
//! on E1, E2, E3. A user commands targets in the design frame, so the
//! calibrated geometry is placed there by the best rigid fit (Kabsch,
//! [`parcal_accuracy::kabsch`](fn@parcal_accuracy::kabsch)) of its base joints onto the design's base
//! joints, and of its platform joints and tool tip onto the design's
//! platform joints and tool. The choice is a convention: any rigid placement
//! is the same machine, and the rigid registration a user makes afterwards
//! (work frame, tool frame) absorbs it; the fit only keeps the placed frames
//! as close as possible to the design's, so that the design's workspace and
//! the targets keep their meaning.

use parcal_accuracy::{RigidMotion, kabsch};
use parcal_kinematics::{Geometry, Vec3};

use crate::ApplyError;

/// The rigid motions that place a canonical geometry in the design frame,
/// with the residual of each fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Canonical base frame -> design base frame.
    pub base: RigidMotion,
    /// Canonical platform frame -> design platform frame.
    pub platform: RigidMotion,
    /// RMS distance of the placed base joints from the design's (mm).
    pub base_rms: f64,
    /// RMS distance of the placed platform joints and tool from the
    /// design's (mm).
    pub platform_rms: f64,
}

/// Places `canonical` (a geometry in its canonical frames) in the frames of
/// `design`: base joints moved by the base fit, platform joints and tool by
/// the platform fit, initial leg lengths unchanged.
pub fn place(canonical: &Geometry, design: &Geometry) -> Result<(Geometry, Placement), ApplyError> {
    let platform_points =
        |g: &Geometry| -> Vec<Vec3> { g.platform.iter().copied().chain([g.tool]).collect() };
    let base = kabsch(&canonical.base, &design.base).map_err(ApplyError::Placement)?;
    let (from, to) = (platform_points(canonical), platform_points(design));
    let platform = kabsch(&from, &to).map_err(ApplyError::Placement)?;
    let placed = Geometry {
        base: canonical.base.map(|b| base.apply(&b)),
        platform: canonical.platform.map(|e| platform.apply(&e)),
        tool: platform.apply(&canonical.tool),
        legs: canonical.legs,
    };
    let rms = |a: &[Vec3], b: &[Vec3]| {
        (a.iter()
            .zip(b)
            .map(|(a, b)| (a - b).norm_squared())
            .sum::<f64>()
            / a.len() as f64)
            .sqrt()
    };
    let placement = Placement {
        base,
        platform,
        base_rms: rms(&placed.base, &design.base),
        platform_rms: rms(&platform_points(&placed), &to),
    };
    Ok((placed, placement))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Translation3, UnitQuaternion};
    use parcal_kinematics::{Pose, leg_lengths, paper};

    #[test]
    fn the_design_placed_on_itself_comes_back_and_keeps_its_leg_lengths() {
        let design = paper::design();
        let canonical = design.canonicalize().unwrap().geometry;
        let (placed, placement) = place(&canonical, &design).unwrap();
        for (a, b) in placed.base.iter().zip(&design.base) {
            assert!((a - b).norm() < 1e-12);
        }
        assert!((placed.tool - design.tool).norm() < 1e-12);
        assert!(placement.base_rms < 1e-12 && placement.platform_rms < 1e-12);
        // The placed truth is the same machine: equal leg lengths at
        // corresponding poses (the pose moved by the two placements).
        let truth = paper::truth().canonicalize().unwrap().geometry;
        let (placed, placement) = place(&truth, &design).unwrap();
        let pose_c = Pose::from_parts(
            Translation3::new(10.0, -5.0, 300.0),
            UnitQuaternion::from_euler_angles(0.1, -0.05, 0.2),
        );
        let iso = |m: &RigidMotion| {
            Pose::from_parts(
                Translation3::from(m.translation),
                UnitQuaternion::from_rotation_matrix(&Rotation3::from(m.rotation)),
            )
        };
        let pose = iso(&placement.base) * pose_c * iso(&placement.platform).inverse();
        let (a, b) = (leg_lengths(&truth, &pose_c), leg_lengths(&placed, &pose));
        for i in 0..6 {
            assert!((a[i] - b[i]).abs() < 1e-9, "leg {i}: {} vs {}", a[i], b[i]);
        }
        // The true joints sit within their tolerances of the design's.
        assert!(placement.base_rms < 0.5 && placement.platform_rms < 0.5);
    }
}
