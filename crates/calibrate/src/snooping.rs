//! Data snooping (Baarda 1968): find the blunders among the observations
//! (ball touches, calibrated distances, measured poses and points).
//!
//! Calibrate; if the run converged ([`crate::verdict::at_minimum`]: no
//! observation is judged elsewhere, and snooping stops, saying so) and the
//! observation of largest normalised residual
//! ([`crate::reliability`]: an observation's is its rows' largest) exceeds
//! the critical value of the family of tests, `|w| > z_{1 − α/(2m)}` (`m`
//! tests, [`Reliability::tests`], family-wise level `α`, Bonferroni),
//! remove it as a whole (a contact, a distance, a pose's six rows, a
//! point's three) and calibrate again; stop when no observation exceeds
//! it, when the limit of removals is reached, or when the observation
//! cannot be removed (its ball would keep fewer contacts than its centre
//! needs, or the calibration fails without it). A robust loss replaces
//! data snooping ([`crate::robust`]): snooping refuses one. One observation at a time:
//! a blunder spreads into the others' residuals, so the largest is removed
//! first and the rest tested again.

use parcal_dataset::Dataset;
use parcal_solver::IterationRecord;

use crate::hypothesis::critical_value;
use crate::instruments::{InstrumentRun, calibrate_instruments};
use crate::observation::ObservationId;
use crate::reliability::Reliability;
use crate::{CalibrateError, CalibrationOptions, CalibrationRun, MIN_CONTACTS_PER_BALL, calibrate};

/// One removed observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Removal {
    /// The observation, by its place in the dataset given.
    pub observation: ObservationId,
    /// Its row of largest normalised residual (a pose's leg, a point's
    /// coordinate).
    pub row: usize,
    /// That row's normalised residual when it was removed.
    pub normalised: f64,
    /// That row's estimated gross error, in units of its standard deviation.
    pub gross_error: f64,
    /// The a-posteriori variance factor before its removal.
    pub variance_factor_before: f64,
    /// And after (NaN if the calibration without it has no global test).
    pub variance_factor_after: f64,
}

/// A calibration that data snooping can check: its observations' checks
/// and its a-posteriori variance factor.
pub trait Snoopable {
    /// The observations' checks, when the run converged.
    fn reliability(&self) -> Option<&Reliability>;
    /// The a-posteriori variance factor (NaN without a global test).
    fn variance_factor(&self) -> f64;
    /// Whether the solver converged.
    fn converged(&self) -> bool;
}

impl Snoopable for CalibrationRun {
    fn reliability(&self) -> Option<&Reliability> {
        self.reliability.as_ref()
    }

    fn variance_factor(&self) -> f64 {
        self.global_test.map_or(f64::NAN, |t| t.variance_factor)
    }

    fn converged(&self) -> bool {
        CalibrationRun::converged(self)
    }
}

impl Snoopable for InstrumentRun {
    fn reliability(&self) -> Option<&Reliability> {
        self.reliability.as_ref()
    }

    fn variance_factor(&self) -> f64 {
        self.global_test.map_or(f64::NAN, |t| t.variance_factor)
    }

    fn converged(&self) -> bool {
        InstrumentRun::converged(self)
    }
}

/// A calibration after data snooping.
pub struct Snooped<Run = CalibrationRun> {
    /// The calibration of the remaining observations.
    pub run: Run,
    /// The removed observations, in the order of their removal.
    pub removals: Vec<Removal>,
    /// Where the remaining dataset's observations, which `run` names, are
    /// in the dataset given.
    pub remaining: Remaining,
    /// The critical value of the last test.
    pub critical_value: f64,
    /// Why snooping stopped before every observation passed, if it did.
    pub stopped: Option<String>,
}

/// The place in the dataset given of each observation of a dataset with
/// some removed: measurements.csv rows, distances, poses.csv and
/// points.csv rows.
#[derive(Debug, Clone, PartialEq)]
pub struct Remaining {
    contacts: Vec<usize>,
    distances: Vec<usize>,
    poses: Vec<usize>,
    points: Vec<usize>,
}

impl Remaining {
    /// Every observation of `dataset`, at its own place.
    pub fn all(dataset: &Dataset) -> Self {
        Self {
            contacts: (0..dataset.measurements.len()).collect(),
            distances: (0..dataset.artefacts.distances.len()).collect(),
            poses: (0..dataset.tracker.poses.len()).collect(),
            points: (0..dataset.tracker.points.len()).collect(),
        }
    }

    /// Where `observation` of the remaining dataset is in the dataset given.
    pub fn original(&self, observation: ObservationId) -> ObservationId {
        match observation {
            ObservationId::Contact(k) => ObservationId::Contact(self.contacts[k]),
            ObservationId::Distance(k) => ObservationId::Distance(self.distances[k]),
            ObservationId::Pose(k) => ObservationId::Pose(self.poses[k]),
            ObservationId::Point(k) => ObservationId::Point(self.points[k]),
        }
    }

