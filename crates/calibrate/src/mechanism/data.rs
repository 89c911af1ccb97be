//! A mechanism calibration's data in memory: the mechanism, the parameters
//! its controller ran with, the priors, the observations; and their
//! validation, which names the observation (kind, 0-based index) or the
//! parameter at fault.

use std::fmt;
use std::sync::Arc;

use nalgebra::{DMatrix, Isometry3};
use parcal_kinematics::mechanism::Mechanism;
use parcal_observe::mechanism::{
    Actuation, BallDistance, BallTouch, CommandedPoint, ManualHeight, MeasuredQuantity,
    POSE_COORDINATES, PartDistance, PointSample, ProbeHeight, TrackerPoint, TrackerPose,
};
use rayon::prelude::*;

use super::correlation::check_correlation;
use super::error::MechanismCalibrationError;
use super::observation::{ObservationKind, ObservationRef};
use super::tied::TiedBalls;
use super::touch_start::TouchStart;

/// The most observations of each kind: far beyond a calibration's needs
/// (a probed bed holds tens to hundreds), and small enough that the
/// dense checks over the rows stay within memory.
pub const MAX_OBSERVATIONS: usize = 1_000_000;
/// The most calibrated balls: as many as the most touches allow, each
/// ball taking at least [`MIN_TOUCHES_PER_BALL`] (every ball is a block
/// of its own, its radius too, which the solver eliminates).
pub const MAX_BALLS: usize = MAX_OBSERVATIONS / MIN_TOUCHES_PER_BALL;
/// The fewest touches of a ball: its centre takes three, and a fourth
/// is the first that checks them.
pub const MIN_TOUCHES_PER_BALL: usize = 4;
/// The most balls that calibrated distances tie together (a ball plate
/// holds tens): each adds its centre (and an uncertain radius) to the
/// dense global block, whose work per row grows with its square.
pub const MAX_TIED_BALLS: usize = 100;
/// The fewest actuators a mechanism calibrated here may have (one per
/// pose coordinate).
pub const MIN_ACTUATORS: usize = 3;
/// The most actuators (a cable robot of eight cables).
pub const MAX_ACTUATORS: usize = 8;
/// The most coordinates of a mechanism's pose (a rigid body's six).
pub const MAX_POSE_COORDINATES: usize = 6;
/// The most values of a mechanism's warm start
/// ([`Mechanism::warm_start`](parcal_kinematics::mechanism::Mechanism::warm_start):
/// a rigid body's translation and unit quaternion).
pub const MAX_WARM_START: usize = 7;
/// The most trackers: each adds its frame's six unknowns to the dense
/// global block (a calibration uses one per placement of the instrument,
/// a handful).
pub const MAX_TRACKERS: usize = 16;
/// The fewest points of a tracker (its poses' body origins counted as
/// points): three not on a line locate its frame.
pub const MIN_POINTS_PER_TRACKER: usize = 3;

/// The observations, by kind.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Observations {
    /// Probe heights.
    pub probes: Vec<ProbeHeight>,
    /// Heights of the nozzle measured by hand.
    pub manual_heights: Vec<ManualHeight>,
    /// Part distances.
    pub distances: Vec<PartDistance>,
    /// Measured points at commanded positions.
    pub points: Vec<CommandedPoint>,
    /// Readings at unknown or measured poses.
    pub samples: Vec<PointSample>,
    /// Quantities of the machine measured directly.
    pub quantities: Vec<MeasuredQuantity>,
    /// The calibrated balls the touches touch (not observations: their
    /// centres are unknowns).
    pub balls: Vec<Ball>,
    /// Touches of the balls.
    pub touches: Vec<BallTouch>,
    /// Calibrated distances between the balls' centres.
    pub ball_distances: Vec<BallDistance>,
    /// The trackers, one per placement of an instrument (not
    /// observations: each tracker's frame is six unknowns of the global
    /// block).
    pub trackers: Vec<Tracker>,
    /// Points the trackers measured.
    pub tracker_points: Vec<TrackerPoint>,
    /// Poses of a body on the platform the trackers measured.
    pub tracker_poses: Vec<TrackerPose>,
    /// `B₀`, the reference of the body frame the tracker poses see (body →
    /// platform; [`parcal_observe::mechanism::BodyFrame`]): the fit's start,
    /// the body frame's correction six unknowns of the global block when
    /// there are tracker poses. The identity by default.
    pub body_reference: Isometry3<f64>,
}

