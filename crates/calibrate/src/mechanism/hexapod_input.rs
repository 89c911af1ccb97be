//! A hexapod's ball touches ([`parcal_dataset::Dataset`]) as the data of
//! the common calibration: the 6-6 Stewart platform through the
//! [`Mechanism`](parcal_kinematics::mechanism::Mechanism) interface, by the
//! same path as a linear delta or a cable robot, under the model of the
//! hexapod calibration's options ([`CalibrationOptions`]).
//!
//! - The mechanism: [`Hexapod`] at the design of the machine; with the
//!   paper's prior, each of its 33 canonical parameters has the design
//!   tolerance of its group (eq. 7); with the propagated prior, the input
//!   coordinates' tolerances propagated through the canonical frame
//!   ([`KinematicPrior::propagated`]: the marginal sigmas and their
//!   correlation, [`super::prior`]); without a prior, none.
//! - Each ball: its calibrated radius, an unknown with the prior of its
//!   calibration sigma ([`RadiusModel::PerBall`]) or exact, its sigma then
//!   an error of every touch ([`RadiusModel::PerContact`]); its centre an
//!   unknown of its own, with the ball's `centre_sigma` about its centre
//!   at the design under the paper's prior, about its stated location
//!   under the propagated prior when the balls are located in the
//!   canonical frame ([`CentrePrior`]).
//! - The actuators' scales: known, each contact's readings times them are
//!   the legs' extensions the mechanism reads; or, when machine.json gives
//!   their sigmas, unknowns `s_1..s_6` of the mechanism about their design
//!   values ([`Hexapod::with_unknown_scales`]), the hexapod then reading
//!   the readings themselves.
//! - Each contact: a [`BallTouch`] at its readings (as above), weighted as
//!   the hexapod calibration weighs it at the design, and held fixed: the
//!   weight the hexapod's own set-up forms ([`Setup::new`]: the tool tip
//!   `T` and `dT/dq` by the design's forward kinematics, the ball's centre
//!   the best fit of its tips or its mirror image, the direction `n0` from
//!   it to the tip or the commanded approach direction). Under the radius
//!   observation (eq. 9), `σ² = n0ᵀ Σ_tip n0 (+ σ_r²)`
//!   ([`radius_variance`]); under the coordinate observation (eq. 10),
//!   `W = Σ_tip (+ σ_r² n0 n0ᵀ)` ([`coordinate_covariance`]), `σ² = n0ᵀ W
//!   n0` along the normal, and its contact angles' prior about `n0` where
//!   the hexapod calibration states one ([`Approach`]: every contact's under
//!   the paper's prior, those with a commanded direction under the
//!   propagated prior).
//!
//! - Each calibrated distance between two balls: a
//!   [`BallDistance`](parcal_observe::mechanism::BallDistance), the
//!   two balls' centres then unknowns of the global block, as the
//!   hexapod's own calibration ties them.
//! - Each session of points.csv: a tracker, its frame six unknowns
//!   ([`super::trackers`]), and for a later session, when machine.json's
//!   session model re-homes the legs, their zero offsets (six unknowns
//!   with its `leg_offset_sigma`, in mm: the legs' extensions, at unknown
//!   scales too, so that `l_i + o_i + s_i q_i` is the own model's); each
//!   point a [`TrackerPoint`] at its readings (as above), weighted as the
//!   hexapod calibration weighs it at its initial estimate (the
//!   instrument's position sigma and the actuators' repeatability through
//!   `dT/dq`, in the instrument's frame, [`InstrumentRows::whiten`]).
//! - Each row of poses.csv: a [`TrackerPose`] of its session's tracker at
//!   its readings (as above), the body frame six unknowns from the
//!   hexapod calibration's start `B₀`; weighted as the hexapod calibration
//!   weighs it at its initial estimate (its rows in leg length, `L⁻¹`,
//!   at unknown scales too: the rows are the readings' times the scales'
//!   estimates, [`TrackerPose`]'s `S`, so that both paths minimise the
//!   same cost).
//!
//! - The start: the own set-up's ([`TouchStart`]): each ball's centre (the
//!   best fit of its design tool tips, or its mirror image) and each
//!   contact's pose by the design's forward kinematics, as its warm start.
//!
//! Both calibrations then minimise the same cost from the same start (but for a
//! tracker with poses, whose frame the common calibration locates by the
//! body's origins, [`super::trackers`]): the common door's estimate is the
//! dedicated path's (the common calibration runs
//! the observation of the options' [`MechanismOptions::observation`]).
//! A later session with poses, when the session model re-mounts the body,
//! has the body's rotation and origin shift as its tracker's
//! ([`Tracker::with_body_turned`], [`Tracker::with_body_moved`]).
//! Poses alone see the body frame, not the tool: the hexapod's own
//! calibration leaves the tool out, while the common hexapod always has
//! it. Without a prior ([`PriorMode::None`]) the tool then keeps its
//! tolerance as its prior: its columns are zero in every pose's rows, so
//! that the prior holds it at the design, with the tolerance as its sigma,
//! and moves nothing else: the other unknowns, the cost and the redundancy
//! (three rows more, three unknowns more) are the own path's.
//!
//! [`coordinate_covariance`]: parcal_observe::coordinate_covariance
//! [`MechanismOptions::observation`]: super::MechanismOptions

