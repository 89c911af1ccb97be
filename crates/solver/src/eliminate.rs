//! Point and group elimination in square-root form: a small Householder QR
//! of each point's panel (its rows restricted to the point columns) gives an
//! explicit `Q`, whose nullspace part `Q₂ᵀ` turns the point's rows into
//! point-eliminated rows; a QR on the group columns of a group's stacked rows
//! eliminates the group; what remains (global columns and residual only) is
//! multiplied into the chunk's reduced matrix (`AᵀA`, [`add_gram_lower`]).

use std::ops::Range;

use nalgebra::{SMatrix, SVector, Vector3};

use crate::chunks::{Chunk, Dims, ElimBuffers};
use crate::gram::add_gram_lower;
use crate::point_panel::{panel_normal, panel_qr, prior_panel_qr};
use crate::problem::{BATCH, GlobalJacobian, Linearization, Problem, State};
use crate::qr::{PriorRows, RANK_TOLERANCE, householder_rows, triangle_has_full_rank};
use crate::solution::BlockId;

/// Levenberg–Marquardt diagonal entries are clamped to this range (as in
/// Ceres), so that a parameter without information is still damped.
pub(crate) const MIN_DIAGONAL: f64 = 1e-6;
/// See [`MIN_DIAGONAL`].
pub(crate) const MAX_DIAGONAL: f64 = 1e32;

/// The Marquardt scaling of one unknown from its diagonal entry of the normal
/// matrix.
pub(crate) fn damping_diagonal(normal_diagonal: f64) -> f64 {
    normal_diagonal.clamp(MIN_DIAGONAL, MAX_DIAGONAL)
}

/// Why a pass over the points stopped. `point`: the failing point, `None`
/// for the global observations.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Failure {
    /// The problem's evaluation returned an error.
    Linearize {
        point: Option<usize>,
        message: String,
    },
    /// The problem's evaluation returned a non-finite value.
    NonFinite { point: Option<usize> },
    /// A point or group block is rank deficient.
    Singular(BlockId),
}

impl Failure {
    pub(crate) fn linearize(point: usize, error: &impl std::fmt::Display) -> Self {
        Failure::Linearize {
            point: Some(point),
            message: error.to_string(),
        }
    }
}

/// One point's panel `[d_point; U_p; √(λ D_p)]` (its data, prior and
/// damping rows restricted to the point columns), factorised: `Qᵀ · panel =
/// [R_pp; 0]` with `Q` explicit. Row `e` of `Qᵀ` applied to the point's full
/// rows gives, for `e < P`, the point's back-substitution rows and, for
/// `e ≥ P`, its point-eliminated rows (zero in the point columns): the rows of
/// `Q₂ᵀ`, `Q₂ = Q[:, P..]`, span the left nullspace of the panel.
pub(crate) struct PointFactor<const P: usize> {
    /// Rows of the panel: `R` data rows, then `P` prior rows if any, then `P`
    /// damping rows if damped.
    pub(crate) rows: usize,
    /// The damping diagonal `D_p` (zero when undamped).
    pub(crate) damping: SVector<f64, P>,
}