/// An instrument at one placement, measuring tool points in its own frame
/// ([`TrackerPoint`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Tracker {
    /// Its label.
    pub label: String,
    /// Whether the machine was re-homed before it measured: each
    /// actuator's zero offset is then an unknown of the global block;
    /// otherwise the actuators read as for the other observations.
    pub rehomed: bool,
    /// The standard deviations of the offsets' priors about zero (the
    /// actuators' extension, mm, where their scales are the mechanism's
    /// parameters, else the readings' unit), when re-homed: one for every actuator, or one per
    /// actuator; `None`: no prior.
    pub offset_sigmas: Option<Vec<f64>>,
    /// Whether the body its poses see was turned on the platform before it
    /// measured: the rotation `φ` about the body frame the other trackers
    /// see is then three unknowns of the global block (`C_B,k = (Exp(ω_B +
    /// φ), τ_B + ρ)`).
    pub body_turned: bool,
    /// The standard deviation of `φ`'s prior about zero (rad), when
    /// turned; `None`: no prior.
    pub body_rotation_sigma: Option<f64>,
    /// Whether the body was moved on the platform before it measured: the
    /// origin shift `ρ` is then three unknowns of the global block.
    pub body_moved: bool,
    /// The standard deviation of `ρ`'s prior about zero (mm), when moved;
    /// `None`: no prior.
    pub body_origin_sigma: Option<f64>,
}

impl Tracker {
    /// A tracker labelled `label`, the actuators read as for the other
    /// observations.
    pub fn new(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            rehomed: false,
            offset_sigmas: None,
            body_turned: false,
            body_rotation_sigma: None,
            body_moved: false,
            body_origin_sigma: None,
        }
    }

    /// A tracker labelled `label` that measured after the machine was
    /// re-homed, each actuator's offset with the prior `N(0, sigma²)`
    /// (`None`: no prior).
    pub fn rehomed(label: impl Into<String>, offset_sigma: Option<f64>) -> Self {
        Self {
            rehomed: true,
            offset_sigmas: offset_sigma.map(|sigma| vec![sigma]),
            ..Self::new(label)
        }
    }

    /// A tracker labelled `label` that measured after the machine was
    /// re-homed, actuator `i`'s offset with the prior `N(0, sigmas[i]²)`
    /// (actuators of different units or scales).
    pub fn rehomed_each(label: impl Into<String>, sigmas: Vec<f64>) -> Self {
        Self {
            rehomed: true,
            offset_sigmas: Some(sigmas),
            ..Self::new(label)
        }
    }

    /// The prior sigma of actuator `i`'s offset, if any.
    pub(crate) fn offset_sigma(&self, i: usize) -> Option<f64> {
        let sigmas = self.offset_sigmas.as_ref()?;
        sigmas.get(i).or(sigmas.first()).copied()
    }

    /// This tracker after the body on the platform was turned, the
    /// rotation's prior `N(0, sigma² I)` (`None`: no prior).
    pub fn with_body_turned(mut self, sigma: Option<f64>) -> Self {
        self.body_turned = true;
        self.body_rotation_sigma = sigma;
        self
    }

    /// This tracker after the body on the platform was moved, the origin
    /// shift's prior `N(0, sigma² I)` (`None`: no prior).
    pub fn with_body_moved(mut self, sigma: Option<f64>) -> Self {
        self.body_moved = true;
        self.body_origin_sigma = sigma;
        self
    }
}