    fn remove(&mut self, observation: ObservationId) {
        match observation {
            ObservationId::Contact(k) => self.contacts.remove(k),
            ObservationId::Distance(k) => self.distances.remove(k),
            ObservationId::Pose(k) => self.poses.remove(k),
            ObservationId::Point(k) => self.points.remove(k),
        };
    }
}

/// Calibrates the ball touches (and distances) of `dataset` with data
/// snooping at family-wise `level`, removing at most `max_removals`
/// observations (module doc).
pub fn calibrate_with_snooping(
    dataset: &Dataset,
    options: &CalibrationOptions,
    level: f64,
    max_removals: usize,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<Snooped, CalibrateError> {
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

/// Calibrates the measured poses and points of `dataset` with data
/// snooping, as [`calibrate_with_snooping`] does the ball touches.
pub fn calibrate_instruments_with_snooping(
    dataset: &Dataset,
    options: &CalibrationOptions,
    level: f64,
    max_removals: usize,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<Snooped<InstrumentRun>, CalibrateError> {
    snoop(dataset, level, max_removals, |d| {
        calibrate_instruments(d, options, &mut *observer)
    })
}

/// Data snooping of `dataset` with the calibration `calibrate` (module
/// doc).
fn snoop<Run: Snoopable>(
    dataset: &Dataset,
    level: f64,
    max_removals: usize,
    mut calibrate: impl FnMut(&Dataset) -> Result<Run, CalibrateError>,
) -> Result<Snooped<Run>, CalibrateError> {
    let mut current = dataset.clone();
    let mut remaining = Remaining::all(dataset);
    let mut removals: Vec<Removal> = Vec::new();
    let mut run = calibrate(&current)?;
    loop {
        // The checks exist at a least-squares minimum only
        // ([`crate::verdict::at_minimum`]): nothing is judged, or removed,
        // elsewhere.
        let Some(reliability) = run.reliability() else {
            let stopped = (!run.converged()).then(|| {
                let not_judged = "its residuals are not those of a least-squares minimum";
                if removals.is_empty() {
                    format!(
                        "the calibration did not converge: {not_judged}, so no observation is judged and nothing was removed"
                    )
                } else {
                    format!(
                        "the calibration without the removed observations did not converge: {not_judged}, so no further observation is judged"
                    )
                }
            });
            return Ok(Snooped {
                critical_value: f64::NAN,
                run,
                removals,
                remaining,
                stopped,
            });
        };
        let critical = critical_value(level, reliability.tests());
        let worst = reliability.worst();
        let finish = |run, removals, remaining, stopped| {
            Ok(Snooped {
                run,
                removals,
                remaining,
                critical_value: critical,
                stopped,
            })
        };
        let Some((worst, w, gross_error)) =
            worst.and_then(|c| Some((c, c.normalised()?, c.gross_error()?)))
        else {
            return finish(run, removals, remaining, None);
        };
        if w.abs() <= critical {
            return finish(run, removals, remaining, None);
        }
        let original = remaining.original(worst.observation());
        if removals.len() == max_removals {
            let stopped = format!(
                "the limit of {max_removals} removals was reached with an observation still failing ({original}, |w| = {:.1})",
                w.abs()
            );
            return finish(run, removals, remaining, Some(stopped));
        }
        if let ObservationId::Contact(row) = worst.observation() {
            let ball = current.measurements.ball[row] as usize;
            if current.contacts_per_ball()[ball] <= MIN_CONTACTS_PER_BALL {
                let stopped = format!(
                    "the failing contact ({original}, |w| = {:.1}) is one of the {MIN_CONTACTS_PER_BALL} its ball {:?} needs at least",
                    w.abs(),
                    current.artefacts.balls[ball].id
                );
                return finish(run, removals, remaining, Some(stopped));
            }
        }
        let mut next = current.clone();
        remove(&mut next, worst.observation());
        let next_run = match calibrate(&next) {
            Ok(next_run) => next_run,
            Err(error) => {
                let stopped = format!(
                    "the failing observation ({original}, |w| = {:.1}) cannot be removed: without it, {error}",
                    w.abs()
                );
                return finish(run, removals, remaining, Some(stopped));
            }
        };
        removals.push(Removal {
            observation: original,
            row: worst.row(),
            normalised: w,
            gross_error,
            variance_factor_before: run.variance_factor(),
            variance_factor_after: next_run.variance_factor(),
        });
        remaining.remove(worst.observation());
        (current, run) = (next, next_run);
    }
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
            if let Some(truth) = &mut dataset.truth {
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
