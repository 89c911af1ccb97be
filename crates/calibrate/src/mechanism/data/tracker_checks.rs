//! The trackers, their points and poses checked
//! ([`check_tracker_points`], [`check_tracker_poses`]): how many trackers,
//! their offsets' and body shifts' sigmas, points and poses of trackers
//! that exist with finite values and weights, enough of them to locate
//! each frame.

use parcal_kinematics::mechanism::Mechanism;
use parcal_observe::mechanism::Actuation;

use super::super::error::MechanismCalibrationError;
use super::super::observation::{ObservationKind, ObservationRef};
use super::limits::{MAX_TRACKERS, MIN_POINTS_PER_TRACKER};
use super::observations::Observations;
use super::tracker::Tracker;
use super::value_checks::{check_values, observation_error};

/// At most [`MAX_TRACKERS`] trackers, each with at least
/// [`MIN_POINTS_PER_TRACKER`] points and poses, offsets (with a finite and positive
/// sigma) only for a mechanism of as many actuators as pose coordinates
/// (`square`); every tracker point of a tracker
/// that exists, where the machine was put as `check_at` accepts, its
/// measured point finite and its weight's `L⁻¹` finite with a positive
/// diagonal; every tracker pose the same, at readings, on a mechanism
/// with a platform frame.
pub(super) fn check_tracker_points(
    observations: &Observations,
    mechanism: &dyn Mechanism,
    square: bool,
    check_at: impl Fn(ObservationRef, &Actuation) -> Result<(), MechanismCalibrationError>,
) -> Result<(), MechanismCalibrationError> {
    let trackers = observations.trackers.len();
    let actuators = mechanism.actuators().len();
    if trackers > MAX_TRACKERS {
        return Err(MechanismCalibrationError::InvalidData {
            what: "trackers".to_string(),
            reason: format!("{trackers} is more than the {MAX_TRACKERS} accepted"),
        });
    }
    for tracker in &observations.trackers {
        let refuse = |reason: String| MechanismCalibrationError::InvalidData {
            what: format!("tracker {:?}", tracker.label),
            reason,
        };
        for (what, unknown, sigma) in [
            (
                "body rotation",
                tracker.body_turned,
                tracker.body_rotation_sigma,
            ),
            ("body origin", tracker.body_moved, tracker.body_origin_sigma),
        ] {
            match (unknown, sigma) {
                (false, Some(_)) => {
                    return Err(refuse(format!(
                        "it has a {what}'s sigma, but its {what} is not an unknown"
                    )));
                }
                (true, Some(sigma)) if !(sigma.is_finite() && sigma > 0.0) => {
                    return Err(refuse(format!(
                        "its {what}'s sigma {sigma} is not finite and positive"
                    )));
                }
                _ => {}
            }
        }
        match (tracker.rehomed, &tracker.offset_sigmas) {
            (false, None) => continue,
            (false, Some(_)) => {
                return Err(refuse(
                    "it has an offsets' sigma but was not re-homed: it has no offsets".to_string(),
                ));
            }
            (true, Some(sigmas)) if sigmas.len() != 1 && sigmas.len() != actuators => {
                return Err(refuse(format!(
                    "it has {} offsets' sigmas: one for every actuator, or one for each of the {actuators}",
                    sigmas.len()
                )));
            }
            (true, Some(sigmas)) => {
                if let Some(sigma) = sigmas.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
                    return Err(refuse(format!(
                        "its offsets' sigma {sigma} is not finite and positive"
                    )));
                }
            }
            (true, None) => {}
        }
        if !square {
            return Err(refuse(
                "its actuators' offsets need as many actuators as pose coordinates".to_string(),
            ));
        }
    }
    let mut points_of = vec![0usize; trackers];
    for (k, point) in observations.tracker_points.iter().enumerate() {
        let id = ObservationRef {
            kind: ObservationKind::TrackerPoint,
            index: k,
        };
        if point.tracker >= trackers {
            return Err(observation_error(
                id,
                format!(
                    "it is of tracker {}, and there are {trackers} trackers",
                    point.tracker
                ),
            ));
        }
        check_at(id, &point.at)?;
        check_values(id, "measured point", &point.measured)?;
        let whitening = point.weight.inverse_factor();
        if !(whitening.iter().all(|v| v.is_finite()) && whitening.diagonal().min() > 0.0) {
            return Err(observation_error(
                id,
                "its weight is not that of a positive definite covariance".to_string(),
            ));
        }
        points_of[point.tracker] += 1;
    }
    let mut poses_of = vec![0usize; trackers];
    check_tracker_poses(observations, mechanism, &mut poses_of)?;
    let remounted = |t: &Tracker| t.body_turned || t.body_moved;
    if let Some(t) =
        (0..trackers).find(|&t| poses_of[t] == 0 && remounted(&observations.trackers[t]))
    {
        return Err(MechanismCalibrationError::InvalidData {
            what: format!("tracker {:?}", observations.trackers[t].label),
            reason: "its body was re-mounted, and it measured no pose that sees the body"
                .to_string(),
        });
    }
    match (0..trackers).find(|&t| points_of[t] + poses_of[t] < MIN_POINTS_PER_TRACKER) {
        Some(t) => Err(MechanismCalibrationError::InvalidData {
            what: format!("tracker {:?}", observations.trackers[t].label),
            reason: match poses_of[t] {
                0 => format!(
                    "it has {} points; its frame needs at least {MIN_POINTS_PER_TRACKER} not on a line",
                    points_of[t]
                ),
                poses => format!(
                    "it has {} points and {poses} poses; its frame needs at least {MIN_POINTS_PER_TRACKER} of them (the poses by their body's origin) not on a line",
                    points_of[t]
                ),
            },
        }),
        None => Ok(()),
    }
}

