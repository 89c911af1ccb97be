//! What a caller sees of a run while it goes on: each history record, and
//! each new iterate with its groups' costs, at which it may stop the run
//! (as Ceres' `IterationCallback` may end a solve).

use crate::problem::State;
use crate::solution::IterationRecord;

/// An iterate the solver has just evaluated (its reduced system is built),
/// before the step there is computed.
pub struct Iterate<'a, const C: usize, const P: usize, T> {
    /// The iterate.
    pub state: &'a State<C, P>,
    /// Linear solves before it (0: the initial state).
    pub solves: usize,
    /// Its cost (data and priors; with a robust loss, the loss).
    pub cost: f64,
    /// The same of the iterate before it (`None` at the initial state).
    pub previous_cost: Option<f64>,
    /// Each group's data cost `Σ |r_i|²` over its points (whitened: a
    /// goodness-of-fit statistic per group).
    pub group_costs: &'a [f64],
    /// The points' caches as its evaluation left them.
    pub caches: &'a [T],
}

impl<const C: usize, const P: usize, T> Iterate<'_, C, P, T> {
    /// `|cost − previous cost| / cost`: how far the iteration still moves
    /// the cost (infinite at the initial state).
    pub fn relative_change(&self) -> f64 {
        self.previous_cost.map_or(f64::INFINITY, |previous| {
            (previous - self.cost).abs() / self.cost
        })
    }
}

/// A [`Monitor`]'s answer to an iterate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Decision {
    /// Go on.
    Continue,
    /// End the run at this iterate with
    /// [`Status::Stopped`](crate::Status::Stopped).
    Stop,
}

/// Watches a run of [`solve_with_caches`](crate::solve_with_caches). Any
/// `FnMut(&IterationRecord)` is a monitor that records and never stops.
pub trait Monitor<const C: usize, const P: usize, T> {
    /// Sees each history record as it is made.
    fn record(&mut self, record: &IterationRecord);

    /// Sees each new iterate once (the initial state, then each iterate a
    /// step led to; not an iterate the iteration limit ends the run at).
    fn inspect(&mut self, _iterate: &Iterate<'_, C, P, T>) -> Decision {
        Decision::Continue
    }
}

impl<const C: usize, const P: usize, T, F> Monitor<C, P, T> for F
where
    F: FnMut(&IterationRecord),
{
    fn record(&mut self, record: &IterationRecord) {
        self(record)
    }
}