/// Builds and factorises the panel of a point into `buf` (the panel, `m × P`
/// row-major, then `Q`, `m × m` row-major, at offset `(R + 2P) · P`; only
/// the columns from `first_column` on are formed; for 3 data rows and 2
/// point unknowns, undamped, in closed form by [`panel_normal`] and
/// [`panel_qr`], or with the point's prior by [`prior_panel_qr`] where it
/// takes the panel). Returns `None` if the panel is rank deficient.
pub(crate) fn factor_point<const C: usize, const P: usize, const R: usize, J>(
    lin: &Linearization<C, P, R, J>,
    prior: Option<&PriorRows<P>>,
    lambda: f64,
    buf: &mut [f64],
    first_column: usize,
) -> Option<PointFactor<P>> {
    let (panel, q) = buf.split_at_mut((R + 2 * P) * P);
    if P == 0 {
        identity(&mut q[..R * R], R);
        return Some(PointFactor {
            rows: R,
            damping: SVector::zeros(),
        });
    }
    if R == 3 && P == 2 && lambda == 0.0 {
        let column = |j| Vector3::from_fn(|r, _| lin.d_point[(r, j)]);
        let (c1, c2) = (column(0), column(1));
        if let Some(prior) = prior {
            // With the prior's two rows, the common case of the paper
            // prior's angles: in closed form where the panel is well
            // conditioned.
            let s = [prior.sqrt[(0, 0)], prior.sqrt[(0, 1)], prior.sqrt[(1, 1)]];
            let q = &mut q[..(R + P) * (R + P)];
            if prior_panel_qr(&c1, &c2, s, panel, q, first_column) {
                return Some(PointFactor {
                    rows: R + P,
                    damping: SVector::zeros(),
                });
            }
        } else {
            // Three data rows and two point unknowns, the common case, in
            // closed form: the eliminated row, and for the
            // back-substitution the rest of `Q` and `R`.
            let q = &mut q[..R * R];
            let full_rank = panel_normal(&c1, &c2, q);
            if first_column < P {
                panel_qr(&c1, &c2, panel, q);
            }
            return full_rank.then_some(PointFactor {
                rows: R,
                damping: SVector::zeros(),
            });
        }
    }
    let (panel, _) = panel.as_chunks_mut::<P>();
    let mut m = 0;
    for r in 0..R {
        for j in 0..P {
            panel[m][j] = lin.d_point[(r, j)];
        }
        m += 1;
    }
    if let Some(prior) = prior {
        for a in 0..P {
            for j in 0..P {
                panel[m][j] = if j >= a { prior.sqrt[(a, j)] } else { 0.0 };
            }
            m += 1;
        }
    }
    let mut norms2 = [0.0; P];
    for row in &panel[..m] {
        for j in 0..P {
            norms2[j] += row[j] * row[j];
        }
    }
    let mut damping = SVector::<f64, P>::zeros();
    if lambda > 0.0 {
        for j in 0..P {
            damping[j] = damping_diagonal(norms2[j]);
            let d = lambda * damping[j];
            panel[m] = [0.0; P];
            panel[m][j] = d.sqrt();
            norms2[j] += d;
            m += 1;
        }
    }
    if m < P {
        return None;
    }
    let panel = &mut panel[..m];
    if m == R {
        // Data rows only (no prior, undamped), the common case: the same
        // code with a length known at compile time, so that its loops
        // unroll.
        householder_q(&mut panel[..R], &mut q[..R * R], first_column);
    } else if m == R + P {
        // Data and prior rows, undamped (the paper prior's angles): the
        // same, unrolled.
        householder_q(
            &mut panel[..R + P],
            &mut q[..(R + P) * (R + P)],
            first_column,
        );
    } else {
        householder_q(panel, &mut q[..m * m], first_column);
    }
    let full_rank = (0..P).all(|j| {
        norms2[j] > 0.0 && panel[j][j] * panel[j][j] > RANK_TOLERANCE * RANK_TOLERANCE * norms2[j]
    });
    for (r, row) in panel.iter_mut().enumerate() {
        for x in row.iter_mut().take(r) {
            *x = 0.0;
        }
    }
    full_rank.then_some(PointFactor { rows: m, damping })
}

#[inline(always)]
fn identity(q: &mut [f64], m: usize) {
    q.fill(0.0);
    for i in 0..m {
        q[i * m + i] = 1.0;
    }
}

/// [`point_householder`] of the panel, then its `Q` (`m × m`, row-major)
/// into `q` by [`point_q`]. Inlined, so that a constant panel length
/// reaches the loops.
#[inline(always)]
fn householder_q<const P: usize>(panel: &mut [[f64; P]], q: &mut [f64], first_column: usize) {
    let tau = point_householder(panel);
    point_q(panel, &tau, q, first_column);
}

/// Householder QR of an `m × P` panel (`m ≥ P`): `R` on and above the
/// diagonal, the reflectors `v_j` below it (unit diagonal implicit); returns
/// the `τ_j` (`H_j = I − τ_j v_j v_jᵀ`).
#[inline(always)]
fn point_householder<const P: usize>(panel: &mut [[f64; P]]) -> [f64; P] {
    let mut tau = [0.0; P];
    for j in 0..P {
        let mut sigma = 0.0;
        for row in &panel[j + 1..] {
            sigma += row[j] * row[j];
        }
        if sigma == 0.0 {
            continue;
        }
        let alpha = panel[j][j];
        let norm = (alpha * alpha + sigma).sqrt();
        let beta = if alpha > 0.0 { -norm } else { norm };
        tau[j] = (beta - alpha) / beta;
        let inv = 1.0 / (alpha - beta);
        let (head, tail) = panel.split_at_mut(j + 1);
        let top = &mut head[j];
        for row in tail.iter_mut() {
            row[j] *= inv;
        }
        top[j] = beta;
        for c in j + 1..P {
            let mut s = top[c];
            for row in tail.iter() {
                s += row[j] * row[c];
            }
            s *= tau[j];
            top[c] -= s;
            for row in tail.iter_mut() {
                row[c] -= s * row[j];
            }
        }
    }
    tau
}

/// `Q = H_0 ⋯ H_{P−1}` (`m × m`, row-major) from [`point_householder`],
/// columns `first_column..m` only (the others are left as the identity's).
#[inline(always)]
fn point_q<const P: usize>(panel: &[[f64; P]], tau: &[f64; P], q: &mut [f64], first_column: usize) {
    let m = panel.len();
    identity(q, m);
    for j in (0..P).rev() {
        if tau[j] == 0.0 {
            continue;
        }
        for c in j.max(first_column)..m {
            let mut s = q[j * m + c];
            for r in j + 1..m {
                s += panel[r][j] * q[r * m + c];
            }
            s *= tau[j];
            q[j * m + c] -= s;
            for r in j + 1..m {
                q[r * m + c] -= s * panel[r][j];
            }
        }
    }
}

