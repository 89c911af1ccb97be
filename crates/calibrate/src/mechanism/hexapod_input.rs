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
//! - Each contact: a [`BallTouch`] at its readings (as above), the radius
//!   observation (eq. 9), weighted as the hexapod calibration weighs it at
//!   the design, and held fixed ([`radius_variance`]): the tool tip `T` and
//!   `dT/dq` (per unit of the readings, whose repeatability is in it) by
//!   the design's forward kinematics, the ball's centre the
//!   best fit of its tips, the direction `n0` from it to the tip (or the
//!   commanded approach direction), `σ² = n0ᵀ Σ_tip n0 (+ σ_r²)`.
//!
//! - Each calibrated distance between two balls: a
//!   [`BallDistance`](parcal_observe::mechanism::BallDistance), the
//!   two balls' centres then unknowns of the global block, as the
//!   hexapod's own calibration ties them.
//!
//! Both calibrations then minimise the same cost from the same start: the
//! common door's estimate is the dedicated path's. What only the hexapod's
//! own calibration models is refused by name: the coordinate observation
//! (eq. 10) and its contact angles, tracker poses and points.

use std::sync::Arc;

use nalgebra::{DMatrix, Matrix3x6, Matrix6};
use parcal_dataset::{ArtefactFrame, Dataset};
use parcal_kinematics::hexapod::Hexapod;
use parcal_kinematics::mechanism::{Mechanism, design, tool_point_reading_jacobian};
use parcal_kinematics::{Geometry, N_PARAMS, Vec3};
use parcal_observe::KinematicPrior;
use parcal_observe::mechanism::{Actuation, BallTouch};
use parcal_observe::unit_direction;
use parcal_observe::weights::{Repeatability, radius_variance};
use rayon::prelude::*;

