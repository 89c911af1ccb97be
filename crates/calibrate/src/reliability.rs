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

use nalgebra::{DMatrix, SVector};
use parcal_dataset::Histogram;
use parcal_solver::{
    MIN_REDUNDANCY, Problem, State, normalised_residual, point_degrees_of_freedom, redundancy,
};

use crate::CalibrateError;
use crate::external::{self, ExternalShift, external_shifts};
use crate::hypothesis::{
    SNOOPING_LEVEL, critical_value, estimated_gross_error, minimal_detectable_bias,
};
use crate::observation::ObservationId;
use crate::robust::{self, DownWeighted};
use crate::systematic::{Effect, SystematicTest, systematic_tests};

/// Redundancy (per test, [`ObservationId::tests`]) below which an
/// observation counts as uncontrolled.
pub const UNCONTROLLED: f64 = 0.1;

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

/// What an observation's check is derived from: its redundancy and its
/// worst row's residual and redundancy number.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Numbers {
    /// Its redundancy (sum over its rows).
    redundancy: f64,
    /// The whitened residual `e` and redundancy number `r` of its row of
    /// largest normalised residual; both 0 when no row is checked.
    worst_residual: f64,
    worst_redundancy: f64,
}

impl Numbers {
    /// The normalised residual of its worst row; `None` when no other
    /// observation checks it.
    fn normalised(&self) -> Option<f64> {
        normalised_residual(self.worst_residual, self.worst_redundancy)
    }
}

/// The observation of largest normalised residual in magnitude among those
/// seen, the first of [`Reliability::observations`] among equals (under
/// `total_cmp`), whatever order they are seen in.
#[derive(Debug, Default)]
struct Largest(Option<(f64, usize)>);

impl Largest {
    /// Sees the observation at `index` of [`Reliability::observations`],
    /// of check `numbers` (as kept).
    fn see(&mut self, index: usize, numbers: &Numbers) {
        let Some(w) = numbers.normalised().map(f64::abs) else {
            return;
        };
        let larger = match self.0 {
            None => true,
            Some((largest, at)) => match w.total_cmp(&largest) {
                std::cmp::Ordering::Greater => true,
                std::cmp::Ordering::Equal => index < at,
                std::cmp::Ordering::Less => false,
            },
        };
        if larger {
            self.0 = Some((w, index));
        }
    }

    /// Its index, if any observation was checked.
    fn index(&self) -> Option<usize> {
        self.0.map(|(_, index)| index)
    }
}

/// [`Numbers`] as every contact keeps them, in single precision (12 bytes
/// a contact): their rounding, a relative 6e-8, is far below what they are
/// read for (a normalised residual against a critical value near 4, a
/// redundancy against [`UNCONTROLLED`]). What is summed over the
/// contacts (redundancy, variance components) is summed from the full
/// [`Numbers`] as the pass goes.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct Stored {
    redundancy: f32,
    worst_residual: f32,
    worst_redundancy: f32,
}

impl From<Numbers> for Stored {
    fn from(n: Numbers) -> Self {
        Self {
            redundancy: n.redundancy as f32,
            worst_residual: n.worst_residual as f32,
            worst_redundancy: n.worst_redundancy as f32,
        }
    }
}

impl From<Stored> for Numbers {
    fn from(s: Stored) -> Self {
        Self {
            redundancy: s.redundancy.into(),
            worst_residual: s.worst_residual.into(),
            worst_redundancy: s.worst_redundancy.into(),
        }
    }
}