/// A calibrated sphere placed at an unknown centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Its calibrated radius `ρ` (mm).
    pub radius: f64,
    /// The standard deviation of its calibration (mm); `None`: exact. With
    /// one, the radius is an unknown of the fit with that prior.
    pub radius_sigma: Option<f64>,
    /// What is known of its centre before the touches (where it was
    /// placed); `None`: the touches alone locate it.
    pub centre_prior: Option<CentrePrior>,
}

/// A Gaussian prior on a ball's centre: `c ~ N(centre, σ² I)` (paper eq.
/// 7's artefact terms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentrePrior {
    /// The centre's prior mean (mm, the mechanism's frame).
    pub centre: [f64; 3],
    /// Its standard deviation on each axis (mm).
    pub sigma: f64,
}

impl Ball {
    /// A ball of calibrated radius `radius` (mm), with its calibration's
    /// sigma or exact, and no prior on its centre.
    pub fn new(radius: f64, radius_sigma: Option<f64>) -> Self {
        Self {
            radius,
            radius_sigma,
            centre_prior: None,
        }
    }
}

impl Observations {
    /// The number of observations of `kind`.
    pub fn count(&self, kind: ObservationKind) -> usize {
        match kind {
            ObservationKind::Probe => self.probes.len(),
            ObservationKind::Distance => self.distances.len(),
            ObservationKind::Point => self.points.len(),
            ObservationKind::Sample => self.samples.len(),
            ObservationKind::Quantity => self.quantities.len(),
            ObservationKind::Touch => self.touches.len(),
            ObservationKind::BallDistance => self.ball_distances.len(),
            ObservationKind::TrackerPoint => self.tracker_points.len(),
            ObservationKind::TrackerPose => self.tracker_poses.len(),
            ObservationKind::ManualHeight => self.manual_heights.len(),
        }
    }

    /// The number of observations.
    pub fn len(&self) -> usize {
        ObservationKind::ALL.iter().map(|&k| self.count(k)).sum()
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The balls the ball distances tie, their unknowns from global column
    /// `first` on ([`super::tied`]).
    pub(crate) fn tied_balls(&self, first: usize) -> TiedBalls {
        let radius_unknown: Vec<bool> = self
            .balls
            .iter()
            .map(|ball| ball.radius_sigma.is_some())
            .collect();
        TiedBalls::new(&self.ball_distances, &radius_unknown, first)
    }

    /// Each ball's number of touches, and whether the touches come ball by
    /// ball (their balls' indices never decrease); every touch on a ball
    /// that exists. The touches are read a chunk at a time on the threads,
    /// each chunk as its runs of touches of one ball, which are then added
    /// up in order.
    pub(crate) fn touches_per_ball(&self) -> (Vec<usize>, bool) {
        let runs: Vec<Vec<(usize, usize)>> = (self.touches.par_chunks(COUNT_CHUNK))
            .map(|touches| {
                let mut runs: Vec<(usize, usize)> = Vec::new();
                for touch in touches {
                    match runs.last_mut() {
                        Some((ball, count)) if *ball == touch.ball => *count += 1,
                        _ => runs.push((touch.ball, 1)),
                    }
                }
                runs
            })
            .collect();
        let mut counts = vec![0; self.balls.len()];
        let (mut grouped, mut last) = (true, 0);
        for &(ball, count) in runs.iter().flatten() {
            counts[ball] += count;
            grouped &= last <= ball;
            last = ball;
        }
        (counts, grouped)
    }

    /// These observations without `observation`.
    pub fn without(&self, observation: ObservationRef) -> Self {
        let mut rest = self.clone();
        let k = observation.index;
        match observation.kind {
            ObservationKind::Probe => drop(rest.probes.remove(k)),
            ObservationKind::Distance => drop(rest.distances.remove(k)),
            ObservationKind::Point => drop(rest.points.remove(k)),
            ObservationKind::Sample => drop(rest.samples.remove(k)),
            ObservationKind::Quantity => drop(rest.quantities.remove(k)),
            ObservationKind::Touch => drop(rest.touches.remove(k)),
            ObservationKind::BallDistance => drop(rest.ball_distances.remove(k)),
            ObservationKind::TrackerPoint => drop(rest.tracker_points.remove(k)),
            ObservationKind::TrackerPose => drop(rest.tracker_poses.remove(k)),
            ObservationKind::ManualHeight => drop(rest.manual_heights.remove(k)),
        }
        rest
    }
}

/// The number of touches [`Observations::touches_per_ball`] reads at a time
/// on the threads.
const COUNT_CHUNK: usize = 4096;

/// A Gaussian prior on one unknown: its mean and standard deviation;
/// without a standard deviation, no prior, the mean being only where the
/// solver starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterPrior {
    /// The mean (the start of the solver).
    pub mean: f64,
    /// The standard deviation, `None` for no prior.
    pub sigma: Option<f64>,
}

