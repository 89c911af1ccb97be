//! Back-substitution: with `δg` known, every point is linearised again
//! ([`Problem::linearize_along`]: only `d_global δg` of the global Jacobian
//! is needed), its block reduced to `[d_point | d_group | r + d_global δg]`
//! and eliminated again; the group's triangle gives `δc`, each point's
//! triangle `δp`. Each group's share of the step's `−bᵀδ`, `−(b_cᵀδc +
//! Σ b_pᵀδp)` over its own unknowns and its points', goes to
//! [`ChunkedProblem::group_shares`]: for an undamped step, what the
//! group's unknowns contribute to `δᵀHδ` (up to their coupling with the
//! global block), which [`crate::refine`] reads. With local steps
//! ([`crate::local`]), each group's unknowns then move on from the linear
//! step against its points' anchors.

use nalgebra::{DVector, SVector};

use crate::chunked_problem::ChunkedProblem;
use crate::chunks::{Chunk, ElimBuffers, run_chunks, split_by};
use crate::eliminate::{
    Failure, GroupRows, add_group_column_norms2, batches, factor_point,
    push_group_prior_and_damping, stepped_row,
};
use crate::local::{LocalScratch, LocalSteps, local_steps};
use crate::problem::{BATCH, Linearization, Problem, State};
use crate::qr::{PriorRows, solve_upper_in_place};
use crate::reduced::ReducedSystem;
use crate::solution::BlockId;

/// Sums over the unknowns that the iteration needs from a step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct StepSummary {
    /// `|δ|²`.
    pub(crate) delta_norm2: f64,
    /// `|x|²`.
    pub(crate) state_norm2: f64,
    /// `bᵀδ`, with `b = Jᵀr + Λ (x − m)` the full gradient (half the gradient
    /// of the cost).
    pub(crate) gradient_dot: f64,
    /// `δᵀ (λ D) δ`, the damping actually applied.
    pub(crate) damping_quad: f64,
}

impl StepSummary {
    fn add(&mut self, o: &StepSummary) {
        self.delta_norm2 += o.delta_norm2;
        self.state_norm2 += o.state_norm2;
        self.gradient_dot += o.gradient_dot;
        self.damping_quad += o.damping_quad;
    }

    /// The decrease of the linearised cost model predicted for the step:
    /// `−2bᵀδ − δᵀHδ = −bᵀδ + δᵀ(λD)δ` since `(H + λD) δ = −b`.
    pub(crate) fn predicted_decrease(&self) -> f64 {
        -self.gradient_dot + self.damping_quad
    }

    /// `√(δᵀHδ)`, `H` the undamped normal matrix: `δᵀHδ = −bᵀδ − δᵀ(λD)δ`
    /// since `(H + λD) δ = −b` (rounding can make a vanishing step's
    /// negative: 0 then; NaN stays NaN). The step in standard deviations
    /// ([`IterationRecord::step_sigmas`](crate::IterationRecord::step_sigmas)).
    pub(crate) fn sigmas(&self) -> f64 {
        let quadratic = -self.gradient_dot - self.damping_quad;
        if quadratic < 0.0 {
            0.0
        } else {
            quadratic.sqrt()
        }
    }
}