/// Writes `Σ_r c_r d[r, ·]` into `out` (`C` values): a combination of the
/// rows of a point's group Jacobian.
#[inline(always)]
pub(crate) fn combine_group_rows<const R: usize, const C: usize>(
    d: &SMatrix<f64, R, C>,
    c: &[f64; R],
    out: &mut [f64],
) {
    for (j, o) in out.iter_mut().enumerate().take(C) {
        let column = d.column(j);
        *o = (0..R).map(|r| c[r] * column[r]).sum();
    }
}

/// Adds the squared column norms of a point's group Jacobian to `out`.
pub(crate) fn add_group_column_norms2<const R: usize, const C: usize>(
    d: &SMatrix<f64, R, C>,
    out: &mut [f64; C],
) {
    for (o, column) in out.iter_mut().zip(d.column_iter()) {
        *o += column.norm_squared();
    }
}

/// The coefficients `Q[0..R, e]` of the data rows in row `e` of `Qᵀ`.
fn q_column<const R: usize>(q: &[f64], m: usize, e: usize) -> [f64; R] {
    let mut c = [0.0; R];
    for (r, c) in c.iter_mut().enumerate() {
        *c = q[r * m + e];
    }
    c
}

/// Writes row `e` of `Qᵀ [d_group | d_global | r]` (prior rows contributing
/// their residual) into `out` (`C + G + 1` values).
pub(crate) fn eliminated_row<
    const C: usize,
    const P: usize,
    const R: usize,
    J: GlobalJacobian<R>,
>(
    lin: &Linearization<C, P, R, J>,
    prior: Option<&PriorRows<P>>,
    q: &[f64],
    m: usize,
    e: usize,
    out: &mut [f64],
) {
    let c = q_column::<R>(q, m, e);
    let (last, out) = out.split_last_mut().expect("a row has a residual");
    combine_group_rows(&lin.d_group, &c, &mut out[..C]);
    lin.d_global.combine_rows(&c, &mut out[C..]);
    *last = residual_combination(&c, &lin.residual, prior, q, m, e);
}

/// `Σ_r c_r t_r + Σ_a Q[R + a, e] e_a`: a residual column `t` of the data
/// rows, and the prior rows' residual `e`.
pub(crate) fn residual_combination<const P: usize, const R: usize>(
    c: &[f64; R],
    t: &SVector<f64, R>,
    prior: Option<&PriorRows<P>>,
    q: &[f64],
    m: usize,
    e: usize,
) -> f64 {
    let mut s = 0.0;
    for r in 0..R {
        s += c[r] * t[r];
    }
    if let Some(prior) = prior {
        for a in 0..P {
            s += q[(R + a) * m + e] * prior.residual[a];
        }
    }
    s
}

/// Row `e` of `Qᵀ c` for each effect's column `c` of the data rows
/// ([`Problem::point_effects`]; the point priors do not move) into `out`
/// (one value per effect).
pub(crate) fn effect_row<const P: usize, const R: usize>(
    effects: &[SVector<f64, R>],
    q: &[f64],
    m: usize,
    e: usize,
    out: &mut [f64],
) {
    let c = q_column::<R>(q, m, e);
    for (o, t) in out.iter_mut().zip(effects) {
        *o = residual_combination::<P, R>(&c, t, None, q, m, e);
    }
}

/// Row `e` of `Qᵀ [d_group | t]` (prior rows contributing their residual)
/// into `out` (`C + 1` values).
pub(crate) fn stepped_row<const C: usize, const P: usize, const R: usize, J>(
    lin: &Linearization<C, P, R, J>,
    t: &SVector<f64, R>,
    prior: Option<&PriorRows<P>>,
    q: &[f64],
    m: usize,
    e: usize,
    out: &mut [f64],
) {
    let c = q_column::<R>(q, m, e);
    combine_group_rows(&lin.d_group, &c, &mut out[..C]);
    out[C] = residual_combination(&c, t, prior, q, m, e);
}

/// The rows of one group being eliminated: a row-major buffer whose first
/// `C` rows, after each fold, are the running triangular factor. When the
/// buffer is full the rows are folded: a QR on the group columns, the rows
/// below the triangle (zero in the group columns) are emitted, and only the
/// triangle stays.
pub(crate) struct GroupRows<'w, const C: usize> {
    buf: &'w mut [f64],
    width: usize,
    capacity: usize,
    rows: usize,
}

impl<'w, const C: usize> GroupRows<'w, C> {
    pub(crate) fn new(buf: &'w mut [f64], width: usize) -> Self {
        let capacity = buf.len() / width;
        debug_assert!(capacity > C);
        Self {
            buf,
            width,
            capacity,
            rows: 0,
        }
    }

    /// Starts the next group.
    pub(crate) fn reset(&mut self) {
        self.rows = 0;
    }

    /// A slot for the next row (its old contents must be overwritten).
    pub(crate) fn next_row(&mut self, emit: &mut impl FnMut(&[f64])) -> &mut [f64] {
        if self.rows == self.capacity {
            self.fold(emit);
        }
        let w = self.width;
        self.rows += 1;
        &mut self.buf[(self.rows - 1) * w..self.rows * w]
    }

