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
//!   standard normal for a correct model. An observation (a contact, a
//!   distance, a pose of six rows, a point of three) is tested as a whole
//!   by its rows' largest `|w_j|`; the family of data snooping counts one
//!   test per contact (its rows' `|w_j|` are equal for the coordinate
//!   observation, Förstner and Wrobel 2016, and it has one row for the
//!   radius observation) and per distance, and one per row of a pose or a
//!   point (their rows are correlated but not equal: Bonferroni over the
//!   rows, conservative).
//! - The **minimal detectable bias** of a row, in units of its
//!   standard deviation, `∇₀ = δ₀ / √r`, `δ₀ = z_{1−α/2} + z_{1−β}`: the
//!   smallest error the test at level `α` finds with power `1 − β`
//!   (data snooping's: `α` its level over the family, Bonferroni).
//! - The **external reliability** of a row: what an undetected error of
//!   its minimal detectable bias does to the global block, `∇g = Cov(g)
//!   u_j ∇₀`, summarised as the bias-to-noise ratio `λ = √(∇gᵀ Cov(g)⁻¹
//!   ∇g) = δ₀ √(|z_j|² / r_j)` (Baarda 1968; Förstner and Wrobel 2016,
//!   section 4.6.5), from the global leverage `|z_j|²` that the redundancy
//!   pass gives (`parcal_solver::redundancy`); an observation's is its
//!   rows' largest.
//! - The **variance component** of each group of observations, `σ̂² = Ω_g /
//!   r_g` (its weighted sum of squares over its redundancy): about 1 for a
//!   group whose stated noise is right, larger for the group that does not
//!   fit.

use nalgebra::DMatrix;
use parcal_solver::{Problem, Redundancy, State, Status, normalised_residual, redundancy};
use statrs::distribution::{ContinuousCDF, Normal};

use crate::CalibrateError;
use crate::external::{ExternalShift, external_shifts};
use crate::robust::{DownWeighted, down_weighted};
use crate::snooping::SNOOPING_LEVEL;

/// Redundancy (per test, [`ObservationId::tests`]) below which an
/// observation counts as uncontrolled.
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

/// An observation of a dataset, by its place there (0-based): what data
/// snooping tests and removes as a whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ObservationId {
    /// A ball touch: its measurements.csv row.
    Contact(usize),
    /// A calibrated distance: its index in artefacts.json's `distances`.
    Distance(usize),
    /// A measured pose (six rows): its poses.csv row.
    Pose(usize),
    /// A measured tool point (three rows): its points.csv row.
    Point(usize),
}

impl ObservationId {
    /// Its whitened rows.
    pub fn rows(self) -> usize {
        match self {
            Self::Contact(_) | Self::Distance(_) => 1,
            Self::Pose(_) => 6,
            Self::Point(_) => 3,
        }
    }

    /// The tests it adds to the family of data snooping (module doc): one
    /// for a contact (its rows' `|w|` are equal for the coordinate
    /// observation, and it has one row for the radius observation) and a
    /// distance, one per row for a pose or a point.
    pub fn tests(self) -> usize {
        match self {
            Self::Contact(_) => 1,
            other => other.rows(),
        }
    }

    /// The group of its variance component.
    pub fn group(self) -> &'static str {
        match self {
            Self::Contact(_) => "ball touches",
            Self::Distance(_) => "distances",
            Self::Pose(_) => "poses",
            Self::Point(_) => "points",
        }
    }
}

/// Its place, rows 0-based: `measurements.csv row 12`, `distances[3]`,
/// `poses.csv row 4`, `points.csv row 7`.
impl std::fmt::Display for ObservationId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Contact(k) => write!(f, "measurements.csv row {k}"),
            Self::Distance(k) => write!(f, "distances[{k}]"),
            Self::Pose(k) => write!(f, "poses.csv row {k}"),
            Self::Point(k) => write!(f, "points.csv row {k}"),
        }
    }
}