/// One observation's check, from its rows' redundancy numbers `r`,
/// whitened residuals `e` and global leverages `global`: its [`Numbers`],
/// its worst row, and its bias-to-noise ratio for a minimal detectable
/// bias of `delta0 / √r` row sigmas (`None` when no row is checked), the
/// largest `delta0 √(h / r)` taken as `delta0 √max(h / r)`, the same
/// value since both functions are monotonic. Each checked row's normalised
/// residual goes to `normalised`, in the order of the rows.
fn check_rows(
    r: &[f64],
    e: &[f64],
    global: &[f64],
    delta0: f64,
    mut normalised: impl FnMut(f64),
) -> (Numbers, u8, Option<f64>) {
    let largest_ratio = r
        .iter()
        .zip(global)
        .filter(|(r, _)| **r > MIN_REDUNDANCY)
        .map(|(r, h)| h.max(0.0) / r)
        .max_by(f64::total_cmp);
    let bias_to_noise = largest_ratio.map(|ratio| delta0 * ratio.sqrt());
    let worst = r
        .iter()
        .zip(e)
        .enumerate()
        .filter_map(|(j, (&r, &e))| normalised_residual(e, r).map(|w| (j, w, e, r)))
        .inspect(|&(_, w, _, _)| normalised(w))
        .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()));
    // `j` indexes an observation's rows: at most six.
    let (row, worst_residual, worst_redundancy) =
        worst.map_or((0, 0.0, 0.0), |(j, _, e, r)| (j as u8, e, r));
    let numbers = Numbers {
        redundancy: r.iter().sum(),
        worst_residual,
        worst_redundancy,
    };
    (numbers, row, bias_to_noise)
}

/// One observation's check (a view of [`Reliability`]'s storage).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObservationCheck {
    observation: ObservationId,
    numbers: Numbers,
    row: u8,
}

impl ObservationCheck {
    /// The observation.
    pub fn observation(&self) -> ObservationId {
        self.observation
    }

    /// Its redundancy (sum over its rows).
    pub fn redundancy(&self) -> f64 {
        self.numbers.redundancy
    }

    /// Its normalised residual: that of its row of largest magnitude;
    /// `None` when no other observation checks it.
    pub fn normalised(&self) -> Option<f64> {
        self.numbers.normalised()
    }

    /// Its estimated gross error `w / √r` ([`estimated_gross_error`]), in
    /// units of the standard deviation of what its test sees: a
    /// contact's, tested as one, over its redundancy (the sum over its
    /// rows); a pose's or a point's, tested by row, that row's `e / r`.
    pub fn gross_error(&self) -> Option<f64> {
        let r = match self.observation.tests() {
            1 => self.numbers.redundancy,
            _ => self.numbers.worst_redundancy,
        };
        self.normalised().map(|w| estimated_gross_error(w, r))
    }

    /// The whitened residual `e` of its row of largest `|w|` (in units of
    /// that row's standard deviation); `None` when no other observation
    /// checks it.
    pub fn residual(&self) -> Option<f64> {
        self.normalised().map(|_| self.numbers.worst_residual)
    }

    /// That row, among a pose's or a point's (its leg, its coordinate); 0
    /// for a contact, whose rows are tested as one ([`ObservationId::tests`]).
    pub fn row(&self) -> usize {
        self.row.into()
    }
}

/// How many observations of largest bias-to-noise ratio a run keeps
/// ([`Reliability::least_reliable`]).
pub const LEAST_RELIABLE: usize = 10;
const _: () = assert!(external::SHIFTED <= LEAST_RELIABLE);

/// Bins of the histogram of the rows' normalised residuals: `[-6, 6)` by
/// 0.25.
pub const NORMALISED_BINS: (f64, f64, usize) = (-6.0, 0.25, 48);

/// The checks of a converged calibration
/// ([`crate::verdict::at_minimum`]).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Reliability {
    /// The variance components of each kind of observation present (ball
    /// touches, distances, poses, points) and the priors (if any).
    pub components: Vec<VarianceComponent>,
    /// The histogram ([`NORMALISED_BINS`]) of the normalised residual of
    /// every checked row (standard normal under the model, unlike an
    /// observation's largest).
    pub row_normalised: Histogram,
    /// Each contact's numbers, by measurements.csv row.
    contacts: Vec<Stored>,
    /// The global observations' checks, in order.
    global: Vec<ObservationCheck>,
    /// The [`LEAST_RELIABLE`] observations of largest bias-to-noise ratio,
    /// largest first.
    least_reliable: Vec<(ObservationId, f64)>,
    /// The sum of the observations' redundancy, added up in the solver's
    /// order of the contacts, then the global observations'.
    redundancy: f64,
    /// [`Reliability::worst`]'s index in [`Reliability::observations`].
    worst: Option<usize>,
    /// The global shift of the least reliable observations' minimal
    /// detectable biases, largest `λ` first ([`crate::external`]).
    pub external: Vec<ExternalShift>,
    /// With a robust loss, the observations it down-weighted
    /// ([`crate::robust::down_weighted`]); `None` for least squares.
    pub down_weighted: Option<Vec<DownWeighted>>,
    /// When the global test rejects a least-squares run, the tests of the
    /// common errors that could explain it ([`crate::systematic`]); empty
    /// otherwise.
    pub systematic: Vec<SystematicTest>,
}

