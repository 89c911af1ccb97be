//! The candidate poses of an instrument calibration: platform origins on a
//! grid of the workspace box (`|x|, |y| <= half_width`, `z` in `height`,
//! design base frame, [`POSITION_LEVELS`] levels per axis, the box's faces,
//! edges and corners included) times orientations on the grid of the tilt
//! box (`crate::pool`, corners and edges included). A pose is kept when
//! its platform is above the base (the machine's assembly mode), its
//! design readings are inside machine.json's stroke (when it gives one), its closure Jacobian is conditioned at least
//! [`crate::pool::MIN_CONDITIONING`] and its joints are within
//! machine.json's joint limits (when it gives them,
//! [`crate::pool::feasible_commands`]).

use nalgebra::Translation3;
use parcal_kinematics::{Geometry, JointLimits, Pose, Vec3, rotation_zyx};
use parcal_simulate::Workspace;

use crate::DesignError;
use crate::pool::{MIN_CONDITIONING, feasible_commands, orientation_grid};

/// Levels of each coordinate of the platform origin on the workspace box.
pub const POSITION_LEVELS: usize = 5;

/// One feasible candidate pose.
#[derive(Debug, Clone, PartialEq)]
pub struct CandidatePose {
    /// `[roll, pitch, yaw]` (rad), `R = Rz(yaw) Ry(pitch) Rx(roll)`.
    pub angles: [f64; 3],
    /// The platform pose (design frame).
    pub pose: Pose,
    /// The design's tool tip at the pose (design frame, mm).
    pub tip: Vec3,
    /// The design's readings (actuators' unit).
    pub q: [f64; 6],
}

/// The feasible poses of `design` (module doc), in a fixed order (z, y, x,
/// then orientation); `scale` turns leg extensions into readings, `stroke`
/// bounds the readings and `joint_limits` the joint angles when given.
pub fn pose_pool(
    design: &Geometry,
    workspace: &Workspace,
    tilt: f64,
    scale: &[f64; 6],
    stroke: Option<[f64; 2]>,
    joint_limits: Option<&JointLimits>,
) -> Result<Vec<CandidatePose>, DesignError> {
    let [low, high] = workspace.height;
    let valid = tilt.is_finite()
        && (0.0..std::f64::consts::FRAC_PI_2).contains(&tilt)
        && workspace.half_width.is_finite()
        && workspace.half_width >= 0.0
        && low.is_finite()
        && high.is_finite()
        && low <= high
        && scale.iter().all(|s| s.is_finite() && *s > 0.0);
    if !valid {
        return Err(DesignError::Options(format!(
            "pose pool: tilt {tilt} rad, workspace half width {} mm, height {:?} mm, scales {scale:?}",
            workspace.half_width, workspace.height
        )));
    }
    let level =
        |from: f64, to: f64, k: usize| from + (to - from) * k as f64 / (POSITION_LEVELS - 1) as f64;
    let w = workspace.half_width;
    let stroke = stroke.unwrap_or([f64::NEG_INFINITY, f64::INFINITY]);
    let orientations = orientation_grid(tilt);
    let mut pool = Vec::new();
    for iz in 0..POSITION_LEVELS {
        for iy in 0..POSITION_LEVELS {
            for ix in 0..POSITION_LEVELS {
                let origin = Vec3::new(level(-w, w, ix), level(-w, w, iy), level(low, high, iz));
                for angles in &orientations {
                    let [roll, pitch, yaw] = *angles;
                    let pose = Pose::from_parts(
                        Translation3::from(origin),
                        rotation_zyx(yaw, pitch, roll),
                    );
                    if let Some(q) = feasible_commands(
                        design,
                        &pose,
                        scale,
                        &stroke,
                        MIN_CONDITIONING,
                        joint_limits,
                    ) {
                        pool.push(CandidatePose {
                            angles: *angles,
                            tip: design.tool_tip(&pose),
                            pose,
                            q,
                        });
                    }
                }
            }
        }
    }
    if pool.is_empty() {
        return Err(DesignError::Options(format!(
            "no candidate pose in the workspace (half width {w} mm, height {:?} mm) has the platform above the base, within the stroke {stroke:?}, away from singularity and within the joint limits",
            workspace.height
        )));
    }
    Ok(pool)
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::paper;

    #[test]
    fn every_candidate_is_feasible_and_the_box_corners_are_in() {
        let design = paper::design();
        let workspace = Workspace {
            half_width: 60.0,
            height: [300.0, 380.0],
        };
        let tilt = 10f64.to_radians();
        let pool = pose_pool(
            &design,
            &workspace,
            tilt,
            &[1.0; 6],
            Some([0.0, 200.0]),
            None,
        )
        .unwrap();
        assert!(pool.len() > 1000, "{} candidates", pool.len());
        for c in &pool {
            assert!(c.q.iter().all(|q| (0.0..=200.0).contains(q)));
            assert!((design.tool_tip(&c.pose) - c.tip).norm() < 1e-12);
        }
        let t = tilt;
        assert!(
            pool.iter().any(|c| c.angles == [t, t, t]
                && c.pose.translation.vector == Vec3::new(60.0, 60.0, 380.0))
        );
        // A scale of 2 mm per unit halves every reading.
        let halved = pose_pool(&design, &workspace, tilt, &[2.0; 6], None, None).unwrap();
        assert!(halved.len() >= pool.len());
        let same = halved.iter().find(|c| c.pose == pool[0].pose).unwrap();
        assert!((0..6).all(|i| (2.0 * same.q[i] - pool[0].q[i]).abs() < 1e-12));
    }
}
