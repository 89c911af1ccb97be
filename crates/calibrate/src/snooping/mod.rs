//! Data snooping (Baarda 1968): find the blunders among the observations,
//! one path for every calibration (the hexapod's ball touches, its
//! measured poses and points, a mechanism's probe heights, part distances
//! and samples).
//!
//! Calibrate; if the run is at a least-squares minimum (its observations
//! have checks: [`Snoopable::tests`]; otherwise nothing is judged, and
//! snooping stops, saying so) and the observation of largest normalised
//! residual (an observation's is its rows' largest) exceeds the critical
//! value of the family of tests, `|w| > z_{1 − α/(2m)}` (`m` tests,
//! family-wise level `α`, Bonferroni:
//! [`crate::hypothesis::critical_value`]), remove it as a whole (a contact,
//! a distance, a pose's six rows, a point's three) and calibrate again;
//! stop when no observation exceeds it, when the limit of removals is
//! reached, or when the observation cannot be removed (the data would be
//! incomplete without it, or the calibration fails without it). One
//! observation at a time: a blunder spreads into the others' residuals, so
//! the largest is removed first and the rest tested again.

mod hexapod;

use std::fmt;
use std::marker::PhantomData;

use crate::hypothesis::critical_value;

pub use hexapod::calibrate_with_snooping;

/// An observation named by its kind and its 0-based index among those of
/// its kind.
pub trait Place: Copy + fmt::Display {
    /// How many kinds there are.
    const KINDS: usize;
    /// Its kind's place among the [`Place::KINDS`].
    fn kind(self) -> usize;
    /// Its index among those of its kind.
    fn index(self) -> usize;
    /// The observation of the same kind at `index`.
    fn at(self, index: usize) -> Self;
}

/// Data from which an observation can be removed.
pub trait Removable: Sized {
    /// How its observations are named.
    type Place: Place;
    /// How many observations of each kind it holds.
    fn counts(&self) -> Vec<usize>;
    /// These data without `observation`, or why it cannot be removed.
    fn without(&self, observation: Self::Place) -> Result<Self, String>;
}

/// The worst observation of a calibration: the one of largest `|w|`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Worst<P> {
    /// The observation.
    pub observation: P,
    /// Its row of largest `|w|` (a pose's leg, a point's coordinate).
    pub row: usize,
    /// That row's normalised residual `w = e / √r` (`e` whitened).
    pub normalised: f64,
    /// Its estimated gross error `w / √r`, in units of the standard
    /// deviation of what its test sees
    /// ([`estimated_gross_error`](crate::hypothesis::estimated_gross_error)).
    pub gross_error: f64,
}

/// The family of tests of a calibration at a least-squares minimum.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tests<P> {
    /// Its size `m`.
    pub size: usize,
    /// Its worst observation, if any is checked by the others.
    pub worst: Option<Worst<P>>,
}

/// A calibration that data snooping can check.
pub trait Snoopable {
    /// How its observations are named.
    type Place: Place;
    /// Its family of tests; `None` away from a least-squares minimum, where
    /// nothing is judged.
    fn tests(&self) -> Option<Tests<Self::Place>>;
    /// The a-posteriori variance factor (NaN without a global test).
    fn variance_factor(&self) -> f64;
    /// Whether the solver converged.
    fn converged(&self) -> bool;
}

/// One removed observation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Removal<P> {
    /// The observation, by its place in the data given.
    pub observation: P,
    /// Its row of largest normalised residual.
    pub row: usize,
    /// That row's normalised residual when it was removed.
    pub normalised: f64,
    /// Its estimated gross error when it was removed, in units of the
    /// standard deviation of what its test sees
    /// ([`estimated_gross_error`](crate::hypothesis::estimated_gross_error)).
    pub gross_error: f64,
    /// The a-posteriori variance factor before its removal.
    pub variance_factor_before: f64,
    /// And after (NaN if the calibration without it has no global test).
    pub variance_factor_after: f64,
}