use super::data::{Ball, CentrePrior, MechanismData, Observations};
use super::error::MechanismCalibrationError;
use super::input::ball_distances;
use crate::CalibrationOptions;
use crate::options::{Observation, PriorMode, RadiusModel, Simulation};
use crate::setup::design_geometry;
use crate::sphere_fit::{SphereFitError, best_fit};

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
        check_representable(dataset, options)?;
        let machine = &dataset.machine;
        let input = design_geometry(dataset);
        let invalid =
            |what: String, reason: String| MechanismCalibrationError::InvalidData { what, reason };
        let hexapod = Hexapod::new(&input, &machine.prior_sigma)
            .map_err(|e| invalid("the design geometry".to_string(), e.to_string()))?;
        let legs = LegReadings::of(dataset);
        let hexapod = legs.reader(hexapod, &machine.actuator);
        let configured: Vec<f64> = design(&hexapod).iter().copied().collect();
        let start = design_start(&hexapod, &configured, &legs, &input, dataset, options)?;
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
            .iter()
            .zip(&m.q)
            .zip(start.weights)
            .map(|((&ball, q), sigma)| BallTouch {
                ball: ball as usize,
                at: Actuation::Readings(legs.actuation(q)),
                sigma,
            })
            .collect();
        let observations = Observations {
            balls,
            touches,
            ball_distances: ball_distances(&dataset.artefacts.distances),
            ..Observations::default()
        };
        let data = Self::new(Arc::new(hexapod), configured, observations);
        Ok(match options.prior {
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
    /// with these prior sigmas.
    UnknownScales([f64; 6]),
}

impl LegReadings {
    fn of(dataset: &Dataset) -> Self {
        let actuator = &dataset.machine.actuator;
        match actuator.scale_sigma {
            Some(sigma) => Self::UnknownScales(sigma),
            None => Self::KnownScales(actuator.scale),
        }
    }

    /// The hexapod that reads them: `hexapod`, with the scales of
    /// `actuator` as its unknowns when they are.
    fn reader(&self, hexapod: Hexapod, actuator: &parcal_dataset::Actuator) -> Hexapod {
        match self {
            Self::KnownScales(_) => hexapod,
            Self::UnknownScales(sigma) => {
                hexapod.with_unknown_scales(&actuator.unit, actuator.scale, *sigma)
            }
        }
    }

    /// The mechanism's readings of a contact's readings `q`.
    fn actuation(&self, q: &[f64; 6]) -> Vec<f64> {
        match self {
            Self::KnownScales(scale) => (0..6).map(|i| scale[i] * q[i]).collect(),
            Self::UnknownScales(_) => q.to_vec(),
        }
    }

    /// `d(mechanism's reading)/dq`: the scales, or the identity.
    fn per_reading(&self) -> Matrix6<f64> {
        match self {
            Self::KnownScales(scale) => Matrix6::from_diagonal(&(*scale).into()),
            Self::UnknownScales(_) => Matrix6::identity(),
        }
    }
}

/// Refuses what only the hexapod's own calibration models (module doc).
fn check_representable(
    dataset: &Dataset,
    options: &CalibrationOptions,
) -> Result<(), MechanismCalibrationError> {
    let refusals = [
        (
            options.observation != Observation::Radius,
            "the coordinate observation (eq. 10)",
            "its contact angles are not unknowns of the common calibration, whose touch is the radius observation (eq. 9)",
        ),
        (
            !dataset.tracker.is_empty(),
            "tracker poses and points",
            "an instrument's frames are not modelled by the common calibration",
        ),
    ];
    match refusals.into_iter().find(|(refused, _, _)| *refused) {
        Some((_, what, reason)) => Err(MechanismCalibrationError::InvalidData {
            what: what.to_string(),
            reason: format!("{reason}; the hexapod's own calibration takes it"),
        }),
        None => Ok(()),
    }
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

/// What the hexapod calibration computes at the design before its first
/// iteration (module doc).
struct DesignStart {
    /// The standard deviation of every contact's radius row, in the order
    /// of the measurements.
    weights: Vec<f64>,
    /// Each ball's centre: the best fit of its design tool tips.
    centres: Vec<Vec3>,
}

/// The weights and the balls' centres the hexapod calibration forms at
/// the design (module doc).
fn design_start(
    hexapod: &Hexapod,
    configured: &[f64],
    legs: &LegReadings,
    input: &Geometry,
    dataset: &Dataset,
    options: &CalibrationOptions,
) -> Result<DesignStart, MechanismCalibrationError> {
    let m = &dataset.measurements;
    let contact_error = |row: usize, reason: String| MechanismCalibrationError::InvalidData {
        what: format!("contact {row}"),
        reason,
    };
    // The design's tool tips and dT/dq, contact by contact on the
    // threads, the first failing contact named.
    let per_reading = legs.per_reading();
    let design_tip = |row: usize, q: &[f64; 6]| {
        let pose = Actuation::Readings(legs.actuation(q))
            .pose(hexapod, configured, configured)
            .map_err(|e| contact_error(row, format!("the design's forward kinematics: {e}")))?;
        let tip = hexapod
            .tool_point(configured, pose.as_slice())
            .map_err(|e| contact_error(row, e.to_string()))?
            .point;
        let jacobian = tool_point_reading_jacobian(hexapod, configured, pose.as_slice())
            .map_err(|e| contact_error(row, e.to_string()))?;
        // Per unit of the readings, whose repeatability is in it.
        Ok((
            tip,
            Matrix3x6::from_column_slice(jacobian.as_slice()) * per_reading,
        ))
    };
    let designed: Vec<Result<(Vec3, Matrix3x6<f64>), MechanismCalibrationError>> =
        m.q.par_iter()
            .enumerate()
            .map(|(row, q)| design_tip(row, q))
            .collect();
    let (tips, d_q): (Vec<Vec3>, Vec<Matrix3x6<f64>>) = designed
        .into_iter()
        .collect::<Result<Vec<_>, _>>()?
        .into_iter()
        .unzip();
    let rotation = match dataset.artefacts.frame {
        ArtefactFrame::Design => {
            let canonical =
                input
                    .canonicalize()
                    .map_err(|e| MechanismCalibrationError::InvalidData {
                        what: "the design geometry".to_string(),
                        reason: e.to_string(),
                    })?;
            canonical.base_from_input.rotation
        }
        ArtefactFrame::Canonical => Default::default(),
    };
    let r = &dataset.machine.repeatability;
    let mut weights = vec![0.0; m.len()];
    let mut centres = Vec::with_capacity(dataset.artefacts.balls.len());
    let mut rows_of = vec![Vec::new(); dataset.artefacts.balls.len()];
    for (k, &b) in m.ball.iter().enumerate() {
        rows_of[b as usize].push(k);
    }
    for (ball, rows) in dataset.artefacts.balls.iter().zip(rows_of) {
        let points: Vec<Vec3> = rows.iter().map(|&k| tips[k]).collect();
        let centre = match best_fit(&points, ball.radius) {
            Ok(fit) | Err(SphereFitError::NotConverged { last: fit }) => fit.centre,
            Err(e) => {
                return Err(MechanismCalibrationError::InvalidData {
                    what: format!("ball {}", ball.id),
                    reason: format!("its design tool tips do not locate its centre: {e}"),
                });
            }
        };
        let repeatability = Repeatability {
            actuator: r.actuator,
            tool: r.tool,
            radius: match options.radius {
                RadiusModel::PerContact => ball.radius_sigma,
                RadiusModel::PerBall => 0.0,
            },
        };
        for &k in &rows {
            let direction = match &m.direction {
                Some(commanded) => rotation * Vec3::from(commanded[k]),
                None => tips[k] - centre,
            };
            let n0 = unit_direction(&direction).map_err(|e| contact_error(k, e.to_string()))?;
            let variance = radius_variance(options.weighting, &repeatability, &d_q[k], &n0)
                .map_err(|e| contact_error(k, e.to_string()))?;
            weights[k] = variance.sqrt();
        }
        centres.push(centre);
    }
    Ok(DesignStart { weights, centres })
}
