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
//! A warning names the parameters with `|z|` beyond the two-sided 0.1 %
//! quantile (3.29) and the global chi-square beyond its 99.9 % quantile.

use parcal_kinematics::PARAM_NAMES;
use parcal_observe::KinematicPrior;

/// |z| beyond which one prior counts as contradicted (two-sided 0.1 %).
pub const Z_LIMIT: f64 = 3.29;
/// Upper tail probability of the global test.
const TAIL: f64 = 1e-3;

/// One a priori value compared with the estimate.
#[derive(Debug, Clone, PartialEq)]
pub struct Innovation {
    /// What is tested (`kinematic parameters`, `ball centres`).
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
                // Guard: the posterior variance cannot exceed the prior's; a
                // floor keeps z finite where the data add nothing.
                let variance = (prior - posterior).max(1e-12 * prior);
                Innovation {
                    name,
                    difference,
                    z: difference / variance.sqrt(),
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

    /// The contradicted priors, the largest `|z|` first.
    pub fn offenders(&self) -> Vec<&Innovation> {
        let mut out: Vec<&Innovation> = self
            .innovations
            .iter()
            .filter(|i| i.z.abs() > Z_LIMIT)
            .collect();
        out.sort_by(|a, b| b.z.abs().total_cmp(&a.z.abs()));
        out
    }

    /// Whether the prior contradicts the data.
    pub fn conflicts(&self) -> bool {
        self.chi_square > self.limit || !self.offenders().is_empty()
    }

    /// A one-paragraph warning naming the worst offenders, or `None`.
    pub fn warning(&self) -> Option<String> {
        if !self.conflicts() {
            return None;
        }
        let offenders = self.offenders();
        let listed: Vec<String> = offenders
            .iter()
            .take(8)
            .map(|i| format!("{} (z = {:+.1})", i.name, i.z))
            .collect();
        let more = offenders.len().saturating_sub(listed.len());
        Some(format!(
            "the prior on the {} contradicts the data: chi-square {:.1} for {} (99.9% limit {:.1}); {} of {} values beyond |z| = {Z_LIMIT}{}{}",
            self.what,
            self.chi_square,
            self.degrees_of_freedom,
            self.limit,
            offenders.len(),
            self.innovations.len(),
            if listed.is_empty() {
                String::new()
            } else {
                format!(": {}", listed.join(", "))
            },
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            },
        ))
    }
}

/// Does the paper's diagonal prior express the design tolerances it stands
/// for? A machine built within tolerance has canonical parameters with the
/// propagated covariance `Sigma_t` (spec section 4); under the paper prior
/// `Sigma_p` their chi-square then has expectation `tr(Sigma_p^-1 Sigma_t)`,
/// 33 if the two agree. Returns a warning naming the parameters whose
/// tolerance-implied sigma exceeds the paper's by more than 3 times, when
/// that expectation is beyond the 99.9 % quantile of chi-square(33).
pub fn paper_prior_consistency(
    paper: &KinematicPrior,
    tolerances: &KinematicPrior,
) -> Option<String> {
    let expected = (paper.information() * tolerances.covariance()).trace();
    let n = paper.mean().len();
    let limit = chi_square_quantile(n, 1.0 - TAIL);
    if expected <= limit {
        return None;
    }
    let (paper_sigma, tolerance_sigma) = (paper.sigma(), tolerances.sigma());
    let mut understated: Vec<(usize, f64)> = (0..n)
        .map(|k| (k, tolerance_sigma[k] / paper_sigma[k]))
        .filter(|(_, ratio)| *ratio > 3.0)
        .collect();
    understated.sort_by(|a, b| b.1.total_cmp(&a.1));
    let listed: Vec<String> = understated
        .iter()
        .map(|&(k, ratio)| {
            format!(
                "{} ({:.3} vs {:.3} mm, x{ratio:.1})",
                PARAM_NAMES[k], tolerance_sigma[k], paper_sigma[k]
            )
        })
        .collect();
    Some(format!(
        "the paper-form prior is over-confident: a machine within the design tolerances has an expected chi-square of {expected:.0} for {n} under it (99.9% limit {limit:.1}), because the canonical frames tilt with the joints; the tolerances imply larger sigmas for {}. Use the propagated prior.",
        listed.join(", ")
    ))
}

/// Quantile of chi-square(`dof`) at probability `p`, by the Wilson-Hilferty
/// cube approximation (relative error below 1 % for dof >= 3 at the tails
/// used here).
pub fn chi_square_quantile(dof: usize, p: f64) -> f64 {
    let k = dof as f64;
    let z = normal_quantile(p);
    let h = 2.0 / (9.0 * k);
    k * (1.0 - h + z * h.sqrt()).powi(3)
}

/// Standard normal quantile (Acklam's rational approximation, relative error
/// below 1.2e-9).
fn normal_quantile(p: f64) -> f64 {
    const A: [f64; 6] = [
        -3.969683028665376e1,
        2.209460984245205e2,
        -2.759285104469687e2,
        1.383_577_518_672_69e2,
        -3.066479806614716e1,
        2.506628277459239,
    ];
    const B: [f64; 5] = [
        -5.447609879822406e1,
        1.615858368580409e2,
        -1.556989798598866e2,
        6.680131188771972e1,
        -1.328068155288572e1,
    ];
    const C: [f64; 6] = [
        -7.784894002430293e-3,
        -3.223964580411365e-1,
        -2.400758277161838,
        -2.549732539343734,
        4.374664141464968,
        2.938163982698783,
    ];
    const D: [f64; 4] = [
        7.784695709041462e-3,
        3.224671290700398e-1,
        2.445134137142996,
        3.754408661907416,
    ];
    let tail = |q: f64| {
        (((((C[0] * q + C[1]) * q + C[2]) * q + C[3]) * q + C[4]) * q + C[5])
            / ((((D[0] * q + D[1]) * q + D[2]) * q + D[3]) * q + 1.0)
    };
    if p < 0.02425 {
        tail((-2.0 * p.ln()).sqrt())
    } else if p > 1.0 - 0.02425 {
        -tail((-2.0 * (1.0 - p).ln()).sqrt())
    } else {
        let q = p - 0.5;
        let r = q * q;
        (((((A[0] * r + A[1]) * r + A[2]) * r + A[3]) * r + A[4]) * r + A[5]) * q
            / (((((B[0] * r + B[1]) * r + B[2]) * r + B[3]) * r + B[4]) * r + 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_match_tables() {
        // chi-square(33) 99.9 %: 63.870; chi-square(3) 99.9 %: 16.266.
        assert!((chi_square_quantile(33, 0.999) - 63.870).abs() < 0.3);
        assert!((chi_square_quantile(3, 0.999) - 16.266).abs() < 0.3);
        assert!((normal_quantile(0.9995) - 3.2905).abs() < 1e-3);
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
        assert!(!agree.conflicts() && agree.warning().is_none());
        let conflict = ConflictTest::new(
            "test",
            names,
            &[0.1, -1.0, 0.0],
            &[0.01; 3],
            &[0.001; 3],
            101.0,
        );
        let warning = conflict.warning().unwrap();
        assert!(warning.contains("b (z = -10.5)"), "{warning}");
        assert_eq!(conflict.offenders().len(), 1);
    }
}
