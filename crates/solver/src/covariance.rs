//! Uncertainty at the final state: `Cov(g) = S⁻¹` of the undamped reduced
//! matrix, and the full marginal covariance of each group block,
//! `Cov(c) = R_cc⁻¹R_cc⁻ᵀ + K Cov(g) Kᵀ` with `K = R_cc⁻¹R_cg` from the
//! group's triangular rows (recomputed in one more pass over the points).

use nalgebra::{SMatrix, SVector};

use crate::chunks::run_ordered;
use crate::context::Context;
use crate::eliminate::{EliminationSink, Failure, eliminate_chunk};
use crate::problem::{Problem, State};

/// Turns each group's triangular rows into its marginal sigmas.
struct SigmaSink<'a, const G: usize, const C: usize> {
    cov: &'a SMatrix<f64, G, G>,
    first_group: usize,
    out: Vec<SVector<f64, C>>,
}

impl<const G: usize, const C: usize> EliminationSink for SigmaSink<'_, G, C> {
    fn reduced_row(&mut self, _row: &[f64]) {}

    fn group_done(&mut self, k: usize, top: &[f64], _data_cost: f64) {
        debug_assert_eq!(k, self.first_group + self.out.len());
        self.out.push(group_sigma(top, self.cov));
    }
}

/// Marginal sigmas of a group from its triangular rows `[R_cc | R_cg | z]`
/// (row-major, width `C + G + 1`) and the global covariance.
pub(crate) fn group_sigma<const G: usize, const C: usize>(
    top: &[f64],
    cov: &SMatrix<f64, G, G>,
) -> SVector<f64, C> {
    let w = C + G + 1;
    let r_cc = SMatrix::<f64, C, C>::from_fn(|a, b| if b >= a { top[a * w + b] } else { 0.0 });
    let r_cg = SMatrix::<f64, C, G>::from_fn(|a, j| top[a * w + C + j]);
    let m = upper_solve(&r_cc, SMatrix::<f64, C, C>::identity());
    let k = upper_solve(&r_cc, r_cg);
    let kc = k * cov;
    SVector::<f64, C>::from_fn(|a, _| (m.row(a).norm_squared() + kc.row(a).dot(&k.row(a))).sqrt())
}

/// `U⁻¹ B` for upper-triangular `U`.
fn upper_solve<const C: usize, const N: usize>(
    u: &SMatrix<f64, C, C>,
    mut b: SMatrix<f64, C, N>,
) -> SMatrix<f64, C, N> {
    for a in (0..C).rev() {
        for l in a + 1..C {
            let ual = u[(a, l)];
            for j in 0..N {
                b[(a, j)] -= ual * b[(l, j)];
            }
        }
        let inv = 1.0 / u[(a, a)];
        for j in 0..N {
            b[(a, j)] *= inv;
        }
    }
    b
}

impl<const G: usize, const C: usize, const P: usize, const R: usize, Pr> Context<'_, G, C, P, R, Pr>
where
    Pr: Problem<G, C, P, R>,
{
    /// Marginal sigmas of every group at `state`, given the covariance of
    /// the global block there.
    pub(crate) fn group_sigmas(
        &mut self,
        state: &State<G, C, P>,
        cov: &SMatrix<f64, G, G>,
    ) -> Result<Vec<SVector<f64, C>>, Failure> {
        let problem = self.problem;
        let dims = self.dims;
        let mut sigmas = Vec::with_capacity(state.groups.len());
        let mut failure = None;
        let global = problem.prepare_global(&state.global);
        let global = &global;
        let (pool, jobs) = self.jobs();
        run_ordered(
            jobs,
            |(chunk, caches)| {
                pool.with(|ws| {
                    let (bufs, _, _) = ws.split();
                    let mut sink = SigmaSink {
                        cov,
                        first_group: chunk.groups.start,
                        out: Vec::with_capacity(chunk.groups.len()),
                    };
                    eliminate_chunk::<G, C, P, R, _, _>(
                        problem, chunk, state, global, caches, 0.0, dims, bufs, None, &mut sink,
                    )?;
                    Ok(sink.out)
                })
            },
            |result: Result<Vec<SVector<f64, C>>, Failure>| match result {
                Ok(part) => {
                    sigmas.extend(part);
                    true
                }
                Err(f) => {
                    failure.get_or_insert(f);
                    false
                }
            },
        );
        match failure {
            Some(f) => Err(f),
            None => Ok(sigmas),
        }
    }
}
