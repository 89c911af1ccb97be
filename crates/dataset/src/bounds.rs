//! Bounds on the counts a user types or a file holds: the one way parcal
//! bounds a count before the work that it sizes starts, so that a count
//! given by mistake (`--pool 18446744073709551615`) is an error naming it,
//! its bounds and why, rather than an abort of the allocator, a panic or a
//! run that never ends.
//!
//! Each crate states the bounds of its own counts as [`Count`] constants
//! (the reason of the upper bound in the doc comment and in
//! [`Count::reason`]); its functions check them with [`Count::check`] and
//! products of counts with [`check_product`]; the command line parses its
//! flags with them (`crates/cli/src/bounds.rs`). `docs/reliability.md`
//! tabulates them.

/// The bounds of one count: `min ..= max`, and why `max`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Count {
    /// The smallest value that makes sense.
    pub min: usize,
    /// The largest value accepted.
    pub max: usize,
    /// Why `max`, as a clause for the message: what it costs at the bound.
    pub reason: &'static str,
}

impl Count {
    /// The bounds `min ..= max`, `max` for `reason`.
    pub const fn new(min: usize, max: usize, reason: &'static str) -> Self {
        Self { min, max, reason }
    }

    /// `value` if it is within the bounds, else a message naming `name`
    /// (a flag such as `--pool`, or a field), the value, the bounds and
    /// the reason.
    pub fn check(&self, name: &str, value: usize) -> Result<usize, String> {
        if (self.min..=self.max).contains(&value) {
            Ok(value)
        } else {
            Err(self.refusal(name, &value.to_string()))
        }
    }

    /// The message refusing `value` (as typed) for `name`.
    pub fn refusal(&self, name: &str, value: &str) -> String {
        format!(
            "{name} {value}: must be a whole number from {} to {} ({})",
            self.min, self.max, self.reason
        )
    }
}

/// The sessions of instrument measurements a dataset holds: each adds
/// its instrument frame (and, re-homed, six leg offsets) to the dense
/// global block every iteration solves, whose memory grows as the square
/// of their number and its factorisation as the cube (300 sessions of 6
/// poses take about 100 s and 480 MB).
pub const SESSIONS: Count = Count::new(
    1,
    100,
    "each session adds up to twelve unknowns to the dense block every iteration solves",
);

/// The product of `counts` (name, value) if it is at most `max` (checked
/// arithmetic: an overflow is beyond it), else a message naming every
/// factor, the bound and `reason`.
pub fn check_product(counts: &[(&str, usize)], max: usize, reason: &str) -> Result<usize, String> {
    counts
        .iter()
        .try_fold(1usize, |product, (_, n)| product.checked_mul(*n))
        .filter(|&product| product <= max)
        .ok_or_else(|| {
            let factors: Vec<String> = counts
                .iter()
                .map(|(name, n)| format!("{name} {n}"))
                .collect();
            format!("{} make more than {max} {reason}", factors.join(" x "))
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_count_outside_its_bounds_is_named_with_them() {
        let count = Count::new(2, 100, "each one costs a calibration");
        assert_eq!(count.check("--folds", 2), Ok(2));
        assert_eq!(count.check("--folds", 100), Ok(100));
        assert_eq!(
            count.check("--folds", usize::MAX).unwrap_err(),
            format!(
                "--folds {}: must be a whole number from 2 to 100 (each one costs a calibration)",
                usize::MAX
            )
        );
        assert!(count.check("--folds", 1).is_err());
    }

    #[test]
    fn a_product_beyond_the_bound_or_overflowing_is_refused() {
        assert_eq!(
            check_product(&[("a", 1000), ("b", 7)], 7000, "rows"),
            Ok(7000)
        );
        let error = check_product(&[("a", usize::MAX), ("b", 2)], 10, "rows").unwrap_err();
        assert_eq!(
            error,
            format!("a {} x b 2 make more than 10 rows", usize::MAX)
        );
        assert!(check_product(&[("a", 11)], 10, "rows").is_err());
    }
}