/// The place in the data given of each observation of data with some
/// removed.
#[derive(Debug, Clone, PartialEq)]
pub struct Remaining<P> {
    places: Vec<Vec<usize>>,
    observation: PhantomData<P>,
}

impl<P: Place> Remaining<P> {
    /// Every observation of `data`, at its own place.
    pub fn all<D: Removable<Place = P>>(data: &D) -> Self {
        let places = data
            .counts()
            .into_iter()
            .map(|n| (0..n).collect())
            .collect();
        Self {
            places,
            observation: PhantomData,
        }
    }

    /// Where `observation` of the remaining data is in the data given.
    pub fn original(&self, observation: P) -> P {
        observation.at(self.places[observation.kind()][observation.index()])
    }

    fn remove(&mut self, observation: P) {
        self.places[observation.kind()].remove(observation.index());
    }
}

/// A calibration after data snooping.
pub struct Snooped<Run, P> {
    /// The calibration of the remaining observations.
    pub run: Run,
    /// The removed observations, in the order of their removal.
    pub removals: Vec<Removal<P>>,
    /// Where the remaining observations, which `run` names, are in the
    /// data given.
    pub remaining: Remaining<P>,
    /// The critical value of the last test (NaN if none was made).
    pub critical_value: f64,
    /// Why snooping stopped before every observation passed, if it did.
    pub stopped: Option<String>,
}

/// Data snooping of `data` at family-wise `level`, removing at most
/// `max_removals` observations, with the calibration `calibrate` (module
/// doc).
pub fn snoop<D, Run, E>(
    data: &D,
    level: f64,
    max_removals: usize,
    mut calibrate: impl FnMut(&D) -> Result<Run, E>,
) -> Result<Snooped<Run, D::Place>, E>
where
    D: Removable,
    Run: Snoopable<Place = D::Place>,
    E: fmt::Display,
{
    let mut remaining = Remaining::all(data);
    let mut removals = Vec::new();
    let mut run = calibrate(data)?;
    let mut current: Option<D> = None;
    let (critical, stopped) = loop {
        let Some(tests) = run.tests() else {
            break (
                f64::NAN,
                (!run.converged()).then(|| not_converged(removals.is_empty())),
            );
        };
        let critical = critical_value(level, tests.size);
        let Some(worst) = tests.worst.filter(|w| w.normalised.abs() > critical) else {
            break (critical, None);
        };
        let original = remaining.original(worst.observation);
        let failing = format!("({original}, |w| = {:.1})", worst.normalised.abs());
        if removals.len() == max_removals {
            let stopped = format!(
                "the limit of {max_removals} removals was reached with an observation still failing {failing}"
            );
            break (critical, Some(stopped));
        }
        let next_run = current
            .as_ref()
            .unwrap_or(data)
            .without(worst.observation)
            .and_then(|next| {
                let next_run = calibrate(&next).map_err(|error| format!("without it, {error}"))?;
                Ok((next, next_run))
            });
        let (next, next_run) = match next_run {
            Ok(next) => next,
            Err(why) => {
                break (
                    critical,
                    Some(format!(
                        "the failing observation {failing} cannot be removed: {why}"
                    )),
                );
            }
        };
        removals.push(Removal {
            observation: original,
            row: worst.row,
            normalised: worst.normalised,
            gross_error: worst.gross_error,
            variance_factor_before: run.variance_factor(),
            variance_factor_after: next_run.variance_factor(),
        });
        remaining.remove(worst.observation);
        (current, run) = (Some(next), next_run);
    };
    Ok(Snooped {
        run,
        removals,
        remaining,
        critical_value: critical,
        stopped,
    })
}

/// Why nothing more is judged when a calibration did not converge.
fn not_converged(first: bool) -> String {
    let not_judged = "its residuals are not those of a least-squares minimum";
    if first {
        format!(
            "the calibration did not converge: {not_judged}, so no observation is judged and nothing was removed"
        )
    } else {
        format!(
            "the calibration without the removed observations did not converge: {not_judged}, so no further observation is judged"
        )
    }
}
