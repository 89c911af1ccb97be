//! A mechanism calibration's data checked before any work
//! ([`MechanismData::validate`]): the mechanism's size, the parameters and
//! priors, the observations' counts, each kind's values and sigmas (the
//! balls' and trackers' by their own checks), the touch start's sizes; the
//! first problem named.

use parcal_kinematics::mechanism::MechanismError;
use parcal_observe::mechanism::{Actuation, POSE_COORDINATES};

use super::super::correlation::check_correlation;
use super::super::error::MechanismCalibrationError;
use super::super::observation::{ObservationKind, ObservationRef};
use super::ball_checks::{check_ball_distances, check_balls};
use super::limits::{
    MAX_ACTUATORS, MAX_BALLS, MAX_OBSERVATIONS, MAX_POSE_COORDINATES, MAX_WARM_START, MIN_ACTUATORS,
};
use super::mechanism_data::MechanismData;
use super::tracker_checks::check_tracker_points;
use super::value_checks::{check_prior, check_sigma, check_values, observation_error};

#[cfg(doc)]
use super::limits::{MAX_TIED_BALLS, MIN_TOUCHES_PER_BALL};

impl MechanismData {
    /// Checks the data before any work: a mechanism with
    /// [`MIN_ACTUATORS`]..=[`MAX_ACTUATORS`] actuators, at most
    /// [`MAX_POSE_COORDINATES`] pose coordinates and a warm start of at
    /// most [`MAX_WARM_START`] values; for one whose pose
    /// is not a position `(x, y, z)` (the hexapod), touches at readings
    /// and measured quantities alone; sizes matching it; finite values; positive sigmas; counts within
    /// [`MAX_OBSERVATIONS`] (balls within [`MAX_BALLS`]) and at least one
    /// observation; every ball touched at least [`MIN_TOUCHES_PER_BALL`]
    /// times; every ball distance between two balls that exist, each
    /// pair at most once, tying at most [`MAX_TIED_BALLS`] balls; a touch
    /// start of their sizes. The first problem names the parameter, the
    /// observation or the ball.
    pub fn validate(&self) -> Result<(), MechanismCalibrationError> {
        let mechanism = self.mechanism.as_ref();
        let invalid = |what: String, reason: String| {
            Err(MechanismCalibrationError::InvalidData { what, reason })
        };
        let name = mechanism.name();
        let coordinates = mechanism.pose_coordinates().len();
        // Every kind but a touch at readings puts the machine at a position
        // (x, y, z), or makes its pose a block of three unknowns.
        let needs_position = |id: ObservationRef| {
            if coordinates == POSE_COORDINATES {
                Ok(())
            } else {
                Err(observation_error(
                    id,
                    format!(
                        "the {name}'s pose has {coordinates} coordinates, not a position (x, y, z): of its observations this calibration takes touches at the actuators' readings"
                    ),
                ))
            }
        };
        if coordinates > MAX_POSE_COORDINATES {
            return invalid(
                format!("the {name}"),
                format!(
                    "its pose has {coordinates} coordinates; this calibration takes at most {MAX_POSE_COORDINATES}"
                ),
            );
        }
        let warm_start = mechanism.warm_start_len();
        if warm_start > MAX_WARM_START {
            return invalid(
                format!("the {name}"),
                format!(
                    "its warm start has {warm_start} values; this calibration keeps at most {MAX_WARM_START}"
                ),
            );
        }
        let actuators = mechanism.actuators().len();
        if !(MIN_ACTUATORS..=MAX_ACTUATORS).contains(&actuators) {
            return invalid(
                format!("the {name}"),
                format!(
                    "it has {actuators} actuators; this calibration takes {MIN_ACTUATORS} to {MAX_ACTUATORS}"
                ),
            );
        }
        let parameters = mechanism.parameters();
        let n = parameters.len();
        for (what, len) in [
            ("configured parameters", self.configured.len()),
            ("priors", self.priors.len()),
        ] {
            if len != n {
                return invalid(
                    what.to_string(),
                    format!("{len} values for the {n} parameters of the {name}"),
                );
            }
        }
        for (k, parameter) in parameters.iter().enumerate() {
            let what = || format!("parameter {}", parameter.name);
            if !self.configured[k].is_finite() {
                return invalid(
                    what(),
                    format!("configured value {} is not finite", self.configured[k]),
                );
            }
            check_prior(&self.priors[k], what)?;
        }
        match mechanism.check_parameters(&self.configured) {
            Ok(()) => {}
            Err(MechanismError::Parameter {
                name,
                value,
                reason,
            }) => {
                return invalid(
                    format!("parameter {name}"),
                    format!("configured value {value}: {reason}"),
                );
            }
            Err(other) => return invalid("configured parameters".to_string(), other.to_string()),
        }
        check_prior(&self.trigger_height, || "trigger height".to_string())?;
        if let Some(correlation) = &self.prior_correlation {
            let has_prior: Vec<bool> = self.priors.iter().map(|p| p.sigma.is_some()).collect();
            check_correlation(mechanism, &has_prior, correlation)?;
        }
        let observations = &self.observations;
        for kind in ObservationKind::ALL {
            let count = observations.count(kind);
            if count > MAX_OBSERVATIONS {
                return invalid(
                    format!("{} observations", kind.name()),
                    format!("{count} is more than the {MAX_OBSERVATIONS} accepted"),
                );
            }
        }
        if observations.balls.len() > MAX_BALLS {
            return invalid(
                "balls".to_string(),
                format!(
                    "{} is more than the {MAX_BALLS} accepted",
                    observations.balls.len()
                ),
            );
        }
        if observations.is_empty() {
            return invalid(
                "observations".to_string(),
                "there is none: nothing to calibrate from".to_string(),
            );
        }
        let at = |kind, index| ObservationRef { kind, index };
        for (k, probe) in observations.probes.iter().enumerate() {
            let id = at(ObservationKind::Probe, k);
            needs_position(id)?;
            check_values(id, "commanded position", &probe.commanded)?;
            check_sigma(id, probe.sigma)?;
        }
        for (k, manual) in observations.manual_heights.iter().enumerate() {
            let id = at(ObservationKind::ManualHeight, k);
            needs_position(id)?;
            check_values(id, "commanded position", &manual.commanded)?;
            check_values(id, "height", &[manual.height])?;
            check_sigma(id, manual.sigma)?;
        }
        for (k, distance) in observations.distances.iter().enumerate() {
            let id = at(ObservationKind::Distance, k);
            needs_position(id)?;
            check_values(id, "first position", &distance.first)?;
            check_values(id, "second position", &distance.second)?;
            check_values(id, "distance", &[distance.distance])?;
            check_sigma(id, distance.sigma)?;
            if distance.first == distance.second {
                return Err(observation_error(id, "its two positions coincide".into()));
            }
        }
        for (k, point) in observations.points.iter().enumerate() {
            let id = at(ObservationKind::Point, k);
            needs_position(id)?;
            check_values(id, "commanded position", &point.commanded)?;
            check_values(id, "measured position", &point.measured)?;
            for sigma in point.sigma {
                check_sigma(id, sigma)?;
            }
        }
        for (k, sample) in observations.samples.iter().enumerate() {
            let id = at(ObservationKind::Sample, k);
            needs_position(id)?;
            if sample.readings.len() != actuators {
                return Err(observation_error(
                    id,
                    format!(
                        "{} readings for the {actuators} actuators of the {name}",
                        sample.readings.len()
                    ),
                ));
            }
            check_values(id, "readings", &sample.readings)?;
            check_sigma(id, sample.sigma)?;
            if let Some((pose, sigmas)) = &sample.known_pose {
                check_values(id, "known pose", pose)?;
                for &sigma in sigmas {
                    check_sigma(id, sigma)?;
                }
            }
            if let Some(loads) = &sample.loads {
                if loads.len() != actuators {
                    return Err(observation_error(
                        id,
                        format!(
                            "{} loads for the {actuators} actuators of the {name}",
                            loads.len()
                        ),
                    ));
                }
                check_values(id, "loads", loads)?;
            }
        }
        let check_at = |id, at: &Actuation| match at {
            Actuation::Commanded(commanded) => {
                needs_position(id)?;
                check_values(id, "commanded position", commanded)
            }
            Actuation::Readings(readings) if readings.len() != actuators => Err(observation_error(
                id,
                format!(
                    "{} readings for the {actuators} actuators of the {name}",
                    readings.len()
                ),
            )),
            Actuation::Readings(readings) => check_values(id, "readings", readings),
        };
        check_balls(observations, check_at)?;
        check_ball_distances(observations)?;
        check_tracker_points(observations, mechanism, actuators == coordinates, check_at)?;
        let quantities = mechanism.quantities();
        for (k, measured) in observations.quantities.iter().enumerate() {
            let id = at(ObservationKind::Quantity, k);
            if measured.quantity >= quantities.len() {
                return Err(observation_error(
                    id,
                    format!(
                        "the {name} has {} measurable quantities, not a quantity {}",
                        quantities.len(),
                        measured.quantity
                    ),
                ));
            }
            check_values(id, "value", &[measured.value])?;
            check_sigma(id, measured.sigma)?;
        }
        match &self.touch_start {
            Some(start) => start.validate(
                observations.balls.len(),
                observations.touches.len(),
                mechanism.warm_start_len(),
            ),
            None => Ok(()),
        }
    }
}
