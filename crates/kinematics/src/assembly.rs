//! The assembly mode: which of the poses that share their leg lengths the
//! machine is in.
//!
//! The legs fix only the lengths `L_i = |R E_i + t - B_i|` (paper eq. 1),
//! and several poses share them: with the base joints in a plane, the
//! mirror image of a pose through that plane (the platform as far below
//! the base as it was above, turned over) has the same leg lengths, and a
//! 6-6 platform has up to 40 poses per set of lengths. The branch the
//! machine is in is its assembly mode. parcal starts every forward
//! kinematics at the home pose ([`Geometry::home_pose`]: the platform
//! parallel to the base on the side of the base frame's `+z`); the
//! calibration's contacts, the simulated machine and the commands of a
//! calibration all lie in that branch. Two checks of a pose against it:
//!
//! - [`platform_height`]: the platform on the home pose's side of the base;
//! - [`reached_from_home`]: the forward kinematics from the home pose of
//!   the pose's own leg lengths comes back to the pose, within
//!   [`REACH_TOLERANCE`] ([`pose_distance`]); several poses at once in
//!   SIMD lanes ([`reached_from_home_batch`]).

use crate::forward_batch::forward_batch;
use crate::{
    ForwardOptions, ForwardSolution, Geometry, KinematicsError, Pose, Vec3, forward_from_home,
};

/// The largest [`pose_distance`] (mm) between a pose and the pose the
/// forward kinematics of its leg lengths reaches for it to count as
/// reached. Newton's method stops with every closure residual below
/// [`ForwardOptions::default`]'s 1e-10 mm; the pose then differs from the
/// solution by at most that over the closure Jacobian's smallest singular
/// value, 1e-8 mm at a conditioning of 1e-2 (the least a command is given
/// at, `parcal_apply::SINGULARITY_RATIO`), times the lever of a point
/// about the platform's joints. A hundred times that is left for the
/// lever; another branch lies millimetres to metres away.
pub const REACH_TOLERANCE: f64 = 1e-6;

/// The height `h = (c_E - c_B) . e_z` (mm) of the platform joints'
/// centroid `c_E = R ē + t` above the base joints' centroid `c_B` along the
/// base frame's `+z`, the side [`Geometry::home_pose`] puts the platform on:
/// a pose with `h <= 0` is not in the machine's assembly mode (module doc).
pub fn platform_height(geometry: &Geometry, pose: &Pose) -> f64 {
    let centroid = |joints: &[Vec3; 6]| joints.iter().sum::<Vec3>() / 6.0;
    let platform = pose.transform_point(&centroid(&geometry.platform).into());
    (platform.coords - centroid(&geometry.base)).z
}

/// The largest distance (mm) between where the two poses put a platform
/// joint `E_i` or the tool tip `E_T`: zero only for the same pose (three
/// platform joints are not collinear).
pub fn pose_distance(geometry: &Geometry, a: &Pose, b: &Pose) -> f64 {
    geometry
        .platform
        .iter()
        .chain(std::iter::once(&geometry.tool))
        .map(|p| (a.transform_point(&(*p).into()) - b.transform_point(&(*p).into())).norm())
        .fold(0.0, f64::max)
}

/// The pose the machine reaches at the leg lengths of `pose`: the forward
/// kinematics of the extensions `L_i(pose) - l_i` from the home pose
/// (module doc). For a pose in the machine's assembly mode it is `pose`
/// within [`REACH_TOLERANCE`]; for its mirror image through a planar base,
/// `pose` mirrored back.
pub fn reached_from_home(geometry: &Geometry, pose: &Pose) -> Result<Pose, KinematicsError> {
    forward_from_home(
        geometry,
        &extensions_at(geometry, pose),
        &ForwardOptions::default(),
    )
    .map(|s| s.pose)
}

/// [`reached_from_home`] of each of up to
/// [`LANES`](crate::forward_batch::LANES) poses, in order,
/// together: in SIMD lanes ([`forward_batch`]) from their home poses, and
/// one by one where the batch fails, so that each outcome is its own.
///
/// # Panics
/// If there are more than [`LANES`](crate::forward_batch::LANES) poses.
pub fn reached_from_home_batch(
    geometry: &Geometry,
    poses: &[Pose],
) -> Vec<Result<Pose, KinematicsError>> {
    let extensions: Vec<[f64; 6]> = poses.iter().map(|p| extensions_at(geometry, p)).collect();
    let mut solutions: Vec<ForwardSolution> = (extensions.iter())
        .map(|q| ForwardSolution {
            pose: geometry.home_pose(q),
            ..ForwardSolution::default()
        })
        .collect();
    let q: Vec<&[f64; 6]> = extensions.iter().collect();
    match forward_batch(
        geometry,
        &q,
        &ForwardOptions::default(),
        &mut solutions,
        |s| s,
    ) {
        Ok(()) => solutions.into_iter().map(|s| Ok(s.pose)).collect(),
        Err(_) => poses
            .iter()
            .map(|p| reached_from_home(geometry, p))
            .collect(),
    }
}

