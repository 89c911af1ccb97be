//! Where a batch of touches is: the rooms a worker keeps from batch to
//! batch for what the mechanism reaches, and a batch of touch points as
//! the mechanism's batches take them.

use parcal_kinematics::batch_workspace::BatchWorkspace;
use parcal_kinematics::mechanism::{MechanismError, Reached, ReachedAlong};
use parcal_observe::mechanism::{Actuation, ActuationBatch, BallTouch};

use super::warm_start::WarmStart;

/// Where the touches of a batch are: a worker's, kept from batch to batch
/// (the solver's workspace), so that the mechanism writes into the room
/// the last batch left: the coordinate rows hand each touch's room back,
/// the radius rows (eq. 9, `BallTouch::radius_row`) borrow it. A batch
/// shorter than the one before leaves its extra rooms aside for the next
/// longer one (a ball's 7 touches go in batches of 4 and 3).
#[derive(Debug, Default)]
pub(crate) struct Reaches {
    /// Where they are, with `dT/dp |_q` ([`MechanismProblem::reach`](super::problem::MechanismProblem::reach)).
    pub(crate) at: Vec<Result<Reached, MechanismError>>,
    /// Where they are along a step, for a back-substitution
    /// ([`MechanismProblem::reach_along`](super::problem::MechanismProblem::reach_along)).
    pub(crate) along: Vec<Result<ReachedAlong, MechanismError>>,
    /// The rooms of `at` beyond the last batch.
    pub(super) spare_at: Vec<Result<Reached, MechanismError>>,
    /// The rooms of `along` beyond the last batch.
    pub(super) spare_along: Vec<Result<ReachedAlong, MechanismError>>,
    /// What the mechanism's batches share (the hexapod's geometry of the
    /// pass's parameters and its lanes' row order).
    pub(super) kinematics: BatchWorkspace,
}

/// A batch of touch points as a mechanism's batch takes them
/// ([`ActuationBatch`]): each one's touch's actuation and the warm start in
/// its cache, read in place (a pass hands the mechanism some hundred
/// thousand batches).
pub(super) struct TouchBatch<'b> {
    /// The touches.
    pub(super) touches: &'b [BallTouch],
    /// The batch's touches, in the order of its points.
    pub(super) order: &'b [usize],
    /// Their caches.
    pub(super) caches: &'b [WarmStart],
    /// The mechanism's [`Mechanism::warm_start_len`](parcal_kinematics::mechanism::Mechanism::warm_start_len).
    pub(super) warm_start_len: usize,
}

impl ActuationBatch for TouchBatch<'_> {
    fn len(&self) -> usize {
        self.order.len()
    }

    fn actuation(&self, k: usize) -> &Actuation {
        &self.touches[self.order[k]].at
    }

    fn start(&self, k: usize) -> Option<&[f64]> {
        self.caches[k].start(self.warm_start_len)
    }
}

/// `entries` cut or grown to `n` entries from and into `spare` (as far as
/// it holds them), so that what is written into them finds its room.
pub(super) fn batch_rooms<T>(entries: &mut Vec<T>, spare: &mut Vec<T>, n: usize) {
    if entries.len() > n {
        spare.extend(entries.drain(n..));
    }
    while entries.len() < n {
        match spare.pop() {
            Some(room) => entries.push(room),
            None => break,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Batches of 4, 3 and 4 keep the rooms: the fourth set aside and
    /// taken back, the vector never shorter than a batch it can fill.
    #[test]
    fn batch_rooms_set_aside_and_take_back() {
        let (mut entries, mut spare) = (vec![10, 11, 12, 13], Vec::new());
        batch_rooms(&mut entries, &mut spare, 3);
        assert_eq!(
            (entries.as_slice(), spare.as_slice()),
            (&[10, 11, 12][..], &[13][..])
        );
        batch_rooms(&mut entries, &mut spare, 4);
        assert_eq!(
            (entries.as_slice(), spare.len()),
            (&[10, 11, 12, 13][..], 0)
        );
        batch_rooms(&mut entries, &mut spare, 6);
        assert_eq!(entries.len(), 4, "only what is set aside is taken back");
    }
}