/// A mechanism calibration's data (module doc).
#[derive(Clone)]
#[non_exhaustive]
pub struct MechanismData {
    /// The mechanism.
    pub mechanism: Arc<dyn Mechanism>,
    /// The parameters the controller ran with, `p_c`: every commanded
    /// position became readings through them.
    pub configured: Vec<f64>,
    /// Each parameter's prior (the builder's knowledge of the true
    /// machine), in the mechanism's parameter order.
    pub priors: Vec<ParameterPrior>,
    /// The correlation of the parameters' priors (`n × n`, unit
    /// diagonal; [`super::prior`]); `None`: independent.
    pub prior_correlation: Option<DMatrix<f64>>,
    /// The probe's trigger height `h` above the bed (mm): an unknown when
    /// there are probe heights.
    pub trigger_height: ParameterPrior,
    /// The observations.
    pub observations: Observations,
    /// Where a fit starts the balls and touches, when another set-up has
    /// located them ([`TouchStart`]); `None`: from the mechanism's start
    /// poses.
    pub touch_start: Option<TouchStart>,
    /// A printer's printable radius (mm, machine.json's), which
    /// [`Self::mechanism`] keeps the nozzle within and the calibration's
    /// record carries to what applies it (compensation, the firmware's
    /// lines); `None`: the mechanism's own limits, unrecorded.
    pub print_radius: Option<f64>,
}

impl fmt::Debug for MechanismData {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MechanismData")
            .field("mechanism", &self.mechanism.name())
            .field("configured", &self.configured)
            .field("priors", &self.priors)
            .field("prior_correlation", &self.prior_correlation)
            .field("trigger_height", &self.trigger_height)
            .field("observations", &self.observations)
            .field("touch_start", &self.touch_start.as_ref().map(|_| "given"))
            .field("print_radius", &self.print_radius)
            .finish()
    }
}

impl MechanismData {
    /// The data of `mechanism` run with `configured` parameters: each
    /// parameter's prior its design value and tolerance
    /// ([`parcal_kinematics::mechanism::Parameter`]), the trigger height
    /// without a prior, starting at 0.
    pub fn new(
        mechanism: Arc<dyn Mechanism>,
        configured: Vec<f64>,
        observations: Observations,
    ) -> Self {
        let priors = mechanism
            .parameters()
            .iter()
            .map(|p| ParameterPrior {
                mean: p.design,
                sigma: Some(p.prior_sigma),
            })
            .collect();
        Self {
            mechanism,
            configured,
            priors,
            prior_correlation: None,
            trigger_height: ParameterPrior {
                mean: 0.0,
                sigma: None,
            },
            observations,
            touch_start: None,
            print_radius: None,
        }
    }

