//! The checks every kind's values share: finite values, a finite and
//! positive sigma, a prior of a finite mean and a finite and positive
//! sigma if any; an error naming the observation.

use super::super::error::MechanismCalibrationError;
use super::super::observation::ObservationRef;
use super::mechanism_data::ParameterPrior;

pub(super) fn observation_error(
    observation: ObservationRef,
    reason: String,
) -> MechanismCalibrationError {
    MechanismCalibrationError::Observation {
        observation,
        reason,
    }
}

pub(super) fn check_values(
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

pub(super) fn check_sigma(
    observation: ObservationRef,
    sigma: f64,
) -> Result<(), MechanismCalibrationError> {
    if sigma.is_finite() && sigma > 0.0 {
        Ok(())
    } else {
        Err(observation_error(
            observation,
            format!("its standard deviation {sigma} is not finite and positive"),
        ))
    }
}

pub(super) fn check_prior(
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
