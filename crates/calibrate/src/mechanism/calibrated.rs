//! What applying a mechanism calibration needs of its record
//! (`calibration.json`, [`MechanismCalibrationRecord`]): the mechanism, the
//! estimate `θ̂ = (p̂, ĥ)` of its global block in the canonical frame (the
//! parameters, then the trigger height if it was estimated), its
//! covariance `Σ_θ`, the calibration's global test `(Ω, r)` and the priors'
//! means (the design the controller was configured from).

use std::sync::Arc;

use nalgebra::{DMatrix, DVector};
use parcal_dataset::mechanism::MechanismCalibrationRecord;
use parcal_kinematics::mechanism::Mechanism;
use parcal_kinematics::mechanisms;

use super::error::MechanismCalibrationError;
use super::result::{MechanismCalibration, TRIGGER_HEIGHT};

/// A mechanism calibration as numbers (module doc).
#[derive(Clone)]
pub struct CalibratedMechanism {
    /// The mechanism.
    pub mechanism: Arc<dyn Mechanism>,
    /// `θ̂`: the parameters (canonical frame), then the trigger height if
    /// the calibration estimated one.
    pub values: DVector<f64>,
    /// `Σ_θ`, the covariance of [`Self::values`].
    pub covariance: DMatrix<f64>,
    /// The parameters' prior means: the design the calibration started
    /// from, what a controller configured from the design runs with.
    pub nominal: Vec<f64>,
    /// The calibration's global test `(Ω, r)`, if it has one.
    pub global_test: Option<(f64, usize)>,
}

impl CalibratedMechanism {
    /// From a calibration's record: a known mechanism (the variant of its
    /// parameters, [`mechanisms::with_parameters`]; a printer within the
    /// printable radius the record states, [`mechanisms::by_name_within`];
    /// a cable robot with the elastic lines it states,
    /// [`LineElasticity::cable_robot`](parcal_dataset::mechanism::LineElasticity::cable_robot)),
    /// its parameters in its order (then `trigger_height`, if any), and a
    /// covariance (a calibration that did not converge has none and is
    /// refused).
    pub fn from_record(
        record: &MechanismCalibrationRecord,
    ) -> Result<Self, MechanismCalibrationError> {
        let invalid = |what: &str, reason: String| MechanismCalibrationError::InvalidData {
            what: what.to_string(),
            reason,
        };
        let recorded: Vec<(&str, &str)> = record
            .parameters
            .iter()
            .filter(|p| p.name != TRIGGER_HEIGHT)
            .map(|p| (p.name.as_str(), p.unit.as_str()))
            .collect();
        // A printer is built within the printable radius it was calibrated
        // for, a cable robot with the elastic lines it was calibrated with;
        // any other mechanism as the variant its parameters name.
        let known = match (record.print_radius, &record.elasticity) {
            (_, Some(elasticity)) => {
                Some((elasticity.cable_robot()).map_err(|reason| invalid("elasticity", reason))?)
            }
            (Some(radius), None) => mechanisms::by_name_within(&record.mechanism, Some(radius)),
            (None, None) => mechanisms::with_parameters(&record.mechanism, &recorded)
                .or_else(|| mechanisms::by_name(&record.mechanism)),
        };
        let mechanism: Arc<dyn Mechanism> = known
            .ok_or_else(|| {
                invalid(
                    "mechanism",
                    format!(
                        "unknown mechanism {:?} (known: {})",
                        record.mechanism,
                        mechanisms::NAMES.join(", ")
                    ),
                )
            })?
            .into();
        let names: Vec<String> = mechanism
            .parameters()
            .iter()
            .map(|p| p.name.clone())
            .collect();
        let recorded: Vec<&str> = record.parameters.iter().map(|p| p.name.as_str()).collect();
        let n = names.len();
        let matches = recorded.len() >= n
            && recorded[..n].iter().zip(&names).all(|(a, b)| a == b)
            && (recorded.len() == n || recorded[n..] == [TRIGGER_HEIGHT]);
        if !matches {
            return Err(invalid(
                "parameters",
                format!(
                    "the calibration's parameters ({}) are not the {}'s ({}), with {TRIGGER_HEIGHT} last if estimated",
                    recorded.join(", "),
                    record.mechanism,
                    names.join(", ")
                ),
            ));
        }
        let g = recorded.len();
        let covariance = record.covariance.as_ref().ok_or_else(|| {
            invalid(
                "covariance",
                "the calibration has none (it did not converge): nothing predicts its uncertainty"
                    .to_string(),
            )
        })?;
        Ok(Self {
            mechanism,
            values: DVector::from_iterator(g, record.parameters.iter().map(|p| p.value)),
            covariance: DMatrix::from_fn(g, g, |i, j| covariance[i][j]),
            nominal: record.parameters[..n]
                .iter()
                .map(|p| p.prior_mean)
                .collect(),
            global_test: record.global_test.as_ref().map(|t| (t.cost, t.redundancy)),
        })
    }

    /// From a calibration in memory, through its record (one path).
    pub fn of_calibration(
        calibration: &MechanismCalibration,
    ) -> Result<Self, MechanismCalibrationError> {
        Self::from_record(&calibration.record())
    }

    /// The number of the mechanism's parameters.
    pub fn n_params(&self) -> usize {
        self.mechanism.parameters().len()
    }

    /// `p̂`, the calibrated parameters.
    pub fn params(&self) -> &[f64] {
        &self.values.as_slice()[..self.n_params()]
    }

    /// `ĥ`, the calibrated trigger height, if the calibration estimated one.
    pub fn trigger_height(&self) -> Option<f64> {
        (self.values.len() > self.n_params()).then(|| self.values[self.n_params()])
    }
}