    /// These data with their balls and touches started at `start`
    /// (checked by [`MechanismData::validate`]).
    pub fn with_touch_start(mut self, start: TouchStart) -> Self {
        self.touch_start = Some(start);
        self
    }

    /// These data with the prior sigma of every parameter of `group` set
    /// to `sigma` (`None`: no prior). An error names a group the
    /// mechanism does not have.
    pub fn with_group_sigma(
        mut self,
        group: &str,
        sigma: Option<f64>,
    ) -> Result<Self, MechanismCalibrationError> {
        let parameters = self.mechanism.parameters();
        if !parameters.iter().any(|p| p.group == group) {
            let mut groups: Vec<&str> = parameters.iter().map(|p| p.group).collect();
            groups.dedup();
            return Err(MechanismCalibrationError::InvalidData {
                what: format!("parameter group {group:?}"),
                reason: format!(
                    "the {} has no such group (its groups: {})",
                    self.mechanism.name(),
                    groups.join(", ")
                ),
            });
        }
        for (prior, parameter) in self.priors.iter_mut().zip(parameters) {
            if parameter.group == group {
                prior.sigma = sigma;
            }
        }
        Ok(self)
    }

    /// These data with every parameter's prior mean set to `means` (the
    /// design the builder aimed at), keeping the sigmas.
    pub fn with_prior_means(mut self, means: &[f64]) -> Self {
        for (prior, &mean) in self.priors.iter_mut().zip(means) {
            prior.mean = mean;
        }
        self
    }

    /// These data with the parameters' priors correlated by `correlation`
    /// (`n × n` for the `n` parameters, symmetric, unit diagonal, positive
    /// definite over the parameters with a prior; [`super::prior`]), their
    /// sigmas kept. [`MechanismData::validate`] checks it.
    pub fn with_prior_correlation(mut self, correlation: DMatrix<f64>) -> Self {
        self.prior_correlation = Some(correlation);
        self
    }

    /// These data with the trigger height's prior `mean ± sigma`.
    pub fn with_trigger_height(mut self, mean: f64, sigma: Option<f64>) -> Self {
        self.trigger_height = ParameterPrior { mean, sigma };
        self
    }

    /// These data with no prior on any parameter nor on any tracker's
    /// offsets or body shifts (the means kept as the solver's start).
    pub fn without_priors(mut self) -> Self {
        for prior in &mut self.priors {
            prior.sigma = None;
        }
        for tracker in &mut self.observations.trackers {
            tracker.offset_sigmas = None;
            tracker.body_rotation_sigma = None;
            tracker.body_origin_sigma = None;
        }
        self
    }

    /// [`MechanismData::without_priors`], but for the parameters of the
    /// mechanism's `group`, whose priors stay: what holds parameters that
    /// no observation sees.
    pub fn without_priors_but(self, group: &str) -> Self {
        let kept: Vec<ParameterPrior> = self.priors.clone();
        let mut data = self.without_priors();
        let parameters = data.mechanism.parameters();
        for ((prior, kept), parameter) in data.priors.iter_mut().zip(kept).zip(parameters) {
            if parameter.group == group {
                *prior = kept;
            }
        }
        data
    }

    /// Whether the trigger height is an unknown: there are probe heights.
    pub fn has_trigger_height(&self) -> bool {
        !self.observations.probes.is_empty()
    }

