//! Local steps: inside the back-substitution, each group's unknowns (its
//! own and its points') moved on by Gauss–Newton steps of their own,
//! against its points' rows with what they take of the global block held
//! at its prediction at the new global block ([`Problem::local_rows`] at
//! the anchors [`Problem::linearize_along_batch`] wrote).
//!
//! The back-substitution's own local step is the first such step: its
//! rows `r + J_g δg + J_c δc + J_p δp` are the local rows at the anchors,
//! linearised at the group's and points' values of the iterate (exactly
//! where a point's rows are affine in what they take of the global block,
//! as an observation block is in its tool point). Where the rows are far
//! from linear in the local unknowns (the angles of a contact far from
//! their minimum, after a start far off), that one step leaves the group
//! far from its minimum at the new global block; the trial point's cost
//! pays for it, and the next step's global part with it. The next local
//! steps take the group towards that minimum with no forward kinematics:
//! a few evaluations of its rows at the anchors and a Schur solve of its
//! `C + n P` unknowns.
//!
//! Each step solves the group's normal equations by the Schur complement
//! on its points: `A_p = J_pᵀJ_p + Λ_p` of each point (its rows and
//! prior) and the group's `S` are a few unknowns wide, inverted in closed
//! form.
//!
//! Each step is kept only if it lowers the group's cost at the anchors
//! (its points' rows and priors, its own prior); the local steps end at
//! the first that does not, that cannot be solved (a singular block) or
//! whose rows cannot be evaluated, or once the decrease the
//! step's linear model predicts is below the iteration's threshold. The
//! sums that judge the iteration (`δᵀHδ`, `|δ|`, the stopping rule) stay
//! the back-substitution's: the stopping rule judges the joint step
//! computed at an iterate, as without local steps. When they are taken:
//! `iterate::local_steps_of`.

use std::ops::Range;

use nalgebra::{Const, SMatrix, SVector};

use crate::problem::{GaussianPrior, LocalRows, Problem, State};

/// When and how far the back-substitution takes local steps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct LocalSteps {
    /// The most local steps of one group.
    pub(crate) steps: usize,
    /// A local step whose predicted decrease of the group's cost is below
    /// this is not taken.
    pub(crate) least_decrease: f64,
}

/// A group's working memory for local steps, reused from group to group.
pub(crate) struct LocalScratch<const C: usize, const P: usize, const R: usize> {
    /// The points' values being stepped.
    values: Vec<SVector<f64, P>>,
    /// The points' priors, their information whole ([`symmetric`]).
    priors: Vec<Option<GaussianPrior<Const<P>>>>,
    /// Each point's rows at the values being stepped from.
    rows: Vec<LocalRows<C, P, R>>,
    /// Each point's `A_p⁻¹ B_p` and `A_p⁻¹ b_p` (the point's normal block
    /// `A_p`, its coupling `B_p` to the group, its gradient `b_p`).
    solves: Vec<(SMatrix<f64, P, C>, SVector<f64, P>)>,
    /// The points' values tried.
    tried: Vec<SVector<f64, P>>,
    /// Their rows there.
    tried_rows: Vec<LocalRows<C, P, R>>,
}

impl<const C: usize, const P: usize, const R: usize> Default for LocalScratch<C, P, R> {
    fn default() -> Self {
        Self {
            values: Vec::new(),
            priors: Vec::new(),
            rows: Vec::new(),
            solves: Vec::new(),
            tried: Vec::new(),
            tried_rows: Vec::new(),
        }
    }
}

/// `prior` with its information's upper triangle taken from its lower one
/// (the only one [`GaussianPrior`] reads), so that products with it may
/// read the whole matrix.
fn symmetric<const D: usize>(mut prior: GaussianPrior<Const<D>>) -> GaussianPrior<Const<D>> {
    prior.information.fill_upper_triangle_with_lower_triangle();
    prior
}

/// The cost of a group at its values `group` and `points` (their priors
/// `group_prior` and `priors`), each point's rows at its anchor written into
/// `rows`: `Σ |r_i|²` plus the priors' terms. `None` if a point's rows
/// cannot be evaluated or the problem has none.
#[allow(clippy::too_many_arguments)]
fn group_cost<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    range: &Range<usize>,
    anchors: &[Pr::Anchor],
    group: &SVector<f64, C>,
    points: &[SVector<f64, P>],
    group_prior: Option<&GaussianPrior<Const<C>>>,
    priors: &[Option<GaussianPrior<Const<P>>>],
    rows: &mut [LocalRows<C, P, R>],
) -> Option<f64> {
    let mut cost = group_prior.map_or(0.0, |prior| prior.cost(group));
    let each = range.clone().zip(anchors).zip(points.iter().zip(priors));
    for (((i, anchor), (point, prior)), rows) in each.zip(rows) {
        if !matches!(problem.local_rows(i, anchor, group, point, rows), Ok(true)) {
            return None;
        }
        cost += rows.residual.norm_squared();
        if let Some(prior) = prior {
            cost += prior.cost(point);
        }
    }
    cost.is_finite().then_some(cost)
}

