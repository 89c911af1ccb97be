//! Where a fit starts its balls and touches when another set-up has
//! located them: each ball's centre and each touch's pose, given. Without
//! one, each ball's touches are reached from the mechanism's start poses
//! ([`Mechanism::start_pose`](parcal_kinematics::mechanism::Mechanism::start_pose))
//! and its centre is the best fit of their tool points. A hexapod's data
//! carry the own set-up's ([`MechanismData::from_hexapod_touches`]: the
//! design's forward kinematics of every contact and each ball's centre, or
//! its mirror image), so that the common calibration starts where the
//! hexapod's own does, its touches' forward kinematics each a step or none.

use super::data::MechanismData;
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

    /// A centre for each of `data`'s balls and a pose of its mechanism's
    /// coordinates for each of its touches, every value finite.
    pub(crate) fn validate(&self, data: &MechanismData) -> Result<(), MechanismCalibrationError> {
        let coordinates = data.mechanism.pose_coordinates().len();
        let (balls, touches) = (
            data.observations.balls.len(),
            data.observations.touches.len(),
        );
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
        if let Some(k) = self.poses.iter().position(|v| !v.is_finite()) {
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
    use crate::mechanism::problem::tests::small_delta;

    /// A start of the data's sizes, finite, is taken; another is refused,
    /// naming what is wrong.
    #[test]
    fn a_start_must_fit_the_data() {
        let data = small_delta();
        let (balls, touches) = (
            data.observations.balls.len(),
            data.observations.touches.len(),
        );
        let start = TouchStart {
            centres: vec![[0.0, 0.0, 10.0]; balls],
            poses: vec![1.0; 3 * touches],
        };
        assert!(start.validate(&data).is_ok());
        let refused = |start: TouchStart| {
            let data = data.clone().with_touch_start(start);
            data.validate().unwrap_err().to_string()
        };
        let mut short = start.clone();
        short.centres.pop();
        let error = refused(short);
        assert!(
            error.contains(&format!("{} ball centres for {balls} balls", balls - 1)),
            "{error}"
        );
        let mut infinite = start.clone();
        infinite.poses[3 * (touches - 1) + 2] = f64::INFINITY;
        let error = refused(infinite);
        assert!(
            error.contains(&format!("touch {}'s pose", touches - 1)),
            "{error}"
        );
        let mut centre = start;
        centre.centres[0][1] = f64::NAN;
        assert!(refused(centre).contains("ball 0's centre"));
    }
}
