//! What stays fixed during a run: the problem, its chunking, the per-point
//! caches and the per-thread workspaces.

use crate::chunks::{Chunk, Dims, WorkspacePool, make_chunks, split_by};
use crate::problem::{Problem, State};

/// The chunks, each with the caches of its points.
pub(crate) type Jobs<'c, T> = Vec<(&'c Chunk, &'c mut [T])>;

/// A problem during one run, chunked: its chunks, their points' caches
/// and the per-thread workspaces.
pub(crate) struct ChunkedProblem<'a, const C: usize, const P: usize, const R: usize, Pr>
where
    Pr: Problem<C, P, R>,
{
    pub(crate) problem: &'a Pr,
    pub(crate) chunks: Vec<Chunk>,
    pub(crate) dims: Dims,
    pub(crate) pool: WorkspacePool,
    pub(crate) caches: &'a mut Vec<Pr::PointCache>,
    /// Each group's share of the last back-substituted step
    /// ([`crate::backsub`]): `−(b_cᵀδc + Σ b_pᵀδp)` over its own unknowns
    /// and its points'.
    pub(crate) group_shares: Vec<f64>,
}

impl<'a, const C: usize, const P: usize, const R: usize, Pr> ChunkedProblem<'a, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// Checks the problem's structure against `state` and sets up the run;
    /// `caches`: the points' caches, filled from the problem's
    /// [`Problem::initial_cache`] if empty, and updated by every pass.
    pub(crate) fn new(
        problem: &'a Pr,
        state: &State<C, P>,
        caches: &'a mut Vec<Pr::PointCache>,
        groups_per_chunk: usize,
    ) -> Result<Self, String> {
        let g = problem.global_size();
        if state.global.len() != g {
            return Err(format!(
                "the problem has {g} global unknowns but the state {}",
                state.global.len()
            ));
        }
        if let Some(prior) = problem.global_prior() {
            let (rows, columns) = prior.information.shape();
            if prior.mean.len() != g || rows != g || columns != g {
                return Err(format!(
                    "the global prior has a mean of {} values and a {rows} x {columns} information matrix, for {g} global unknowns",
                    prior.mean.len()
                ));
            }
        }
        if let Some(reason) = problem.loss().invalid() {
            return Err(format!("the loss {reason}"));
        }
        let n_groups = problem.n_groups();
        if state.groups.len() != n_groups {
            return Err(format!(
                "the problem has {n_groups} groups but the state {}",
                state.groups.len()
            ));
        }
        let chunks = make_chunks(
            |k| problem.group_points(k),
            n_groups,
            state.points.len(),
            groups_per_chunk,
        )?;
        if !state.is_finite() {
            return Err("the initial state is not finite".into());
        }
        if caches.is_empty() {
            caches.extend((0..state.points.len()).map(|i| problem.initial_cache(i)));
        }
        if caches.len() != state.points.len() {
            return Err(format!(
                "{} point caches for {} points",
                caches.len(),
                state.points.len()
            ));
        }
        let dims = Dims {
            g,
            c: C,
            p: P,
            r: R,
            effects: 0,
        };
        Ok(Self {
            problem,
            chunks,
            dims,
            pool: WorkspacePool::new(dims),
            caches,
            group_shares: vec![0.0; n_groups],
        })
    }

    /// The same, its passes carrying the problem's effects as extra
    /// right-hand sides ([`Problem::effects`]).
    pub(crate) fn carrying_effects(mut self) -> Self {
        self.dims.effects = self.problem.effects();
        self.pool = WorkspacePool::new(self.dims);
        self
    }

    /// The workspace pool, and the chunks with their slices of the caches.
    pub(crate) fn jobs(&mut self) -> (&WorkspacePool, Jobs<'_, Pr::PointCache>) {
        let slices = split_by(self.caches, self.chunks.iter().map(|c| c.points.len()));
        (&self.pool, self.chunks.iter().zip(slices).collect())
    }
}
