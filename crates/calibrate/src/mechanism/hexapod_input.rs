//! A hexapod's ball touches ([`parcal_dataset::Dataset`]) as the data of
//! the common calibration: the 6-6 Stewart platform through the
//! [`Mechanism`](parcal_kinematics::mechanism::Mechanism) interface, by the
//! same path as a linear delta or a cable robot.
//!
//! - The mechanism: [`Hexapod`] at the design of the machine, its 33
//!   canonical parameters' priors the design tolerances of their groups
//!   (the paper's a priori knowledge of the parameters, eq. 7).
//! - Each ball: its calibrated radius, an unknown with the prior of its
//!   calibration sigma (the hexapod calibration's per-ball radius), its
//!   centre an unknown of its own (no prior on it).
//! - Each contact: a [`BallTouch`] at the legs' readings, the radius
//!   observation (paper eq. 9), with the diagonal weight of the
//!   repeatabilities, `σ² = σ_a² + σ_t²`.
//!
//! With the hexapod calibration's options of the same model (eq. 9, the
//! diagonal weights, per-ball radii, the same prior or none) both reach
//! the same minimum: the common door's estimate is the dedicated path's.
//! What the hexapod's own calibration adds is refused here, by name: the
//! actuators' scales, tracker poses and points, calibrated distances
//! between balls.

use std::sync::Arc;

use parcal_dataset::Dataset;
use parcal_kinematics::hexapod::Hexapod;
use parcal_kinematics::mechanism::design;
use parcal_observe::mechanism::{Actuation, BallTouch};

use super::data::{Ball, MechanismData, Observations};
use super::error::MechanismCalibrationError;
use crate::setup::design_geometry;

impl MechanismData {
    /// The data of a hexapod's ball touches (module doc), each touch of
    /// the ball of its index in the artefacts (as the dataset's reader
    /// checked; [`MechanismData::validate`] checks it again). An error
    /// names what the dataset holds that the common calibration does not
    /// model.
    pub fn from_hexapod_touches(dataset: &Dataset) -> Result<Self, MechanismCalibrationError> {
        let machine = &dataset.machine;
        let refuse = |what: &str, reason: &str| {
            Err(MechanismCalibrationError::InvalidData {
                what: what.to_string(),
                reason: format!("{reason}; the hexapod's own calibration takes it"),
            })
        };
        if machine.actuator.scale != [1.0; 6] || machine.actuator.scale_sigma.is_some() {
            return refuse(
                "the actuators' scales",
                "the hexapod through the common interface reads its legs in mm, scale 1",
            );
        }
        if !dataset.tracker.is_empty() {
            return refuse(
                "tracker poses and points",
                "an instrument's frames are not modelled by the common calibration",
            );
        }
        if !dataset.artefacts.distances.is_empty() {
            return refuse(
                "calibrated distances between balls",
                "the common calibration's balls are independent",
            );
        }
        let hexapod =
            Hexapod::new(&design_geometry(dataset), &machine.prior_sigma).map_err(|e| {
                MechanismCalibrationError::InvalidData {
                    what: "the design geometry".to_string(),
                    reason: e.to_string(),
                }
            })?;
        let configured = design(&hexapod).iter().copied().collect();
        let balls = dataset
            .artefacts
            .balls
            .iter()
            .map(|ball| Ball {
                radius: ball.radius,
                radius_sigma: Some(ball.radius_sigma),
            })
            .collect();
        let r = &machine.repeatability;
        let sigma = (r.actuator * r.actuator + r.tool * r.tool).sqrt();
        let m = &dataset.measurements;
        let touches = m
            .ball
            .iter()
            .zip(&m.q)
            .map(|(&ball, q)| BallTouch {
                ball: ball as usize,
                at: Actuation::Readings(q.to_vec()),
                sigma,
            })
            .collect();
        let observations = Observations {
            balls,
            touches,
            ..Observations::default()
        };
        Ok(Self::new(Arc::new(hexapod), configured, observations))
    }
}
