//! Group refinement: after a step, the groups that carry a large share of
//! it take Gauss–Newton steps of their own, the global block held fixed,
//! before the trial point is evaluated.
//!
//! A group whose own problem is far from linear (a ball settled in a poor
//! local minimum, its contacts' residuals large and strongly curved about
//! it) converges only linearly under the joint steps, and its coupling
//! drags the global block along: the run's tail is that one group's. Its
//! own unknowns (the group's and its points') minimised with the global
//! block fixed, a block-coordinate step (the "inner iterations" of
//! Ceres Solver, here for the few groups that need them), bring it to its
//! minimum for the current global block at the cost of a few
//! eliminations of one group, and the joint iteration goes on as for a
//! well-behaved problem.
//!
//! When: once the iteration has settled, the step's `δᵀHδ` (the decrease
//! of the cost the linear model predicts) below [`SETTLED`] of the cost:
//! in the first steps from a start far off, where full steps overshoot,
//! a group's minimum for a global block about to move far is no guide.
//!
//! Which groups: those whose share of the step's `δᵀHδ`, `s_k = −(b_cᵀδc +
//! Σ_p b_pᵀδp)` over their own unknowns and their points'
//! (from the back-substitution), is above both [`DOMINANT_SHARE`] of the step's and
//! `sigma_tolerance²`, the largest of them, at most one group in
//! [`GROUPS_PER_REFINED`]. Each takes up to
//! [`LOCAL_STEPS`] steps: the back-substitution of its block with `δg = 0`
//! (the Gauss–Newton step of its unknowns alone), kept only if it lowers
//! the group's cost (its points' rows and its priors), until that step's
//! `δᵀHδ` is below `(sigma_tolerance / 10)²`. A step that fails (a point
//! that cannot be linearised, a singular block) ends the group's
//! refinement, leaving its unknowns as they are: the joint evaluation of
//! the trial point judges them.
//!
//! Least squares only (a robust loss's reweighting is the joint
//! iteration's), and only with the sigma tolerance on. The stopping rule
//! is unchanged: it judges the joint step computed at an iterate, so it
//! guarantees what it did. Groups are refined one after the other in
//! index order: the result does not depend on the number of threads.

use nalgebra::{DVector, SVector};

use crate::backsub::{ChunkOut, back_substitute_chunk};
use crate::chunked_problem::ChunkedProblem;
use crate::chunks::Chunk;
use crate::eliminate::{EliminationSink, Failure, eliminate_chunk};
use crate::problem::{Problem, State};
use crate::qr::PriorRows;

/// The steps after which groups are refined: those whose `δᵀHδ` is below
/// this fraction of the cost.
pub const SETTLED: f64 = 1e-2;

/// The least share of a step's `δᵀHδ` that makes a group refined.
pub const DOMINANT_SHARE: f64 = 0.01;

/// Groups per group refined after one step: at most one in this many
/// (and at least one), so that refining costs a small part of a pass
/// over the points whatever the problem's size.
pub const GROUPS_PER_REFINED: usize = 64;

/// The most local steps of one group after one joint step.
pub const LOCAL_STEPS: usize = 8;

