//! Data snooping (Baarda 1968): find the blunders among the ball touches.
//!
//! Calibrate; if the contact of largest normalised residual
//! ([`crate::reliability`]) exceeds the critical value of the family of
//! tests, `|w| > z_{1 − α/(2m)}` (`m` contacts, family-wise level `α`,
//! Bonferroni), remove it and calibrate again; stop when no contact
//! exceeds it, when the limit of removals is reached, or when the contact
//! cannot be removed (its ball would keep fewer contacts than its centre
//! needs). One contact at a time: a blunder spreads into the others'
//! residuals, so the largest is removed first and the rest tested again.

use parcal_dataset::Dataset;
use parcal_solver::IterationRecord;

use crate::reliability::critical_value;
use crate::{CalibrateError, CalibrationOptions, CalibrationRun, MIN_CONTACTS_PER_BALL, calibrate};

/// The default family-wise level of data snooping.
pub const SNOOPING_LEVEL: f64 = 0.05;
/// The default limit of removals.
pub const MAX_REMOVALS: usize = 10;

/// One removed contact.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Removal {
    /// Its measurements.csv row in the dataset given (0-based).
    pub row: usize,
    /// Its normalised residual when it was removed.
    pub normalised: f64,
    /// Its estimated gross error, in units of its row's standard deviation.
    pub gross_error: f64,
    /// The a-posteriori variance factor before its removal.
    pub variance_factor_before: f64,
    /// And after (NaN if the calibration without it has no global test).
    pub variance_factor_after: f64,
}

/// A calibration after data snooping.
pub struct Snooped {
    /// The calibration of the remaining contacts.
    pub run: CalibrationRun,
    /// The removed contacts, in the order of their removal.
    pub removals: Vec<Removal>,
    /// The measurements.csv row (in the dataset given) of each row of the
    /// remaining dataset, whose rows `run` names.
    pub original_rows: Vec<usize>,
    /// The critical value of the last test.
    pub critical_value: f64,
    /// Why snooping stopped before every contact passed, if it did.
    pub stopped: Option<String>,
}

/// Calibrates `dataset` with data snooping at family-wise `level`,
/// removing at most `max_removals` contacts (module doc).
pub fn calibrate_with_snooping(
    dataset: &Dataset,
    options: &CalibrationOptions,
    level: f64,
    max_removals: usize,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<Snooped, CalibrateError> {
    let mut current = dataset.clone();
    let mut original_rows: Vec<usize> = (0..dataset.measurements.len()).collect();
    let mut removals: Vec<Removal> = Vec::new();
    loop {
        let run = calibrate(&current, options, observer)?;
        let factor = run.global_test.map_or(f64::NAN, |t| t.variance_factor);
        if let Some(last) = removals.last_mut() {
            last.variance_factor_after = factor;
        }
        let contacts = current.measurements.len();
        let critical = critical_value(level, contacts);
        let finish = |run, removals, original_rows, stopped| Snooped {
            run,
            removals,
            original_rows,
            critical_value: critical,
            stopped,
        };
        let Some(worst) = run.reliability.as_ref().and_then(|r| r.worst()).copied() else {
            let stopped =
                (!run.converged()).then(|| "the calibration did not converge".to_string());
            return Ok(finish(run, removals, original_rows, stopped));
        };
        let (Some(w), Some(gross_error)) = (worst.normalised, worst.gross_error) else {
            return Ok(finish(run, removals, original_rows, None));
        };
        if w.abs() <= critical {
            return Ok(finish(run, removals, original_rows, None));
        }
        if removals.len() == max_removals {
            let stopped = format!(
                "the limit of {max_removals} removals was reached with a contact still failing (|w| = {:.1})",
                w.abs()
            );
            return Ok(finish(run, removals, original_rows, Some(stopped)));
        }
        let ball = current.measurements.ball[worst.row] as usize;
        if current.contacts_per_ball()[ball] <= MIN_CONTACTS_PER_BALL {
            let stopped = format!(
                "the failing contact (measurements.csv row {}, |w| = {:.1}) is one of the {MIN_CONTACTS_PER_BALL} its ball {:?} needs at least",
                original_rows[worst.row],
                w.abs(),
                current.artefacts.balls[ball].id
            );
            return Ok(finish(run, removals, original_rows, Some(stopped)));
        }
        removals.push(Removal {
            row: original_rows[worst.row],
            normalised: w,
            gross_error,
            variance_factor_before: factor,
            variance_factor_after: f64::NAN,
        });
        remove_row(&mut current, worst.row);
        original_rows.remove(worst.row);
    }
}

/// `dataset` without its measurements.csv row `row` (and its truth
/// contact).
fn remove_row(dataset: &mut Dataset, row: usize) {
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
