//! Data snooping of a mechanism calibration (Baarda 1968), as
//! [`crate::snooping`] does the hexapod's: at a least-squares minimum, if
//! the observation of largest normalised residual exceeds the critical
//! value of the family (`|w| > z_{1 − α/(2m)}`, `m` data rows,
//! Bonferroni: [`crate::hypothesis::critical_value`]), remove it as a
//! whole and calibrate again; stop when none exceeds it, when the limit of
//! removals is reached, or when the calibration fails without it. Every
//! observation of the result is named by its place in the data given.

use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::fit::fit;
use super::observation::{ObservationKind, ObservationRef};
use super::options::MechanismOptions;
use super::result::{MechanismCalibration, Removal, assemble, reasons};

/// Where each remaining observation is in the data given, by kind.
struct Remaining([Vec<usize>; ObservationKind::ALL.len()]);

impl Remaining {
    fn all(data: &MechanismData) -> Self {
        Self(ObservationKind::ALL.map(|kind| (0..data.observations.count(kind)).collect()))
    }

    fn original(&self, observation: ObservationRef) -> ObservationRef {
        ObservationRef {
            index: self.0[observation.kind.index()][observation.index],
            ..observation
        }
    }

    fn remove(&mut self, observation: ObservationRef) {
        self.0[observation.kind.index()].remove(observation.index);
    }
}

/// One calibration of `data`, its observations named as in `data`.
pub(crate) fn calibrate_once(
    data: &MechanismData,
    options: &MechanismOptions,
) -> Result<MechanismCalibration, MechanismCalibrationError> {
    assemble(data, fit(data, options)?, options)
}

/// Calibrates `data` with data snooping (module doc).
pub(crate) fn snoop(
    data: &MechanismData,
    options: &MechanismOptions,
) -> Result<MechanismCalibration, MechanismCalibrationError> {
    let mut current = data.clone();
    let mut remaining = Remaining::all(data);
    let mut removals = Vec::new();
    let mut run = calibrate_once(&current, options)?;
    let stopped = loop {
        let Some((worst, row, w)) = run.worst() else {
            break (!run.converged()).then(|| {
                "the calibration did not converge, so no observation is judged".to_string()
            });
        };
        if w.abs() <= run.critical_value {
            break None;
        }
        let original = remaining.original(worst);
        if removals.len() == options.max_removals {
            break Some(format!(
                "the limit of {} removals was reached with an observation still failing ({original}, |w| = {:.2})",
                options.max_removals,
                w.abs()
            ));
        }
        let next = current.with_observations(current.observations.without(worst));
        let next_run = match next
            .validate()
            .and_then(|()| calibrate_once(&next, options))
        {
            Ok(next_run) => next_run,
            Err(error) => {
                break Some(format!(
                    "the failing observation ({original}, |w| = {:.2}) cannot be removed: without it, {error}",
                    w.abs()
                ));
            }
        };
        removals.push(Removal {
            observation: original,
            row,
            normalised: w,
            variance_factor_before: run.variance_factor(),
            variance_factor_after: next_run.variance_factor(),
        });
        remaining.remove(worst);
        (current, run) = (next, next_run);
    };
    for check in &mut run.observations {
        check.observation = remaining.original(check.observation);
    }
    run.removals = removals;
    run.snooping_stopped = stopped;
    run.reasons = reasons(&run);
    Ok(run)
}
