//! How well each observation is checked by the others, and which group of
//! observations does not fit (Baarda, "A testing procedure for use in
//! geodetic networks", 1968; Förstner and Wrobel, "Photogrammetric
//! Computer Vision", 2016, section 4.6).
//!
//! - The **redundancy number** `r_j = 1 − h_jj` of each whitened row (the
//!   solver's [`parcal_solver::redundancy`], through the Schur levels): the
//!   share of an error in that row that shows in its residual. A contact's
//!   is the sum over its rows; a contact with `r` near 0 is *uncontrolled*:
//!   an error in it goes straight into the parameters.
//! - The **normalised residual** `w_j = e_j / √r_j` (`e_j` whitened),
//!   standard normal for a correct model; a contact's is its rows' largest
//!   in magnitude.
//! - The **minimal detectable bias** of a contact, in units of its
//!   standard deviation, `∇₀ = δ₀ / √r`, `δ₀ = z_{1−α/2} + z_{1−β}`: the
//!   smallest error the test at level `α` finds with power `1 − β`.
//! - The **variance component** of each group of observations, `σ̂² = Ω_g /
//!   r_g` (its weighted sum of squares over its redundancy): about 1 for a
//!   group whose stated noise is right, larger for the group that does not
//!   fit.

use nalgebra::DMatrix;
use parcal_solver::{Problem, Redundancy, State, normalised_residual, redundancy};
use statrs::distribution::{ContinuousCDF, Normal};

use crate::CalibrateError;

/// Redundancy below which a contact counts as uncontrolled.
pub const UNCONTROLLED: f64 = 0.1;
/// Power `1 − β` of the minimal detectable bias.
pub const POWER: f64 = 0.8;

/// The variance component of one group of observations.
#[derive(Debug, Clone, PartialEq)]
pub struct VarianceComponent {
    /// The group: `ball touches`, `distances`, `priors`.
    pub group: &'static str,
    /// Its weighted sum of squares `Ω_g`.
    pub cost: f64,
    /// Its redundancy `r_g = Σ r_j`.
    pub redundancy: f64,
}

impl VarianceComponent {
    /// `σ̂² = Ω_g / r_g` (NaN without redundancy).
    pub fn factor(&self) -> f64 {
        self.cost / self.redundancy
    }

    /// Whether the group has at least one redundant observation's worth of
    /// redundancy: below it, `Ω_g / r_g` divides by (almost) nothing and
    /// says nothing of the group's noise (a prior much tighter than the
    /// data, which nothing checks).
    pub fn estimable(&self) -> bool {
        self.redundancy >= 1.0
    }
}

/// One contact's check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContactCheck {
    /// Its measurements.csv row (0-based).
    pub row: usize,
    /// Its redundancy (sum over its rows).
    pub redundancy: f64,
    /// Its normalised residual (the row of largest magnitude); `None` when
    /// no other observation checks it.
    pub normalised: Option<f64>,
    /// Its estimated gross error `e / r` of that row, in units of the row's
    /// standard deviation.
    pub gross_error: Option<f64>,
}

/// The checks of a converged calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Reliability {
    /// The variance components of the ball touches, the distances, poses
    /// and points (if any) and the priors (if any).
    pub components: Vec<VarianceComponent>,
    /// Every contact's check, in the solver's (by-ball) order.
    pub contacts: Vec<ContactCheck>,
    /// The normalised residual of every row another observation checks
    /// (standard normal under the model, unlike a contact's largest).
    pub row_normalised: Vec<f64>,
}

impl Reliability {
    /// The redundancy numbers of `problem` at `state` (its points in
    /// measurements.csv rows `rows`), with `prior_cost` the final prior
    /// term and `prior_rows` its number of rows; `global_groups`: the
    /// groups of the global observation rows (name, rows), one variance
    /// component each.
    #[allow(clippy::too_many_arguments)]
    pub fn new<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
        problem: &Pr,
        state: &State<C, P>,
        covariance: &DMatrix<f64>,
        caches: &mut Vec<Pr::PointCache>,
        groups_per_chunk: usize,
        rows: &[u32],
        prior_cost: f64,
        prior_rows: usize,
        global_groups: &[(&'static str, std::ops::Range<usize>)],
    ) -> Result<Self, CalibrateError> {
        let numbers: Redundancy<R> =
            redundancy(problem, state, covariance, caches, groups_per_chunk).map_err(|status| {
                CalibrateError::Calibration {
                    reason: format!("the redundancy numbers could not be computed: {status:?}"),
                }
            })?;
        let contacts = numbers
            .points
            .iter()
            .zip(&numbers.point_residuals)
            .zip(rows)
            .map(|((r, e), &row)| {
                let worst = (0..R)
                    .filter_map(|j| normalised_residual(e[j], r[j]).map(|w| (w, e[j] / r[j])))
                    .max_by(|a, b| a.0.abs().total_cmp(&b.0.abs()));
                ContactCheck {
                    row: row as usize,
                    redundancy: r.sum(),
                    normalised: worst.map(|(w, _)| w),
                    gross_error: worst.map(|(_, g)| g),
                }
            })
            .collect();
        let mut components = vec![VarianceComponent {
            group: "ball touches",
            cost: numbers
                .point_residuals
                .iter()
                .map(|e| e.norm_squared())
                .sum(),
            redundancy: numbers.points.iter().map(|r| r.sum()).sum(),
        }];
        for (group, range) in global_groups {
            components.push(VarianceComponent {
                group,
                cost: numbers.global_observation_residuals.as_slice()[range.clone()]
                    .iter()
                    .map(|e| e * e)
                    .sum(),
                redundancy: numbers.global_observations.as_slice()[range.clone()]
                    .iter()
                    .sum(),
            });
        }
        if prior_rows > 0 {
            components.push(VarianceComponent {
                group: "priors",
                cost: prior_cost,
                redundancy: prior_rows as f64 - numbers.prior_leverage.total(),
            });
        }
        let row_normalised = numbers
            .points
            .iter()
            .zip(&numbers.point_residuals)
            .flat_map(|(r, e)| (0..R).filter_map(|j| normalised_residual(e[j], r[j])))
            .collect();
        Ok(Self {
            components,
            contacts,
            row_normalised,
        })
    }

    /// The contacts no other observation checks enough (redundancy under
    /// [`UNCONTROLLED`]).
    pub fn uncontrolled(&self) -> impl Iterator<Item = &ContactCheck> {
        self.contacts.iter().filter(|c| c.redundancy < UNCONTROLLED)
    }

    /// The contact of largest normalised residual.
    pub fn worst(&self) -> Option<&ContactCheck> {
        self.contacts
            .iter()
            .filter(|c| c.normalised.is_some())
            .max_by(|a, b| {
                let w = |c: &ContactCheck| c.normalised.map_or(0.0, f64::abs);
                w(a).total_cmp(&w(b))
            })
    }
}

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

fn standard_normal() -> Normal {
    Normal::new(0.0, 1.0).expect("a standard normal")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn critical_values_are_normal_quantiles() {
        // z_{0.975} = 1.959964, z_{1 - 0.05/200} = 3.480756.
        assert!((critical_value(0.05, 1) - 1.959964).abs() < 1e-6);
        assert!((critical_value(0.05, 100) - 3.480756).abs() < 1e-6);
        // δ₀ for α = 0.1 %, β = 20 %: 3.290527 + 0.841621 = 4.132148.
        assert!((minimal_detectable_bias(1.0, 0.001) - 4.132148).abs() < 1e-6);
        assert!((minimal_detectable_bias(0.25, 0.001) - 2.0 * 4.132148).abs() < 1e-5);
    }
}
