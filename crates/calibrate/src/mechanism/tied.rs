//! The balls that calibrated distances tie together
//! ([`BallDistance`](parcal_observe::mechanism::BallDistance)).
//!
//! A distance couples two balls' centres, so that they cannot be
//! eliminated ball by ball. Each tied ball's centre, and its radius when
//! that has a calibration sigma, joins the global block after the
//! mechanism's parameters and the trigger height, the balls in their
//! order:
//!
//! ```text
//! g = [ p | h | c_a (3) ρ_a (1, uncertain radius only) | c_b … ]
//! ```
//!
//! and the solver holds the ball's own local block fixed. Its touches'
//! rows then see the centre (and radius) through the global block, and
//! the distances are global observations. Every other ball keeps its
//! centre in its local block, eliminated with its touches. The hexapod's
//! own calibration ties its balls in the same way.

use std::ops::Range;

use parcal_observe::mechanism::BallDistance;

/// Where each tied ball's unknowns are in the global block (module doc).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TiedBalls {
    /// For each ball, if it is tied, the global columns of its unknowns:
    /// its centre, then an uncertain radius.
    columns: Vec<Option<Range<usize>>>,
    /// The balls tied.
    count: usize,
    /// The global unknowns they add.
    unknowns: usize,
}

impl TiedBalls {
    /// The balls that `distances` tie, of the balls whose radii are
    /// unknowns where `radius_unknown` says so (one flag a ball), their
    /// unknowns from global column `first` on (module doc).
    pub(crate) fn new(distances: &[BallDistance], radius_unknown: &[bool], first: usize) -> Self {
        let mut tied = vec![false; radius_unknown.len()];
        for distance in distances {
            for b in [distance.first, distance.second] {
                if let Some(t) = tied.get_mut(b) {
                    *t = true;
                }
            }
        }
        let mut next = first;
        let mut count = 0;
        let columns = tied
            .iter()
            .zip(radius_unknown)
            .map(|(&tied, &radius)| {
                tied.then(|| {
                    let first = next;
                    next += 3 + usize::from(radius);
                    count += 1;
                    first..next
                })
            })
            .collect();
        Self {
            columns,
            count,
            unknowns: next - first,
        }
    }

    /// The global column of ball `b`'s centre's `x` (its `y`, `z` and an
    /// uncertain radius follow), `None` if it is not tied.
    pub(crate) fn column(&self, b: usize) -> Option<usize> {
        self.columns.get(b)?.as_ref().map(|columns| columns.start)
    }

    /// The number of balls tied.
    pub(crate) fn len(&self) -> usize {
        self.count
    }

    /// The number of global unknowns they add.
    pub(crate) fn unknowns(&self) -> usize {
        self.unknowns
    }

    /// Each tied ball and the global columns of its unknowns, in ball
    /// order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (usize, Range<usize>)> + '_ {
        self.columns
            .iter()
            .enumerate()
            .filter_map(|(b, columns)| Some((b, columns.clone()?)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tied_balls_follow_each_other_an_uncertain_radius_after_its_centre() {
        let distance = |first, second| BallDistance {
            first,
            second,
            distance: 100.0,
            sigma: 1e-3,
        };
        let distances = [distance(3, 1), distance(1, 3)];
        let tied = TiedBalls::new(&distances, &[false, true, false, false], 10);
        assert_eq!(tied.column(0), None);
        assert_eq!(tied.column(1), Some(10));
        assert_eq!(tied.column(2), None);
        assert_eq!(tied.column(3), Some(14));
        assert_eq!(tied.column(7), None);
        assert_eq!((tied.len(), tied.unknowns()), (2, 7));
        assert_eq!(tied.iter().collect::<Vec<_>>(), [(1, 10..14), (3, 14..17)]);
    }
}
