//! Every held-out observation predicted at a calibration's global block,
//! in the order of the kinds ([`predict`]). A probe height, a height
//! measured by hand, a part distance, a measured point, a measured
//! quantity: the observation kind's own rows
//! ([`parcal_observe::mechanism`]) at `θ̂` and the controller's configured
//! parameters `p_c`, un-whitened (`r = σ r_w`, `G = σ dr_w/dθ`, `D = σ²`;
//! [`unwhitened`]); a point sample, a tracker, a set of balls by its own
//! module (`sample`, `tracker`, `balls`).

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};
use parcal_observe::mechanism::Rows;
use rayon::prelude::*;

use super::super::data::Observations;
use super::super::error::MechanismCalibrationError;
use super::super::observation::{HeldOut, ObservationKind, ObservationRef};
use super::ball_sets::{tied_sets, touches_by_ball};
use super::balls::predict_balls;
use super::rows::PredictedRows;
use super::sample::predict_sample;
use super::tracker::predict_tracker;

#[cfg(doc)]
use super::ball_sets::MAX_HELD_OUT_TOUCHES_PER_BALL;

/// Every observation of `observations` (validated) predicted at the
/// global block `global` (`p̂` then, with probes, `ĥ`) with the
/// controller's `configured` parameters (module doc), in the order of the
/// kinds, each kind's in its order, the touches ball by ball; samples at
/// an unknown pose of a mechanism of 3 actuators give none. An error
/// names a ball of more than [`MAX_HELD_OUT_TOUCHES_PER_BALL`] touches
/// before any work.
pub fn predict(
    mechanism: &dyn Mechanism,
    global: &DVector<f64>,
    configured: &[f64],
    observations: &Observations,
    reference: Option<usize>,
) -> Result<Vec<PredictedRows>, MechanismCalibrationError> {
    if reference.is_some() && !observations.samples.is_empty() {
        return Err(MechanismCalibrationError::InvalidData {
            what: "the reference observations".to_string(),
            reason: "they locate each held-out ball's centre and tracker's frame; a point sample's pose is located by its own readings: validate samples without reference observations".to_string(),
        });
    }
    let n = mechanism.parameters().len();
    let g = global.len();
    let params = &global.as_slice()[..n];
    let at = |kind, index| ObservationRef { kind, index };
    let failed = |observation, error: MechanismError| MechanismCalibrationError::Observation {
        observation,
        reason: error.to_string(),
    };
    let balls = touches_by_ball(observations)?;
    let mut predicted = Vec::new();
    for (k, probe) in observations.probes.iter().enumerate() {
        let id = at(ObservationKind::Probe, k);
        let trigger =
            global
                .get(n)
                .copied()
                .ok_or_else(|| MechanismCalibrationError::InvalidData {
                    what: "trigger height".to_string(),
                    reason:
                        "probe heights need one, and neither the calibration nor the data give it"
                            .to_string(),
                })?;
        let evaluated = probe
            .evaluate(mechanism, params, configured, trigger)
            .map_err(|e| failed(id, e))?;
        let mut rows = unwhitened(id, &evaluated.rows, &[probe.sigma], g);
        rows.d_global[(0, n)] = evaluated.d_trigger_height * probe.sigma;
        predicted.push(rows);
    }
    for (k, manual) in observations.manual_heights.iter().enumerate() {
        let id = at(ObservationKind::ManualHeight, k);
        let rows = manual
            .evaluate(mechanism, params, configured)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &[manual.sigma], g));
    }
    for (k, distance) in observations.distances.iter().enumerate() {
        let id = at(ObservationKind::Distance, k);
        let rows = distance
            .evaluate(mechanism, params, configured)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &[distance.sigma], g));
    }
    for (k, point) in observations.points.iter().enumerate() {
        let id = at(ObservationKind::Point, k);
        let rows = point
            .evaluate(mechanism, params, configured)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &point.sigma, g));
    }
    for (k, quantity) in observations.quantities.iter().enumerate() {
        let id = at(ObservationKind::Quantity, k);
        let rows = quantity
            .evaluate(mechanism, params)
            .map_err(|e| failed(id, e))?;
        predicted.push(unwhitened(id, &rows, &[quantity.sigma], g));
    }
    for (k, sample) in observations.samples.iter().enumerate() {
        let id = at(ObservationKind::Sample, k);
        if let Some(rows) =
            predict_sample(mechanism, params, id, sample, g).map_err(|e| failed(id, e))?
        {
            predicted.push(rows);
        }
    }
    for tracker in 0..observations.trackers.len() {
        predicted.push(predict_tracker(
            mechanism,
            params,
            configured,
            observations,
            (tracker, reference),
            g,
        )?);
    }
    // The sets on the threads, each on its own; the first error in their
    // order is the one returned, on any number of threads.
    let sets: Vec<_> = (tied_sets(observations, balls)?.into_par_iter())
        .map(|set| {
            predict_balls(
                mechanism,
                params,
                configured,
                observations,
                set,
                reference,
                g,
            )
        })
        .collect();
    for set in sets {
        predicted.push(set?);
    }
    Ok(predicted)
}

