//! Redundancy numbers of the whitened residual rows at a state: the share
//! of each row's error that shows in its residual (Förstner & Wrobel,
//! "Photogrammetric Computer Vision", 2016, ch. 4), computed level by level
//! through the factors the elimination keeps, never from the full matrix.
//!
//! # Leverage and redundancy
//!
//! Let `A` be the whitened Jacobian of all `M` rows (data, global
//! observations, priors) over all `n` unknowns, `N = AᵀA` and
//! `Cov = N⁻¹`. The hat matrix `A N⁻¹ Aᵀ` projects onto the column space
//! of `A`, of rank `n`; its diagonal holds the rows' **leverages** `h_j` and
//!
//! ```text
//! r_j = 1 − h_j,   0 ≤ r_j ≤ 1,   Σ_j r_j = M − n,
//! ```
//!
//! their **redundancy numbers**: to first order the residual of row `j`
//! responds to an error `ε` in its observation by `r_j ε`, and has variance
//! `r_j`.
//!
//! # Through the levels
//!
//! The elimination keeps a block upper-triangular `𝓡` with `N = 𝓡ᵀ𝓡`:
//! each point's rows `[R_pp R_pc R_pg]`, each group's `[R_cc R_cg]`, and
//! `R_g` with `R_gᵀR_g = S` (Triggs et al., "Bundle adjustment — a modern
//! synthesis", 2000, for the Schur form). Then `h_j = |𝓡⁻ᵀ a_jᵀ|²`, solved
//! from the points down.
//!
//! The `m` rows of point `i` (`R` data rows, then `P` prior rows if it has
//! a prior) are transformed by the `Q` of its panel. Row `j` splits as
//!
//! ```text
//! a_j = Q₁[j,·] [R_pp R_pc R_pg]  +  q_j [0 E_c E_g],    q_j = Q₂[j,·],
//! ```
//!
//! with `[E_c E_g] = Q₂ᵀ[d_group d_global]` the point's `m − P` eliminated
//! rows. The first term is a combination of rows of `𝓡`: it puts `Q₁[j,·]`
//! in the point's slots of `𝓡⁻ᵀa_jᵀ`, of squared norm `1 − |q_j|²` since the
//! rows of `Q` are unit vectors. The second term goes on to the group and
//! the global level:
//!
//! ```text
//! y = R_cc⁻ᵀ E_cᵀ q_j,     u = Ũᵀ q_j,   Ũ = E_g − E_c K,   K = R_cc⁻¹R_cg,
//! h_j = (1 − |q_j|²) + |y|² + uᵀ Cov(g) u,
//! ```
//!
//! `u` being the row's reduced row and `Cov(g) = S⁻¹`. Hence
//!
//! ```text
//! r_j = |q_j|² − q_jᵀ M q_j,    M = E_c (R_ccᵀR_cc)⁻¹ E_cᵀ + Ũ Cov(g) Ũᵀ,
//! ```
//!
//! `M` (`(m − P) × (m − P)`) being the leverage of the point's eliminated
//! rows at the group and global levels. With `Cov(g) = LLᵀ`,
//! `M = VVᵀ`, where row `e` of `V` is `[R_cc⁻ᵀE_c[e,·]ᵀ | LᵀŨ[e,·]ᵀ]`. A
//! fixed group has no group level (`M = E_g Cov(g) E_gᵀ`); for `P = 0`,
//! `Q = I`. For three rows and two point unknowns, `Q₂` is the unit normal
//! `n` of the panel's columns: `r_j = n_j² (1 − M)`.
//!
//! The point's residuals have covariance `Q₂ (I − M) Q₂ᵀ`: they are
//! correlated (for `R = 3`, `P = 2`, all along `n`).
//!
//! A global observation row has `r_o = 1 − J_o[o,·] Cov(g) J_o[o,·]ᵀ`.
//!
//! # Global leverage (external reliability)
//!
//! An error `∇` in whitened row `j` moves the unknowns by `N⁻¹ a_jᵀ ∇`;
//! its global part is `Cov(g) u_j ∇` (Schur complement), `u_j = Ũᵀ q_j`
//! the row's reduced row. Measured in the global block's own noise, its
//! size is `∇ √(u_jᵀ Cov(g) u_j) = ∇ |z_j|`, `z_j = Lᵀ u_j = Σ_e q_j[e]
//! V[e, C..]`: the row's **global leverage** `|z_j|² = q_jᵀ V_g V_gᵀ q_j ≤
//! h_j` (`V_g` the global columns of `V`, whose Gram is part of `M`), a
//! by-product of the pass (for a global observation row it is its whole
//! leverage `1 − r_o`). With `∇` the row's minimal detectable bias `δ₀ / √r_j`, the
//! bias-to-noise ratio of the global block is `δ₀ √(|z_j|² / r_j)`
//! (Baarda 1968; Förstner and Wrobel 2016, section 4.6.5, whose
//! `δ₀ √((1 − r_j) / r_j)` is the same over all unknowns).
//!
//! # Priors
//!
//! Prior rows are rows too: a point's prior rows are rows `R..m` above, a
//! group's `[U_c | 0]` enter at the group level (`q = 1`, `E_c = U_c`,
//! `E_g = 0`). Their leverage sums over a block to `tr(Λ_b Cov(x_b))`,
//! whatever square root `U_b` of `Λ_b` is taken; the global prior's is
//! `tr(Λ_g Cov(g))`. Since all leverages sum to `n`,
//!
//! ```text
//! Σ_data r_j + Σ_obs r_o = m_data + m_obs − n + Σ_b tr(Λ_b Cov(x_b)).
//! ```
//!
//! # Cost
//!
//! One more pass over the points, like the group sigmas' pass: each
//! group's eliminated rows are kept until its triangle is known, then each
//! of its points costs `(m − P)` products with `Lᵀ` (`G²/2` each) and `R`
//! quadratic forms of size `m − P`.