/// Every tracker pose of a tracker that exists, at as many finite readings
/// as `mechanism` has actuators, on a mechanism with a platform frame, its
/// measured frame finite and its weight's `L⁻¹` square of that size, finite
/// with a positive diagonal; each counted in its tracker's `poses_of`.
fn check_tracker_poses(
    observations: &Observations,
    mechanism: &dyn Mechanism,
    poses_of: &mut [usize],
) -> Result<(), MechanismCalibrationError> {
    let actuators = mechanism.actuators().len();
    let name = mechanism.name();
    let trackers = poses_of.len();
    let frame = match observations.tracker_poses.first() {
        Some(_) => {
            let pose = vec![0.0; mechanism.pose_coordinates().len()];
            mechanism.platform_frame(&pose).map(|_| ())
        }
        None => Ok(()),
    };
    let body = observations.body_reference.to_homogeneous();
    if !body.iter().all(|v| v.is_finite()) {
        return Err(MechanismCalibrationError::InvalidData {
            what: "the body frame's reference".to_string(),
            reason: "it has a value that is not finite".to_string(),
        });
    }
    for (k, pose) in observations.tracker_poses.iter().enumerate() {
        let id = ObservationRef {
            kind: ObservationKind::TrackerPose,
            index: k,
        };
        if let Err(e) = &frame {
            return Err(observation_error(
                id,
                format!("the {name} has no platform frame a pose could see: {e}"),
            ));
        }
        if pose.tracker >= trackers {
            return Err(observation_error(
                id,
                format!(
                    "it is of tracker {}, and there are {trackers} trackers",
                    pose.tracker
                ),
            ));
        }
        if pose.readings.len() != actuators {
            return Err(observation_error(
                id,
                format!(
                    "{} readings for the {actuators} actuators of the {name}",
                    pose.readings.len()
                ),
            ));
        }
        check_values(id, "readings", &pose.readings)?;
        check_values(
            id,
            "measured frame",
            pose.measured.to_homogeneous().as_slice(),
        )?;
        let w = &pose.weight;
        if w.shape() != (actuators, actuators)
            || !(w.iter().all(|v| v.is_finite()) && w.diagonal().min() > 0.0)
        {
            return Err(observation_error(
                id,
                format!(
                    "its weight is not the {actuators} x {actuators} whitening of a positive definite covariance"
                ),
            ));
        }
        poses_of[pose.tracker] += 1;
    }
    Ok(())
}