/// The extensions `L_i(pose) - l_i` at which the legs hold `pose`.
fn extensions_at(geometry: &Geometry, pose: &Pose) -> [f64; 6] {
    let lengths = crate::leg_lengths(geometry, pose);
    std::array::from_fn(|i| lengths[i] - geometry.legs[i])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{leg_lengths, paper, rotation_zyx};
    use nalgebra::{Translation3, UnitQuaternion, Vector3};

    /// The mirror image of `pose` through the base plane z = 0 (the
    /// design's base joints lie in it), as a proper pose: the reflection
    /// `S = diag(1, 1, -1)` of the base frame composed with the same
    /// reflection of the planar platform frame, `S T S`.
    fn mirrored(pose: &Pose) -> Pose {
        let s = nalgebra::Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, -1.0));
        let r = s * pose.rotation.to_rotation_matrix().matrix() * s;
        let mut t = pose.translation.vector;
        t.z = -t.z;
        Pose::from_parts(Translation3::from(t), UnitQuaternion::from_matrix(&r))
    }

    #[test]
    fn a_pose_and_its_mirror_share_their_legs_and_the_machine_reaches_the_upper_one() {
        let design = paper::design();
        let above = Pose::from_parts(
            Translation3::new(15.0, -25.0, 340.0),
            rotation_zyx(0.2, -0.1, 0.05),
        );
        let below = mirrored(&above);
        let (up, down) = (leg_lengths(&design, &above), leg_lengths(&design, &below));
        for i in 0..6 {
            assert!(
                (up[i] - down[i]).abs() < 1e-9,
                "leg {i}: {} vs {}",
                up[i],
                down[i]
            );
        }
        assert!(platform_height(&design, &above) > 300.0);
        assert!(platform_height(&design, &below) < -300.0);
        let reached = reached_from_home(&design, &above).unwrap();
        assert!(pose_distance(&design, &reached, &above) < REACH_TOLERANCE);
        // The mirror's legs bring the machine back above the base.
        let reached = reached_from_home(&design, &below).unwrap();
        assert!(pose_distance(&design, &reached, &above) < REACH_TOLERANCE);
        assert!(pose_distance(&design, &reached, &below) > 600.0);
    }

    #[test]
    fn the_distance_of_poses_is_the_largest_joint_or_tool_displacement() {
        let design = paper::design();
        let pose = Pose::from_parts(
            Translation3::new(0.0, 0.0, 300.0),
            rotation_zyx(0.0, 0.0, 0.0),
        );
        let shifted = Pose::from_parts(
            Translation3::new(0.0, 3.0, 304.0),
            rotation_zyx(0.0, 0.0, 0.0),
        );
        assert!((pose_distance(&design, &pose, &shifted) - 5.0).abs() < 1e-12);
        // A turn by 0.01 rad about z moves the farthest joint, at radius
        // |E_i| in the xy-plane, by 2 |E_i| sin(0.005).
        let turned = Pose::from_parts(
            Translation3::new(0.0, 0.0, 300.0),
            rotation_zyx(0.01, 0.0, 0.0),
        );
        let radius = design.platform.iter().map(|e| e.norm()).fold(0.0, f64::max);
        let expected = 2.0 * radius * 0.005f64.sin();
        assert!((pose_distance(&design, &pose, &turned) - expected).abs() < 1e-12);
    }

    /// Poses reached together in lanes are those reached one by one, to
    /// within the forward kinematics' tolerance (1e-10 mm of closure, some
    /// 1e-8 mm of pose at the worst conditioning: 1e-7 mm allowed), a
    /// mirror image among them too; a pose that fails, fails alone.
    #[test]
    fn poses_reached_together_are_those_reached_one_by_one() {
        let design = paper::design();
        let pose = |k: usize| {
            let f = k as f64;
            Pose::from_parts(
                Translation3::new(20.0 * f.sin(), -15.0 * f.cos(), 320.0 + 5.0 * f),
                rotation_zyx(0.1 * f.cos(), -0.05 * f.sin(), 0.03 * f),
            )
        };
        let mut poses: Vec<Pose> = (0..8).map(pose).collect();
        poses[5] = mirrored(&poses[5]);
        let together = reached_from_home_batch(&design, &poses);
        for (k, (reached, pose)) in together.iter().zip(&poses).enumerate() {
            let alone = reached_from_home(&design, pose).unwrap();
            let reached = reached.as_ref().unwrap();
            assert!(pose_distance(&design, reached, &alone) < 1e-7, "pose {k}");
        }
        // A pose not finite fails the batch: each is then reached alone,
        // that one refused by name, the others as before.
        poses[2] = Pose::from_parts(
            Translation3::new(0.0, f64::NAN, 300.0),
            rotation_zyx(0.0, 0.0, 0.0),
        );
        let together = reached_from_home_batch(&design, &poses[..7]);
        for (k, pose) in poses[..7].iter().enumerate() {
            match (&together[k], reached_from_home(&design, pose)) {
                (Ok(a), Ok(b)) => assert!(pose_distance(&design, a, &b) < 1e-7, "pose {k}"),
                (Err(a), Err(b)) => assert_eq!((k, a.to_string()), (2, b.to_string())),
                (a, b) => panic!("pose {k}: {a:?} together, {b:?} alone"),
            }
        }
    }
}