    /// QR on the group columns; emits the trailing columns (from column `C`)
    /// of the rows below the triangle.
    fn fold(&mut self, emit: &mut impl FnMut(&[f64])) {
        let w = self.width;
        householder_rows::<C>(self.buf, self.rows, w);
        for r in C..self.rows {
            emit(&self.buf[r * w + C..(r + 1) * w]);
        }
        self.rows = self.rows.min(C);
    }

    /// Folds the remaining rows; returns the group's triangular rows
    /// `[R_cc | R_c… | z_c]` (`C` rows of the buffer's width), or `None` if
    /// the group block is rank deficient.
    pub(crate) fn finish(&mut self, emit: &mut impl FnMut(&[f64])) -> Option<&[f64]> {
        self.fold(emit);
        let w = self.width;
        triangle_has_full_rank(self.buf, self.rows, w, C).then(|| &self.buf[..C * w])
    }
}

/// Writes the prior rows `[U | 0 | e | −U ∂m/∂t …]` (`effects`: the
/// prior mean's `∂m/∂t` of each effect carried, [`Problem::group_prior_effects`])
/// and (if damped) the damping rows of a
/// group into `group`; `raw_norms2` holds `Σ |d_group column|²` of the group's
/// data rows (used for the damping diagonal). Returns the damping diagonal
/// `D_c` (zero when undamped).
pub(crate) fn push_group_prior_and_damping<const C: usize>(
    group: &mut GroupRows<'_, C>,
    prior: Option<&PriorRows<C>>,
    effects: &[SVector<f64, C>],
    mut raw_norms2: [f64; C],
    lambda: f64,
    emit: &mut impl FnMut(&[f64]),
) -> SVector<f64, C> {
    if let Some(prior) = prior {
        for row in 0..C {
            let dst = group.next_row(emit);
            dst.fill(0.0);
            for j in row..C {
                dst[j] = prior.sqrt[(row, j)];
                raw_norms2[j] += prior.sqrt[(row, j)] * prior.sqrt[(row, j)];
            }
            let residual = dst.len() - 1 - effects.len();
            prior_row_effects(prior, effects, row, &mut dst[residual..]);
        }
    }
    let mut diagonal = SVector::<f64, C>::zeros();
    if lambda > 0.0 {
        for j in 0..C {
            diagonal[j] = damping_diagonal(raw_norms2[j]);
            let dst = group.next_row(emit);
            dst.fill(0.0);
            dst[j] = (lambda * diagonal[j]).sqrt();
        }
    }
    diagonal
}

/// The tail `[e_a | −(U ∂m/∂t)_a …]` of a group's prior row `a` (its
/// residual, then each effect's column) into `out`.
fn prior_row_effects<const C: usize>(
    prior: &PriorRows<C>,
    effects: &[SVector<f64, C>],
    a: usize,
    out: &mut [f64],
) {
    out[0] = prior.residual[a];
    for (o, dm) in out[1..].iter_mut().zip(effects) {
        *o = -(a..C).map(|j| prior.sqrt[(a, j)] * dm[j]).sum::<f64>();
    }
}

/// Costs accumulated over a chunk.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Costs {
    /// `Σ |r_i|²` (of the rows weighted by a robust loss).
    pub(crate) data: f64,
    /// The points' term of a robust loss, `Σ 2 d ρ(u_i)` ([`crate::Loss`]);
    /// 0 for least squares.
    pub(crate) loss: f64,
    /// Point and group prior terms.
    pub(crate) prior: f64,
    /// The prior terms of fixed groups (part of `prior`): rows without an
    /// unknown, which no reduced row carries.
    pub(crate) fixed_prior: f64,
}

/// Receives what the elimination of a chunk produces, for a problem with
/// `C` group and `P` point unknowns, `R` rows per point and global
/// Jacobians `J`.
pub(crate) trait EliminationSink<const C: usize, const P: usize, const R: usize, J> {
    /// One reduced row `[A_g | a]` (`G + 1` values), and the effects'
    /// columns if the pass carries them ([`crate::effects`]).
    fn reduced_row(&mut self, row: &[f64]);
    /// Point `i`'s rows were weighted by `weight` (a robust loss only,
    /// [`Linearization::weigh`]), before it is factorised. Default: nothing.
    fn point_weighed(&mut self, i: usize, weight: f64) {
        let _ = (i, weight);
    }
    /// Point `i` is factorised: its linearisation, its prior rows, and the
    /// `Q` of its panel (`m × m`, row-major, [`factor_point`]; only the
    /// columns `P..m` are formed). Default: nothing.
    fn point_factorised(
        &mut self,
        i: usize,
        lin: &Linearization<C, P, R, J>,
        prior: Option<&PriorRows<P>>,
        q: &[f64],
        m: usize,
    ) {
        let _ = (i, lin, prior, q, m);
    }
    /// One of the point's eliminated rows `[E_c | E_g | r]` (`C + G + 1`
    /// values, [`eliminated_row`]), in order, after
    /// [`EliminationSink::point_factorised`]. Default: nothing.
    fn point_row(&mut self, row: &[f64]) {
        let _ = row;
    }
    /// Group `k` is done: its triangular rows `[R_cc | R_cg | z_c]`
    /// (row-major, `C` rows of width `C + G + 1` and the effects' columns,
    /// [`Dims::group_width`]; `None` for a fixed group,
    /// which has none), its prior rows, and its points' data cost
    /// `Σ |r_i|²`.
    fn group_done(
        &mut self,
        k: usize,
        top: Option<&[f64]>,
        prior: Option<&PriorRows<C>>,
        data_cost: f64,
    );
}