impl<const C: usize, const P: usize, const R: usize, Pr> ChunkedProblem<'_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// Completes the step `δg` of `system` (built at `state`) to all unknowns
    /// and writes `δ` into `delta` (same shape as `state`); with `local`,
    /// each group's part of `δ` goes on with local steps (the summary
    /// stays the linear step's).
    pub(crate) fn back_substitute(
        &mut self,
        state: &State<C, P>,
        system: &ReducedSystem,
        dg: &DVector<f64>,
        local: Option<LocalSteps>,
        delta: &mut State<C, P>,
    ) -> Result<StepSummary, Failure> {
        let problem = self.problem;
        let lambda = system.lambda;
        let group_slices = split_by(
            &mut delta.groups,
            self.chunks.iter().map(|c| c.groups.len()),
        );
        let point_slices = split_by(
            &mut delta.points,
            self.chunks.iter().map(|c| c.points.len()),
        );
        let mut shares = std::mem::take(&mut self.group_shares);
        let share_slices = split_by(&mut shares, self.chunks.iter().map(|c| c.groups.len()));
        let (pool, jobs) = self.jobs();
        let jobs: Vec<_> = jobs
            .into_iter()
            .zip(group_slices)
            .zip(point_slices)
            .zip(share_slices)
            .map(|((((chunk, caches), groups), points), shares)| {
                (
                    chunk,
                    caches,
                    ChunkOut {
                        groups,
                        points,
                        shares,
                    },
                )
            })
            .collect();
        let mut total = StepSummary::default();
        let global = problem.prepare_global(&state.global);
        let global = &global;
        let passed = run_chunks(
            pool,
            jobs,
            |ws, (chunk, caches, out)| {
                let (bufs, _, point_data) = ws.split();
                back_substitute_chunk::<C, P, R, Pr>(
                    problem, chunk, state, global, caches, dg, lambda, local, bufs, point_data, out,
                )
            },
            |part| total.add(&part),
        );
        self.group_shares = shares;
        passed?;
        // The global block.
        let g = dg.len();
        let mut global = StepSummary {
            delta_norm2: dg.norm_squared(),
            state_norm2: state.global.norm_squared(),
            gradient_dot: 0.0,
            damping_quad: 0.0,
        };
        if let Some(prior) = problem.global_prior() {
            let e = &state.global - &prior.mean;
            for j in 0..g {
                for i in j..g {
                    let v = prior.information[(i, j)];
                    global.gradient_dot += v * e[j] * dg[i];
                    if i != j {
                        global.gradient_dot += v * e[i] * dg[j];
                    }
                }
            }
        }
        for (b, d) in system.observation_gradient.iter().zip(dg.iter()) {
            global.gradient_dot += b * d;
        }
        for j in 0..g {
            global.damping_quad += system.damping[j] * dg[j] * dg[j];
        }
        total.add(&global);
        delta.global.copy_from(dg);
        Ok(total)
    }
}

