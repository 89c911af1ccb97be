//! A mechanism dataset read from files
//! ([`parcal_dataset::mechanism::MechanismDataset`]) as the data of a
//! calibration: the mechanism from the one list (a printer within its
//! printable radius), the configured
//! parameters, the design as the priors' means with the mechanism's
//! tolerances overridden per group and the matched groups' correlation,
//! the trigger height's prior, each
//! observation with the noise of its kind, the samples' loads, the
//! measured quantities with their own sigmas, and the calibrated balls
//! (where placed, a prior on the centre) with their touches and the
//! calibrated distances between them, and the trackers (in order of first
//! appearance) with their points.

use std::sync::Arc;

use nalgebra::Isometry3;
use parcal_dataset::Distance;
use parcal_dataset::mechanism::{MechanismDataset, MechanismTruth, tracker_labels};
use parcal_kinematics::mechanisms;
use parcal_observe::CoordinateWhitening;
use parcal_observe::mechanism::{
    Actuation, BallDistance, BallTouch, ManualHeight, MeasuredQuantity, PartDistance, PointSample,
    ProbeHeight, TrackerPoint,
};

use super::data::{Ball, CentrePrior, MechanismData, Observations, Tracker};
use super::error::MechanismCalibrationError;
use super::trackers::frame_motion;

/// Calibrated distances between balls as read (a hexapod's
/// artefacts.json, a mechanism's ball_distances.csv), as observations.
pub(super) fn ball_distances(distances: &[Distance]) -> Vec<BallDistance> {
    distances
        .iter()
        .map(|d| BallDistance {
            first: d.a,
            second: d.b,
            distance: d.length,
            sigma: d.sigma,
        })
        .collect()
}

impl MechanismData {
    /// The data of `dataset` (module doc). The dataset's reader has
    /// checked it; an unknown mechanism or a missing noise is still an
    /// error here (a dataset built in memory).
    pub fn from_dataset(dataset: &MechanismDataset) -> Result<Self, MechanismCalibrationError> {
        let machine = &dataset.machine;
        let mechanism = machine.mechanism().ok_or_else(|| {
            let invalid = |what: &str, reason| MechanismCalibrationError::InvalidData {
                what: what.to_string(),
                reason,
            };
            match mechanisms::by_name(&machine.mechanism) {
                Some(_) => invalid(
                    "print_radius",
                    format!("the {} has no printable radius", machine.mechanism),
                ),
                None => invalid(
                    "mechanism",
                    format!(
                        "unknown mechanism {:?} (known: {})",
                        machine.mechanism,
                        mechanisms::NAMES.join(", ")
                    ),
                ),
            }
        })?;
        let noise = |sigma: Option<f64>, what: &str| {
            sigma.ok_or_else(|| MechanismCalibrationError::InvalidData {
                what: format!("noise.{what}"),
                reason: "required: the dataset holds measurements of this kind".to_string(),
            })
        };
        let n = &machine.noise;
        let probes = dataset
            .probes
            .iter()
            .map(|&commanded| {
                Ok(ProbeHeight {
                    commanded,
                    sigma: noise(n.probe, "probe")?,
                })
            })
            .collect::<Result<_, MechanismCalibrationError>>()?;
        let manual_heights = dataset
            .heights
            .iter()
            .map(|&[x, y, z, height]| {
                Ok(ManualHeight {
                    commanded: [x, y, z],
                    height,
                    sigma: noise(n.height, "height")?,
                })
            })
            .collect::<Result<_, MechanismCalibrationError>>()?;
        let distances = dataset
            .distances
            .iter()
            .map(|row| {
                Ok(PartDistance {
                    first: [row[0], row[1], row[2]],
                    second: [row[3], row[4], row[5]],
                    distance: row[6],
                    sigma: noise(n.distance, "distance")?,
                })
            })
            .collect::<Result<_, MechanismCalibrationError>>()?;
        let samples = dataset
            .samples
            .iter()
            .map(|row| {
                let known_pose = match row.position {
                    Some(position) => Some((position, [noise(n.position, "position")?; 3])),
                    None => None,
                };
                Ok(PointSample {
                    readings: row.readings.clone(),
                    sigma: noise(n.actuator, "actuator")?,
                    known_pose,
                    loads: row.loads.clone(),
                })
            })
            .collect::<Result<_, MechanismCalibrationError>>()?;
        let quantities = dataset
            .quantities
            .iter()
            .enumerate()
            .map(|(k, row)| {
                let quantity = mechanism
                    .quantities()
                    .iter()
                    .position(|q| q.name == row.quantity)
                    .ok_or_else(|| MechanismCalibrationError::InvalidData {
                        what: format!("measured quantity {k}"),
                        reason: format!(
                            "{:?} is not a quantity of the {}",
                            row.quantity,
                            mechanism.name()
                        ),
                    })?;
                Ok(MeasuredQuantity {
                    quantity,
                    value: row.value,
                    sigma: row.sigma,
                })
            })
            .collect::<Result<_, MechanismCalibrationError>>()?;
        let balls = dataset
            .balls
            .iter()
            .map(|row| Ball {
                centre_prior: row.placement.map(|p| CentrePrior {
                    centre: p.centre,
                    sigma: p.sigma,
                }),
                ..Ball::new(row.radius, row.radius_sigma)
            })
            .collect();
        let touches = dataset
            .touches
            .iter()
            .map(|row| {
                Ok(BallTouch::new(
                    row.ball,
                    Actuation::Commanded(row.commanded),
                    noise(n.touch, "touch")?,
                ))
            })
            .collect::<Result<_, MechanismCalibrationError>>()?;
        let labels = tracker_labels(&dataset.tracker_points);
        let tracker_points = dataset
            .tracker_points
            .iter()
            .map(|row| {
                Ok(TrackerPoint {
                    tracker: labels
                        .iter()
                        .position(|label| *label == row.tracker)
                        .expect("every row's label is among the labels"),
                    at: Actuation::Commanded(row.commanded),
                    measured: row.measured,
                    weight: CoordinateWhitening::isotropic(noise(n.tracker, "tracker")?).map_err(
                        |e| MechanismCalibrationError::InvalidData {
                            what: "noise.tracker".to_string(),
                            reason: e.to_string(),
                        },
                    )?,
                })
            })
            .collect::<Result<_, MechanismCalibrationError>>()?;
        let trackers = labels.into_iter().map(Tracker::new).collect();
        let observations = Observations {
            probes,
            manual_heights,
            distances,
            samples,
            quantities,
            balls,
            touches,
            ball_distances: ball_distances(&dataset.ball_distances),
            trackers,
            tracker_points,
            ..Observations::default()
        };
        let mut data = MechanismData::new(
            Arc::from(mechanism),
            machine.configured.clone(),
            observations,
        )
        .with_prior_means(&machine.design);
        for (group, sigma) in &machine.tolerances {
            data = data.with_group_sigma(group, *sigma)?;
        }
        for (group, sigma) in &machine.matched {
            data = data.with_matched_group(group, *sigma)?;
        }
        if let Some(trigger) = machine.trigger_height {
            data = data.with_trigger_height(trigger.value, trigger.sigma);
        }
        data.print_radius = machine.print_radius;
        Ok(data)
    }

