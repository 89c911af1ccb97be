//! Uncertainty at the final state: `Cov(g) = S⁻¹` of the undamped reduced
//! matrix, and the full marginal covariance of each group block,
//! `Cov(c) = R_cc⁻¹R_cc⁻ᵀ + K Cov(g) Kᵀ` with `K = R_cc⁻¹R_cg` from the
//! group's triangular rows (recomputed in one more pass over the points,
//! or given by the redundancy pass, [`crate::redundancy`]).
//! A fixed group is not an unknown: its sigmas are zero.

use nalgebra::{Const, DMatrix, Dim, Dyn, Matrix, OMatrix, SMatrix, SVector, StorageMut};

use crate::chunked_problem::ChunkedProblem;
use crate::chunks::run_chunks;
use crate::eliminate::{EliminationSink, Failure, eliminate_chunk};
use crate::iterate::status_of;
use crate::problem::{Problem, State};
use crate::qr::PriorRows;
use crate::solution::Status;

/// Each group's marginal sigmas from its triangular rows, in the order the
/// groups are eliminated.
pub(crate) struct GroupSigmas<const C: usize> {
    /// `Cov(g)` transposed: column `l` holds row `l` of `Cov(g)`, so that
    /// `K Cov(g)` is formed a row of `Cov(g)` at a time.
    cov_rows: DMatrix<f64>,
    /// `K = R_cc⁻¹R_cg` of the current group (`C × G`).
    gain: OMatrix<f64, Const<C>, Dyn>,
    /// One row of `K Cov(g)` (`G`).
    gain_cov: Vec<f64>,
    /// One row of `K` (`G`), contiguous.
    gain_row: Vec<f64>,
    pub(crate) out: Vec<SVector<f64, C>>,
}

impl<const C: usize> GroupSigmas<C> {
    /// For `groups` groups, given `Cov(g)`.
    pub(crate) fn new(cov: &DMatrix<f64>, groups: usize) -> Self {
        Self {
            cov_rows: cov.transpose(),
            gain: OMatrix::zeros_generic(Const::<C>, Dyn(cov.nrows())),
            gain_cov: vec![0.0; cov.nrows()],
            gain_row: vec![0.0; cov.nrows()],
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
    /// `R_cc⁻¹R_cc⁻ᵀ + K Cov(g) Kᵀ`.
    fn group_sigma(&mut self, top: &[f64]) -> SVector<f64, C> {
        let g = self.cov_rows.nrows();
        let w = top.len() / C;
        let r_cc = SMatrix::<f64, C, C>::from_fn(|a, b| if b >= a { top[a * w + b] } else { 0.0 });
        let mut m = SMatrix::<f64, C, C>::identity();
        upper_solve(&r_cc, &mut m);
        let gain = &mut self.gain;
        for a in 0..C {
            for j in 0..g {
                gain[(a, j)] = top[a * w + C + j];
            }
        }
        upper_solve(&r_cc, gain);
        let (rows, kc, k) = (&self.cov_rows, &mut self.gain_cov, &mut self.gain_row);
        SVector::<f64, C>::from_fn(|a, _| {
            for (j, k) in k.iter_mut().enumerate() {
                *k = gain[(a, j)];
            }
            (m.row(a).norm_squared() + spread(rows.as_slice(), k, kc)).sqrt()
        })
    }
}

/// `kᵀ Cov(g) k` for a row `k` of `K`, `cov_rows` holding `Cov(g)` row by
/// row (`G × G`) and `kc` room for one row of `K Cov(g)`: `(k Cov(g))_j =
/// Σ_l k_l Cov(g)_lj`, summed over `l` in order for every `j` at once
/// (independent sums, which vectorise), then `Σ_j (k Cov(g))_j k_j`.
///
/// Compiled twice: for AVX2, chosen at run time where the machine has it
/// (four sums at a time instead of two), and for any x86-64. Both multiply
/// and add in the same order, without fused multiply-adds, so they give
/// the same bits.
#[allow(unsafe_code, reason = "the AVX2 build, called after the feature check")]
fn spread(cov_rows: &[f64], k: &[f64], kc: &mut [f64]) -> f64 {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the machine runs AVX2.
        return unsafe { spread_avx2(cov_rows, k, kc) };
    }
    spread_in(cov_rows, k, kc)
}

/// [`spread`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn spread_avx2(cov_rows: &[f64], k: &[f64], kc: &mut [f64]) -> f64 {
    spread_in(cov_rows, k, kc)
}

/// The body of [`spread`], inlined into each of its builds.
#[inline(always)]
fn spread_in(cov_rows: &[f64], k: &[f64], kc: &mut [f64]) -> f64 {
    let g = k.len();
    let Some(&k0) = k.first() else {
        return 0.0;
    };
    let (first, rest) = cov_rows.split_at(g);
    for (kc, &c) in kc.iter_mut().zip(first) {
        *kc = k0 * c;
    }
    for (row, &kl) in rest.chunks_exact(g).zip(&k[1..]) {
        for (kc, &c) in kc.iter_mut().zip(row) {
            *kc += kl * c;
        }
    }
    let mut spread = 0.0;
    for (&kc, &k) in kc.iter().zip(k) {
        spread += kc * k;
    }
    spread
}

/// Turns each group's triangular rows into its marginal sigmas.
struct SigmaSink<const C: usize> {
    first_group: usize,
    sigmas: GroupSigmas<C>,
}

impl<const C: usize, const P: usize, const R: usize, J> EliminationSink<C, P, R, J>
    for SigmaSink<C>
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

/// `B ← U⁻¹ B` for upper-triangular `U`.
fn upper_solve<const C: usize, N: Dim, S>(
    u: &SMatrix<f64, C, C>,
    b: &mut Matrix<f64, Const<C>, N, S>,
) where
    S: StorageMut<f64, Const<C>, N>,
{
    let n = b.ncols();
    for a in (0..C).rev() {
        for l in a + 1..C {
            let ual = u[(a, l)];
            for j in 0..n {
                b[(a, j)] -= ual * b[(l, j)];
            }
        }
        let inv = 1.0 / u[(a, a)];
        for j in 0..n {
            b[(a, j)] *= inv;
        }
    }
}

impl<const C: usize, const P: usize, const R: usize, Pr> ChunkedProblem<'_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// Marginal sigmas of every group at `state`, given the covariance of
    /// the global block there.
    pub(crate) fn group_sigmas(
        &mut self,
        state: &State<C, P>,
        cov: &DMatrix<f64>,
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
                    sigmas: GroupSigmas::new(cov, chunk.groups.len()),
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
/// takes them.
pub fn group_sigmas<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    covariance: &DMatrix<f64>,
    caches: &mut Vec<Pr::PointCache>,
    groups_per_chunk: usize,
) -> Result<Vec<SVector<f64, C>>, Status> {
    let mut ctx = ChunkedProblem::new(problem, state, caches, groups_per_chunk)
        .map_err(|message| Status::InvalidProblem { message })?;
    ctx.group_sigmas(state, covariance)
        .map_err(|f| status_of(f, 0))
}
