//! Data snooping of the hexapod's calibration ([`super`]): its ball
//! touches, distances, measured poses and points, whatever the dataset
//! holds ([`calibrate_with_snooping`]; a robust loss replaces it, and
//! snooping refuses one: [`crate::robust`]).

use parcal_dataset::Dataset;
use parcal_solver::IterationRecord;

use super::{Place, Removable, Snoopable, Snooped, Tests, Worst, snoop};
use crate::observation::ObservationId;
use crate::reliability::Reliability;
use crate::{CalibrateError, CalibrationOptions, CalibrationRun, MIN_CONTACTS_PER_BALL, calibrate};

impl Place for ObservationId {
    const KINDS: usize = 4;

    fn kind(self) -> usize {
        match self {
            Self::Contact(_) => 0,
            Self::Distance(_) => 1,
            Self::Pose(_) => 2,
            Self::Point(_) => 3,
        }
    }

    fn index(self) -> usize {
        match self {
            Self::Contact(k) | Self::Distance(k) | Self::Pose(k) | Self::Point(k) => k,
        }
    }

    fn at(self, index: usize) -> Self {
        match self {
            Self::Contact(_) => Self::Contact(index),
            Self::Distance(_) => Self::Distance(index),
            Self::Pose(_) => Self::Pose(index),
            Self::Point(_) => Self::Point(index),
        }
    }
}

impl Removable for Dataset {
    type Place = ObservationId;

    /// measurements.csv rows, distances, poses.csv and points.csv rows.
    fn counts(&self) -> Vec<usize> {
        vec![
            self.measurements.len(),
            self.artefacts.distances.len(),
            self.tracker.poses.len(),
            self.tracker.points.len(),
        ]
    }

    /// Refuses to remove a contact its ball needs
    /// ([`MIN_CONTACTS_PER_BALL`]).
    fn without(&self, observation: ObservationId) -> Result<Self, String> {
        if let ObservationId::Contact(row) = observation {
            let ball = self.measurements.ball[row] as usize;
            if self.contacts_per_ball()[ball] <= MIN_CONTACTS_PER_BALL {
                return Err(format!(
                    "it is one of the {MIN_CONTACTS_PER_BALL} contacts its ball {:?} needs at least",
                    self.artefacts.balls[ball].id
                ));
            }
        }
        let mut rest = self.clone();
        remove(&mut rest, observation);
        Ok(rest)
    }
}

/// The family of tests of a run's observations' checks.
fn tests(reliability: Option<&Reliability>) -> Option<Tests<ObservationId>> {
    let reliability = reliability?;
    let worst = reliability.worst().and_then(|c| {
        Some(Worst {
            observation: c.observation(),
            row: c.row(),
            normalised: c.normalised()?,
            gross_error: c.gross_error()?,
        })
    });
    Some(Tests {
        size: reliability.tests(),
        worst,
    })
}

impl Snoopable for CalibrationRun {
    type Place = ObservationId;

    fn tests(&self) -> Option<Tests<ObservationId>> {
        tests(self.reliability.as_ref())
    }

    fn variance_factor(&self) -> f64 {
        self.global_test.map_or(f64::NAN, |t| t.variance_factor)
    }

    fn converged(&self) -> bool {
        CalibrationRun::converged(self)
    }
}

/// Calibrates `dataset` ([`calibrate`]) with data snooping at
/// family-wise `level`, removing at most `max_removals`
/// observations (module doc).
pub fn calibrate_with_snooping(
    dataset: &Dataset,
    options: &CalibrationOptions,
    level: f64,
    max_removals: usize,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<Snooped<CalibrationRun, ObservationId>, CalibrateError> {
    if !options.loss.is_squared() {
        return Err(CalibrateError::RobustLoss {
            loss: options.loss,
            reason: "with data snooping: it replaces it",
        });
    }
    snoop(dataset, level, max_removals, |d| {
        calibrate(d, options, &mut *observer)
    })
}

/// `dataset` without `observation` (and a contact's truth).
fn remove(dataset: &mut Dataset, observation: ObservationId) {
    match observation {
        ObservationId::Contact(row) => {
            let m = &mut dataset.measurements;
            m.ball.remove(row);
            m.q.remove(row);
            if let Some(directions) = &mut m.direction {
                directions.remove(row);
            }
            // A truth read without its contact points has none to remove.
            if let Some(truth) = &mut dataset.truth
                && !truth.contacts.is_empty()
            {
                truth.contacts.remove(row);
            }
        }
        ObservationId::Distance(k) => {
            dataset.artefacts.distances.remove(k);
        }
        ObservationId::Pose(row) => {
            let poses = &mut dataset.tracker.poses;
            poses.session.remove(row);
            poses.q.remove(row);
            poses.position.remove(row);
            poses.orientation.remove(row);
        }
        ObservationId::Point(row) => {
            let points = &mut dataset.tracker.points;
            points.session.remove(row);
            points.q.remove(row);
            points.position.remove(row);
        }
    }
}