use std::collections::VecDeque;
use std::ops::Range;

use nalgebra::{DMatrix, SMatrix, SVector};

use crate::chunked_problem::ChunkedProblem;
use crate::chunks::{Absorb, run_chunks_in_waves};
use crate::covariance::GroupSigmas;
use crate::effects::{EffectProjection, EffectSums};
use crate::eliminate::{EliminationSink, Failure, eliminate_chunk};
use crate::factor_product::{norm2, times_factor, times_factor_rows};
use crate::iterate::status_of;
use crate::problem::{BATCH, GlobalJacobian, Linearization, Problem, State};
use crate::qr::PriorRows;
use crate::reduced::covariance_factor;
use crate::solution::Status;

/// The numbers of one point's `R` data rows at a state, handed by
/// [`redundancy`] to its caller point by point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointRows<const R: usize> {
    /// `r_j` of each row.
    pub redundancy: SVector<f64, R>,
    /// The whitened residual `e_j` of each row (as [`normalised_residual`]
    /// takes it).
    pub residual: SVector<f64, R>,
    /// The global leverage `|z_j|²` of each row (module doc).
    pub global_leverage: SVector<f64, R>,
    /// The weight `w(u)` by which a robust loss ([`Problem::loss`]) scaled
    /// the point's rows by `√w` (the numbers above are the weighted
    /// rows'); 1 for least squares.
    pub weight: f64,
}

/// What [`redundancy`] returns besides the points' rows: the global
/// observation rows and the priors.
#[derive(Clone, Debug, PartialEq)]
pub struct Redundancy<const C: usize> {
    /// The marginal sigmas of every group (those of
    /// [`Solution::group_sigmas`](crate::Solution::group_sigmas)), from the
    /// same pass.
    pub group_sigmas: Vec<SVector<f64, C>>,
    /// `r_o` of each global observation row.
    pub global_observations: Vec<f64>,
    /// The global observations' whitened residuals at the state.
    pub global_observation_residuals: Vec<f64>,
    /// The leverage taken by the prior rows.
    pub prior_leverage: PriorLeverage,
    /// With a robust loss ([`Problem::loss`]), the weight of each global
    /// observation row (its observation's), by which the rows here are
    /// weighted; `None` for least squares.
    pub global_observation_weights: Option<Vec<f64>>,
    /// `n`, the number of unknowns: `G`, `C` per group that is not fixed,
    /// `P` per point.
    pub unknowns: usize,
    /// The problem's effects ([`Problem::effects`]) projected at the state
    /// ([`crate::effects`]), in order; none with a robust loss.
    pub effects: Vec<EffectProjection>,
}

/// Leverage of the prior rows, `Σ_b tr(Λ_b Cov(x_b))` over the blocks of
/// each level: the number of unknowns the priors determine.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PriorLeverage {
    /// Over the point priors.
    pub points: f64,
    /// Over the priors of the groups that are not fixed (a fixed group's
    /// prior touches no unknown).
    pub groups: f64,
    /// Of the global prior.
    pub global: f64,
}

impl PriorLeverage {
    /// Over all prior rows.
    pub fn total(&self) -> f64 {
        self.points + self.groups + self.global
    }

    fn add(&mut self, other: &PriorLeverage) {
        self.points += other.points;
        self.groups += other.groups;
        self.global += other.global;
    }
}

/// Chunks of the pass run in parallel while the caller is handed the
/// wave before: each chunk's points' rows (`3 R + 1` values a point) wait
/// for it, so that fewer chunks a wave than the other passes' keep them
/// small (about 0.5 MB a wave, two waves held, at 64 groups of 7 points a
/// chunk, `R = 3`).
const CHUNKS_PER_WAVE: usize = 16;

/// Redundancy at or below which a row counts as determined by the unknowns
/// it touches: its residual and its redundancy are both rounding noise.
pub const MIN_REDUNDANCY: f64 = 1e-10;

/// The normalised (studentised) residual `w_j = e_j / √r_j` of a row with
/// whitened residual `e_j` and redundancy number `r_j`: standard normal
/// for a correct model (Baarda's data snooping). `None` if `r_j ≤ 1e-10`
/// (a row that no other row checks).
///
/// Exact for one row at a time; the `R` rows of a point have correlated
/// residuals ([`redundancy`]), of which a per-row `w_j` is the row-wise
/// approximation (for `R = 3`, `P = 2` the point's three `|w_j|` are
/// equal).
pub fn normalised_residual(residual: f64, redundancy: f64) -> Option<f64> {
    (redundancy > MIN_REDUNDANCY).then(|| residual / redundancy.sqrt())
}