/// Eliminates the points and groups of one chunk at `state` (its global
/// block prepared as `global`) with damping `lambda` (0: undamped), each
/// point's rows weighted by the problem's robust loss if it has one.
/// `caches` are the caches of the chunk's points.
/// `global_norms2`, if given, accumulates `Σ |d_global column|²` (the data
/// part of the global damping diagonal). The points of a fixed group
/// ([`Problem::group_is_fixed`]) send their point-eliminated rows, without
/// the group columns, straight to the sink.
#[allow(clippy::too_many_arguments)]
pub(crate) fn eliminate_chunk<const C: usize, const P: usize, const R: usize, Pr, S>(
    problem: &Pr,
    chunk: &Chunk,
    state: &State<C, P>,
    global: &Pr::Global,
    caches: &mut [Pr::PointCache],
    lambda: f64,
    dims: Dims,
    bufs: ElimBuffers<'_>,
    mut global_norms2: Option<&mut [f64]>,
    sink: &mut S,
) -> Result<Costs, Failure>
where
    Pr: Problem<C, P, R>,
    S: EliminationSink<C, P, R, Pr::Jacobian>,
{
    let ElimBuffers {
        point: point_buf,
        group: group_buf,
        row: single,
    } = bufs;
    let mut group = GroupRows::<C>::new(group_buf, dims.group_width());
    let mut costs = Costs::default();
    let mut lins: [_; BATCH] = std::array::from_fn(|_| Linearization::zeros(dims.g));
    let mut workspace = Pr::Workspace::default();
    let loss = problem.loss();
    let robust = !loss.is_squared();
    // The effects' columns of a point's data rows and of a group's prior
    // mean, and where they go in a group row.
    let mut point_effects = vec![SVector::<f64, R>::zeros(); dims.effects];
    let mut group_effects = vec![SVector::<f64, C>::zeros(); dims.effects];
    let residual_end = C + dims.g + 1;
    for k in chunk.groups.clone() {
        let c = &state.groups[k];
        let fixed = problem.group_is_fixed(k);
        group.reset();
        let mut raw_norms2 = [0.0; C];
        let mut group_data = 0.0;
        for batch in batches(problem.group_points(k)) {
            let lins = &mut lins[..batch.len()];
            let caches = &mut caches[chunk.local(&batch)];
            problem
                .linearize_batch(
                    batch.start,
                    global,
                    c,
                    &state.points[batch.clone()],
                    caches,
                    lins,
                    &mut workspace,
                )
                .map_err(|(i, e)| Failure::linearize(i, &e))?;
            if robust {
                for (i, lin) in batch.clone().zip(lins.iter_mut()) {
                    let weighed = lin.weigh(loss);
                    costs.loss += weighed.cost;
                    sink.point_weighed(i, weighed.weight);
                }
            }
            for (i, lin) in batch.zip(lins.iter()) {
                let p = &state.points[i];
                let data = lin.residual.norm_squared();
                costs.data += data;
                group_data += data;
                let prior = problem.point_prior(i).map(|pr| PriorRows::new(&pr, p));
                if let Some(prior) = &prior {
                    costs.prior += prior.residual.norm_squared();
                }
                if lambda > 0.0 {
                    add_group_column_norms2(&lin.d_group, &mut raw_norms2);
                    if let Some(out) = global_norms2.as_deref_mut() {
                        lin.d_global.add_column_norms2(out, &mut single[..dims.g]);
                    }
                }
                let factor = factor_point(lin, prior.as_ref(), lambda, point_buf, P)
                    .ok_or(Failure::Singular(BlockId::Point(i)))?;
                let m = factor.rows;
                let q = &point_buf[(R + 2 * P) * P..];
                sink.point_factorised(i, lin, prior.as_ref(), q, m);
                if dims.effects > 0 {
                    point_effects.fill(SVector::zeros());
                    problem.point_effects(i, lin, p, &mut point_effects);
                }
                for e in P..m {
                    let row = if fixed {
                        &mut *single
                    } else {
                        group.next_row(&mut |row| sink.reduced_row(row))
                    };
                    let (row, effects) = row.split_at_mut(residual_end);
                    eliminated_row(lin, prior.as_ref(), q, m, e, row);
                    sink.point_row(row);
                    effect_row::<P, R>(&point_effects, q, m, e, effects);
                    if fixed {
                        sink.reduced_row(&single[C..]);
                    }
                }
            }
        }
        let prior = problem.group_prior(k).map(|pr| PriorRows::new(&pr, c));
        if let Some(prior) = &prior {
            let cost = prior.residual.norm_squared();
            costs.prior += cost;
            if fixed {
                costs.fixed_prior += cost;
            }
            if dims.effects > 0 {
                group_effects.fill(SVector::zeros());
                problem.group_prior_effects(k, &mut group_effects);
            }
        }
        let group_effects = if prior.is_some() {
            &group_effects[..]
        } else {
            &[]
        };
        if fixed {
            // A fixed group's prior rows touch no unknown: with effects,
            // they are reduced rows as they are.
            if let Some(prior) = prior.as_ref().filter(|_| dims.effects > 0) {
                let row = &mut single[C..];
                for a in 0..C {
                    row.fill(0.0);
                    prior_row_effects(prior, group_effects, a, &mut row[dims.g..]);
                    sink.reduced_row(row);
                }
            }
            sink.group_done(k, None, prior.as_ref(), group_data);
            continue;
        }
        push_group_prior_and_damping(
            &mut group,
            prior.as_ref(),
            group_effects,
            raw_norms2,
            lambda,
            &mut |row| sink.reduced_row(row),
        );
        let top = group
            .finish(&mut |row| sink.reduced_row(row))
            .ok_or(Failure::Singular(BlockId::Group(k)))?;
        sink.group_done(k, Some(top), prior.as_ref(), group_data);
    }
    Ok(costs)
}