/// One observation's check.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservationCheck {
    /// The observation.
    pub observation: ObservationId,
    /// Its redundancy (sum over its rows).
    pub redundancy: f64,
    /// Its normalised residual: that of its row of largest magnitude;
    /// `None` when no other observation checks it.
    pub normalised: Option<f64>,
    /// That row's estimated gross error `e / r`, in units of the row's
    /// standard deviation.
    pub gross_error: Option<f64>,
    /// That row, among the observation's (a pose's leg, a point's
    /// coordinate).
    pub row: usize,
    /// External reliability: the largest over its rows of the bias-to-noise
    /// ratio `λ = δ₀ √(|z_j|² / r_j)` of the global block (kinematic
    /// parameters and tied centres), the shift an undetected error of the
    /// row's minimal detectable bias makes in them, in units of their own
    /// noise (`√(∇gᵀ Cov(g)⁻¹ ∇g)`; `|z_j|²` the row's global leverage,
    /// `parcal_solver::redundancy`); `None` when no row is checked.
    pub bias_to_noise: Option<f64>,
}

impl ObservationCheck {
    /// The check of `observation` from its rows' redundancy numbers `r`,
    /// whitened residuals `e` and global leverages `global`: the largest
    /// normalised residual of its rows, and the largest bias-to-noise
    /// ratio for a minimal detectable bias of `delta0 / √r` row sigmas.
    pub fn new(
        observation: ObservationId,
        r: &[f64],
        e: &[f64],
        global: &[f64],
        delta0: f64,
    ) -> Self {
        let bias_to_noise = r
            .iter()
            .zip(global)
            .filter(|(r, _)| normalised_residual(0.0, **r).is_some())
            .map(|(r, h)| delta0 * (h.max(0.0) / r).sqrt())
            .max_by(f64::total_cmp);
        let worst = r
            .iter()
            .zip(e)
            .enumerate()
            .filter_map(|(j, (&r, &e))| normalised_residual(e, r).map(|w| (j, w, e / r)))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
        Self {
            observation,
            redundancy: r.iter().sum(),
            normalised: worst.map(|(_, w, _)| w),
            gross_error: worst.map(|(_, _, g)| g),
            row: worst.map_or(0, |(j, _, _)| j),
            bias_to_noise,
        }
    }
}

/// The checks of a converged calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct Reliability {
    /// The variance components of each kind of observation present (ball
    /// touches, distances, poses, points) and the priors (if any).
    pub components: Vec<VarianceComponent>,
    /// Every observation's check: the contacts in the solver's (by-ball)
    /// order, then the global observations in their order.
    pub observations: Vec<ObservationCheck>,
    /// The normalised residual of every row (standard normal under the
    /// model, unlike an observation's largest).
    pub row_normalised: Vec<f64>,
    /// The global shift of the least reliable observations' minimal
    /// detectable biases, largest `λ` first ([`crate::external`]).
    pub external: Vec<ExternalShift>,
    /// With a robust loss, the observations it down-weighted
    /// ([`crate::robust::down_weighted`]); `None` for least squares.
    pub down_weighted: Option<Vec<DownWeighted>>,
}