/// Up to `options.steps` local steps of group `k` (points `range`, their
/// anchors `anchors`) from its values in `state` moved by the linear step
/// `dc` and `dp`, which the steps kept overwrite (module doc).
#[allow(clippy::too_many_arguments)]
pub(crate) fn local_steps<const C: usize, const P: usize, const R: usize, Pr>(
    problem: &Pr,
    k: usize,
    range: Range<usize>,
    anchors: &[Pr::Anchor],
    state: &State<C, P>,
    dc: &mut SVector<f64, C>,
    dp: &mut [SVector<f64, P>],
    options: LocalSteps,
    scratch: &mut LocalScratch<C, P, R>,
) where
    Pr: Problem<C, P, R>,
{
    let start = &state.points[range.clone()];
    let mut group = state.groups[k] + *dc;
    scratch.values.clear();
    (scratch.values).extend(start.iter().zip(&*dp).map(|(p, d)| p + d));
    if scratch.steps_from(problem, k, &range, anchors, &mut group, options) > 0 {
        *dc = group - state.groups[k];
        for ((d, value), p) in dp.iter_mut().zip(&scratch.values).zip(start) {
            *d = value - p;
        }
    }
}

impl<const C: usize, const P: usize, const R: usize> LocalScratch<C, P, R> {
    /// [`local_steps`] from the values `group` and the points' `values`,
    /// which each step kept overwrites. Returns the number of steps kept.
    fn steps_from<Pr: Problem<C, P, R>>(
        &mut self,
        problem: &Pr,
        k: usize,
        range: &Range<usize>,
        anchors: &[Pr::Anchor],
        group: &mut SVector<f64, C>,
        options: LocalSteps,
    ) -> usize {
        let Self {
            values: points,
            priors,
            rows,
            solves,
            tried,
            tried_rows,
        } = self;
        let n = range.len();
        rows.resize(n, LocalRows::default());
        tried_rows.resize(n, LocalRows::default());
        solves.resize(n, (SMatrix::zeros(), SVector::zeros()));
        priors.clear();
        priors.extend(range.clone().map(|i| problem.point_prior(i).map(symmetric)));
        let group_prior = problem.group_prior(k).map(symmetric);
        let group_prior = group_prior.as_ref();
        let at = |group: &SVector<f64, C>, points: &[SVector<f64, P>], rows: &mut [_]| {
            group_cost(
                problem,
                range,
                anchors,
                group,
                points,
                group_prior,
                priors,
                rows,
            )
        };
        let Some(mut cost) = at(group, points, rows) else {
            return 0;
        };
        let mut kept = 0;
        while kept < options.steps {
            // The Schur complement `S δc = −s` of the group's normal equations.
            let (mut schur, mut s) = match group_prior {
                Some(prior) => (prior.information, prior.information * (*group - prior.mean)),
                None => (SMatrix::<f64, C, C>::zeros(), SVector::<f64, C>::zeros()),
            };
            // `Σ b_pᵀ A_p⁻¹ b_p`, the points' part of the predicted decrease.
            let mut points_decrease = 0.0;
            let eliminated = (points.iter().zip(priors.iter())).zip(rows.iter());
            for (((point, prior), rows), solve) in eliminated.zip(solves.iter_mut()) {
                let mut a = rows.d_point.tr_mul(&rows.d_point);
                let mut b = rows.d_point.tr_mul(&rows.residual);
                if let Some(prior) = prior {
                    a += prior.information;
                    b += prior.information * (point - prior.mean);
                }
                let Some(a) = a.try_inverse() else {
                    return kept;
                };
                let coupling = rows.d_point.tr_mul(&rows.d_group);
                *solve = (a * coupling, a * b);
                points_decrease += b.dot(&solve.1);
                schur += rows.d_group.tr_mul(&rows.d_group) - coupling.tr_mul(&solve.0);
                s += rows.d_group.tr_mul(&rows.residual) - coupling.tr_mul(&solve.1);
            }
            let Some(schur) = schur.try_inverse() else {
                return kept;
            };
            let dc = -(schur * s);
            // The decrease of the group's cost its linear model predicts,
            // `−gᵀδ = sᵀS⁻¹s + Σ b_pᵀA_p⁻¹b_p` (`g` the gradient, half the
            // cost's): below the threshold (or NaN), no step.
            let worth_it = points_decrease - s.dot(&dc) >= options.least_decrease;
            if !worth_it {
                return kept;
            }
            tried.clear();
            for (point, (coupled, own)) in points.iter().zip(solves.iter()) {
                tried.push(point - (own + coupled * dc));
            }
            let next = *group + dc;
            match at(&next, tried, tried_rows) {
                Some(lower) if lower < cost => {
                    cost = lower;
                    *group = next;
                    points.copy_from_slice(tried);
                    std::mem::swap(rows, tried_rows);
                    kept += 1;
                }
                _ => return kept,
            }
        }
        kept
    }
}
