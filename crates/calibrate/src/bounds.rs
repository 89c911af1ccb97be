//! The bounds of the counts a calibration or a validation is asked for
//! ([`parcal_dataset::bounds`]), checked by `parcal calibrate` and
//! `parcal validate` as they parse their flags, and the folds by
//! [`crate::cross_validation::cross_validate`] too.

use parcal_dataset::bounds::Count;

/// The iteration limit (0: the initial state only): 50 times the default
/// of Levenberg-Marquardt and of a robust loss
/// (`LEVENBERG_MARQUARDT_ITERATIONS`); each iteration
/// is a solve of the whole problem, and `--time-limit` bounds the time.
pub const MAX_ITERATIONS: Count = Count::new(
    0,
    10_000,
    "each iteration solves the whole problem: 50 times the longest default, 200",
);

/// Cross-validation folds: each is a whole calibration of the others'
/// rows, so 100 folds take 100 calibrations.
pub const FOLDS: Count = Count::new(
    2,
    100,
    "each fold is a whole calibration of the other folds' rows",
);

/// Reference rows of each session (touches of each ball) re-fitted before
/// the others are predicted: no session or ball holds more rows than the
/// largest campaign parcal simulates (`parcal_simulate::MAX_ROWS`).
pub const REFERENCE: Count = Count::new(
    1,
    10_000_000,
    "no session or ball holds more rows than the largest campaign",
);
