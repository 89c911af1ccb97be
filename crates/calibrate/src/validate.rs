//! The check at the boundary: [`calibrate`](crate::calibrate) refuses a
//! dataset it cannot index or fit, with an error instead of a panic, however
//! the dataset was made (read from files, or built in memory).

use parcal_dataset::Dataset;

use crate::CalibrateError;

/// Contacts a ball needs: its initial centre is the best-fit sphere of known
/// radius through its contact points ([`crate::sphere_fit::best_fit`]),
/// which takes 4 points.
pub const MIN_CONTACTS_PER_BALL: usize = 4;

/// What [`calibrate`](crate::calibrate) checks first: [`Dataset::validate`]
/// (lengths, indices, finite values, positive sigmas; of the truth too,
/// although the calibration does not read it: a dataset is valid as a
/// whole) and at least [`MIN_CONTACTS_PER_BALL`] contacts per ball. Errors name the measurement
/// row, the ball or the field ([`CalibrateError::InvalidDataset`],
/// [`CalibrateError::TooFewContacts`]).
pub fn validate(dataset: &Dataset) -> Result<(), CalibrateError> {
    dataset
        .validate()
        .map_err(CalibrateError::invalid_dataset)?;
    let counts = dataset.contacts_per_ball();
    match counts.iter().position(|&n| n < MIN_CONTACTS_PER_BALL) {
        None => Ok(()),
        Some(i) => Err(CalibrateError::TooFewContacts {
            ball: dataset.artefacts.balls[i].id.clone(),
            count: counts[i],
            min: MIN_CONTACTS_PER_BALL,
        }),
    }
}
