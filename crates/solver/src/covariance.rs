//! Uncertainty at the final state: `Cov(g) = S⁻¹` of the undamped reduced
//! matrix, and the full marginal covariance of each group block,
//! `Cov(c) = R_cc⁻¹R_cc⁻ᵀ + K Cov(g) Kᵀ` with `K = R_cc⁻¹R_cg` from the
//! group's triangular rows (recomputed in one more pass over the points,
//! or given by the redundancy pass, [`crate::redundancy`]).
//! A fixed group is not an unknown: its sigmas are zero.

use nalgebra::{DMatrix, SVector};

use crate::chunked_problem::ChunkedProblem;
use crate::chunks::run_chunks;
use crate::eliminate::{EliminationSink, Failure, eliminate_chunk};
use crate::factor_product::{norm2, quadratic_forms};
use crate::iterate::status_of;
use crate::problem::{Problem, State};
use crate::qr::{PriorRows, solve_upper_in_place};
use crate::reduced::covariance_factor;
use crate::solution::Status;

/// Each group's marginal sigmas from its triangular rows, in the order the
/// groups are eliminated.
pub(crate) struct GroupSigmas<'a, const C: usize> {
    /// `L` with `Cov(g) = LLᵀ` ([`covariance_factor`]).
    factor: &'a [f64],
    /// `R_cc⁻¹` of the current group (`C × C`, row-major).
    inverse: Vec<f64>,
    /// `K = R_cc⁻¹R_cg` of the current group (`C × G`, row-major).
    gain: Vec<f64>,
    /// Room for `LᵀKᵀ` (`C × G`).
    z: Vec<f64>,
    pub(crate) out: Vec<SVector<f64, C>>,
}

impl<'a, const C: usize> GroupSigmas<'a, C> {
    /// For `groups` groups, given `L` (`G × G`) with `Cov(g) = LLᵀ`.
    pub(crate) fn new(factor: &'a [f64], g: usize, groups: usize) -> Self {
        Self {
            factor,
            inverse: vec![0.0; C * C],
            gain: vec![0.0; C * g],
            z: vec![0.0; C * g],
            out: Vec::with_capacity(groups),
        }
    }

    /// The sigmas of the next group, of triangular rows `top` (`None`: a
    /// fixed group, whose sigmas are zero).
    pub(crate) fn push(&mut self, top: Option<&[f64]>) {
        let sigma = match top {
            Some(top) => self.group_sigma(top),
            None => SVector::zeros(),
        };
        self.out.push(sigma);
    }

    /// Marginal sigmas of a group from its triangular rows `[R_cc | R_cg |
    /// z]` (row-major, `C` rows of width `C + G + 1` and any effects'
    /// columns, [`crate::effects`]): the roots of the diagonal of
    /// `R_cc⁻¹R_cc⁻ᵀ + K Cov(g) Kᵀ`, whose second term's `a`-th entry is
    /// `|Lᵀk_a|²` for row `k_a` of `K` ([`quadratic_forms`]).
    fn group_sigma(&mut self, top: &[f64]) -> SVector<f64, C> {
        let g = self.gain.len() / C;
        let w = top.len() / C;
        // R_cc⁻¹ and K = R_cc⁻¹R_cg, R_cc read where the triangle holds it.
        self.inverse.fill(0.0);
        for a in 0..C {
            self.inverse[a * C + a] = 1.0;
        }
        solve_upper_in_place(top, w, C, &mut self.inverse, C);
        for (a, k) in self.gain.chunks_exact_mut(g).enumerate() {
            k.copy_from_slice(&top[a * w + C..a * w + C + g]);
        }
        solve_upper_in_place(top, w, C, &mut self.gain, g);
        let spreads = quadratic_forms::<C>(self.factor, &self.gain, &mut self.z);
        let rows = self.inverse.chunks_exact(C);
        let mut sigmas = SVector::<f64, C>::zeros();
        for ((sigma, row), spread) in sigmas.iter_mut().zip(rows).zip(spreads) {
            *sigma = (norm2(row) + spread).sqrt();
        }
        sigmas
    }
}

/// Turns each group's triangular rows into its marginal sigmas.
struct SigmaSink<'a, const C: usize> {
    first_group: usize,
    sigmas: GroupSigmas<'a, C>,
}

impl<const C: usize, const P: usize, const R: usize, J> EliminationSink<C, P, R, J>
    for SigmaSink<'_, C>
{
    fn reduced_row(&mut self, _row: &[f64]) {}

    fn group_done(
        &mut self,
        k: usize,
        top: Option<&[f64]>,
        _prior: Option<&PriorRows<C>>,
        _data_cost: f64,
    ) {
        debug_assert_eq!(k, self.first_group + self.sigmas.out.len());
        self.sigmas.push(top);
    }
}

impl<const C: usize, const P: usize, const R: usize, Pr> ChunkedProblem<'_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// Marginal sigmas of every group at `state`, given `L` with `Cov(g) =
    /// LLᵀ` of the global block there ([`covariance_factor`]).
    pub(crate) fn group_sigmas(
        &mut self,
        state: &State<C, P>,
        factor: &[f64],
    ) -> Result<Vec<SVector<f64, C>>, Failure> {
        let problem = self.problem;
        let dims = self.dims;
        let mut sigmas = Vec::with_capacity(state.groups.len());
        let global = problem.prepare_global(&state.global);
        let global = &global;
        let (pool, jobs) = self.jobs();
        run_chunks(
            pool,
            jobs,
            |ws, (chunk, caches)| {
                let (bufs, _, _) = ws.split();
                let mut sink = SigmaSink {
                    first_group: chunk.groups.start,
                    sigmas: GroupSigmas::new(factor, dims.g, chunk.groups.len()),
                };
                eliminate_chunk::<C, P, R, _, _>(
                    problem, chunk, state, global, caches, 0.0, dims, bufs, None, &mut sink,
                )?;
                Ok(sink.sigmas.out)
            },
            |part| sigmas.extend(part),
        )?;
        Ok(sigmas)
    }
}

/// The marginal sigmas of every group of `problem` at `state`, given the
/// covariance `Cov(g)` of the global block there (what
/// [`Solution::group_sigmas`](crate::Solution::group_sigmas) holds): one
/// pass over the points. `caches` as [`linear_step`](crate::linear_step)
/// takes them. Fails with [`Status::InvalidProblem`] if the covariance is
/// not `G × G` and numerically positive definite.
pub fn group_sigmas<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    covariance: &DMatrix<f64>,
    caches: &mut Vec<Pr::PointCache>,
    groups_per_chunk: usize,
) -> Result<Vec<SVector<f64, C>>, Status> {
    let mut ctx = ChunkedProblem::new(problem, state, caches, groups_per_chunk)
        .map_err(|message| Status::InvalidProblem { message })?;
    let (_, factor) = covariance_factor(covariance, ctx.dims.g)?;
    ctx.group_sigmas(state, &factor)
        .map_err(|f| status_of(f, 0))
}
