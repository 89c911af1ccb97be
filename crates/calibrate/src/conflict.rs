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

/// One a priori value compared with the estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct Innovation {
    /// What is tested (`kinematic parameters`, `ball centres`).
    pub name: String,
    /// Estimate minus prior mean.
    pub difference: f64,
    /// Normalised innovation `z`; `None` when the data do not inform the
    /// value (its posterior variance is its prior's up to `1e-9`).
    pub z: Option<f64>,
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
    /// Every tested value, in input order.
    pub innovations: Vec<Innovation>,
}

impl ConflictTest {
    /// Builds the test from innovations `d`, the prior variances, the
    /// posterior variances and the prior chi-square `d^T Sigma_0^-1 d`.
    pub fn new(
        what: &str,
        names: impl IntoIterator<Item = String>,
        differences: &[f64],
        prior_variances: &[f64],
        posterior_variances: &[f64],
        chi_square: f64,
    ) -> Self {
        let innovations = names
            .into_iter()
            .zip(differences)
            .zip(prior_variances.iter().zip(posterior_variances))
            .map(|((name, &difference), (&prior, &posterior))| {
                let variance = prior - posterior;
                Innovation {
                    name,
                    difference,
                    z: (variance > UNINFORMED * prior).then(|| difference / variance.sqrt()),
                }
            })
            .collect::<Vec<_>>();
        let degrees_of_freedom = innovations.len();
        Self {
            what: what.to_string(),
            chi_square,
            degrees_of_freedom,
            limit: chi_square_quantile(degrees_of_freedom, 1.0 - TAIL),
            innovations,
        }
    }

    /// The number of values the data inform (those with a `z`).
    pub fn informed(&self) -> usize {
        self.innovations.iter().filter(|i| i.z.is_some()).count()
    }

    /// The `|z|` beyond which a value counts as contradicted: the two-sided
    /// quantile at family-wise level 0.1 % over the [`informed`](Self::informed)
    /// values (Bonferroni, module doc).
    pub fn z_limit(&self) -> f64 {
        let tests = self.informed().max(1) as f64;
        Normal::new(0.0, 1.0)
            .expect("a standard normal")
            .inverse_cdf(1.0 - TAIL / (2.0 * tests))
    }

    /// The contradicted priors, the largest `|z|` first.
    pub fn offenders(&self) -> Vec<&Innovation> {
        let limit = self.z_limit();
        let mut out: Vec<&Innovation> = self
            .innovations
            .iter()
            .filter(|i| i.z.is_some_and(|z| z.abs() > limit))
            .collect();
        out.sort_by(|a, b| z_size(b).total_cmp(&z_size(a)));
        out
    }

    /// Whether the prior contradicts the data.
    pub fn conflicts(&self) -> bool {
        self.chi_square > self.limit || !self.offenders().is_empty()
    }
}

/// `|z|` of an innovation, 0 when the data do not inform it.
fn z_size(innovation: &Innovation) -> f64 {
    innovation.z.map_or(0.0, f64::abs)
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
        let names = ["a", "b", "c"].map(String::from);
        let agree = ConflictTest::new(
            "test",
            names.clone(),
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
        let offenders = conflict.offenders();
        assert_eq!(offenders.len(), 1);
        assert_eq!(offenders[0].name, "b");
        assert!((offenders[0].z.unwrap() + 10.54).abs() < 0.01);
    }

    #[test]
    fn values_the_data_do_not_inform_are_not_tested() {
        // A prior far tighter than the data: the posterior variance is the
        // prior's up to rounding, and the estimate moves by rounding only.
        let names = ["a", "b"].map(String::from);
        let prior = [1e-18; 2];
        let posterior = [1e-18 * (1.0 - 1e-13); 2];
        let test = ConflictTest::new("test", names, &[1e-17, -1e-17], &prior, &posterior, 2e-16);
        assert!(test.innovations.iter().all(|i| i.z.is_none()));
        assert!(!test.conflicts());
    }

    #[test]
    fn the_limit_is_family_wise_over_the_values_the_data_inform() {
        // Many values: |z| = 4.5 is beyond one value's 3.29 but within the
        // family-wise limit of 142857 values (5.79); |z| = 6 is beyond it.
        let n = 142_857;
        let names = (0..n).map(|k| format!("radius {k}"));
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
        let offenders = test.offenders();
        assert_eq!(offenders.len(), 1);
        assert_eq!(offenders[0].name, "radius 8");
        // One value: the two-sided 0.1 % quantile itself.
        let one = ConflictTest::new("one", ["a".to_string()], &[4.5], &[2.0], &[1.0], 20.25);
        assert!((one.z_limit() - 3.2905).abs() < 1e-3);
        assert_eq!(one.offenders().len(), 1);
    }
}