    /// These data with other observations, started from the mechanism's
    /// start poses.
    pub fn with_observations(&self, observations: Observations) -> Self {
        Self {
            observations,
            // Its places are the old observations'.
            touch_start: None,
            ..self.clone()
        }
    }

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

/// Every ball's radius finite and positive and its sigma, if any, finite
/// and positive; every touch on a ball that exists, where the machine was
/// put as `check_at` accepts, with a positive sigma; every ball touched at
/// least [`MIN_TOUCHES_PER_BALL`] times.
fn check_balls(
    observations: &Observations,
    check_at: impl Fn(ObservationRef, &Actuation) -> Result<(), MechanismCalibrationError> + Sync,
) -> Result<(), MechanismCalibrationError> {
    let balls = &observations.balls;
    let ball_error = |b: usize, reason: String| MechanismCalibrationError::InvalidData {
        what: format!("ball {b}"),
        reason,
    };
    for (b, ball) in balls.iter().enumerate() {
        if !(ball.radius.is_finite() && ball.radius > 0.0) {
            return Err(ball_error(
                b,
                format!("its radius {} is not finite and positive", ball.radius),
            ));
        }
        if let Some(sigma) = ball.radius_sigma
            && !(sigma.is_finite() && sigma > 0.0)
        {
            return Err(ball_error(
                b,
                format!("its radius sigma {sigma} is not finite and positive (exact: none)"),
            ));
        }
        if let Some(prior) = ball.centre_prior {
            if prior.centre.iter().any(|c| !c.is_finite()) {
                return Err(ball_error(
                    b,
                    format!("its centre prior {:?} is not finite", prior.centre),
                ));
            }
            if !(prior.sigma.is_finite() && prior.sigma > 0.0) {
                return Err(ball_error(
                    b,
                    format!(
                        "its centre prior's sigma {} is not finite and positive (no prior: none)",
                        prior.sigma
                    ),
                ));
            }
        }
    }
    // The touches on the threads, the first refused named.
    let refused = (observations.touches.par_iter().enumerate()).find_map_first(|(k, touch)| {
        let id = ObservationRef {
            kind: ObservationKind::Touch,
            index: k,
        };
        let checked = if touch.ball >= balls.len() {
            Err(observation_error(
                id,
                format!(
                    "it touches ball {}, and there are {} balls",
                    touch.ball,
                    balls.len()
                ),
            ))
        } else {
            check_at(id, &touch.at).and_then(|()| check_sigma(id, touch.sigma))
        };
        checked.err()
    });
    if let Some(error) = refused {
        return Err(error);
    }
    let (touches_of, _) = observations.touches_per_ball();
    match touches_of
        .iter()
        .position(|&count| count < MIN_TOUCHES_PER_BALL)
    {
        Some(b) => Err(ball_error(
            b,
            format!(
                "it has {} touches; its centre needs at least {MIN_TOUCHES_PER_BALL} (give it more, or remove it)",
                touches_of[b]
            ),
        )),
        None => Ok(()),
    }
}

/// At most [`MAX_TRACKERS`] trackers, each with at least
/// [`MIN_POINTS_PER_TRACKER`] points and poses, offsets (with a finite and positive
/// sigma) only for a mechanism of as many actuators as pose coordinates
/// (`square`); every tracker point of a tracker
/// that exists, where the machine was put as `check_at` accepts, its
/// measured point finite and its weight's `L⁻¹` finite with a positive
/// diagonal; every tracker pose the same, at readings, on a mechanism
/// with a platform frame.
fn check_tracker_points(
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

/// Every ball distance between two distinct balls that exist, of a finite
/// and positive distance and sigma, each pair of balls at most once, the
/// balls they tie at most [`MAX_TIED_BALLS`].
fn check_ball_distances(observations: &Observations) -> Result<(), MechanismCalibrationError> {
    let balls = observations.balls.len();
    let mut pairs = std::collections::HashMap::new();
    for (k, d) in observations.ball_distances.iter().enumerate() {
        let id = ObservationRef {
            kind: ObservationKind::BallDistance,
            index: k,
        };
        if let Some(b) = [d.first, d.second].into_iter().find(|&b| b >= balls) {
            return Err(observation_error(
                id,
                format!("it ties ball {b}, and there are {balls} balls"),
            ));
        }
        if d.first == d.second {
            return Err(observation_error(
                id,
                format!("it ties ball {} to itself", d.first),
            ));
        }
        if !(d.distance.is_finite() && d.distance > 0.0) {
            return Err(observation_error(
                id,
                format!("its distance {} is not finite and positive", d.distance),
            ));
        }
        check_sigma(id, d.sigma)?;
        let pair = (d.first.min(d.second), d.first.max(d.second));
        if let Some(earlier) = pairs.insert(pair, k) {
            return Err(observation_error(
                id,
                format!(
                    "balls {} and {} already have ball distance {earlier}",
                    pair.0, pair.1
                ),
            ));
        }
    }
    let tied = observations.tied_balls(0).len();
    if tied > MAX_TIED_BALLS {
        return Err(MechanismCalibrationError::InvalidData {
            what: "ball distances".to_string(),
            reason: format!(
                "they tie {tied} balls together, more than the {MAX_TIED_BALLS} accepted (each tied ball's centre is an unknown of the dense global block)"
            ),
        });
    }
    Ok(())
}

fn observation_error(observation: ObservationRef, reason: String) -> MechanismCalibrationError {
    MechanismCalibrationError::Observation {
        observation,
        reason,
    }
}

fn check_values(
    observation: ObservationRef,
    what: &str,
    values: &[f64],
) -> Result<(), MechanismCalibrationError> {
    match values.iter().find(|v| !v.is_finite()) {
        Some(v) => Err(observation_error(
            observation,
            format!("its {what} has a value {v} that is not finite"),
        )),
        None => Ok(()),
    }
}

fn check_sigma(observation: ObservationRef, sigma: f64) -> Result<(), MechanismCalibrationError> {
    if sigma.is_finite() && sigma > 0.0 {
        Ok(())
    } else {
        Err(observation_error(
            observation,
            format!("its standard deviation {sigma} is not finite and positive"),
        ))
    }
}

fn check_prior(
    prior: &ParameterPrior,
    what: impl Fn() -> String,
) -> Result<(), MechanismCalibrationError> {
    let invalid = |reason| {
        Err(MechanismCalibrationError::InvalidData {
            what: what(),
            reason,
        })
    };
    if !prior.mean.is_finite() {
        return invalid(format!("prior mean {} is not finite", prior.mean));
    }
    match prior.sigma {
        Some(sigma) if !(sigma.is_finite() && sigma > 0.0) => invalid(format!(
            "prior sigma {sigma} is not finite and positive (no prior: none)"
        )),
        _ => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Touches of `balls` balls in the order `order`.
    fn observations(balls: usize, order: &[usize]) -> Observations {
        let ball = Ball {
            radius: 5.0,
            radius_sigma: None,
            centre_prior: None,
        };
        Observations {
            balls: vec![ball; balls],
            touches: (order.iter())
                .map(|&b| BallTouch::new(b, Actuation::Commanded([0.0, 0.0, 10.0]), 0.01))
                .collect(),
            ..Observations::default()
        }
    }

    /// Each ball's count, and whether the touches come ball by ball, as
    /// one pass in order finds them, for runs that cross the threads'
    /// chunks and for a ball whose touches come back after another's.
    #[test]
    fn touches_are_counted_per_ball_across_chunks() {
        let n = 3 * COUNT_CHUNK + 17;
        let grouped: Vec<usize> = (0..n).map(|t| t * 5 / n).collect();
        let mut back = grouped.clone();
        back[2 * COUNT_CHUNK] = 0;
        // A decrease exactly at a chunk's first touch.
        let at_boundary: Vec<usize> = (0..n)
            .map(|t| if t < COUNT_CHUNK { 5 } else { t * 5 / n })
            .collect();
        for (order, expected) in [(grouped, true), (back, false), (at_boundary, false)] {
            let mut counts = vec![0; 6];
            let (mut in_order, mut last) = (true, 0);
            for &b in &order {
                counts[b] += 1;
                in_order &= last <= b;
                last = b;
            }
            assert_eq!(in_order, expected);
            assert_eq!(
                observations(6, &order).touches_per_ball(),
                (counts, in_order)
            );
        }
    }
}