/// Redundancy numbers of every whitened row of `problem` at `state`, given
/// the covariance `Cov(g)` of the global block there (e.g.
/// [`Solution::covariance`](crate::Solution::covariance) with its state;
/// its lower triangle is read): one pass over the points, in chunks of
/// `groups_per_chunk` groups, bit-identical for any number of threads.
/// Each point's rows go to `visit`, in the order of the points, as each
/// wave of chunks ends (nothing per point is kept here: the caller keeps
/// what it needs of them); the global observation rows and the priors'
/// leverage are returned, and the groups' marginal sigmas (the
/// elimination gives them along the way, as a solve's final pass would;
/// a caller that asks for both spares that pass with
/// [`SolverOptions::group_sigmas`](crate::SolverOptions::group_sigmas)).
/// `caches` as [`linear_step`](crate::linear_step)
/// takes them. Fails with the [`Status`] a solve would end with at this
/// state, or [`Status::InvalidProblem`] if the covariance is not `G × G`
/// and numerically positive definite. With a least-squares loss the
/// pass carries the problem's effects ([`Problem::effects`]) and projects
/// them ([`Redundancy::effects`]).
pub fn redundancy<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    covariance: &DMatrix<f64>,
    caches: &mut Vec<Pr::PointCache>,
    groups_per_chunk: usize,
    visit: impl FnMut(&PointRows<R>),
) -> Result<Redundancy<C>, Status> {
    let invalid = |message: String| Status::InvalidProblem { message };
    let mut ctx = ChunkedProblem::new(problem, state, caches, groups_per_chunk).map_err(invalid)?;
    if problem.loss().is_squared() {
        ctx = ctx.carrying_effects();
    }
    let g = ctx.dims.g;
    let (symmetric, factor) = covariance_factor(covariance, g)?;
    let (observations, weighed) = ctx
        .global_observations(&state.global)
        .map_err(|f| status_of(f, 0))?;
    let (mut prior_leverage, group_sigmas, mut effect_sums) = ctx
        .point_redundancy(state, &factor, visit)
        .map_err(|f| status_of(f, 0))?;
    let k = ctx.dims.effects;
    let mut mean_effects = DMatrix::zeros(g, k);
    let mut observation_effects = DMatrix::zeros(observations.residual.len(), k);
    problem.global_effects(&mut mean_effects, &mut observation_effects);
    effect_sums.add_global(
        problem.global_prior(),
        &state.global,
        &mean_effects,
        &observations,
        &observation_effects,
    );
    let mut z = vec![0.0; g];
    let global_observations = (0..observations.residual.len())
        .map(|o| {
            let row: Vec<f64> = observations.jacobian.row(o).iter().copied().collect();
            times_factor(&factor, &row, &mut z);
            1.0 - norm2(&z)
        })
        .collect();
    if let Some(prior) = problem.global_prior() {
        // tr(Λ Cov), both symmetric, from their lower triangles.
        let mut trace = 0.0;
        for j in 0..g {
            trace += prior.information[(j, j)] * symmetric[(j, j)];
            for i in j + 1..g {
                trace += 2.0 * prior.information[(i, j)] * symmetric[(i, j)];
            }
        }
        prior_leverage.global = trace;
    }
    let free_groups = (0..problem.n_groups())
        .filter(|&k| !problem.group_is_fixed(k))
        .count();
    Ok(Redundancy {
        group_sigmas,
        global_observations,
        global_observation_residuals: observations.residual.iter().copied().collect(),
        global_observation_weights: weighed.map(|weighed| weighed.weights),
        prior_leverage,
        unknowns: g + C * free_groups + P * state.points.len(),
        effects: effect_sums.projections(&symmetric),
    })
}

impl<const C: usize, const P: usize, const R: usize, Pr> ChunkedProblem<'_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// The redundancy of every point's rows, handed to `visit` in the
    /// order of the points, the leverage of the point and group priors,
    /// every group's marginal sigmas and the effects' sums over the
    /// reduced rows at `state`, given `L` with `Cov(g) = LLᵀ` (row-major,
    /// lower triangular).
    fn point_redundancy(
        &mut self,
        state: &State<C, P>,
        factor: &[f64],
        mut visit: impl FnMut(&PointRows<R>),
    ) -> Result<(PriorLeverage, Vec<SVector<f64, C>>, EffectSums), Failure> {
        let problem = self.problem;
        let dims = self.dims;
        let mut prior_leverage = PriorLeverage::default();
        let mut effects = EffectSums::new(dims.g, dims.effects);
        let mut group_sigmas = Vec::with_capacity(state.groups.len());
        let global = problem.prepare_global(&state.global);
        let global = &global;
        let (pool, jobs) = self.jobs();
        run_chunks_in_waves(
            pool,
            jobs,
            CHUNKS_PER_WAVE,
            Absorb::BesideNextWave,
            |ws, (chunk, caches)| {
                let (bufs, _, rows) = ws.split();
                // Room for the largest group: nothing grows per point.
                let largest = chunk.groups.clone().map(|k| problem.group_points(k).len());
                let largest = largest.max().unwrap_or(0);
                rows.clear();
                rows.reserve(largest * R * dims.group_width());
                let mut sink =
                    RedundancySink::new(factor, dims.g, rows, largest, chunk.points.len(), false);
                sink.sigmas = Some(GroupSigmas::new(factor, dims.g, chunk.groups.len()));
                sink.effects = Some(EffectSums::new(dims.g, dims.effects));
                eliminate_chunk::<C, P, R, _, _>(
                    problem, chunk, state, global, caches, 0.0, dims, bufs, None, &mut sink,
                )?;
                let sigmas = sink.sigmas.map_or_else(Vec::new, |s| s.out);
                Ok((sink.prior_leverage, sink.out, sigmas, sink.effects))
            },
            |(part, points, sigmas, part_effects)| {
                prior_leverage.add(&part);
                points.iter().for_each(&mut visit);
                group_sigmas.extend(sigmas);
                if let Some(part_effects) = &part_effects {
                    effects.add(part_effects);
                }
            },
        )?;
        Ok((prior_leverage, group_sigmas, effects))
    }
}

