//! The check at the boundary: [`calibrate`](crate::calibrate) refuses a
//! dataset it cannot index or fit, with an error instead of a panic, however
//! the dataset was made (read from files, or built in memory).

#[cfg(doc)]
use parcal_dataset::Calibration;
use parcal_dataset::Dataset;

use crate::CalibrateError;

/// Contacts a ball needs: its initial centre is the best-fit sphere of known
/// radius through its contact points ([`crate::sphere_fit::best_fit`]),
/// which takes 4 points. The dataset's own minimum, so that what the
/// dataset reads, writes and validates, a calibration accepts.
pub const MIN_CONTACTS_PER_BALL: usize = parcal_dataset::MIN_CONTACTS_PER_BALL;

/// What [`calibrate`](crate::calibrate) checks first: [`Dataset::validate`],
/// the validation of every dataset read or written (lengths, indices,
/// finite and plausible values, sigmas, a machine geometry with canonical
/// frames, approach directions that normalise, at least
/// [`MIN_CONTACTS_PER_BALL`] contacts per ball; of the truth too, although
/// the calibration does not read it: a dataset is valid as a whole). Errors
/// name the measurement row, the ball or the field
/// ([`CalibrateError::InvalidDataset`], [`CalibrateError::TooFewContacts`]).
pub fn validate(dataset: &Dataset) -> Result<(), CalibrateError> {
    dataset.validate().map_err(CalibrateError::invalid_dataset)
}

/// Refuses to apply a calibration whose actuators read in `unit`
/// ([`Calibration::actuator_unit`]) to `dataset` when its actuators read
/// in another: the calibrated scales (mm per unit) would be applied to
/// readings in another unit.
pub(crate) fn same_unit(dataset: &Dataset, unit: &str) -> Result<(), CalibrateError> {
    let given = dataset.machine.actuator.unit.as_str();
    if given == unit {
        return Ok(());
    }
    Err(CalibrateError::Calibration {
        reason: format!(
            "its actuators read in {unit}, the dataset's in {given} (machine.json's actuator.unit): its scales (mm per {unit}) do not apply to these readings"
        ),
    })
}
