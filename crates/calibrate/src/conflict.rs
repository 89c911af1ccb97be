//! Prior-data conflict: after the solve, does the a priori knowledge
//! contradict what the data say?
//!
//! For a prior `N(m, Sigma_0)` and a posterior estimate `p^` with covariance
//! `Sigma`, the innovation `d = p^ - m` has covariance `Sigma_0 - Sigma` when
//! prior and data agree (the estimate is the data-and-prior blend). Two tests:
//!
//! - per parameter, the normalised innovation
//!   `z_k = d_k / sqrt(Sigma_0,kk - Sigma_kk)` against N(0, 1);
//! - globally, `chi2 = d^T Sigma_0^-1 d` against chi-square(n), whose
//!   expectation under agreement, `n - tr(Sigma_0^-1 Sigma)`, is below `n`,
//!   so the test is conservative.
//!
//! A prior is contradicted when a value has `|z|` beyond the family-wise
//! two-sided 0.1 % quantile over the `n` values the data inform
//! (Bonferroni, `z_{1 − 0.001 / (2 n)}`: 3.29 for one value, 4.17 for 33,
//! 5.79 for 142857, so that a clean run of any size names a value with
//! probability at most 0.1 %, as data snooping judges the observations) or
//! the global chi-square is beyond its 99.9 % quantile
//! (`parcal_report::sentences` words it).

use parcal_observe::KinematicPrior;
use statrs::distribution::{ChiSquared, ContinuousCDF, Normal};

/// Upper tail probability of the global test, and the family-wise level of
/// the values' tests.
const TAIL: f64 = 1e-3;
/// A value whose posterior variance is within this fraction of its prior
/// variance is not informed by the data: its estimate is the prior mean up
/// to rounding, and nothing can contradict it.
const UNINFORMED: f64 = 1e-9;

/// An a priori value the estimate contradicts.
#[derive(Debug, Clone, PartialEq)]
pub struct Innovation {
    /// The value's name (`l_1`, `centre b00001.x`).
    pub name: String,
    /// Estimate minus prior mean.
    pub difference: f64,
    /// Normalised innovation `z`.
    pub z: f64,
}

/// The outcome of the conflict tests for one group of priors.
#[derive(Debug, Clone, PartialEq)]
pub struct ConflictTest {
    /// What was tested (e.g. "kinematic parameters", "ball centres").
    pub what: String,
    /// `Σ (x̂ − m)ᵀ Σ_prior⁻¹ (x̂ − m)` of the estimate against the prior.
    pub chi_square: f64,
    /// Its degrees of freedom (the number of values tested).
    pub degrees_of_freedom: usize,
    /// The 99.9 % quantile of chi-square(degrees of freedom).
    pub limit: f64,
    /// The number of values the data inform (those with a `z`): the
    /// family of the values' tests.
    pub informed: usize,
    /// The contradicted values, the largest `|z|` first.
    pub offenders: Vec<Innovation>,
}

impl ConflictTest {
    /// Builds the test from innovations `d`, the prior variances, the
    /// posterior variances and the prior chi-square `d^T Sigma_0^-1 d`;
    /// `name(k)` names value `k`, called for the offenders alone (a
    /// million ball centres have a handful).
    pub fn new(
        what: &str,
        name: impl Fn(usize) -> String,
        differences: &[f64],
        prior_variances: &[f64],
        posterior_variances: &[f64],
        chi_square: f64,
    ) -> Self {
        // The variance the data take off value `k`'s prior: the data inform
        // it unless its posterior variance is its prior's up to `UNINFORMED`.
        let variance = |k: usize| prior_variances[k] - posterior_variances[k];
        let informs = |k: &usize| variance(*k) > UNINFORMED * prior_variances[*k];
        let degrees_of_freedom = differences.len();
        let informed = (0..degrees_of_freedom).filter(informs).count();
        let z_limit = z_limit(informed);
        let mut offenders: Vec<Innovation> = (0..degrees_of_freedom)
            .filter(informs)
            .filter_map(|k| {
                let z = differences[k] / variance(k).sqrt();
                (z.abs() > z_limit).then(|| Innovation {
                    name: name(k),
                    difference: differences[k],
                    z,
                })
            })
            .collect();
        offenders.sort_by(|a, b| b.z.abs().total_cmp(&a.z.abs()));
        Self {
            what: what.to_string(),
            chi_square,
            degrees_of_freedom,
            limit: chi_square_quantile(degrees_of_freedom, 1.0 - TAIL),
            informed,
            offenders,
        }
    }

    /// The `|z|` beyond which a value counts as contradicted (module doc).
    pub fn z_limit(&self) -> f64 {
        z_limit(self.informed)
    }

    /// Whether the prior contradicts the data.
    pub fn conflicts(&self) -> bool {
        self.chi_square > self.limit || !self.offenders.is_empty()
    }
}

/// The two-sided quantile at family-wise level 0.1 % over `informed`
/// values (Bonferroni, module doc).
fn z_limit(informed: usize) -> f64 {
    let tests = informed.max(1) as f64;
    Normal::new(0.0, 1.0)
        .expect("a standard normal")
        .inverse_cdf(1.0 - TAIL / (2.0 * tests))
}