/// What a point of the current group leaves until the group's triangle is
/// known: the `Q₂` rows of its data and prior rows; its eliminated rows
/// are in [`RedundancySink::rows`].
struct PendingPoint<const P: usize, const R: usize> {
    /// `m − P`, the number of eliminated rows (at most `R`, undamped).
    eliminated: usize,
    /// `q_j` of the data rows (columns `0..eliminated`).
    data: SMatrix<f64, R, R>,
    /// `q_j` of the prior rows, if the point has a prior.
    prior: Option<SMatrix<f64, P, R>>,
}

/// Turns each group's points into their redundancy numbers once the
/// group's triangle is known.
pub(crate) struct RedundancySink<'a, const C: usize, const P: usize, const R: usize> {
    /// `L` with `Cov(g) = LLᵀ`, `G × G` row-major, lower triangular.
    factor: &'a [f64],
    g: usize,
    /// The eliminated rows `[E_c | E_g | ·]` of the current group's points,
    /// row-major, width `C + G + 1`.
    rows: &'a mut Vec<f64>,
    /// The current group's points, in order.
    points: Vec<PendingPoint<P, R>>,
    /// The robust loss's weights of the points weighed and not yet
    /// factorised (a batch at most), in order, each with its point.
    weighed: VecDeque<(usize, f64)>,
    /// `V` of one point: a row `[y | Lᵀu]` (`C + G` values) per eliminated
    /// row.
    coordinates: Vec<f64>,
    /// Scratch for the reduced rows `u` of a point (`R × G` values).
    reduced: Vec<f64>,
    /// Scratch for the `z_j` of one point's data rows (`R × G` values).
    z: Vec<f64>,
    /// The rows of the chunk's points so far: a point's residuals and
    /// weight from its factorisation, its redundancy and global leverage
    /// once its group is done.
    pub(crate) out: Vec<PointRows<R>>,
    /// If asked ([`crate::influence`]), `z_j` of every row of the points of
    /// `out`: `G` values a row, `R` rows a point.
    pub(crate) global_z: Option<Vec<f64>>,
    /// If asked ([`redundancy`]), the marginal sigmas of the chunk's
    /// groups.
    pub(crate) sigmas: Option<GroupSigmas<'a, C>>,
    /// If asked ([`redundancy`]), the effects' sums over the chunk's
    /// reduced rows.
    pub(crate) effects: Option<EffectSums>,
    prior_leverage: PriorLeverage,
}

impl<'a, const C: usize, const P: usize, const R: usize> RedundancySink<'a, C, P, R> {
    /// A sink for a chunk of `points` points whose largest group has
    /// `largest` points, given `L` (`G × G`) and the workspace's `rows`;
    /// keeping each row's `z_j` if `global_z`.
    pub(crate) fn new(
        factor: &'a [f64],
        g: usize,
        rows: &'a mut Vec<f64>,
        largest: usize,
        points: usize,
        global_z: bool,
    ) -> Self {
        Self {
            factor,
            g,
            rows,
            points: Vec::with_capacity(largest),
            weighed: VecDeque::with_capacity(BATCH),
            // A group's eliminated rows, and `R` more (module doc of
            // `point_leverages`' scratch).
            coordinates: vec![0.0; (largest + 1) * R * (C + g)],
            reduced: vec![0.0; (largest + 1) * R * g],
            z: vec![0.0; R * g],
            out: Vec::with_capacity(points),
            global_z: global_z.then(|| Vec::with_capacity(points * R * g)),
            sigmas: None,
            effects: None,
            prior_leverage: PriorLeverage::default(),
        }
    }
}

impl<const C: usize, const P: usize, const R: usize, J> EliminationSink<C, P, R, J>
    for RedundancySink<'_, C, P, R>
where
    J: GlobalJacobian<R>,
{
    fn reduced_row(&mut self, row: &[f64]) {
        if let Some(effects) = &mut self.effects {
            effects.add_row(row);
        }
    }

    fn point_weighed(&mut self, i: usize, weight: f64) {
        self.weighed.push_back((i, weight));
    }

    fn point_factorised(
        &mut self,
        i: usize,
        lin: &Linearization<C, P, R, J>,
        prior: Option<&PriorRows<P>>,
        q: &[f64],
        m: usize,
    ) {
        let eliminated = m - P;
        debug_assert!(eliminated <= R, "point {i} is damped");
        let column = |row: usize, e: usize| {
            if e < eliminated {
                q[row * m + P + e]
            } else {
                0.0
            }
        };
        let weight = match self.weighed.front() {
            Some(&(j, weight)) if j == i => {
                self.weighed.pop_front();
                weight
            }
            _ => 1.0,
        };
        self.out.push(PointRows {
            redundancy: SVector::zeros(),
            residual: lin.residual,
            global_leverage: SVector::zeros(),
            weight,
        });
        self.points.push(PendingPoint {
            eliminated,
            data: SMatrix::from_fn(column),
            prior: prior.map(|_| SMatrix::from_fn(|a, e| column(R + a, e))),
        });
    }

    fn point_row(&mut self, row: &[f64]) {
        self.rows.extend_from_slice(row);
    }

    fn group_done(
        &mut self,
        _k: usize,
        top: Option<&[f64]>,
        prior: Option<&PriorRows<C>>,
        _data_cost: f64,
    ) {
        if let Some(sigmas) = &mut self.sigmas {
            sigmas.push(top);
        }
        let done = self.out.len() - self.points.len();
        point_leverages::<C, P, R>(GroupPoints {
            level: GroupLevel {
                top,
                factor: self.factor,
                g: self.g,
            },
            rows: self.rows,
            points: &self.points,
            prior,
            out: &mut self.out[done..],
            global_z: self.global_z.as_mut(),
            scratch: Scratch {
                coordinates: &mut self.coordinates,
                reduced: &mut self.reduced,
                z: &mut self.z,
            },
            prior_leverage: &mut self.prior_leverage,
        });
        self.points.clear();
        self.rows.clear();
    }
}