use std::sync::Arc;

use nalgebra::{DMatrix, Isometry3};
use parcal_dataset::{ArtefactFrame, Dataset};
use parcal_kinematics::hexapod::{Hexapod, TOOL_GROUP, WARM_START_LEN, warm_start_values};
use parcal_kinematics::mechanism::design;
use parcal_kinematics::{N_PARAMS, Vec3};
use parcal_observe::CoordinateWhitening;
use parcal_observe::KinematicPrior;
use parcal_observe::mechanism::{
    Actuation, Approach, BallTouch, Readings, TrackerPoint, TrackerPose,
};
use rayon::prelude::*;

use super::data::{Ball, CentrePrior, MechanismData, Observations, Tracker};
use super::error::MechanismCalibrationError;
use super::input::ball_distances;
use super::touch_start::TouchStart;
use crate::CalibrationOptions;
use crate::instruments::observations::{groups, initial_block, model_and_rows};
use crate::instruments::rows::InstrumentRows;
use crate::instruments::start::measured_poses;
use crate::layout::ParameterLayout;
use crate::options::{PriorMode, RadiusModel, Simulation};
use crate::setup::{Observations as SetupObservations, Setup, design_geometry};

impl MechanismData {
    /// The data of a hexapod's ball touches under `options`' model
    /// (module doc), each touch of the ball of its index in the artefacts
    /// (as the dataset's reader checked; [`MechanismData::validate`]
    /// checks it again). An error names what the dataset or the options
    /// hold that the common calibration does not model, or the ball or
    /// contact whose weight cannot be formed.
    pub fn from_hexapod_touches(
        dataset: &Dataset,
        options: &CalibrationOptions,
    ) -> Result<Self, MechanismCalibrationError> {
        let machine = &dataset.machine;
        let input = design_geometry(dataset);
        let invalid =
            |what: String, reason: String| MechanismCalibrationError::InvalidData { what, reason };
        let hexapod = Hexapod::new(&input, &machine.prior_sigma)
            .map_err(|e| invalid("the design geometry".to_string(), e.to_string()))?;
        let legs = LegReadings::of(dataset);
        let hexapod = legs.reader(hexapod, &machine.actuator);
        let configured: Vec<f64> = design(&hexapod).iter().copied().collect();
        let start = design_start(dataset, options)?;
        let per_ball = options.radius == RadiusModel::PerBall;
        let balls = dataset
            .artefacts
            .balls
            .iter()
            .zip(&start.centres)
            .map(|(ball, start)| Ball {
                radius: ball.radius,
                radius_sigma: per_ball.then_some(ball.radius_sigma),
                centre_prior: centre_prior(dataset, options, ball, start),
            })
            .collect();
        let m = &dataset.measurements;
        let touches = m
            .ball
            .par_iter()
            .zip(&m.q)
            .enumerate()
            .map(|(row, (&ball, q))| {
                let weight = start.weight(row);
                BallTouch {
                    sigma: weight.sigma,
                    weight: weight.coordinates,
                    approach: weight.approach,
                    ..BallTouch::new(ball as usize, Actuation::Readings(legs.actuation(q)), 0.0)
                }
            })
            .collect();
        let instruments = instrument_observations(dataset, &legs)?;
        let observations = Observations {
            balls,
            touches,
            ball_distances: ball_distances(&dataset.artefacts.distances),
            trackers: trackers(dataset),
            tracker_points: instruments.points,
            tracker_poses: instruments.poses,
            body_reference: instruments.body_reference,
            ..Observations::default()
        };
        // The common calibration starts where the own one does.
        let touch_start = TouchStart {
            centres: start.centres.iter().map(|c| [c.x, c.y, c.z]).collect(),
            warm_starts: start.warm_starts,
        };
        let data =
            Self::new(Arc::new(hexapod), configured, observations).with_touch_start(touch_start);
        let tracker = &dataset.tracker;
        let sees_tool = !dataset.measurements.ball.is_empty() || !tracker.points.is_empty();
        Ok(match options.prior {
            PriorMode::None if !sees_tool => data.without_priors_but(TOOL_GROUP),
            PriorMode::None => data.without_priors(),
            PriorMode::Paper => data,
            PriorMode::Propagated => {
                let prior = KinematicPrior::propagated(&input, &machine.prior_sigma)
                    .map_err(|e| invalid("the propagated prior".to_string(), e.to_string()))?;
                with_prior(data, &prior)
            }
        })
    }