/// What needs every observation, summed as they are seen (the contacts in
/// the solver's order, then the global observations).
struct Summary {
    /// `δ₀` of the minimal detectable bias.
    delta0: f64,
    components: Vec<VarianceComponent>,
    row_normalised: Histogram,
    /// The observations of largest bias-to-noise ratio so far, largest
    /// first, the earlier seen first among equals.
    least_reliable: Vec<(ObservationId, f64)>,
    /// Their redundancy, as `Iterator::sum` adds up.
    redundancy: f64,
}

impl Summary {
    fn new(delta0: f64) -> Self {
        let (lower, width, bins) = NORMALISED_BINS;
        Self {
            delta0,
            components: Vec::new(),
            row_normalised: Histogram::of(std::iter::empty(), lower, width, bins),
            least_reliable: Vec::new(),
            redundancy: -0.0,
        }
    }

    /// Sums `observation`, of rows of redundancy numbers `r`, whitened
    /// residuals `e` (weighted sum of squares `cost`) and global leverages
    /// `global`; its numbers and worst row ([`check_rows`]).
    fn see(
        &mut self,
        observation: ObservationId,
        r: &[f64],
        e: &[f64],
        global: &[f64],
        cost: f64,
    ) -> (Numbers, u8) {
        let histogram = &mut self.row_normalised;
        let (numbers, row, lambda) = check_rows(r, e, global, self.delta0, |w| histogram.add(w));
        add_to_component(&mut self.components, observation, cost, &numbers);
        // Kept when larger than the smallest of a full list.
        let kept = |lambda: &f64| match self.least_reliable.last() {
            Some((_, last)) if self.least_reliable.len() == LEAST_RELIABLE => {
                last.total_cmp(lambda).is_lt()
            }
            _ => true,
        };
        if let Some(lambda) = lambda.filter(kept) {
            let at = self
                .least_reliable
                .partition_point(|(_, l)| l.total_cmp(&lambda) != std::cmp::Ordering::Less);
            if at < LEAST_RELIABLE {
                self.least_reliable.insert(at, (observation, lambda));
                self.least_reliable.truncate(LEAST_RELIABLE);
            }
        }
        self.redundancy += numbers.redundancy;
        (numbers, row)
    }
}

