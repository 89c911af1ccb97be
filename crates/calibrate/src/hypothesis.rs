//! The terms the observation tests share (Baarda's data snooping and
//! reliability): the family-wise level of data snooping and its limit of
//! removals, the critical value of a family of tests (Bonferroni), the
//! power and the minimal detectable bias.

use statrs::distribution::{ContinuousCDF, Normal};

/// The default family-wise level of data snooping.
pub const SNOOPING_LEVEL: f64 = 0.05;
/// The default limit of removals.
pub const MAX_REMOVALS: usize = 10;
/// Power `1 − β` of the minimal detectable bias.
pub const POWER: f64 = 0.8;

/// The critical value of data snooping over `tests` tests at family-wise
/// level `level` (Bonferroni): `z_{1 − level / (2 tests)}`.
pub fn critical_value(level: f64, tests: usize) -> f64 {
    standard_normal().inverse_cdf(1.0 - level / (2.0 * tests.max(1) as f64))
}

/// The minimal detectable bias of an observation of redundancy `r`, in
/// units of its standard deviation, for a test at `level` (two-sided) with
/// power [`POWER`]: `(z_{1−level/2} + z_{POWER}) / √r`.
pub fn minimal_detectable_bias(r: f64, level: f64) -> f64 {
    let normal = standard_normal();
    (normal.inverse_cdf(1.0 - level / 2.0) + normal.inverse_cdf(POWER)) / r.sqrt()
}

/// The estimated gross error of an observation tested by its normalised
/// residual `w` over redundancy `r`, in units of the standard deviation of
/// what the test sees: `∇̂ = w / √r` (Förstner and Wrobel, "Photogrammetric
/// Computer Vision", 2016, section 4.6.4: of a single row, `e / r`). A
/// contact of three coordinate rows is tested as one observation along its
/// one direction of residual, `r` the sum over its rows; a row of a pose
/// or a point is tested alone, `r` its own.
pub fn estimated_gross_error(w: f64, r: f64) -> f64 {
    w / r.sqrt()
}

fn standard_normal() -> Normal {
    Normal::new(0.0, 1.0).expect("a standard normal")
}