    /// The true values of a simulated machine (`truth`, truth.json's) in
    /// the terms of these data's calibration
    /// ([`MechanismCalibration::parameters`](super::MechanismCalibration)):
    /// its parameters carried to their canonical frame, where the estimate
    /// is, then the probe's trigger height when there are probe heights.
    /// An error when the truth is not of this mechanism.
    pub fn true_values(
        &self,
        truth: &MechanismTruth,
    ) -> Result<Vec<f64>, MechanismCalibrationError> {
        let mechanism = self.mechanism.as_ref();
        let kinematics = |source| MechanismCalibrationError::Kinematics {
            mechanism: mechanism.name().to_string(),
            source,
        };
        let canonical = mechanism
            .canonicalize(&truth.parameters)
            .map_err(kinematics)?;
        let mut values: Vec<f64> = canonical.iter().copied().collect();
        if self.has_trigger_height() {
            let height =
                truth
                    .trigger_height
                    .ok_or_else(|| MechanismCalibrationError::InvalidData {
                        what: "the truth".to_string(),
                        reason: "it has no trigger height, and the data have probe heights"
                            .to_string(),
                    })?;
            values.push(height);
        }
        Ok(values)
    }

    /// The true frames of these data's trackers (`truth`'s, by label) where
    /// the calibration reports theirs
    /// ([`MechanismCalibration::trackers`](super::MechanismCalibration)):
    /// from the truth's canonical frame, `F ∘ A⁻¹` with `A` the rigid
    /// motion from the true machine's frame to it (the best fit of the
    /// tool points the trackers' points reach under each, as the fit's
    /// frames follow the canonical frame); in the order of the trackers,
    /// `None` for one the truth does not hold.
    /// An error when the truth is not of this mechanism or its tool points
    /// cannot be reached.
    pub fn true_tracker_frames(
        &self,
        truth: &MechanismTruth,
    ) -> Result<Vec<Option<Isometry3<f64>>>, MechanismCalibrationError> {
        let trackers = &self.observations.trackers;
        if trackers
            .iter()
            .all(|t| !truth.trackers.contains_key(&t.label))
        {
            return Ok(vec![None; trackers.len()]);
        }
        let canonical = self
            .mechanism
            .canonicalize(&truth.parameters)
            .map_err(|source| MechanismCalibrationError::Kinematics {
                mechanism: self.mechanism.name().to_string(),
                source,
            })?;
        let to_canonical = frame_motion(self, &truth.parameters, canonical.as_slice())?;
        let from_canonical = to_canonical.inverse();
        Ok((trackers.iter())
            .map(|t| Some(truth.trackers.get(&t.label)?.isometry() * from_canonical))
            .collect())
    }
}