    /// The ball touches of a hexapod's `dataset` held out from a
    /// calibration through the common path, as it is judged on them
    /// ([`super::validate_mechanism`]): weighted as the hexapod's own
    /// validation weighs touches, whatever the calibration's options (the
    /// radius observation, the propagated weights, each ball's calibrated
    /// radius exact with its sigma in the touches' weights: simulation I's
    /// model), the scales unknowns when machine.json gives their sigmas (as
    /// the calibration's were).
    pub fn hexapod_held_out(dataset: &Dataset) -> Result<Self, MechanismCalibrationError> {
        Self::from_hexapod_touches(dataset, &CalibrationOptions::simulation(Simulation::I))
    }
}

/// `data` with `prior`'s means, marginal sigmas and correlation over the
/// 33 (the propagated prior, paper eq. 7 with the input coordinates'
/// tolerances); the scales' priors, when they are unknowns, independent.
fn with_prior(mut data: MechanismData, prior: &KinematicPrior) -> MechanismData {
    let sigma = prior.sigma();
    for (k, parameter) in data.priors.iter_mut().take(N_PARAMS).enumerate() {
        parameter.mean = prior.mean()[k];
        parameter.sigma = Some(sigma[k]);
    }
    let covariance = prior.covariance();
    let n = data.priors.len();
    let correlation = DMatrix::from_fn(n, n, |j, k| match (j, k) {
        _ if j == k => 1.0,
        _ if j < N_PARAMS && k < N_PARAMS => covariance[(j, k)] / (sigma[j] * sigma[k]),
        _ => 0.0,
    });
    data.with_prior_correlation(correlation)
}

/// What the common calibration's hexapod reads of a contact's readings
/// `q` (module doc).
enum LegReadings {
    /// The legs' extensions `s_i q_i` (mm) at the machine's known scales
    /// `s_i`, as the hexapod calibration applies them.
    KnownScales([f64; 6]),
    /// The readings themselves: the scales are the mechanism's unknowns,
    /// about their design values `scale` with the prior sigmas `sigma`.
    UnknownScales { scale: [f64; 6], sigma: [f64; 6] },
}

impl LegReadings {
    fn of(dataset: &Dataset) -> Self {
        let actuator = &dataset.machine.actuator;
        match actuator.scale_sigma {
            Some(sigma) => Self::UnknownScales {
                scale: actuator.scale,
                sigma,
            },
            None => Self::KnownScales(actuator.scale),
        }
    }

    /// The hexapod that reads them: `hexapod`, with the scales of
    /// `actuator` as its unknowns when they are.
    fn reader(&self, hexapod: Hexapod, actuator: &parcal_dataset::Actuator) -> Hexapod {
        match self {
            Self::KnownScales(_) => hexapod,
            Self::UnknownScales { scale, sigma } => {
                hexapod.with_unknown_scales(&actuator.unit, *scale, *sigma)
            }
        }
    }

