//! Every observation's numbers at the solution: its rows' whitened
//! residuals `e_j / σ_j` (weighted by a robust loss's `√w` when there is
//! one) and redundancy numbers `r_j`, which give their normalised
//! residuals `w_j = e_j / √r_j` (Baarda's w-test), held as two columns, the
//! observations and their rows, with no allocation per observation, and
//! moved as they are into calibration.json's record.

use std::borrow::Cow;

use parcal_dataset::mechanism::{ObservationRecords, RowCheck, worst_row};
use rayon::prelude::*;

use super::observation::ObservationRef;

/// One observation's numbers at the solution, borrowed from
/// [`ObservationChecks`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservationCheck<'a> {
    /// The observation.
    pub observation: ObservationRef,
    /// Its rows' residuals and redundancy numbers (which give their
    /// normalised residuals, [`RowCheck::normalised`]).
    pub rows: &'a [RowCheck],
}

/// The row of largest `|w_j|` among `rows` (the last of equals, as
/// [`worst_row`] keeps it) and that `w_j`, found on the threads: the
/// largest by `|w_j|`, then by place, whatever the threads' shares.
fn worst_of(rows: &[RowCheck]) -> Option<(usize, f64)> {
    (rows.par_iter().enumerate())
        .filter_map(|(j, row)| row.normalised().map(|w| (j, w)))
        .reduce_with(|a, b| {
            let order = a.1.abs().total_cmp(&b.1.abs()).then(a.0.cmp(&b.0));
            if order.is_gt() { a } else { b }
        })
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
    /// its row and that `w_j`: found once, so that the verdict, its
    /// reasons and snooping do not each pass over every row again.
    worst: Option<(usize, usize, f64)>,
}

impl ObservationChecks {
    /// The checks of `observations`, each with its number of rows, whose
    /// rows, in order, are `rows`: those of the observations that fit in
    /// `rows` (the caller's are all of them, with no row left), the one of
    /// largest `|w_j|` found over their rows on the threads.
    pub(crate) fn new(
        rows: Vec<RowCheck>,
        observations: impl IntoIterator<Item = (ObservationRef, usize)>,
    ) -> Self {
        let mut end = 0;
        let observations: Vec<(ObservationRef, usize)> = (observations.into_iter())
            .map_while(|(observation, count)| {
                let next = end + count;
                (next <= rows.len()).then(|| {
                    end = next;
                    (observation, next)
                })
            })
            .collect();
        let worst = worst_of(&rows[..end]).map(|(j, w)| {
            let k = observations.partition_point(|&(_, end)| end <= j);
            let start = k.checked_sub(1).map_or(0, |k| observations[k].1);
            (k, j - start, w)
        });
        Self {
            observations,
            rows,
            worst,
        }
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
        for same_kind in self.observations.chunk_by(|a, b| a.0.kind == b.0.kind) {
            let kind = Cow::Borrowed(same_kind[0].0.kind.name());
            let pushed = records.push_of_kind(
                kind,
                same_kind.iter().map(|&(observation, end)| {
                    let rows = end - start;
                    start = end;
                    (observation.index, rows)
                }),
            );
            debug_assert!(pushed, "the rows end where the observations' do");
        }
        records
    }
}

#[cfg(test)]
mod tests {
    use parcal_dataset::mechanism::UNCHECKED_REDUNDANCY;

    use super::*;
    use crate::mechanism::ObservationKind;

    /// A row whose normalised residual is its residual, `w`.
    fn tested(w: f32) -> RowCheck {
        RowCheck {
            residual: w,
            redundancy: 1.0,
        }
    }

    /// A row no other row checks.
    fn untested(residual: f32) -> RowCheck {
        RowCheck {
            residual,
            redundancy: 0.0,
        }
    }

    /// A row the record keeps untested is one the solver's checks leave
    /// untested: the two thresholds are one.
    #[test]
    fn the_records_untested_rows_are_the_solvers() {
        assert_eq!(UNCHECKED_REDUNDANCY, parcal_solver::MIN_REDUNDANCY);
        for (residual, redundancy) in [(0.5, 0.25), (-1.5, 1e-9), (0.3, 1e-11), (0.3, 0.0)] {
            let row = RowCheck {
                residual,
                redundancy,
            };
            let solver = parcal_solver::normalised_residual(residual.into(), redundancy.into());
            assert_eq!(row.normalised().is_some(), solver.is_some(), "{redundancy}");
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
        let rows = vec![tested(0.3), untested(1.0), tested(-2.75), tested(0.5)];
        let mut checks = ObservationChecks::new(rows, [(probe, 1), (touch, 3), (probe, 1)]);
        assert_eq!(checks.len(), 2, "no row is left for the third");
        let second = checks.get(1).unwrap();
        assert_eq!((second.observation, second.rows.len()), (touch, 3));
        assert_eq!(second.worst(), Some((1, -2.75)));
        let (worst, at, w) = checks.worst().unwrap();
        assert_eq!((worst.observation, at, w), (touch, 1, -2.75));
        // Of equal |w|, the last (as a pass over every row with
        // `Iterator::max_by` finds it), on any number of threads;
        // untested rows, and rows of no observation, are passed over.
        let mut ties = vec![tested(2.0), untested(1.0), tested(-2.0)];
        ties.extend((0..5000).map(|k| tested(if k % 7 == 0 { 2.0 } else { 1.0 })));
        ties.extend([tested(-2.0), tested(1.0), tested(9.0)]);
        let observations = (0..ties.len() - 1).map(|index| (ObservationRef { index, ..touch }, 1));
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            let ties = pool.install(|| ObservationChecks::new(ties.clone(), observations.clone()));
            let (worst, at, w) = ties.worst().unwrap();
            assert_eq!(
                (worst.observation.index, at, w),
                (5003, 0, -2.0),
                "{threads}"
            );
        }
        assert!(
            ObservationChecks::new(vec![untested(1.0)], [(probe, 1)])
                .worst()
                .is_none()
        );
        assert!(checks.get(2).is_none());
        let residuals: Vec<Vec<f32>> = (checks.iter())
            .map(|c| c.rows.iter().map(|r| r.residual).collect())
            .collect();
        assert_eq!(residuals, [vec![0.3], vec![1.0, -2.75, 0.5]]);
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