impl<const C: usize, const P: usize, const R: usize, Pr> ChunkedProblem<'_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// Refines the groups of `trial` that dominate the step just
    /// back-substituted ([`ChunkedProblem::group_shares`]) from an iterate
    /// of cost `cost`, the step's `δᵀHδ` being `quadratic`, for the sigma
    /// tolerance `tolerance` (module doc). Returns the number of groups
    /// refined.
    pub(crate) fn refine_groups(
        &mut self,
        trial: &mut State<C, P>,
        cost: f64,
        quadratic: f64,
        tolerance: f64,
    ) -> usize {
        let settled = quadratic < SETTLED * cost;
        if !(tolerance > 0.0 && settled && self.problem.loss().is_squared()) {
            return 0;
        }
        let floor = (DOMINANT_SHARE * quadratic).max(tolerance * tolerance);
        let shares = &self.group_shares;
        let mut chosen: Vec<usize> = (0..shares.len()).filter(|&k| shares[k] > floor).collect();
        chosen.sort_by(|&a, &b| shares[b].total_cmp(&shares[a]).then(a.cmp(&b)));
        chosen.truncate(shares.len() / GROUPS_PER_REFINED + 1);
        chosen.sort_unstable();
        let global = self.problem.prepare_global(&trial.global);
        let local_tolerance2 = (tolerance / 10.0).powi(2);
        for &k in &chosen {
            self.refine_group(k, trial, &global, local_tolerance2);
        }
        chosen.len()
    }

    /// Up to [`LOCAL_STEPS`] Gauss–Newton steps of group `k`'s own
    /// unknowns in `state` (its global block prepared as `global`), each
    /// kept if it lowers the group's cost, until one's `δᵀHδ` is below
    /// `tolerance2`.
    fn refine_group(
        &mut self,
        k: usize,
        state: &mut State<C, P>,
        global: &Pr::Global,
        tolerance2: f64,
    ) {
        let points = self.problem.group_points(k);
        let chunk = Chunk {
            groups: k..k + 1,
            points: points.clone(),
        };
        let dg = DVector::zeros(state.global.len());
        let mut dc = [SVector::<f64, C>::zeros()];
        let mut dp = vec![SVector::<f64, P>::zeros(); points.len()];
        let mut share = [0.0];
        let Ok(mut cost) = self.group_cost(&chunk, state, global) else {
            return;
        };
        for _ in 0..LOCAL_STEPS {
            let ChunkedProblem {
                problem,
                pool,
                caches,
                ..
            } = self;
            let stepped = pool.with(|ws| {
                let (bufs, _, point_data) = ws.split();
                let out = ChunkOut {
                    groups: &mut dc,
                    points: &mut dp,
                    shares: &mut share,
                };
                back_substitute_chunk::<C, P, R, Pr>(
                    *problem,
                    &chunk,
                    state,
                    global,
                    &mut caches[points.clone()],
                    &dg,
                    0.0,
                    None,
                    bufs,
                    point_data,
                    out,
                )
            });
            // Stops at a NaN share too.
            let worth_it = share[0] > tolerance2;
            if stepped.is_err() || !worth_it {
                return;
            }
            let (group_before, points_before) =
                (state.groups[k], state.points[points.clone()].to_vec());
            state.groups[k] += dc[0];
            for (p, d) in state.points[points.clone()].iter_mut().zip(&dp) {
                *p += d;
            }
            match self.group_cost(&chunk, state, global) {
                Ok(lower) if lower < cost => cost = lower,
                _ => {
                    state.groups[k] = group_before;
                    state.points[points.clone()].copy_from_slice(&points_before);
                    return;
                }
            }
        }
    }

    /// The cost of the group of `chunk` at `state`: its points' rows and
    /// its and their priors.
    fn group_cost(
        &mut self,
        chunk: &Chunk,
        state: &State<C, P>,
        global: &Pr::Global,
    ) -> Result<f64, Failure> {
        let ChunkedProblem {
            problem,
            pool,
            caches,
            dims,
            ..
        } = self;
        let costs = pool.with(|ws| {
            let (bufs, _, _) = ws.split();
            eliminate_chunk::<C, P, R, _, _>(
                *problem,
                chunk,
                state,
                global,
                &mut caches[chunk.points.clone()],
                0.0,
                *dims,
                bufs,
                None,
                &mut CostOnly,
            )
        })?;
        Ok(costs.data + costs.prior)
    }
}

/// An elimination whose rows serve nothing: only its costs are read.
struct CostOnly;

impl<const C: usize, const P: usize, const R: usize, J> EliminationSink<C, P, R, J> for CostOnly {
    fn reduced_row(&mut self, _row: &[f64]) {}

    fn group_done(
        &mut self,
        _k: usize,
        _top: Option<&[f64]>,
        _prior: Option<&PriorRows<C>>,
        _data_cost: f64,
    ) {
    }
}