    /// The mechanism's readings of a contact's readings `q`.
    fn actuation(&self, q: &[f64; 6]) -> Readings {
        match self {
            Self::KnownScales(scale) => (0..6).map(|i| scale[i] * q[i]).collect(),
            Self::UnknownScales { .. } => Readings::from_slice(q),
        }
    }
}

/// Each session of points.csv and poses.csv as a tracker: the first as the
/// touches read the legs, each later one with its legs' zero offsets when
/// the session model re-homes them, and with poses its body's rotation and
/// origin shift when the session model re-mounts it (module doc).
fn trackers(dataset: &Dataset) -> Vec<Tracker> {
    let model = &dataset.machine.session_model;
    let poses = &dataset.tracker.poses;
    (dataset.tracker.sessions.iter().enumerate())
        .map(|(session, label)| {
            let mut tracker = match model.leg_offset_sigma {
                Some(sigma) if session > 0 => Tracker::rehomed(label.clone(), Some(sigma)),
                _ => Tracker::new(label.clone()),
            };
            let with_poses = poses.session.iter().any(|&s| s as usize == session);
            if session > 0 && with_poses {
                if let Some(sigma) = model.body_rotation_sigma {
                    tracker = tracker.with_body_turned(Some(sigma));
                }
                if let Some(sigma) = model.body_origin_sigma {
                    tracker = tracker.with_body_moved(Some(sigma));
                }
            }
            tracker
        })
        .collect()
}

/// The tracker points and poses of a hexapod's dataset, and the body
/// frame's reference the poses start from.
struct InstrumentObservations {
    points: Vec<TrackerPoint>,
    poses: Vec<TrackerPose>,
    body_reference: Isometry3<f64>,
}