/// The paper's diagonal prior against the design tolerances it stands for
/// ([`paper_prior_consistency`]), when it is over-confident.
#[derive(Debug, Clone, PartialEq)]
pub struct PaperPriorInconsistency {
    /// `tr(Sigma_p^-1 Sigma_t)`: the expected chi-square, under the paper
    /// prior, of a machine built within the tolerances.
    pub expected_chi_square: f64,
    /// The number of parameters.
    pub degrees_of_freedom: usize,
    /// The 99.9 % quantile of chi-square(degrees of freedom).
    pub limit: f64,
    /// The parameters whose tolerance-implied sigma exceeds the paper's by
    /// more than 3 times, the largest ratio first: (index, tolerance-implied
    /// sigma, paper sigma), mm.
    pub understated: Vec<(usize, f64, f64)>,
}

/// Does the paper's diagonal prior express the design tolerances it stands
/// for? A machine built within tolerance has canonical parameters with the
/// propagated covariance `Sigma_t` (docs/paper-scenario.md section 4); under the paper prior
/// `Sigma_p` their chi-square then has expectation `tr(Sigma_p^-1 Sigma_t)`,
/// 33 if the two agree. `Some` when that expectation is beyond the 99.9 %
/// quantile of chi-square(33).
pub fn paper_prior_consistency(
    paper: &KinematicPrior,
    tolerances: &KinematicPrior,
) -> Option<PaperPriorInconsistency> {
    let expected = (paper.information() * tolerances.covariance()).trace();
    let n = paper.mean().len();
    let limit = chi_square_quantile(n, 1.0 - TAIL);
    if expected <= limit {
        return None;
    }
    let (paper_sigma, tolerance_sigma) = (paper.sigma(), tolerances.sigma());
    let mut understated: Vec<(usize, f64, f64)> = (0..n)
        .map(|k| (k, tolerance_sigma[k], paper_sigma[k]))
        .filter(|(_, tolerance, paper)| *tolerance > 3.0 * paper)
        .collect();
    understated.sort_by(|a, b| (b.1 / b.2).total_cmp(&(a.1 / a.2)));
    Some(PaperPriorInconsistency {
        expected_chi_square: expected,
        degrees_of_freedom: n,
        limit,
        understated,
    })
}

/// Quantile of chi-square(`dof`) at probability `p` (statrs' inverse CDF);
/// NaN for `dof = 0`.
pub fn chi_square_quantile(dof: usize, p: f64) -> f64 {
    ChiSquared::new(dof as f64).map_or(f64::NAN, |chi| chi.inverse_cdf(p))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_tables() {
        // chi-square(33) 99.9 %: 63.870, 0.1 %: 13.431; chi-square(3) 99.9 %: 16.266.
        assert!((chi_square_quantile(33, 0.999) - 63.870).abs() < 1e-3);
        assert!((chi_square_quantile(3, 0.999) - 16.266).abs() < 1e-3);
        assert!((chi_square_quantile(33, 0.001) - 13.431).abs() < 1e-3);
    }

    #[test]
    fn flags_a_contradicted_prior_by_name() {
        let names = |k: usize| ["a", "b", "c"][k].to_string();
        let agree = ConflictTest::new(
            "test",
            names,
            &[0.1, -0.05, 0.0],
            &[0.01; 3],
            &[0.001; 3],
            1.25,
        );
        assert!(!agree.conflicts());
        let conflict = ConflictTest::new(
            "test",
            names,
            &[0.1, -1.0, 0.0],
            &[0.01; 3],
            &[0.001; 3],
            101.0,
        );
        let offenders = &conflict.offenders;
        assert_eq!(offenders.len(), 1);
        assert_eq!(offenders[0].name, "b");
        assert!((offenders[0].z + 10.54).abs() < 0.01);
    }

    #[test]
    fn values_the_data_do_not_inform_are_not_tested() {
        // A prior far tighter than the data: the posterior variance is the
        // prior's up to rounding, and the estimate moves by rounding only.
        let names = |k: usize| ["a", "b"][k].to_string();
        let prior = [1e-18; 2];
        let posterior = [1e-18 * (1.0 - 1e-13); 2];
        let test = ConflictTest::new("test", names, &[1e-17, -1e-17], &prior, &posterior, 2e-16);
        assert_eq!(test.informed, 0);
        assert!(!test.conflicts());
    }

    #[test]
    fn the_limit_is_family_wise_over_the_values_the_data_inform() {
        // Many values: |z| = 4.5 is beyond one value's 3.29 but within the
        // family-wise limit of 142857 values (5.79); |z| = 6 is beyond it.
        let n = 142_857;
        let names = |k: usize| format!("radius {k}");
        let mut differences = vec![0.0; n];
        differences[7] = 4.5;
        differences[8] = -6.0;
        let test = ConflictTest::new(
            "ball radii",
            names,
            &differences,
            &vec![2.0; n],
            &vec![1.0; n],
            n as f64,
        );
        assert!((test.z_limit() - 5.7909).abs() < 1e-3, "{}", test.z_limit());
        assert_eq!(test.informed, n);
        assert_eq!(test.offenders.len(), 1);
        assert_eq!(test.offenders[0].name, "radius 8");
        // One value: the two-sided 0.1 % quantile itself.
        let one = ConflictTest::new("one", |_| "a".to_string(), &[4.5], &[2.0], &[1.0], 20.25);
        assert!((one.z_limit() - 3.2905).abs() < 1e-3);
        assert_eq!(one.offenders.len(), 1);
    }
}
