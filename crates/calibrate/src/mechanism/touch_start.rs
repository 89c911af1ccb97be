//! Where a fit starts its balls and touches when another set-up has
//! located them: each ball's centre and each touch's pose, given. Without
//! one, each ball's touches are reached from the mechanism's start poses
//! ([`Mechanism::start_pose`](parcal_kinematics::mechanism::Mechanism::start_pose))
//! and its centre is the best fit of their tool points. A hexapod's data
//! carry the own set-up's ([`super::MechanismData::from_hexapod_touches`]: the
//! design's forward kinematics of every contact and each ball's centre, or
//! its mirror image), so that the common calibration starts where the
//! hexapod's own does: each touch's tool point at its given pose
//! ([`Mechanism::tool_points_at_poses`](parcal_kinematics::mechanism::Mechanism::tool_points_at_poses)),
//! without forward kinematics.

use rayon::prelude::*;

use super::error::MechanismCalibrationError;

/// Each ball's centre and each touch's pose, where a fit starts them
/// (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct TouchStart {
    /// Each ball's centre (mm, the mechanism's frame), in the order of the
    /// balls.
    pub centres: Vec<[f64; 3]>,
    /// Each touch's pose coordinates, in the order of the touches, one
    /// touch after another.
    pub poses: Vec<f64>,
}

impl TouchStart {
    /// Touch `t`'s pose of `coordinates` coordinates.
    pub(crate) fn pose(&self, t: usize, coordinates: usize) -> &[f64] {
        &self.poses[t * coordinates..(t + 1) * coordinates]
    }

    /// A centre for each of `balls` balls and a pose of `coordinates`
    /// coordinates for each of `touches` touches, every value finite.
    pub(crate) fn validate(
        &self,
        balls: usize,
        touches: usize,
        coordinates: usize,
    ) -> Result<(), MechanismCalibrationError> {
        let invalid = |reason: String| MechanismCalibrationError::InvalidData {
            what: "the touches' start".to_string(),
            reason,
        };
        if self.centres.len() != balls {
            return Err(invalid(format!(
                "{} ball centres for {balls} balls",
                self.centres.len()
            )));
        }
        if self.poses.len() != touches * coordinates {
            return Err(invalid(format!(
                "{} pose coordinates for {touches} touches of {coordinates} each",
                self.poses.len()
            )));
        }
        if let Some(b) = (self.centres.iter()).position(|c| c.iter().any(|v| !v.is_finite())) {
            return Err(invalid(format!("ball {b}'s centre is not finite")));
        }
        if let Some(k) = self.poses.par_iter().position_first(|v| !v.is_finite()) {
            return Err(invalid(format!(
                "touch {}'s pose is not finite",
                k / coordinates.max(1)
            )));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A start of the data's sizes, finite, is taken; another is refused,
    /// naming what is wrong.
    #[test]
    fn a_start_must_fit_the_data() {
        let (balls, touches) = (2, 9);
        let start = TouchStart {
            centres: vec![[0.0, 0.0, 10.0]; balls],
            poses: vec![1.0; 3 * touches],
        };
        assert!(start.validate(balls, touches, 3).is_ok());
        let refused = |start: &TouchStart, coordinates| {
            (start.validate(balls, touches, coordinates))
                .unwrap_err()
                .to_string()
        };
        let error = refused(&start, 6);
        assert!(
            error.contains("27 pose coordinates for 9 touches of 6 each"),
            "{error}"
        );
        let mut short = start.clone();
        short.centres.pop();
        let error = refused(&short, 3);
        assert!(error.contains("1 ball centres for 2 balls"), "{error}");
        let mut infinite = start.clone();
        infinite.poses[3 * 8 + 2] = f64::INFINITY;
        let error = refused(&infinite, 3);
        assert!(error.contains("touch 8's pose"), "{error}");
        let mut centre = start;
        centre.centres[0][1] = f64::NAN;
        assert!(refused(&centre, 3).contains("ball 0's centre"));
    }
}