/// The group and global levels of a group's points: its triangle `top`
/// (`[R_cc | R_cg | z_c]`, none for a fixed group) and `L` (`G × G`,
/// row-major) with `Cov(g) = LLᵀ`.
struct GroupLevel<'a> {
    top: Option<&'a [f64]>,
    factor: &'a [f64],
    g: usize,
}

/// The scratch of [`point_leverages`]: `V` of a group's eliminated rows
/// (rows of `C + G`), their reduced rows (rows of `G`), each with room
/// for `R` rows past the group's (read, and their sums dropped, by a point
/// whose Gram is formed over all `R`), and the `z_j` of a point's data
/// rows (`R × G`).
struct Scratch<'a> {
    coordinates: &'a mut [f64],
    reduced: &'a mut [f64],
    z: &'a mut [f64],
}

/// A group's points done, as [`point_leverages`] takes them: their
/// levels, their eliminated `rows` (`[E_c | E_g | ·]`, width `C + G + 1`,
/// the points' in order), the points, the group's prior rows (if any),
/// where the points' numbers go, the `z_j` kept if asked, the scratch, and
/// the sums of the prior rows' leverage.
struct GroupPoints<'a, const C: usize, const P: usize, const R: usize> {
    level: GroupLevel<'a>,
    rows: &'a [f64],
    points: &'a [PendingPoint<P, R>],
    prior: Option<&'a PriorRows<C>>,
    out: &'a mut [PointRows<R>],
    global_z: Option<&'a mut Vec<f64>>,
    scratch: Scratch<'a>,
    prior_leverage: &'a mut PriorLeverage,
}

/// Each point of a group done ([`GroupPoints`]): `V` (a row `[R_cc⁻ᵀ
/// E_c[e,·]ᵀ | LᵀŨ[e,·]ᵀ]` per eliminated row), `M = V_c V_cᵀ + V_g
/// V_gᵀ` (the Grams of its group's and its global columns), each data
/// row's `r_j = |q_j|² − q_jᵀ M q_j` and global leverage `|z_j|² =
/// q_jᵀ V_g V_gᵀ q_j`, `z_j = Σ_e q_j[e] V[e, C..]` (module doc) into
/// `out`; each `z_j`, formed only then, onto `global_z` if kept; the
/// leverage `1 − r` of the points' prior rows
/// added to `prior_leverage.points`, then that of the group's prior rows
/// `[U_c | 0]` (`|R_cc⁻ᵀ U_cᵀ|² + |LᵀŨ|²` a row) to `prior_leverage.groups`.
///
/// Compiled twice: for AVX2, chosen at run time where the machine has it
/// (the products with `L` and `R_cg` four wide instead of two), and for
/// any x86-64. Both multiply and add in the same order, so they give the
/// same bits.
#[allow(unsafe_code, reason = "the AVX2 build, called after the feature check")]
fn point_leverages<const C: usize, const P: usize, const R: usize>(work: GroupPoints<'_, C, P, R>) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the machine runs AVX2.
        return unsafe { point_leverages_avx2::<C, P, R>(work) };
    }
    point_leverages_in::<C, P, R>(work);
}

/// [`point_leverages`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn point_leverages_avx2<const C: usize, const P: usize, const R: usize>(
    work: GroupPoints<'_, C, P, R>,
) {
    point_leverages_in::<C, P, R>(work);
}

/// The body of [`point_leverages`], inlined into each of its builds.
#[inline(always)]
fn point_leverages_in<const C: usize, const P: usize, const R: usize>(
    work: GroupPoints<'_, C, P, R>,
) {
    let GroupPoints {
        level,
        rows,
        points,
        prior,
        out,
        mut global_z,
        scratch,
        prior_leverage,
    } = work;
    let g = level.g;
    let (w, cw) = (C + g + 1, C + g);
    let Scratch {
        coordinates,
        reduced,
        z,
    } = scratch;
    // The group coordinates `y` of all the group's eliminated rows (their
    // divisions independent of one another), their reduced rows `u`, then
    // `Lᵀu` of them all at once.
    let eliminated: usize = points.iter().map(|point| point.eliminated).sum();
    let eliminated_rows = || rows.chunks_exact(w).take(eliminated).enumerate();
    for (e, row) in eliminated_rows() {
        let y = &mut coordinates[e * cw..e * cw + C];
        match level.top {
            Some(top) => group_coordinates::<C>(top, &row[..C], y),
            None => y.fill(0.0),
        }
    }
    for (e, row) in eliminated_rows() {
        let u = &mut reduced[e * g..(e + 1) * g];
        u.copy_from_slice(&row[C..C + g]);
        if let Some(top) = level.top {
            reduce_row::<C>(top, &coordinates[e * cw..e * cw + C], u);
        }
    }
    times_factor_all(level.factor, g, &reduced[..eliminated * g], coordinates, C);
    let mut first_row = 0;
    for (point, out) in points.iter().zip(out) {
        let n = point.eliminated;
        let v = &coordinates[first_row * cw..];
        first_row += n;
        // M = V_c V_cᵀ + V_g V_gᵀ, the group's and the global columns of V.
        let m_group = eliminated_gram::<R>(n, v, cw, 0..C);
        let m_global = eliminated_gram::<R>(n, v, cw, C..cw);
        let m = m_group + m_global;
        out.redundancy = SVector::from(std::array::from_fn(|r| {
            row_redundancy(&point.data, r, &m, n)
        }));
        // |z_j|² = q_jᵀ V_g V_gᵀ q_j, z_j = Σ_e q_j[e] V[e, C..].
        out.global_leverage = SVector::from(std::array::from_fn(|r| {
            quadratic_form(&point.data, r, &m_global, n)
        }));
        if let Some(zs) = global_z.as_mut() {
            for (r, z_r) in z.chunks_exact_mut(g).enumerate() {
                z_r.fill(0.0);
                for e in 0..n {
                    let q = point.data[(r, e)];
                    let v = &v[e * cw + C..(e + 1) * cw];
                    for (z, v) in z_r.iter_mut().zip(v) {
                        *z += q * v;
                    }
                }
            }
            zs.extend_from_slice(z);
        }
        if let Some(q) = &point.prior {
            for a in 0..P {
                prior_leverage.points += 1.0 - row_redundancy(q, a, &m, n);
            }
        }
    }
    if let (Some(top), Some(prior)) = (level.top, prior) {
        // The rows [U_c | 0]: q = 1, E_c = U_c, E_g = 0; through `Lᵀ` `R`
        // at a time, as a point's rows.
        for first in (0..C).step_by(R) {
            let rows = R.min(C - first);
            for (e, u) in reduced.chunks_exact_mut(g).take(rows).enumerate() {
                let u_row: [f64; C] = std::array::from_fn(|b| prior.sqrt[(first + e, b)]);
                let y = &mut coordinates[e * cw..e * cw + C];
                u.fill(0.0);
                group_coordinates::<C>(top, &u_row, y);
                reduce_row::<C>(top, y, u);
            }
            times_factor_all(level.factor, g, &reduced[..rows * g], coordinates, C);
            for row in coordinates.chunks_exact(cw).take(rows) {
                let (y, z) = row.split_at(C);
                prior_leverage.groups += norm2(y) + norm2(z);
            }
        }
    }
}

