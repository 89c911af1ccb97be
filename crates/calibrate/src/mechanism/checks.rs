//! Every observation's numbers at the solution: its rows' whitened
//! residuals `e_j / σ_j` (weighted by a robust loss's `√w` when there is
//! one), redundancy numbers `r_j` and normalised residuals
//! `w_j = e_j / √r_j` (Baarda's w-test), held as two columns, the
//! observations and their rows, with no allocation per observation, and
//! moved as they are into calibration.json's record.

use std::borrow::Cow;

use parcal_dataset::mechanism::{ObservationRecords, RowCheck, worst_row};

use super::observation::ObservationRef;

/// One observation's numbers at the solution, borrowed from
/// [`ObservationChecks`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservationCheck<'a> {
    /// The observation.
    pub observation: ObservationRef,
    /// Its rows' residuals, redundancy numbers and normalised residuals
    /// (`None` for a row no other row checks).
    pub rows: &'a [RowCheck],
}

impl ObservationCheck<'_> {
    /// Its row of largest `|w_j|` and that `w_j`.
    pub fn worst(&self) -> Option<(usize, f64)> {
        worst_row(self.rows)
    }
}

/// Every observation's numbers at the solution, in the order of the data
/// (module doc).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct ObservationChecks {
    /// Each observation, with the end of its rows in `rows`.
    observations: Vec<(ObservationRef, usize)>,
    /// The rows of every observation, in turn.
    rows: Vec<RowCheck>,
    /// The observation of largest `|w_j|` (its place in `observations`),
    /// its row and that `w_j`: found as the observations are pushed, so
    /// that the verdict, its reasons and snooping do not each pass over
    /// every row again.
    worst: Option<(usize, usize, f64)>,
}

impl ObservationChecks {
    /// The checks of the observations whose rows, in order, are `rows`:
    /// none yet ([`ObservationChecks::push`] takes them in turn).
    pub(crate) fn of_rows(rows: Vec<RowCheck>) -> Self {
        Self {
            observations: Vec::new(),
            rows,
            worst: None,
        }
    }

    /// The next observation, holding the next `rows` rows; `false`
    /// (nothing added) when fewer are left.
    pub(crate) fn push(&mut self, observation: ObservationRef, rows: usize) -> bool {
        let start = self.observations.last().map_or(0, |&(_, end)| end);
        let end = start + rows;
        if end > self.rows.len() {
            return false;
        }
        if let Some((row, w)) = worst_row(&self.rows[start..end]) {
            // The last of equal `|w_j|`, as `Iterator::max_by` keeps it.
            let larger =
                |&(_, _, worst): &(usize, usize, f64)| w.abs().total_cmp(&worst.abs()).is_ge();
            if self.worst.as_ref().is_none_or(larger) {
                self.worst = Some((self.observations.len(), row, w));
            }
        }
        self.observations.push((observation, end));
        true
    }

    /// The number of observations.
    pub fn len(&self) -> usize {
        self.observations.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.observations.is_empty()
    }

    /// Observation `k`'s.
    pub fn get(&self, k: usize) -> Option<ObservationCheck<'_>> {
        let &(observation, end) = self.observations.get(k)?;
        let start = k.checked_sub(1).map_or(0, |j| self.observations[j].1);
        Some(ObservationCheck {
            observation,
            rows: &self.rows[start..end],
        })
    }

    /// The observation of largest `|w_j|` (the last of equals), its row of
    /// largest `|w_j|` and that `w_j`; `None` when no row is tested.
    pub fn worst(&self) -> Option<(ObservationCheck<'_>, usize, f64)> {
        let (k, row, w) = self.worst?;
        Some((self.get(k)?, row, w))
    }

    /// Every observation's, in order.
    pub fn iter(&self) -> impl Iterator<Item = ObservationCheck<'_>> + '_ {
        let starts = std::iter::once(0).chain(self.observations.iter().map(|&(_, end)| end));
        (self.observations.iter().zip(starts)).map(|(&(observation, end), start)| {
            ObservationCheck {
                observation,
                rows: &self.rows[start..end],
            }
        })
    }

    /// Each observation named anew by `rename` (snooping's data back to
    /// the original's places).
    pub(crate) fn rename(&mut self, rename: impl Fn(ObservationRef) -> ObservationRef) {
        for (observation, _) in &mut self.observations {
            *observation = rename(*observation);
        }
    }

    /// As calibration.json records them, the rows moved, not copied.
    pub(crate) fn into_records(self) -> ObservationRecords {
        let mut records = ObservationRecords::of_rows(self.rows);
        let mut start = 0;
        for (observation, end) in self.observations {
            let kind = Cow::Borrowed(observation.kind.name());
            let pushed = records.push(kind, observation.index, end - start);
            debug_assert!(pushed, "the rows end where the observations' do");
            start = end;
        }
        records
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::ObservationKind;

    fn row(residual: f32, normalised: Option<f32>) -> RowCheck {
        RowCheck {
            residual,
            redundancy: 0.5,
            normalised,
        }
    }

    /// Each observation keeps its rows, in order, into the record too.
    #[test]
    fn each_observation_keeps_its_rows() {
        let touch = ObservationRef {
            kind: ObservationKind::Touch,
            index: 4,
        };
        let probe = ObservationRef {
            kind: ObservationKind::Probe,
            index: 1,
        };
        let mut checks = ObservationChecks::of_rows(vec![
            row(0.3, Some(0.42)),
            row(1.0, None),
            row(-2.0, Some(-2.75)),
            row(0.5, Some(0.7)),
        ]);
        assert!(checks.push(probe, 1));
        assert!(checks.push(touch, 3));
        assert!(!checks.push(probe, 1), "no row is left");
        assert_eq!(checks.len(), 2);
        let second = checks.get(1).unwrap();
        assert_eq!((second.observation, second.rows.len()), (touch, 3));
        assert_eq!(second.worst(), Some((1, -2.75)));
        let (worst, at, w) = checks.worst().unwrap();
        assert_eq!((worst.observation, at, w), (touch, 1, -2.75));
        // Of equal |w|, the last (as a pass over every row with
        // `Iterator::max_by` finds it); untested rows are passed over.
        let mut ties = ObservationChecks::of_rows(vec![
            row(1.0, Some(2.0)),
            row(1.0, None),
            row(-1.0, Some(-2.0)),
        ]);
        assert!(ties.push(probe, 1) && ties.push(probe, 1) && ties.push(touch, 1));
        let (worst, at, w) = ties.worst().unwrap();
        assert_eq!((worst.observation, at, w), (touch, 0, -2.0));
        assert!(
            ObservationChecks::of_rows(vec![row(1.0, None)])
                .worst()
                .is_none()
        );
        assert!(checks.get(2).is_none());
        let residuals: Vec<Vec<f32>> = (checks.iter())
            .map(|c| c.rows.iter().map(|r| r.residual).collect())
            .collect();
        assert_eq!(residuals, [vec![0.3], vec![1.0, -2.0, 0.5]]);
        checks.rename(|o| ObservationRef {
            index: o.index + 10,
            ..o
        });
        let records = checks.into_records();
        assert_eq!(records.unclaimed_rows(), 0);
        let kinds: Vec<(&str, usize, usize)> = (records.iter())
            .map(|r| (r.kind, r.index, r.rows.len()))
            .collect();
        assert_eq!(
            kinds,
            [
                (ObservationKind::Probe.name(), 11, 1),
                (ObservationKind::Touch.name(), 14, 3)
            ]
        );
    }
}