/// The points of a group in batches of at most [`BATCH`], in order.
pub(crate) fn batches(points: Range<usize>) -> impl Iterator<Item = Range<usize>> {
    points
        .clone()
        .step_by(BATCH)
        .map(move |first| first..(first + BATCH).min(points.end))
}

/// After a chunk's sums came out non-finite: linearises its points again (at
/// `state`, its global block prepared as `global`) and
/// names the first with a non-finite residual or Jacobian (checking every
/// point on the fast path would cost more than the elimination of a small
/// point). `None` if all are finite (the sums overflowed).
pub(crate) fn find_non_finite<const C: usize, const P: usize, const R: usize, Pr>(
    problem: &Pr,
    chunk: &Chunk,
    state: &State<C, P>,
    global: &Pr::Global,
    caches: &mut [Pr::PointCache],
) -> Option<Failure>
where
    Pr: Problem<C, P, R>,
{
    let g = state.global.len();
    let mut lin = Linearization::zeros(g);
    let mut row = vec![0.0; g];
    for k in chunk.groups.clone() {
        for i in problem.group_points(k) {
            let cache = &mut caches[i - chunk.points.start];
            let (c, p) = (&state.groups[k], &state.points[i]);
            match problem.linearize(i, global, c, p, cache, &mut lin) {
                Ok(()) if lin.is_finite(&mut row) => {}
                Ok(()) => return Some(Failure::NonFinite { point: Some(i) }),
                Err(e) => return Some(Failure::linearize(i, &e)),
            }
        }
    }
    None
}

/// Collects reduced rows and multiplies them into the lower triangle of the
/// chunk's augmented reduced matrix `[S b; bᵀ ρ] += AᵀA` ([`add_gram_lower`])
/// whenever the buffer is full (and at the end); keeps each group's data cost.
pub(crate) struct NormalSink<'a> {
    rows: &'a mut [f64],
    width: usize,
    capacity: usize,
    filled: usize,
    /// `(G + 1) × (G + 1)`, column-major; lower triangle accumulated.
    pub(crate) normal: &'a mut [f64],
    /// `Σ |r_i|²` of each group of the chunk, in order.
    group_costs: &'a mut Vec<f64>,
}

impl<'a> NormalSink<'a> {
    pub(crate) fn new(
        rows: &'a mut [f64],
        width: usize,
        normal: &'a mut [f64],
        group_costs: &'a mut Vec<f64>,
    ) -> Self {
        let capacity = rows.len() / width;
        Self {
            rows,
            width,
            capacity,
            filled: 0,
            normal,
            group_costs,
        }
    }

    /// Multiplies the buffered rows in.
    pub(crate) fn flush(&mut self) {
        if self.filled == 0 {
            return;
        }
        let w = self.width;
        add_gram_lower(self.normal, &self.rows[..self.filled * w], self.filled, w);
        self.filled = 0;
    }
}