/// `M = VVᵀ` over the columns `columns` of a point's `n` eliminated rows,
/// the first rows of `v` (rows of `width`): [`gram_rows`] over those rows
/// alone when `n` is one or two (a touch by its coordinates without an
/// angle prior has three rows, one eliminated), else over `R` rows (`v`
/// holds them). The entries kept get the same sums in the same order
/// whatever `n`.
#[inline(always)]
fn eliminated_gram<const R: usize>(
    n: usize,
    v: &[f64],
    width: usize,
    columns: Range<usize>,
) -> SMatrix<f64, R, R> {
    /// The first `N` rows alone, `M` in the top left of an `R × R` zero.
    #[inline(always)]
    fn first<const R: usize, const N: usize>(
        v: &[f64],
        width: usize,
        columns: Range<usize>,
    ) -> SMatrix<f64, R, R> {
        let mut m = SMatrix::<f64, R, R>::zeros();
        m.fixed_view_mut::<N, N>(0, 0)
            .copy_from(&gram_rows::<N>(v, N, width, columns));
        m
    }
    match n {
        1 if R > 1 => first::<R, 1>(v, width, columns),
        2 if R > 2 => first::<R, 2>(v, width, columns),
        _ => gram_rows::<R>(v, n, width, columns),
    }
}

/// Rows of `Lᵀu` at a time in [`times_factor_all`]: with
/// [`FACTOR_BLOCK`] columns, the sums of four rows in eight AVX2
/// registers, each row of `L` read once for all of them.
const ROWS_AT_ONCE: usize = 4;

/// `z_e = Lᵀu_e` for every row `u_e` of `reduced` (rows of `G`), into
/// columns `offset..offset + G` of the rows of `out` (rows of `offset +
/// G`): [`ROWS_AT_ONCE`] rows at a time, then the rest together
/// ([`times_factor_rows`]), so that a group's touches, one eliminated row
/// each, share the reads of `L`. Each row gets the sums of
/// [`times_factor`], whatever rows it goes with.
#[inline(always)]
fn times_factor_all(factor: &[f64], g: usize, reduced: &[f64], out: &mut [f64], offset: usize) {
    let width = offset + g;
    let rows = reduced.len() / g;
    let mut r = 0;
    while r < rows {
        let (reduced, out) = (&reduced[r * g..], &mut out[r * width..]);
        let at_once = ROWS_AT_ONCE.min(rows - r);
        let reduced = &reduced[..at_once * g];
        match at_once {
            1 => times_factor_rows::<1>(factor, reduced, out, offset),
            2 => times_factor_rows::<2>(factor, reduced, out, offset),
            3 => times_factor_rows::<3>(factor, reduced, out, offset),
            _ => times_factor_rows::<ROWS_AT_ONCE>(factor, reduced, out, offset),
        }
        r += at_once;
    }
}

/// `r_j = |q_j|² − q_jᵀ M q_j` for row `j` of `q` (its first `n` values).
fn row_redundancy<const K: usize, const R: usize>(
    q: &SMatrix<f64, K, R>,
    j: usize,
    m: &SMatrix<f64, R, R>,
    n: usize,
) -> f64 {
    let length2: f64 = (0..n).fold(0.0, |sum, e| sum + q[(j, e)] * q[(j, e)]);
    length2 - quadratic_form(q, j, m, n)
}

/// `q_jᵀ M q_j` for row `j` of `q` (its first `n` values).
#[inline(always)]
fn quadratic_form<const K: usize, const R: usize>(
    q: &SMatrix<f64, K, R>,
    j: usize,
    m: &SMatrix<f64, R, R>,
    n: usize,
) -> f64 {
    let mut form = 0.0;
    for e in 0..n {
        let mut mq = 0.0;
        for f in 0..n {
            mq += m[(e, f)] * q[(j, f)];
        }
        form += q[(j, e)] * mq;
    }
    form
}

