//! The entry of a mechanism's calibration ([`calibrate_mechanism`]): the
//! options and data checked, every gauge freedom held by a prior, then one
//! fit or data snooping.

use std::time::Instant;

use parcal_solver::IterationRecord;

use super::coordinate_problem;
use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::fit;
use super::options::MechanismOptions;
use super::result::{MechanismCalibration, named, repeat_warnings};
use super::snooping;

/// Calibrates `data` with `options`: validates both, refuses a gauge
/// freedom that no prior holds, fits (with data snooping if asked) and
/// returns the estimate in the canonical frame with its tests, verdict,
/// identifiability and the observations given twice (warned of).
/// `observer` sees each iteration of each fit, as the hexapod's own
/// [`calibrate`](crate::calibrate) shows them.
pub fn calibrate_mechanism(
    data: &MechanismData,
    options: &MechanismOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<MechanismCalibration, MechanismCalibrationError> {
    let started = Instant::now();
    options.validate()?;
    data.validate()?;
    coordinate_problem::check_observation(data, options)?;
    check_gauge_priors(data)?;
    let mut run = if options.snoop {
        snooping::snoop(data, options, started, observer)
    } else {
        snooping::calibrate_once(data, options, started, observer)
    }?;
    run.repeats = data.observations.repeats();
    run.warnings = repeat_warnings(&run.repeats, &named);
    Ok(run)
}

/// Checks `data` as [`calibrate_mechanism`] does before its first step:
/// valid, every gauge freedom held by a prior, and every observation
/// evaluated at the start (the priors' means; each point sample's pose
/// from its readings, each ball's centre from its touches), so that a
/// commanded position the machine cannot reach, readings no pose
/// explains or touches that fit no sphere are named.
pub fn check_mechanism_data(data: &MechanismData) -> Result<(), MechanismCalibrationError> {
    data.validate()?;
    check_gauge_priors(data)?;
    fit::check_start(data)
}

/// Refuses data where some gauge freedom moves only parameters without a
/// prior: nothing would determine it.
fn check_gauge_priors(data: &MechanismData) -> Result<(), MechanismCalibrationError> {
    let mechanism = data.mechanism.as_ref();
    let means: Vec<f64> = data.priors.iter().map(|p| p.mean).collect();
    let freedoms = mechanism.gauge_freedoms(&means).map_err(|source| {
        MechanismCalibrationError::Kinematics {
            mechanism: mechanism.name().to_string(),
            source,
        }
    })?;
    for freedom in freedoms {
        let held = freedom
            .direction
            .iter()
            .zip(&data.priors)
            .any(|(z, prior)| z.abs() > 1e-9 && prior.sigma.is_some());
        if !held {
            let moved: Vec<&str> = freedom
                .direction
                .iter()
                .zip(mechanism.parameters())
                .filter(|(z, _)| z.abs() > 1e-9)
                .map(|(_, p)| p.name.as_str())
                .collect();
            return Err(MechanismCalibrationError::NotDetermined {
                reason: format!(
                    "no measurement sees the {} ({}), and none of its parameters has a prior: give one of them a prior",
                    freedom.name,
                    moved.join(", ")
                ),
            });
        }
    }
    Ok(())
}
