//! A touch point's cache between passes: the warm start of the pose its
//! touch last reached, where its next forward kinematics starts.

use super::data::MAX_WARM_START;

/// A point's cache: the warm start of the pose its touch last reached
/// (none before its first evaluation and for every other point), where
/// its next forward kinematics starts
/// ([`Mechanism::warm_start`](parcal_kinematics::mechanism::Mechanism::warm_start));
/// held inline, so that a million touches' caches make no allocation,
/// its length the mechanism's and none a NaN first value, so that it
/// holds nothing else.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct WarmStart {
    values: [f64; MAX_WARM_START],
}

impl Default for WarmStart {
    /// None.
    fn default() -> Self {
        Self {
            values: [f64::NAN; MAX_WARM_START],
        }
    }
}

impl WarmStart {
    /// The cache of the warm start `start`; none for one of more values
    /// than it holds (which [`MechanismData::validate`] refuses), or that
    /// is not finite, whose next evaluation then starts from the
    /// mechanism's start pose.
    pub(crate) fn of(start: &[f64]) -> Self {
        let mut last = Self::default();
        // `x · 0` is 0 for a finite `x` and NaN otherwise: one sum, without
        // a branch a value (a million touches' caches twice an iteration).
        if let Some(room) = last.values.get_mut(..start.len())
            && start.iter().fold(0.0, |sum, v| sum + v * 0.0) == 0.0
        {
            room.copy_from_slice(start);
        }
        last
    }

    /// The warm start of a mechanism whose warm starts have `len` values,
    /// if any.
    pub(super) fn start(&self, len: usize) -> Option<&[f64]> {
        (!self.values[0].is_nan())
            .then(|| self.values.get(..len))
            .flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warm_start_cache_holds_a_finite_start_that_fits() {
        // A delta's three values and a hexapod's seven come back at their
        // mechanism's length; a start too long, not finite or never set
        // is none.
        let start = [1.0, -2.0, 3.5, 0.1, 0.2, 0.3, 0.9];
        for len in [3, 7] {
            let cache = WarmStart::of(&start[..len]);
            assert_eq!(cache.start(len), Some(&start[..len]));
        }
        assert_eq!(WarmStart::default().start(3), None);
        assert_eq!(WarmStart::of(&[0.0; MAX_WARM_START + 1]).start(3), None);
        assert_eq!(WarmStart::of(&[1.0, f64::NAN, 2.0]).start(3), None);
        assert_eq!(
            WarmStart::of(&[-1.0, 2.0, f64::NEG_INFINITY]).start(3),
            None
        );
        assert_eq!(WarmStart::of(&start).start(MAX_WARM_START + 1), None);
        assert_eq!(size_of::<WarmStart>(), 8 * MAX_WARM_START);
    }
}