impl Reliability {
    /// The redundancy numbers of `problem` at `state`: its points are the
    /// contacts of measurements.csv rows `rows` (each row once), its
    /// global observation rows those of `global` in order; `prior_cost` is
    /// the final prior term and `prior_rows` its number of rows. Each
    /// contact's rows are reduced to its numbers as the solver's pass
    /// hands them over (with a robust loss, a contact it down-weighted is
    /// listed then); the shifts of the least reliable follow
    /// ([`crate::external`]). The same pass gives the systematic tests of
    /// `effects`, the problem's effects ([`Problem::effects`]) named in
    /// order (none with a robust loss), and the groups' marginal sigmas
    /// ([`parcal_solver::Redundancy::group_sigmas`]), which are returned.
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
        effects: &[Effect],
    ) -> Result<(Self, Vec<SVector<f64, C>>), CalibrateError> {
        let failed = |reason: String| CalibrateError::Calibration { reason };
        let tests = rows.len() + global.iter().map(|o| o.tests()).sum::<usize>();
        let delta0 = minimal_detectable_bias(1.0, SNOOPING_LEVEL / tests.max(1) as f64);
        let mut summary = Summary::new(delta0);
        let mut contacts = vec![Stored::default(); rows.len()];
        // Which rows have been seen, a bit each.
        let mut seen = vec![0u64; rows.len().div_ceil(64)];
        let mut points = 0;
        let mut bad_row = None;
        let mut largest = Largest::default();
        let robust = !problem.loss().is_squared();
        let mut down_weighted = Vec::new();
        let contact_dof = point_degrees_of_freedom(R, P);
        let numbers = redundancy(problem, state, covariance, caches, groups_per_chunk, |p| {
            let i = points;
            points += 1;
            let row = rows.get(i).map_or(usize::MAX, |&row| row as usize);
            let (word, bit) = (row / 64, 1 << (row % 64));
            if row >= contacts.len() || seen[word] & bit != 0 {
                bad_row.get_or_insert(i);
                return;
            }
            seen[word] |= bit;
            let (numbers, _) = summary.see(
                ObservationId::Contact(row),
                p.redundancy.as_slice(),
                p.residual.as_slice(),
                p.global_leverage.as_slice(),
                p.residual.norm_squared(),
            );
            contacts[row] = numbers.into();
            largest.see(row, &contacts[row].into());
            down_weighted.extend(robust::down_weighted(
                ObservationId::Contact(row),
                p.weight,
                p.residual.as_slice(),
                contact_dof,
            ));
        })
        .map_err(|status| {
            failed(format!(
                "the redundancy numbers could not be computed: {status:?}"
            ))
        })?;
        if let Some(i) = bad_row {
            return Err(failed(format!(
                "contact {i} of the solver has no measured contact of its own among {}",
                rows.len()
            )));
        }
        if points != rows.len() {
            return Err(failed(format!(
                "{points} contacts checked for {} measured contacts",
                rows.len()
            )));
        }
        let (r, e) = (
            &numbers.global_observations,
            &numbers.global_observation_residuals,
        );
        let global_rows: usize = global.iter().map(|o| o.rows()).sum();
        if global_rows != r.len() {
            return Err(failed(format!(
                "{} global observation rows for observations of {global_rows} rows",
                r.len()
            )));
        }
        // A global observation row's leverage is all global: 1 − r_o.
        let global_leverage: Vec<f64> = r.iter().map(|r| 1.0 - r).collect();
        let global_weights = numbers.global_observation_weights.as_deref();
        let mut first = 0;
        let mut global_checks = Vec::with_capacity(global.len());
        for &observation in global {
            let range = first..first + observation.rows();
            let e = &e[range.clone()];
            let cost = e.iter().map(|v| v * v).sum();
            let (numbers, row) = summary.see(
                observation,
                &r[range.clone()],
                e,
                &global_leverage[range.clone()],
                cost,
            );
            largest.see(contacts.len() + global_checks.len(), &numbers);
            global_checks.push(ObservationCheck {
                observation,
                numbers,
                row,
            });
            if let Some(weights) = global_weights {
                down_weighted.extend(robust::down_weighted(
                    observation,
                    weights[range.start],
                    e,
                    observation.rows(),
                ));
            }
            first = range.end;
        }
        let external = external_shifts(
            problem,
            state,
            covariance,
            caches,
            &summary.least_reliable[..external::SHIFTED.min(summary.least_reliable.len())],
            rows,
            global,
            delta0,
        )?;
        let mut components = summary.components;
        if prior_rows > 0 {
            components.push(VarianceComponent {
                group: "priors",
                cost: prior_cost,
                redundancy: prior_rows as f64 - numbers.prior_leverage.total(),
            });
        }
        let reliability = Self {
            components,
            row_normalised: summary.row_normalised,
            contacts,
            global: global_checks,
            least_reliable: summary.least_reliable,
            redundancy: summary.redundancy,
            worst: largest.index(),
            external,
            down_weighted: robust.then_some(down_weighted),
            systematic: systematic_tests(effects, &numbers.effects),
        };
        Ok((reliability, numbers.group_sigmas))
    }

    /// The sum of the observations' redundancy.
    pub fn redundancy(&self) -> f64 {
        self.redundancy
    }

    /// The number of observations checked.
    pub fn len(&self) -> usize {
        self.contacts.len() + self.global.len()
    }

    /// Whether no observation is checked.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The check of observation `k` of [`Reliability::observations`].
    ///
    /// # Panics
    ///
    /// If `k` is not below [`Reliability::len`].
    pub fn observation(&self, k: usize) -> ObservationCheck {
        match self.contacts.get(k) {
            Some(&numbers) => ObservationCheck {
                observation: ObservationId::Contact(k),
                numbers: numbers.into(),
                row: 0,
            },
            None => self.global[k - self.contacts.len()],
        }
    }

    /// The check of `observation`, if it is checked.
    pub fn check(&self, observation: ObservationId) -> Option<ObservationCheck> {
        match observation {
            ObservationId::Contact(k) => (k < self.contacts.len()).then(|| self.observation(k)),
            _ => self
                .global
                .iter()
                .find(|c| c.observation == observation)
                .copied(),
        }
    }

    /// Every observation's check: the contacts by measurements.csv row,
    /// then the global observations in their order.
    pub fn observations(&self) -> impl Iterator<Item = ObservationCheck> + '_ {
        (0..self.len()).map(|k| self.observation(k))
    }

    /// The observations no other observation checks enough (redundancy
    /// under [`UNCONTROLLED`] per test they add, [`ObservationId::tests`]).
    pub fn uncontrolled(&self) -> impl Iterator<Item = ObservationCheck> + '_ {
        self.observations()
            .filter(|c| c.redundancy() < UNCONTROLLED * c.observation().tests() as f64)
    }

    /// The observation of largest normalised residual (the first of
    /// [`Reliability::observations`] among equals).
    pub fn worst(&self) -> Option<ObservationCheck> {
        self.worst.map(|k| self.observation(k))
    }

    /// At most `n` (and [`LEAST_RELIABLE`]) observations of largest
    /// bias-to-noise ratio, largest first (external reliability: those
    /// whose undetected blunders would move the parameters most), each
    /// with that ratio: the largest over its rows of `λ = δ₀ √(|z_j|² /
    /// r_j)` for the global block (kinematic parameters and tied centres),
    /// the shift an undetected error of the row's minimal detectable bias
    /// makes in them, in units of their own noise (`√(∇gᵀ Cov(g)⁻¹ ∇g)`;
    /// `|z_j|²` the row's global leverage, `parcal_solver::redundancy`).
    pub fn least_reliable(&self, n: usize) -> &[(ObservationId, f64)] {
        &self.least_reliable[..n.min(self.least_reliable.len())]
    }

    /// Whether the observation of largest normalised residual fails the
    /// test of data snooping at family-wise `level`: `|w| > z_{1 − level /
    /// (2m)}`, `m` = [`Reliability::tests`].
    pub fn fails_snooping(&self, level: f64) -> bool {
        self.worst()
            .and_then(|c| c.normalised())
            .is_some_and(|w| w.abs() > critical_value(level, self.tests()))
    }

    /// The size of the family of tests of data snooping
    /// ([`ObservationId::tests`]).
    pub fn tests(&self) -> usize {
        self.contacts.len()
            + self
                .global
                .iter()
                .map(|c| c.observation.tests())
                .sum::<usize>()
    }
}

