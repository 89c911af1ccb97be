//! Actuator readings taken at an unknown pose: the machine was moved
//! somewhere (by hand, by a fixture) and its readings recorded; the pose
//! `x` is an unknown of its own (a point block, eliminated by the Schur
//! complement like a ball's centre), or measured with a standard deviation
//! per coordinate (a Gaussian prior on it).
//!
//! With `q` the readings and `σ_q` their standard deviation (the
//! actuators' unit):
//!
//! ```text
//! e = g(p, x) − q,     r = e / σ_q,
//! dr/dp = G_p / σ_q,   dr/dx = G_x / σ_q,
//! ```
//!
//! one row per actuator; `x` steps by [`Mechanism::retract`] (addition for
//! a 3-coordinate position). With the actuators' loads `F` recorded (a
//! cable robot's line forces), `g` is the mechanism's model under them,
//! [`Mechanism::loaded_readings`] (an error for a mechanism without one).

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError, check_pose, check_vector};

use super::commanded::{POSE_COORDINATES, Rows, check_sigma};

/// One set of readings (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct PointSample {
    /// The readings `q`, one per actuator (the actuators' unit).
    pub readings: Vec<f64>,
    /// Their standard deviation `σ_q`.
    pub sigma: f64,
    /// The pose, when it was measured: its coordinates and the standard
    /// deviation of each.
    pub known_pose: Option<([f64; 3], [f64; 3])>,
    /// The loads the actuators held, one per actuator, when they were
    /// recorded; `None` for the loads at which they were zeroed.
    pub loads: Option<Vec<f64>>,
}

/// A point sample's whitened rows.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleRows {
    /// `r` and `dr/dp`.
    pub rows: Rows,
    /// `dr/dx` (actuators × 3).
    pub d_pose: DMatrix<f64>,
}

impl PointSample {
    /// The whitened rows at parameters `params` and pose `pose` (module
    /// doc).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        pose: &[f64],
    ) -> Result<SampleRows, MechanismError> {
        check_sigma("reading sigma", self.sigma)?;
        let actuators = mechanism.actuators().len();
        check_vector(mechanism, "readings", &self.readings, actuators)?;
        check_pose(mechanism, pose, POSE_COORDINATES)?;
        let (predicted, jacobians) = match &self.loads {
            Some(loads) => mechanism.loaded_readings(params, pose, loads)?,
            None => (
                mechanism.inverse(params, pose)?,
                mechanism.reading_jacobians(params, pose)?,
            ),
        };
        let residual = DVector::from_fn(actuators, |i, _| {
            (predicted[i] - self.readings[i]) / self.sigma
        });
        Ok(SampleRows {
            rows: Rows {
                residual,
                d_params: jacobians.d_params / self.sigma,
            },
            d_pose: jacobians.d_pose / self.sigma,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::test_support::{assert_matches, delta, differences};

    #[test]
    fn derivatives_match_central_differences() {
        let (delta, configured, truth) = delta();
        let pose = [25.0, -35.0, 80.0];
        let readings = delta.inverse(configured.as_slice(), &pose).unwrap();
        let sample = PointSample {
            readings: readings.iter().copied().collect(),
            sigma: 0.005,
            known_pose: None,
            loads: None,
        };
        let at = |p: &[f64], x: &[f64]| sample.evaluate(&delta, p, x).unwrap();
        let analytic = at(truth.as_slice(), &pose);
        let numeric = differences(&delta, &truth, 1e-4, |p| at(p, &pose).rows.residual);
        assert_matches(&analytic.rows.d_params, &numeric);
        let mut d_pose = DMatrix::zeros(3, 3);
        for k in 0..3 {
            let step = DVector::from_fn(3, |i, _| if i == k { 1e-4 } else { 0.0 });
            let plus = delta.retract(&pose, step.as_slice());
            let minus = delta.retract(&pose, (-step).as_slice());
            let column = (at(truth.as_slice(), plus.as_slice()).rows.residual
                - at(truth.as_slice(), minus.as_slice()).rows.residual)
                / 2e-4;
            d_pose.set_column(k, &column);
        }
        let error = (&analytic.d_pose - &d_pose).amax();
        assert!(error < 1e-6 * d_pose.amax(), "{error:e}");
        // The readings' own pose and parameters: zero residual.
        assert!(at(configured.as_slice(), &pose).rows.residual.amax() < 1e-9);
        let short = PointSample {
            readings: vec![1.0, 2.0],
            ..sample
        };
        let error = short.evaluate(&delta, truth.as_slice(), &pose).unwrap_err();
        assert!(error.to_string().contains("readings"), "{error}");
        let loaded = PointSample {
            readings: vec![0.0; 3],
            loads: Some(vec![1.0; 3]),
            ..short
        };
        let error = loaded
            .evaluate(&delta, truth.as_slice(), &pose)
            .unwrap_err();
        assert!(error.to_string().contains("no load model"), "{error}");
    }
}