/// Each row of points.csv as a [`TrackerPoint`] and each row of poses.csv
/// as a [`TrackerPose`] of the tracker of its session at its readings as
/// `legs` reads them, weighted as the hexapod calibration weighs it at its
/// initial estimate (module doc); the body frame's reference the hexapod
/// calibration starts from.
fn instrument_observations(
    dataset: &Dataset,
    legs: &LegReadings,
) -> Result<InstrumentObservations, MechanismCalibrationError> {
    let tracker = &dataset.tracker;
    if tracker.is_empty() {
        return Ok(InstrumentObservations {
            points: Vec::new(),
            poses: Vec::new(),
            body_reference: Isometry3::identity(),
        });
    }
    let invalid = |reason: String| MechanismCalibrationError::InvalidData {
        what: "the tracker's weights".to_string(),
        reason,
    };
    let canonical = design_geometry(dataset)
        .canonicalize()
        .map_err(|e| invalid(e.to_string()))?
        .geometry;
    let layout = ParameterLayout::with_groups(groups(dataset));
    let design = parcal_kinematics::params::to_params(&canonical);
    let initial = initial_block(&layout, &design, &dataset.machine.actuator.scale);
    let (model, rows): (_, InstrumentRows<'_>) =
        model_and_rows(dataset, &canonical, layout, &initial)
            .map_err(|e| invalid(e.to_string()))?;
    let points = &tracker.points;
    let points = (0..points.len())
        .map(|j| {
            let weight = CoordinateWhitening::from_inverse_factor(&rows.point_whitening[j])
                .map_err(|e| invalid(format!("point {j}: {e}")))?;
            Ok(TrackerPoint {
                tracker: points.session[j] as usize,
                at: Actuation::Readings(legs.actuation(&points.q[j])),
                measured: points.position[j],
                weight,
            })
        })
        .collect::<Result<_, MechanismCalibrationError>>()?;
    let measured = measured_poses(tracker);
    let poses = (0..tracker.poses.len())
        .map(|j| TrackerPose {
            tracker: tracker.poses.session[j] as usize,
            readings: legs.actuation(&tracker.poses.q[j]).to_vec(),
            measured: measured[j],
            // In leg length (mm), as the hexapod calibration whitens them:
            // at unknown scales the rows are too (`TrackerPose`'s `S`).
            weight: DMatrix::from_column_slice(6, 6, rows.pose_whitening[j].as_slice()),
        })
        .collect();
    Ok(InstrumentObservations {
        points,
        poses,
        body_reference: model.body_reference,
    })
}

/// Each ball's centre's prior as the hexapod calibration states it: with
/// the paper's prior, about its centre at the design (`start`) with the
/// ball's `centre_sigma`; with the propagated prior and balls located in
/// the canonical frame, about that location; otherwise none.
fn centre_prior(
    dataset: &Dataset,
    options: &CalibrationOptions,
    ball: &parcal_dataset::Ball,
    start: &Vec3,
) -> Option<CentrePrior> {
    let centre = match (options.prior, dataset.artefacts.frame) {
        (PriorMode::Paper, _) => (*start).into(),
        (PriorMode::Propagated, ArtefactFrame::Canonical) => ball.centre,
        _ => return None,
    };
    Some(CentrePrior {
        centre,
        sigma: ball.centre_sigma,
    })
}

/// A contact's weight as the hexapod calibration forms it (module doc).
#[derive(Clone, Copy, Default)]
struct ContactWeight {
    /// Its standard deviation along the normal.
    sigma: f64,
    /// Its coordinates' whitening, under the coordinate observation.
    coordinates: Option<CoordinateWhitening>,
    /// Its contact direction's prior, where the coordinate observation
    /// has one.
    approach: Option<Approach>,
}

/// What the hexapod calibration computes at the design before its first
/// iteration (module doc).
struct DesignStart {
    /// The set-up's observations: every contact's weight, in the set-up's
    /// sorted order ([`DesignStart::weight`] takes a contact's).
    observations: SetupObservations,
    /// Each contact's slot in that order, in the order of the measurements.
    slot: Vec<u32>,
    /// Each ball's centre: the best fit of its design tool tips, or its
    /// mirror image.
    centres: Vec<Vec3>,
    /// Every contact's pose by the design's forward kinematics, as the
    /// hexapod's warm start `(t, q)`, in the order of the measurements.
    warm_starts: Vec<f64>,
}

/// The weights and the balls' centres the hexapod calibration forms at
/// the design, by its own set-up ([`Setup::new`]) under `options`.
fn design_start(
    dataset: &Dataset,
    options: &CalibrationOptions,
) -> Result<DesignStart, MechanismCalibrationError> {
    let invalid = |reason: String| MechanismCalibrationError::InvalidData {
        what: "the design's start".to_string(),
        reason,
    };
    let (setup, observations) =
        Setup::new(dataset, options).map_err(|error| invalid(error.to_string()))?;
    // The set-up's sorted slot of each contact, then each contact's weight
    // and warm start from its slot, contacts on the threads.
    let mut slot = vec![0u32; setup.order.len()];
    for (k, &row) in setup.order.iter().enumerate() {
        slot[row as usize] = k as u32;
    }
    let mut warm_starts = vec![0.0; WARM_START_LEN * slot.len()];
    (warm_starts.par_chunks_mut(WARM_START_LEN))
        .zip(&slot)
        .for_each(|(start, &k)| {
            start.copy_from_slice(&warm_start_values(&setup.poses[k as usize]))
        });
    Ok(DesignStart {
        observations,
        slot,
        centres: setup.initial_centres,
        warm_starts,
    })
}

impl DesignStart {
    /// The weight of the contact on row `row` of the measurements, as the
    /// set-up formed it (formed as the touches are, not kept for each).
    fn weight(&self, row: usize) -> ContactWeight {
        let k = self.slot[row] as usize;
        match &self.observations {
            SetupObservations::Radius(radius) => ContactWeight {
                sigma: radius.weights[k].sigma(),
                ..ContactWeight::default()
            },
            SetupObservations::Coordinates(coordinates) => {
                let (whitening, u0) = (&coordinates.weights[k], &coordinates.directions[k]);
                ContactWeight {
                    sigma: whitening.variance_along(u0).sqrt(),
                    coordinates: Some(*whitening),
                    approach: coordinates.angle_sigma.map(|sigma| Approach {
                        direction: u0.into_inner().into(),
                        sigma,
                    }),
                }
            }
        }
    }
}