/// Adds an observation of `numbers` and weighted sum of squares `cost` to
/// the variance component of its group (appended on its group's first
/// appearance).
fn add_to_component(
    components: &mut Vec<VarianceComponent>,
    observation: ObservationId,
    cost: f64,
    numbers: &Numbers,
) {
    let group = observation.group();
    match components.iter_mut().find(|c| c.group == group) {
        Some(component) => {
            component.cost += cost;
            component.redundancy += numbers.redundancy;
        }
        None => components.push(VarianceComponent {
            group,
            cost,
            redundancy: numbers.redundancy,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_largest_is_the_first_among_equals_in_any_order() {
        let numbers = |e: f64| Numbers {
            redundancy: 0.25,
            worst_residual: e,
            worst_redundancy: 0.25,
        };
        let unchecked = Numbers::default();
        // |w| = 2|e|: 1.2 at 7 and 3, 0.6 at 1, none at 0.
        let seen = [(7, 0.6), (1, -0.3), (0, f64::NAN), (3, -0.6)];
        for order in [[0, 1, 2, 3], [3, 2, 1, 0], [2, 0, 3, 1]] {
            let mut largest = Largest::default();
            largest.see(0, &unchecked);
            for k in order {
                let (index, e) = seen[k];
                let checked = if e.is_nan() { unchecked } else { numbers(e) };
                largest.see(index, &checked);
            }
            assert_eq!(largest.index(), Some(3), "{order:?}");
        }
        assert_eq!(Largest::default().index(), None);
    }

    #[test]
    fn a_check_keeps_its_worst_row() {
        // Rows: w = 0.5 / √0.25 = 1, -0.9 / √0.36 = -1.5, unchecked.
        let r = [0.25, 0.36, 1e-12];
        let mut normalised = Vec::new();
        let (numbers, row, lambda) =
            check_rows(&r, &[0.5, -0.9, 3.0], &[0.04, 0.09, 0.5], 2.0, |w| {
                normalised.push(w)
            });
        assert_eq!(normalised, [0.5 / 0.5, -0.9 / 0.6]);
        let check = ObservationCheck {
            observation: ObservationId::Pose(7),
            numbers,
            row,
        };
        assert_eq!(check.redundancy(), r.iter().sum::<f64>());
        assert_eq!(check.normalised(), Some(-0.9 / 0.6));
        // A pose's row is tested alone: its gross error is that row's e / r.
        let gross = check.gross_error().unwrap();
        assert!((gross - -0.9 / 0.36).abs() < 1e-15, "{gross}");
        assert_eq!(check.residual(), Some(-0.9));
        // A contact is tested as one: w over the root of its rows' sum.
        let contact = ObservationCheck {
            observation: ObservationId::Contact(7),
            ..check
        };
        let sum = r.iter().sum::<f64>();
        assert_eq!(contact.gross_error(), Some(-0.9 / 0.6 / sum.sqrt()));
        assert_eq!(check.row(), 1);
        // λ = 2 √(h / r): 2 √0.16 = 0.8 and 2 √0.25 = 1.
        assert_eq!(lambda, Some(2.0 * (0.09f64 / 0.36).sqrt()));
        let (numbers, _, lambda) = check_rows(&[1e-11], &[1.0], &[1.0], 2.0, |_| ());
        let unchecked = ObservationCheck { numbers, ..check };
        assert_eq!(unchecked.normalised(), None);
        assert_eq!(unchecked.gross_error(), None);
        assert_eq!(lambda, None);
        // A contact keeps it in 12 bytes, to single precision.
        assert_eq!(std::mem::size_of::<Stored>(), 12);
        let (full, kept) = (check.numbers, Numbers::from(Stored::from(check.numbers)));
        assert_eq!(full.worst_residual, -0.9);
        for (kept, full) in [
            (kept.redundancy, full.redundancy),
            (kept.worst_residual, full.worst_residual),
            (kept.worst_redundancy, full.worst_redundancy),
        ] {
            assert!(
                (kept - full).abs() <= 6e-8 * full.abs(),
                "{kept} for {full}"
            );
        }
    }

    #[test]
    fn the_least_reliable_are_the_largest_ratios_earliest_first() {
        // One row each, of redundancy 1 and global leverage h: with δ₀ = 1,
        // λ = √h; a distance of no redundancy has none.
        let mut summary = Summary::new(1.0);
        let leverages = [
            1.0, 9.0, 4.0, 9.0, 0.25, 6.25, 4.0, 2.25, 0.04, 16.0, 0.01, 0.09, 4.0,
        ];
        for (k, &h) in leverages.iter().enumerate() {
            summary.see(ObservationId::Contact(k), &[1.0], &[0.0], &[h], 0.0);
            summary.see(ObservationId::Distance(k), &[1e-11], &[0.0], &[h], 0.0);
        }
        // What a stable sort by decreasing ratio keeps.
        let mut sorted: Vec<(usize, f64)> =
            leverages.iter().map(|h| h.sqrt()).enumerate().collect();
        sorted.sort_by(|a, b| b.1.total_cmp(&a.1));
        sorted.truncate(LEAST_RELIABLE);
        let expected: Vec<_> = sorted
            .iter()
            .map(|&(k, l)| (ObservationId::Contact(k), l))
            .collect();
        assert_eq!(summary.least_reliable, expected);
    }

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