impl<const C: usize, const P: usize, const R: usize, J> EliminationSink<C, P, R, J>
    for NormalSink<'_>
{
    fn reduced_row(&mut self, row: &[f64]) {
        if self.filled == self.capacity {
            self.flush();
        }
        let w = self.width;
        self.rows[self.filled * w..(self.filled + 1) * w].copy_from_slice(row);
        self.filled += 1;
    }

    fn group_done(
        &mut self,
        _k: usize,
        _top: Option<&[f64]>,
        _prior: Option<&PriorRows<C>>,
        data_cost: f64,
    ) {
        self.group_costs.push(data_cost);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn point_q_is_orthogonal_and_triangularises_the_panel() {
        let a0: [[f64; 2]; 5] = [
            [0.3, -1.2],
            [0.8, 0.1],
            [-0.5, 0.7],
            [0.0, 0.4],
            [1.1, -0.2],
        ];
        let mut panel = a0;
        let tau = point_householder(&mut panel);
        let m = panel.len();
        let mut q = vec![0.0; m * m];
        point_q(&panel, &tau, &mut q, 0);
        for i in 0..m {
            for j in 0..m {
                let d: f64 = (0..m).map(|r| q[r * m + i] * q[r * m + j]).sum();
                assert!((d - f64::from(u8::from(i == j))).abs() < 1e-14);
            }
        }
        // (Qᵀ A)[e, j] is R (upper triangle) for e < 2 and 0 below.
        for e in 0..m {
            for j in 0..2 {
                let x: f64 = (0..m).map(|r| q[r * m + e] * a0[r][j]).sum();
                let want = if e <= j { panel[e][j] } else { 0.0 };
                assert!((x - want).abs() < 1e-14, "{e} {j}: {x} vs {want}");
            }
        }
    }

    /// The Householder path's factorisation of the panel `a`: its `R`
    /// (above the diagonal; the reflectors below) and its `Q` (`M x M`,
    /// row-major, every column).
    fn householder<const M: usize>(a: [[f64; 2]; M]) -> ([[f64; 2]; M], Vec<f64>) {
        let mut panel = a;
        let tau = point_householder(&mut panel);
        let mut q = vec![0.0; M * M];
        point_q(&panel, &tau, &mut q, 0);
        (panel, q)
    }

    /// The Householder path's rank test and column 2 of its `Q`.
    fn householder_normal(c1: [f64; 3], c2: [f64; 3]) -> (bool, [f64; 3]) {
        let a0 = [0, 1, 2].map(|r| [c1[r], c2[r]]);
        let (panel, q) = householder(a0);
        let full_rank = (0..2).all(|j| {
            let norm2: f64 = a0.iter().map(|row| row[j] * row[j]).sum();
            norm2 > 0.0 && panel[j][j] * panel[j][j] > RANK_TOLERANCE * RANK_TOLERANCE * norm2
        });
        (full_rank, [q[2], q[5], q[8]])
    }

    /// [`panel_normal`] and [`panel_qr`] together give an orthogonal `Q`
    /// and an upper-triangular `R` with `Q R = [c1 c2]`.
    fn assert_is_qr_of(c1: [f64; 3], c2: [f64; 3]) {
        let (mut panel, mut q) = ([f64::NAN; 6], [f64::NAN; 9]);
        panel_normal(&c1.into(), &c2.into(), &mut q);
        panel_qr(&c1.into(), &c2.into(), &mut panel, &mut q);
        for i in 0..3 {
            for j in 0..3 {
                let d: f64 = (0..3).map(|r| q[r * 3 + i] * q[r * 3 + j]).sum();
                assert!((d - f64::from(u8::from(i == j))).abs() < 1e-15, "{q:?}");
            }
        }
        assert_eq!(
            [panel[2], panel[4], panel[5]],
            [0.0; 3],
            "R is upper triangular"
        );
        let scale = c1.iter().chain(&c2).fold(0.0_f64, |a, x| a.max(x.abs()));
        for (j, c) in [c1, c2].iter().enumerate() {
            for r in 0..3 {
                let x: f64 = (0..2).map(|a| q[r * 3 + a] * panel[a * 2 + j]).sum();
                assert!((x - c[r]).abs() < 1e-15 * scale, "{j} {r}: {x} vs {}", c[r]);
            }
        }
    }

    #[test]
    fn panel_normal_is_the_householder_column_and_rank_test() {
        let tiny = 0.1 * RANK_TOLERANCE;
        let panels = [
            ([0.3, 0.8, -0.5], [-1.2, 0.1, 0.7], true),
            ([2.0e3, -1.0e2, 3.0e1], [4.0, 5.0e3, -7.0e2], true),
            ([0.0, 0.0, 1.0], [1.0, 0.0, 0.0], true),
            ([1.0, 2.0, 3.0], [2.0, 4.0, 6.0 + tiny], false),
            ([1.0, 2.0, 3.0], [0.0, 0.0, 0.0], false),
            ([0.0, 0.0, 0.0], [1.0, 2.0, 3.0], false),
            ([f64::NAN, 0.0, 1.0], [1.0, 2.0, 3.0], false),
        ];
        for (c1, c2, full_rank) in panels {
            let mut q = [0.0; 9];
            let closed = panel_normal(&c1.into(), &c2.into(), &mut q);
            let (householder, n) = householder_normal(c1, c2);
            assert_eq!(
                (closed, householder),
                (full_rank, full_rank),
                "{c1:?} {c2:?}"
            );
            if full_rank {
                let ours = [q[2], q[5], q[8]];
                let sign = ours
                    .iter()
                    .zip(&n)
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
                    .signum();
                for (a, b) in ours.iter().zip(&n) {
                    assert!((a - sign * b).abs() < 1e-15, "{ours:?} vs {n:?}");
                }
                assert_is_qr_of(c1, c2);
            }
        }
    }

    /// [`prior_panel_qr`] against the Householder path: an orthogonal `Q`
    /// whose first two columns and `R` are Householder's up to the signs of
    /// `R`'s rows, and whose last three span the same space (the projector
    /// `Q₂ Q₂ᵀ` is the same), formed alike from column 2 on; the panels it
    /// leaves to Householder refused.
    #[test]
    fn prior_panel_qr_is_the_householder_factorisation_up_to_a_basis_of_q2() {
        let panels = [
            ([0.3, 0.8, -0.5], [-1.2, 0.1, 0.7], [2.0, 0.3, 1.5]),
            // A touch's whitened angle derivatives against a weak prior.
            (
                [1.2e4, -3.0e3, 2.0e2],
                [5.0e2, 1.1e4, -4.0e3],
                [10.0, 0.0, 10.0],
            ),
            // A prior far stronger than the data.
            ([1e-3, 2e-3, 0.0], [0.0, -1e-3, 3e-3], [1e3, -2e2, 5e2]),
        ];
        for (c1, c2, s) in panels {
            let (mut panel, mut q) = ([f64::NAN; 14], [f64::NAN; 25]);
            let taken = prior_panel_qr(&c1.into(), &c2.into(), s, &mut panel, &mut q, 0);
            assert!(taken, "a well-conditioned panel");
            // The panel `[c1 c2; S]`, its prior rows `S = [[s00, s01], [0,
            // s11]]`.
            let a = [0, 1, 2, 3, 4].map(|r| {
                let prior = [[s[0], s[1]], [0.0, s[2]]];
                if r < 3 { [c1[r], c2[r]] } else { prior[r - 3] }
            });
            let (householder_panel, hq) = householder(a);
            let hr = [
                householder_panel[0][0],
                householder_panel[0][1],
                0.0,
                householder_panel[1][1],
            ];
            let scale = a.iter().flatten().fold(0.0_f64, |m, x| m.max(x.abs()));
            for i in 0..5 {
                for j in 0..5 {
                    let d: f64 = (0..5).map(|r| q[r * 5 + i] * q[r * 5 + j]).sum();
                    assert!(
                        (d - f64::from(u8::from(i == j))).abs() < 1e-14,
                        "{i} {j}: {d}"
                    );
                    let p: f64 = (2..5).map(|e| q[i * 5 + e] * q[j * 5 + e]).sum();
                    let hp: f64 = (2..5).map(|e| hq[i * 5 + e] * hq[j * 5 + e]).sum();
                    assert!((p - hp).abs() < 1e-14, "projector {i} {j}: {p} vs {hp}");
                }
                for j in 0..2 {
                    let x: f64 = (0..5).map(|r| q[r * 5 + i] * a[r][j]).sum();
                    let want = if i < 2 { panel[i * 2 + j] } else { 0.0 };
                    assert!(
                        (x - want).abs() < 1e-14 * scale,
                        "Qᵀ A {i} {j}: {x} vs {want}"
                    );
                }
            }
            for (row, sign) in [(0, hr[0].signum()), (1, hr[3].signum())] {
                for j in 0..2 {
                    let (ours, theirs) = (panel[row * 2 + j], sign * hr[row * 2 + j]);
                    assert!(
                        (ours - theirs).abs() < 1e-14 * scale,
                        "R {row} {j}: {ours} vs {theirs}"
                    );
                    for r in 0..5 {
                        let (ours, theirs) = (q[r * 5 + row], sign * hq[r * 5 + row]);
                        assert!(
                            (ours - theirs).abs() < 1e-14,
                            "Q {r} {row}: {ours} vs {theirs}"
                        );
                    }
                }
            }
            assert_eq!(panel[4..10], [0.0; 6], "zero below R");
            let mut from_two = [f64::NAN; 25];
            let taken = prior_panel_qr(&c1.into(), &c2.into(), s, &mut panel, &mut from_two, 2);
            assert!(taken, "the same panel");
            for r in 0..5 {
                assert_eq!(from_two[r * 5 + 2..r * 5 + 5], q[r * 5 + 2..r * 5 + 5]);
            }
        }
        let refused = [
            // Data rows of rank one, a singular prior, a non-finite value.
            ([1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [1.0, 0.0, 1.0]),
            ([0.3, 0.8, -0.5], [-1.2, 0.1, 0.7], [1.0, 0.5, 0.0]),
            ([0.3, f64::NAN, -0.5], [-1.2, 0.1, 0.7], [1.0, 0.0, 1.0]),
            (
                [0.3, 0.8, -0.5],
                [-1.2, 0.1, 0.7],
                [f64::INFINITY, 0.0, 1.0],
            ),
        ];
        for (c1, c2, s) in refused {
            let (mut panel, mut q) = ([0.0; 14], [0.0; 25]);
            let taken = prior_panel_qr(&c1.into(), &c2.into(), s, &mut panel, &mut q, 0);
            assert!(!taken, "{c1:?} {c2:?} {s:?}");
        }
    }
}