/// An observation kind's whitened `rows` back in its units (`σ` per row),
/// its derivative placed in the first columns of `g`.
fn unwhitened(observation: ObservationRef, rows: &Rows, sigma: &[f64], g: usize) -> PredictedRows {
    let m = rows.residual.len();
    let n = rows.d_params.ncols();
    let mut d_global = DMatrix::zeros(m, g);
    for i in 0..m {
        for j in 0..n {
            d_global[(i, j)] = rows.d_params[(i, j)] * sigma[i];
        }
    }
    PredictedRows {
        observation: HeldOut::Observation(observation),
        residuals: DVector::from_fn(m, |i, _| rows.residual[i] * sigma[i]),
        noise: DMatrix::from_fn(m, m, |i, j| if i == j { sigma[i] * sigma[i] } else { 0.0 }),
        d_global,
        row_observations: Vec::new(),
        mirrored_balls: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::data::Ball;
    use crate::mechanism::predicted::simulated::{delta, touches, tracked};
    use nalgebra::{Isometry3, Vector3};
    use parcal_observe::mechanism::PointSample;

    /// Reference observations must leave a touch of each ball (a point or
    /// pose of each tracker) to predict and locate its centre (a sphere's
    /// fit needs 4), and are refused beside point samples (whose pose their
    /// own readings locate), each error naming what fails.
    #[test]
    fn reference_touches_are_refused_where_they_cannot_serve() {
        let machine = delta();
        let (delta, configured, truth) = &machine;
        let centre = Vector3::new(40.0, -25.0, 6.0);
        let ball = Observations {
            balls: vec![Ball::new(12.7, None)],
            touches: touches(&machine, centre, 12.7, 8, || 0.0),
            ..Default::default()
        };
        let said = |observations: &Observations, reference| {
            (predict(
                delta,
                truth,
                configured.as_slice(),
                observations,
                Some(reference),
            ))
            .unwrap_err()
            .to_string()
        };
        let all = said(&ball, 8);
        assert!(
            all.contains("ball 0")
                && all.contains("none is left to predict after the 8 reference touches"),
            "{all}"
        );
        let two = said(&ball, 2);
        assert!(
            two.starts_with("ball 0: its first 2 touches do not locate its centre"),
            "{two}"
        );
        let tracker = tracked(&machine, &Isometry3::identity(), 4, || 0.0);
        let none = said(&tracker, 4);
        assert!(
            none.starts_with("tracker 0 (tracker points 0-3): it has 4 held-out points and 0 poses: none is left to predict"),
            "{none}"
        );
        let sample = PointSample {
            readings: vec![0.0; 3],
            sigma: 0.01,
            known_pose: Some(([0.0, 0.0, 20.0], [0.01; 3])),
            loads: None,
        };
        let sampled = Observations {
            samples: vec![sample],
            ..ball
        };
        let beside = said(&sampled, 4);
        assert!(beside.contains("a point sample's pose"), "{beside}");
    }
}
