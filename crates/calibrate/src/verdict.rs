//! Can the result be trusted? The global test of the a-posteriori variance
//! factor, and the verdict of a run.
//!
//! With `Ω` the weighted sum of squares at the solution (every observation
//! whitened by its a priori covariance; the priors count as observations)
//! and `r = m − n` the redundancy (rows of data, global observations and
//! priors, less the unknowns), the a-posteriori variance factor is
//! `s₀² = Ω / r`. If the model and the a priori sigmas are right, `Ω ~
//! χ²(r)` (Koch, "Parameter Estimation and Hypothesis Testing in Linear
//! Models", 1999, section 4.3; Förstner and Wrobel, "Photogrammetric
//! Computer Vision", 2016, section 4.6.8). The test is two-sided at level
//! `α`: `Ω` above `χ²_{1−α/2}(r)` says the data do not fit their stated
//! noise (a blunder, a wrong radius, a model error); `Ω` below
//! `χ²_{α/2}(r)` says the fit is better than the stated noise allows (the
//! repeatabilities are pessimistic and the sigmas overstated).

use rayon::prelude::*;
use statrs::distribution::{ChiSquared, ContinuousCDF};

use parcal_solver::{Problem, Status};

/// The default level of the global test.
pub const GLOBAL_TEST_LEVEL: f64 = 0.05;

/// Where `Ω` falls.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Outcome {
    /// Inside the two-sided interval.
    Consistent,
    /// Above it: the data do not fit their stated noise.
    TooLarge,
    /// Below it: the fit is better than the stated noise allows.
    TooSmall,
}

impl Outcome {
    /// Its name in calibration.json: `consistent`, `too large`, `too small`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Consistent => "consistent",
            Self::TooLarge => "too large",
            Self::TooSmall => "too small",
        }
    }
}

/// The global test of a run (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct GlobalTest {
    /// `Ω`, the weighted sum of squares, priors included.
    pub cost: f64,
    /// `r = m − n`.
    pub redundancy: usize,
    /// `s₀² = Ω / r`.
    pub variance_factor: f64,
    /// The test's level `α`.
    pub level: f64,
    /// `χ²_{α/2}(r) / r` and `χ²_{1−α/2}(r) / r`: the interval of `s₀²`.
    pub interval: (f64, f64),
    /// Where `Ω` falls.
    pub outcome: Outcome,
}

impl GlobalTest {
    /// The test of `cost` with `redundancy` degrees of freedom at `level`;
    /// `None` without redundancy (as many unknowns as rows).
    pub fn new(cost: f64, redundancy: usize, level: f64) -> Option<Self> {
        let chi = ChiSquared::new(redundancy as f64).ok()?;
        let r = redundancy as f64;
        let interval = (
            chi.inverse_cdf(level / 2.0) / r,
            chi.inverse_cdf(1.0 - level / 2.0) / r,
        );
        let variance_factor = cost / r;
        let outcome = if variance_factor > interval.1 {
            Outcome::TooLarge
        } else if variance_factor < interval.0 {
            Outcome::TooSmall
        } else {
            Outcome::Consistent
        };
        Some(Self {
            cost,
            redundancy,
            variance_factor,
            level,
            interval,
            outcome,
        })
    }
}

/// Rows and unknowns of a solved problem with `points` points and
/// `global_rows` global observation rows: `R` rows per point, the global
/// rows, and one row per dimension of every prior with information (a
/// global prior counts the coordinates with positive information); a
/// fixed group has neither unknowns nor prior rows.
pub fn rows_and_unknowns<const C: usize, const P: usize, const R: usize, Pr>(
    problem: &Pr,
    points: usize,
    global_rows: usize,
) -> (usize, usize)
where
    Pr: Problem<C, P, R>,
{
    let g = problem.global_size();
    let global_prior = problem.global_prior().map_or(0, |prior| {
        (0..g).filter(|&k| prior.information[(k, k)] > 0.0).count()
    });
    let free_groups: Vec<usize> = (0..problem.n_groups())
        .filter(|&k| !problem.group_is_fixed(k))
        .collect();
    // A group prior's rows: its informed values (a ball's radius prior
    // without a centre prior informs one of its four).
    let group_priors: usize = free_groups
        .iter()
        .filter_map(|&k| problem.group_prior(k))
        .map(|prior| (0..C).filter(|&c| prior.information[(c, c)] > 0.0).count())
        .sum();
    // Counted on the threads: a point's prior may look at its touch, and
    // there are 10^6 of them in the data's order, not the points'.
    let point_priors = (0..points)
        .into_par_iter()
        .filter(|&i| P > 0 && problem.point_prior(i).is_some())
        .count();
    let rows = R * points + global_rows + global_prior + group_priors + P * point_priors;
    let unknowns = g + C * free_groups.len() + P * points;
    (rows, unknowns)
}

/// Whether a run that ended with `status` is at a least-squares minimum,
/// the one state its tests may judge: converged. Elsewhere (an iteration
/// or time limit, a failure) the residuals are not those of the estimate:
/// at the initial state every contact carries the whole of the design's
/// error, and its normalised residuals, the global test, the tests of
/// systematic errors and the prior-data conflicts would blame good
/// observations. So the checks ([`crate::reliability::Reliability`], the
/// systematic tests and sensitivities, [`crate::conflict`], the balls'
/// misfits) are made only when this holds; a run where it does not is
/// rejected for not converging and names no blunder, and data snooping
/// removes nothing from it.
pub fn at_minimum(status: &Status) -> bool {
    matches!(status, Status::Converged)
}

/// A run's verdict: accepted when it converged, its global test does not
/// say the data misfit their noise, and no observation fails the test of
/// data snooping ([`crate::reliability::Reliability::fails_snooping`]: a
/// blunder that `--snoop` would remove).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Verdict {
    /// Whether the result may be used.
    pub accepted: bool,
    /// The global test, when the run converged with redundancy.
    pub global_test: Option<GlobalTest>,
}

impl Verdict {
    /// The verdict of a run that ended with `status` and, when it
    /// converged, whose global test is `global_test` and whose largest
    /// normalised residual fails the test of data snooping if `outlier`.
    pub fn new(status: &Status, global_test: Option<GlobalTest>, outlier: bool) -> Self {
        let converged = at_minimum(status);
        let fits = global_test.is_none_or(|t| t.outcome != Outcome::TooLarge);
        Self {
            accepted: converged && fits && !outlier,
            global_test: global_test.filter(|_| converged),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interval_is_the_chi_square_quantiles() {
        // χ²(100): 2.5 % and 97.5 % quantiles 74.222 and 129.561.
        let t = GlobalTest::new(100.0, 100, 0.05).unwrap();
        assert!((t.interval.0 * 100.0 - 74.222).abs() < 1e-3);
        assert!((t.interval.1 * 100.0 - 129.561).abs() < 1e-3);
        assert_eq!(t.outcome, Outcome::Consistent);
        assert_eq!(
            GlobalTest::new(130.0, 100, 0.05).unwrap().outcome,
            Outcome::TooLarge
        );
        assert_eq!(
            GlobalTest::new(74.0, 100, 0.05).unwrap().outcome,
            Outcome::TooSmall
        );
        assert!(GlobalTest::new(1.0, 0, 0.05).is_none());
    }
}