/// The group coordinates `y = R_cc⁻ᵀ a_c` of a row `[a_c | a_g]` at the
/// group level of the triangle `top` (`[R_cc | R_cg | z_c]`, row-major,
/// `C` rows of width `C + G + 1` and any effects' columns), into `y`.
/// Inlined, so that [`point_leverages`]' AVX2 build has its own.
#[inline(always)]
fn group_coordinates<const C: usize>(top: &[f64], a_c: &[f64], y: &mut [f64]) {
    let w = top.len() / C;
    for a in 0..C {
        let mut s = a_c[a];
        for l in 0..a {
            s -= top[l * w + a] * y[l];
        }
        y[a] = s / top[a * w + a];
    }
}

/// The reduced row `u ← u − R_cgᵀ y` of a row whose global part `a_g` `u`
/// holds on entry, `y` its [`group_coordinates`] in the triangle `top`:
/// `a_g − Kᵀa_c` on return. Inlined, as [`group_coordinates`].
#[inline(always)]
fn reduce_row<const C: usize>(top: &[f64], y: &[f64], u: &mut [f64]) {
    let w = top.len() / C;
    for (a, &y) in y.iter().enumerate() {
        let r_cg = &top[a * w + C..a * w + C + u.len()];
        for (u, r) in u.iter_mut().zip(r_cg) {
            *u -= r * y;
        }
    }
}

/// Partial sums that each entry of [`gram_rows`] keeps side by side, a
/// column in turn to each: independent chains of additions, so that the
/// sum of a 33-column row does not wait on the latency of each addition.
const PARTIAL_SUMS: usize = 4;

/// `M = V Vᵀ` over the columns `columns` of the first `n` rows of `v`
/// (`R` rows of `width`; `M` zero beyond the first `n`): each entry
/// [`partial_dot`]'s sum in the same order, the entries' sums side by side
/// (independent chains rather than one after another), over all `R` rows
/// so that the loops unroll (the sums of rows from `n` on are dropped).
#[inline(always)]
fn gram_rows<const R: usize>(
    v: &[f64],
    n: usize,
    width: usize,
    columns: Range<usize>,
) -> SMatrix<f64, R, R> {
    let rows: [&[f64]; R] =
        std::array::from_fn(|e| &v[e * width..(e + 1) * width][columns.clone()]);
    /// Column `k` of the rows into partial sum `lane` of every entry.
    #[inline(always)]
    fn add<const R: usize>(
        sums: &mut [[[f64; PARTIAL_SUMS]; R]; R],
        rows: &[&[f64]; R],
        k: usize,
        lane: usize,
    ) {
        for e in 0..R {
            let ve = rows[e][k];
            for f in 0..=e {
                sums[e][f][lane] += ve * rows[f][k];
            }
        }
    }
    let mut sums = [[[-0.0; PARTIAL_SUMS]; R]; R];
    let whole = columns.len() - columns.len() % PARTIAL_SUMS;
    for first in (0..whole).step_by(PARTIAL_SUMS) {
        // The four columns' products of an entry side by side, one vector
        // operation where the build has one: lane `l` takes column
        // `first + l`, as `add` would.
        for e in 0..R {
            let ve = &rows[e][first..first + PARTIAL_SUMS];
            for f in 0..=e {
                let vf = &rows[f][first..first + PARTIAL_SUMS];
                for lane in 0..PARTIAL_SUMS {
                    sums[e][f][lane] += ve[lane] * vf[lane];
                }
            }
        }
    }
    for k in whole..columns.len() {
        add(&mut sums, &rows, k, k - whole);
    }
    let mut m = SMatrix::<f64, R, R>::zeros();
    for e in 0..n {
        for f in 0..=e {
            let entry = combined(&sums[e][f]);
            m[(e, f)] = entry;
            m[(f, e)] = entry;
        }
    }
    m
}

/// The total of [`PARTIAL_SUMS`] partial sums, in pairs.
#[inline(always)]
fn combined(partial: &[f64; PARTIAL_SUMS]) -> f64 {
    (partial[0] + partial[1]) + (partial[2] + partial[3])
}

/// `aᵀb` as [`gram_rows`] sums each entry: column `k` into partial sum `k
/// mod` [`PARTIAL_SUMS`], then [`combined`].
#[cfg(test)]
fn partial_dot(a: &[f64], b: &[f64]) -> f64 {
    let mut sums = [-0.0; PARTIAL_SUMS];
    for (k, (x, y)) in a.iter().zip(b).enumerate() {
        sums[k % PARTIAL_SUMS] += x * y;
    }
    combined(&sums)
}