impl Reliability {
    /// The redundancy numbers of `problem` at `state`: its points are the
    /// contacts of measurements.csv rows `rows`, its global observation
    /// rows those of `global` in order; `prior_cost` is the final prior
    /// term and `prior_rows` its number of rows.
    #[allow(clippy::too_many_arguments)]
    pub fn new<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
        problem: &Pr,
        state: &State<C, P>,
        covariance: &DMatrix<f64>,
        caches: &mut Vec<Pr::PointCache>,
        groups_per_chunk: usize,
        rows: &[u32],
        global: &[ObservationId],
        prior_cost: f64,
        prior_rows: usize,
    ) -> Result<Self, CalibrateError> {
        let numbers: Redundancy<R> =
            redundancy(problem, state, covariance, caches, groups_per_chunk).map_err(|status| {
                CalibrateError::Calibration {
                    reason: format!("the redundancy numbers could not be computed: {status:?}"),
                }
            })?;
        let (r, e) = (
            &numbers.global_observations,
            &numbers.global_observation_residuals,
        );
        let global_rows: usize = global.iter().map(|o| o.rows()).sum();
        if global_rows != r.len() {
            return Err(CalibrateError::Calibration {
                reason: format!(
                    "{} global observation rows for observations of {global_rows} rows",
                    r.len()
                ),
            });
        }
        let tests = rows.len() + global.iter().map(|o| o.tests()).sum::<usize>();
        let delta0 = minimal_detectable_bias(1.0, SNOOPING_LEVEL / tests.max(1) as f64);
        let mut observations: Vec<ObservationCheck> = numbers
            .points
            .iter()
            .zip(&numbers.point_residuals)
            .zip(&numbers.point_global_leverage)
            .zip(rows)
            .map(|(((r, e), h), &row)| {
                ObservationCheck::new(
                    ObservationId::Contact(row as usize),
                    r.as_slice(),
                    e.as_slice(),
                    h.as_slice(),
                    delta0,
                )
            })
            .collect();
        // A global observation row's leverage is all global: 1 − r_o.
        let global_leverage: Vec<f64> = r.iter().map(|r| 1.0 - r).collect();
        let mut first = 0;
        for &observation in global {
            let range = first..first + observation.rows();
            observations.push(ObservationCheck::new(
                observation,
                &r[range.clone()],
                &e[range.clone()],
                &global_leverage[range.clone()],
                delta0,
            ));
            first = range.end;
        }
        // Each kind's cost and redundancy, in the order of first appearance.
        let mut components: Vec<VarianceComponent> = Vec::new();
        let costs = numbers
            .point_residuals
            .iter()
            .map(|e| e.norm_squared())
            .chain(global.iter().scan(0, |first, o| {
                let range = *first..*first + o.rows();
                *first = range.end;
                Some(e[range].iter().map(|v| v * v).sum())
            }));
        for (check, cost) in observations.iter().zip(costs) {
            let group = check.observation.group();
            match components.iter_mut().find(|c| c.group == group) {
                Some(component) => {
                    component.cost += cost;
                    component.redundancy += check.redundancy;
                }
                None => components.push(VarianceComponent {
                    group,
                    cost,
                    redundancy: check.redundancy,
                }),
            }
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
            .flat_map(|(r, e)| (0..R).map(|j| (e[j], r[j])))
            .chain(e.iter().copied().zip(r.iter().copied()))
            .filter_map(|(e, r)| normalised_residual(e, r))
            .collect();
        let external = external_shifts(problem, state, covariance, caches, &observations, delta0)?;
        let down_weighted = numbers
            .weights
            .is_some()
            .then(|| down_weighted(&numbers, P, rows, global));
        Ok(Self {
            components,
            observations,
            row_normalised,
            external,
            down_weighted,
        })
    }

    /// The observations no other observation checks enough (redundancy
    /// under [`UNCONTROLLED`] per test they add, [`ObservationId::tests`]).
    pub fn uncontrolled(&self) -> impl Iterator<Item = &ObservationCheck> {
        self.observations
            .iter()
            .filter(|c| c.redundancy < UNCONTROLLED * c.observation.tests() as f64)
    }

    /// The observation of largest normalised residual.
    pub fn worst(&self) -> Option<&ObservationCheck> {
        self.observations
            .iter()
            .filter(|c| c.normalised.is_some())
            .max_by(|a, b| {
                let w = |c: &ObservationCheck| c.normalised.map_or(0.0, f64::abs);
                w(a).total_cmp(&w(b))
            })
    }

    /// The `n` observations of largest bias-to-noise ratio, largest first
    /// (external reliability: those whose undetected blunders would move
    /// the parameters most).
    pub fn least_reliable(&self, n: usize) -> Vec<&ObservationCheck> {
        let mut checked: Vec<&ObservationCheck> = self
            .observations
            .iter()
            .filter(|c| c.bias_to_noise.is_some())
            .collect();
        let lambda = |c: &ObservationCheck| c.bias_to_noise.unwrap_or(0.0);
        checked.sort_by(|a, b| lambda(b).total_cmp(&lambda(a)));
        checked.truncate(n);
        checked
    }

    /// Whether the observation of largest normalised residual fails the
    /// test of data snooping at family-wise `level`: `|w| > z_{1 − level /
    /// (2m)}`, `m` = [`Reliability::tests`].
    pub fn fails_snooping(&self, level: f64) -> bool {
        self.worst()
            .and_then(|c| c.normalised)
            .is_some_and(|w| w.abs() > critical_value(level, self.tests()))
    }

    /// The size of the family of tests of data snooping
    /// ([`ObservationId::tests`]).
    pub fn tests(&self) -> usize {
        self.observations
            .iter()
            .map(|c| c.observation.tests())
            .sum()
    }
}

/// Whether a run that ended with `status` is checked: converged, or at its
/// iteration or time limit (whose final iterate's checks name the blunder
/// that may have kept it from converging, for data snooping to remove).
pub fn checked(status: &Status) -> bool {
    matches!(
        status,
        Status::Converged | Status::IterationLimit | Status::TimeLimit
    )
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