/// Where a chunk writes its `δ` and its groups' shares of `−bᵀδ`.
pub(crate) struct ChunkOut<'a, const C: usize, const P: usize> {
    pub(crate) groups: &'a mut [SVector<f64, C>],
    pub(crate) points: &'a mut [SVector<f64, P>],
    pub(crate) shares: &'a mut [f64],
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn back_substitute_chunk<const C: usize, const P: usize, const R: usize, Pr>(
    problem: &Pr,
    chunk: &Chunk,
    state: &State<C, P>,
    global: &Pr::Global,
    caches: &mut [Pr::PointCache],
    dg: &DVector<f64>,
    lambda: f64,
    local: Option<LocalSteps>,
    bufs: ElimBuffers<'_>,
    point_data: &mut Vec<f64>,
    out: ChunkOut<'_, C, P>,
) -> Result<StepSummary, Failure>
where
    Pr: Problem<C, P, R>,
{
    let ElimBuffers {
        point: point_buf,
        group: group_buf,
        ..
    } = bufs;
    // Group rows [d_group | t], t = r + d_global δg.
    let gw = C + 1;
    // Per point: P rows [R_pp⁻¹R_pc | R_pp⁻¹z_p], then b_p, then D_p.
    let tri = P * gw;
    let stride = tri + 2 * P;
    let mut group = GroupRows::<C>::new(group_buf, gw);
    let mut discard = |_: &[f64]| {};
    let mut sum = StepSummary::default();
    let mut lins: [_; BATCH] = std::array::from_fn(|_| Linearization::zeros(dg.len()));
    let mut steps = [SVector::<f64, R>::zeros(); BATCH];
    let mut workspace = Pr::Workspace::default();
    let loss = problem.loss();
    let robust = !loss.is_squared();
    let mut anchors = Vec::new();
    let mut scratch = LocalScratch::default();
    for k in chunk.groups.clone() {
        let c = &state.groups[k];
        let fixed = problem.group_is_fixed(k);
        let range = problem.group_points(k);
        point_data.clear();
        point_data.resize(range.len() * stride, 0.0);
        anchors.clear();
        anchors.resize(range.len(), Pr::Anchor::default());
        group.reset();
        let mut raw_norms2 = [0.0; C];
        let mut b_c = SVector::<f64, C>::zeros();
        for batch in batches(range.clone()) {
            let n = batch.len();
            let caches = &mut caches[chunk.local(&batch)];
            let points = &state.points[batch.clone()];
            let first = batch.start - range.start;
            problem
                .linearize_along_batch(
                    batch.start,
                    global,
                    c,
                    points,
                    caches,
                    dg,
                    &mut lins[..n],
                    &mut steps[..n],
                    &mut anchors[first..first + n],
                    &mut workspace,
                )
                .map_err(|(i, e)| Failure::linearize(i, &e))?;
            if robust {
                // The elimination's weights: the same residuals.
                for (lin, step) in lins[..n].iter_mut().zip(&mut steps[..n]) {
                    *step *= lin.weigh(loss).weight.sqrt();
                }
            }
            for (i, (lin, global_step)) in batch.zip(lins.iter().zip(&steps)) {
                let j = i - range.start;
                let p = &state.points[i];
                let prior = problem.point_prior(i).map(|pr| PriorRows::new(&pr, p));
                let mut b_p = lin.d_point.tr_mul(&lin.residual);
                if let Some(prior) = &prior {
                    b_p += prior.gradient();
                }
                b_c += lin.d_group.tr_mul(&lin.residual);
                sum.gradient_dot += lin.residual.dot(global_step);
                if lambda > 0.0 {
                    add_group_column_norms2(&lin.d_group, &mut raw_norms2);
                }
                let factor = factor_point(lin, prior.as_ref(), lambda, point_buf, 0)
                    .ok_or(Failure::Singular(BlockId::Point(i)))?;
                let m = factor.rows;
                let t = lin.residual + global_step;
                let (panel, q) = point_buf.split_at((R + 2 * P) * P);
                let entry = &mut point_data[j * stride..(j + 1) * stride];
                for a in 0..P {
                    stepped_row(
                        lin,
                        &t,
                        prior.as_ref(),
                        q,
                        m,
                        a,
                        &mut entry[a * gw..(a + 1) * gw],
                    );
                }
                solve_upper_in_place(panel, P, P, &mut entry[..tri], gw);
                entry[tri..tri + P].copy_from_slice(b_p.as_slice());
                entry[tri + P..].copy_from_slice(factor.damping.as_slice());
                if fixed {
                    continue;
                }
                for e in P..m {
                    let row = group.next_row(&mut discard);
                    stepped_row(lin, &t, prior.as_ref(), q, m, e, row);
                }
            }
        }
        // `b_cᵀδc + Σ b_pᵀδp`, the group's own part of `bᵀδ`.
        let mut local_dot = 0.0;
        let dc = if fixed {
            SVector::<f64, C>::zeros()
        } else {
            let prior = problem.group_prior(k).map(|pr| PriorRows::new(&pr, c));
            if let Some(prior) = &prior {
                b_c += prior.gradient();
            }
            let d_c = push_group_prior_and_damping(
                &mut group,
                prior.as_ref(),
                &[],
                raw_norms2,
                lambda,
                &mut discard,
            );
            let top = group
                .finish(&mut discard)
                .ok_or(Failure::Singular(BlockId::Group(k)))?;
            let mut z = [0.0; C];
            for (a, z) in z.iter_mut().enumerate() {
                *z = top[a * gw + C];
            }
            solve_upper_in_place(top, gw, C, &mut z, 1);
            let dc = SVector::<f64, C>::from_fn(|a, _| -z[a]);
            sum.delta_norm2 += dc.norm_squared();
            sum.state_norm2 += c.norm_squared();
            let group_dot = b_c.dot(&dc);
            sum.gradient_dot += group_dot;
            local_dot += group_dot;
            sum.damping_quad += lambda * d_c.component_mul(&dc).dot(&dc);
            dc
        };
        out.groups[k - chunk.groups.start] = dc;
        for (j, i) in range.clone().enumerate() {
            let entry = &point_data[j * stride..(j + 1) * stride];
            let dp = SVector::<f64, P>::from_fn(|a, _| {
                let row = &entry[a * gw..(a + 1) * gw];
                let mut v = row[C];
                for l in 0..C {
                    v += row[l] * dc[l];
                }
                -v
            });
            let b_p = SVector::<f64, P>::from_column_slice(&entry[tri..tri + P]);
            let d_p = SVector::<f64, P>::from_column_slice(&entry[tri + P..]);
            let p = &state.points[i];
            out.points[i - chunk.points.start] = dp;
            sum.delta_norm2 += dp.norm_squared();
            sum.state_norm2 += p.norm_squared();
            let point_dot = b_p.dot(&dp);
            sum.gradient_dot += point_dot;
            local_dot += point_dot;
            sum.damping_quad += lambda * d_p.component_mul(&dp).dot(&dp);
        }
        out.shares[k - chunk.groups.start] = -local_dot;
        if let Some(options) = local.filter(|_| !fixed) {
            let dp = &mut out.points[range.start - chunk.points.start..][..range.len()];
            let dc = &mut out.groups[k - chunk.groups.start];
            local_steps(
                problem,
                k,
                range,
                &anchors,
                state,
                dc,
                dp,
                options,
                &mut scratch,
            );
        }
    }
    Ok(sum)
}