/// `aᵀb`, summed in order.
#[cfg(test)]
fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normalised_residual_divides_by_the_root_of_the_redundancy() {
        assert_eq!(normalised_residual(1.5, 0.25), Some(3.0));
        assert_eq!(normalised_residual(-2.0, 1.0), Some(-2.0));
        assert_eq!(normalised_residual(1e-9, 1e-11), None);
        assert_eq!(normalised_residual(0.0, -1e-16), None);
    }

    /// The sums side by side give the bits of [`partial_dot`], one entry
    /// after another, over any range of columns; and, summed in another
    /// order, what [`dot`] gives within its rounding.
    #[test]
    fn side_by_side_sums_give_the_bits_of_one_at_a_time() {
        let width = 37;
        let v: Vec<f64> = (0..3 * width)
            .map(|i| ((i * 7919 % 1013) as f64 - 506.0) * 1.37e-3)
            .collect();
        let row =
            |e: usize, columns: &Range<usize>| &v[e * width..(e + 1) * width][columns.clone()];
        for columns in [0..width, 0..3, 3..width, 5..6] {
            for n in 0..=3 {
                let m = gram_rows::<3>(&v, n, width, columns.clone());
                for e in 0..3 {
                    for f in 0..3 {
                        let (a, b) = (row(e, &columns), row(f, &columns));
                        let expected = if e < n && f < n {
                            partial_dot(a, b)
                        } else {
                            0.0
                        };
                        let what = format!("n = {n}, ({e}, {f}), columns {columns:?}");
                        assert_eq!(m[(e, f)].to_bits(), expected.to_bits(), "{what}");
                        if e < n && f < n {
                            let bound =
                                1e-15 * columns.len() as f64 * norm2(a).sqrt() * norm2(b).sqrt();
                            assert!((m[(e, f)] - dot(a, b)).abs() <= bound, "{what}");
                        }
                    }
                }
            }
        }
    }

    /// A point's `M` over its eliminated rows alone gives the bits of the
    /// Gram of all `R` rows, for every `n`.
    #[test]
    fn the_eliminated_rows_alone_give_the_bits_of_all_rows() {
        let width = 37;
        let value = |i: usize| ((i * 7919 % 1013) as f64 - 506.0) * 1.37e-3;
        let v: Vec<f64> = (0..3 * width).map(value).collect();
        for columns in [0..width, 0..3, 3..width] {
            for n in 0..=3 {
                let expected = gram_rows::<3>(&v, n, width, columns.clone());
                let m = eliminated_gram::<3>(n, &v, width, columns.clone());
                for (a, b) in m.iter().zip(expected.iter()) {
                    assert_eq!(a.to_bits(), b.to_bits(), "n = {n}, columns {columns:?}: M");
                }
            }
        }
    }

    /// `|z_j|²` as the quadratic form `q_jᵀ V_g V_gᵀ q_j` and
    /// `r_j = |q_j|² − q_jᵀ M q_j` agree with `z_j = Σ_e q_j[e] V_g[e]`
    /// formed and squared, and with `M = VVᵀ` over all columns, within
    /// rounding.
    #[test]
    fn leverages_from_the_split_gram_match_the_rows_formed() {
        let (c, width) = (3, 36);
        let value = |i: usize| ((i * 7919 % 1013) as f64 - 506.0) * 1.37e-3;
        let v: Vec<f64> = (0..3 * width).map(value).collect();
        let q = SMatrix::<f64, 3, 3>::new(0.6, -0.3, 0.2, 0.5, 0.7, -0.1, -0.4, 0.2, 0.9);
        for n in 1..=3 {
            let m_global = eliminated_gram::<3>(n, &v, width, c..width);
            let m = eliminated_gram::<3>(n, &v, width, 0..c) + m_global;
            let full = eliminated_gram::<3>(n, &v, width, 0..width);
            for j in 0..3 {
                let z: Vec<f64> = (c..width)
                    .map(|k| (0..n).map(|e| q[(j, e)] * v[e * width + k]).sum())
                    .collect();
                let leverage = quadratic_form(&q, j, &m_global, n);
                let scale = norm2(&v);
                assert!(
                    (leverage - norm2(&z)).abs() <= 1e-14 * scale,
                    "n = {n}, row {j}"
                );
                let (split, whole) = (
                    row_redundancy(&q, j, &m, n),
                    row_redundancy(&q, j, &full, n),
                );
                assert!((split - whole).abs() <= 1e-14 * scale, "n = {n}, row {j}");
            }
        }
    }

    /// The blocked product, which skips the zero rows of each column
    /// block, gives the bits of the row-by-row reference, for sizes with
    /// and without a partial block, and with zeros and `−0` in `u`.
    #[test]
    fn blocked_factor_product_gives_the_reference_bits() {
        let mut seed = 0x9e37_79b9_7f4a_7c15_u64;
        let mut next = || {
            seed = seed
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for g in [1, 7, 8, 9, 33, 40] {
            let mut factor = vec![0.0; g * g];
            for i in 0..g {
                for k in 0..=i {
                    factor[i * g + k] = next();
                }
            }
            let mut reduced: Vec<f64> = (0..3 * g).map(|_| next()).collect();
            reduced[0] = 0.0;
            reduced[g - 1] = -0.0;
            let offset = 2;
            let mut out = vec![f64::NAN; 3 * (offset + g)];
            times_factor_rows::<3>(&factor, &reduced, &mut out, offset);
            let expected = |e: usize, reduced: &[f64]| {
                let mut z = vec![0.0; g];
                times_factor(&factor, &reduced[e * g..(e + 1) * g], &mut z);
                z
            };
            let check = |out: &[f64], rows: usize, reduced: &[f64], what: &str| {
                for e in 0..rows {
                    let row = &out[e * (offset + g) + offset..(e + 1) * (offset + g)];
                    for (a, b) in row.iter().zip(&expected(e, reduced)) {
                        assert_eq!(a.to_bits(), b.to_bits(), "{what}: G = {g}, row {e}");
                    }
                }
            };
            check(&out, 3, &reduced, "3 rows");
            // A group's rows, four at a time and the rest together.
            let many: Vec<f64> = (0..9 * g).map(|_| next()).collect();
            for rows in 1..=9 {
                let mut out = vec![f64::NAN; (rows + 1) * (offset + g)];
                times_factor_all(&factor, g, &many[..rows * g], &mut out, offset);
                check(&out, rows, &many, &format!("{rows} rows at once"));
            }
        }
    }
}
