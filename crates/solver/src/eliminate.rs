//! Point and group elimination in square-root form: the rows of every point
//! are reduced by a small Householder QR on its point columns, the remaining
//! rows of a group by a QR on its group columns, and what remains (global
//! columns and residual only) is multiplied into the chunk's reduced matrix.

use faer::linalg::matmul::triangular::{BlockStructure, matmul};
use faer::{Accum, MatMut, MatRef, Par};
use nalgebra::{SMatrix, SVector};

use crate::chunks::{Chunk, Dims, ElimBuffers};
use crate::problem::{Linearization, Problem, State};
use crate::qr::{PriorRows, add_column_norms2, householder_rows, triangle_has_full_rank};
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

/// Why a pass over the points stopped.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Failure {
    /// `linearize` returned an error.
    Linearize { point: usize, message: String },
    /// `linearize` returned a non-finite value.
    NonFinite { point: usize },
    /// A point or group block is rank deficient.
    Singular(BlockId),
}

/// The trailing columns a point block carries after its point and group
/// columns.
#[derive(Clone, Copy)]
pub(crate) enum Tail<'a, const G: usize> {
    /// The global columns and the residual (`G + 1` columns).
    Global,
    /// The residual after a known global step, `r + d_global · δg` (one
    /// column).
    Stepped(&'a SVector<f64, G>),
}

impl<const G: usize> Tail<'_, G> {
    pub(crate) fn width(self) -> usize {
        match self {
            Tail::Global => G + 1,
            Tail::Stepped(_) => 1,
        }
    }
}

/// Writes the rows of one point into `block` (row-major, width
/// `P + C + tail`): its `R` data rows `[d_point | d_group | tail]`, then the
/// prior rows `[U | 0 | (0…) e]`, then (if `lambda > 0`) the damping rows
/// `[√(λ D_p) | 0 | 0]`. Returns the number of rows and the damping diagonal
/// `D_p` (zero when undamped).
pub(crate) fn assemble_point<const G: usize, const C: usize, const P: usize, const R: usize>(
    lin: &Linearization<G, C, P, R>,
    tail: Tail<'_, G>,
    prior: Option<&PriorRows<P>>,
    lambda: f64,
    block: &mut [f64],
) -> (usize, SVector<f64, P>) {
    let width = P + C + tail.width();
    let mut rows = 0;
    for row in 0..R {
        let dst = &mut block[rows * width..(rows + 1) * width];
        for j in 0..P {
            dst[j] = lin.d_point[(row, j)];
        }
        for j in 0..C {
            dst[P + j] = lin.d_group[(row, j)];
        }
        match tail {
            Tail::Global => {
                for j in 0..G {
                    dst[P + C + j] = lin.d_global[(row, j)];
                }
                dst[P + C + G] = lin.residual[row];
            }
            Tail::Stepped(step) => {
                let mut t = lin.residual[row];
                for j in 0..G {
                    t += lin.d_global[(row, j)] * step[j];
                }
                dst[P + C] = t;
            }
        }
        rows += 1;
    }
    if let Some(prior) = prior {
        for row in 0..P {
            let dst = &mut block[rows * width..(rows + 1) * width];
            dst.fill(0.0);
            for j in row..P {
                dst[j] = prior.sqrt[(row, j)];
            }
            dst[width - 1] = prior.residual[row];
            rows += 1;
        }
    }
    let mut diagonal = SVector::<f64, P>::zeros();
    if lambda > 0.0 {
        let mut norms2 = [0.0; P];
        add_column_norms2(block, rows, width, P, &mut norms2);
        for j in 0..P {
            diagonal[j] = damping_diagonal(norms2[j]);
            let dst = &mut block[rows * width..(rows + 1) * width];
            dst.fill(0.0);
            dst[j] = (lambda * diagonal[j]).sqrt();
            rows += 1;
        }
    }
    (rows, diagonal)
}

/// Householder QR of the `P` point columns of an assembled point block
/// (`rows × width`, row-major); `false` if the point block is rank deficient.
pub(crate) fn eliminate_point<const P: usize>(block: &mut [f64], rows: usize, width: usize, scratch: &mut [f64]) -> bool {
    if P == 0 {
        return true;
    }
    let mut norms2 = [0.0; P];
    add_column_norms2(block, rows, width, P, &mut norms2);
    householder_rows(block, rows, width, P, scratch);
    triangle_has_full_rank(block, rows, width, P, &norms2)
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
    /// Rows `fresh..rows` have not yet entered `norms2`.
    fresh: usize,
    norms2: [f64; C],
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
            fresh: 0,
            norms2: [0.0; C],
        }
    }

    /// Starts the next group.
    pub(crate) fn reset(&mut self) {
        self.rows = 0;
        self.fresh = 0;
        self.norms2 = [0.0; C];
    }

    /// A slot for the next row (its old contents must be overwritten).
    pub(crate) fn next_row(&mut self, scratch: &mut [f64], emit: &mut impl FnMut(&[f64])) -> &mut [f64] {
        if self.rows == self.capacity {
            self.fold(scratch, emit);
        }
        let w = self.width;
        self.rows += 1;
        &mut self.buf[(self.rows - 1) * w..self.rows * w]
    }

    /// QR on the group columns; emits the trailing columns (from column `C`)
    /// of the rows below the triangle.
    fn fold(&mut self, scratch: &mut [f64], emit: &mut impl FnMut(&[f64])) {
        let w = self.width;
        add_column_norms2(&self.buf[self.fresh * w..], self.rows - self.fresh, w, C, &mut self.norms2);
        householder_rows(self.buf, self.rows, w, C, scratch);
        for r in C..self.rows {
            emit(&self.buf[r * w + C..(r + 1) * w]);
        }
        self.rows = self.rows.min(C);
        self.fresh = self.rows;
    }

    /// Folds the remaining rows; returns the group's triangular rows
    /// `[R_cc | R_c… | z_c]` (`C` rows of the buffer's width), or `None` if
    /// the group block is rank deficient.
    pub(crate) fn finish(&mut self, scratch: &mut [f64], emit: &mut impl FnMut(&[f64])) -> Option<&[f64]> {
        self.fold(scratch, emit);
        let w = self.width;
        triangle_has_full_rank(self.buf, self.rows, w, C, &self.norms2).then(|| &self.buf[..C * w])
    }
}

/// Writes the prior rows `[U | 0 | e]` and (if damped) the damping rows of a
/// group into `group`; `raw_norms2` holds `Σ |d_group column|²` of the group's
/// data rows (used for the damping diagonal). Returns the damping diagonal
/// `D_c` (zero when undamped).
pub(crate) fn push_group_prior_and_damping<const C: usize>(
    group: &mut GroupRows<'_, C>,
    prior: Option<&PriorRows<C>>,
    mut raw_norms2: [f64; C],
    lambda: f64,
    scratch: &mut [f64],
    emit: &mut impl FnMut(&[f64]),
) -> SVector<f64, C> {
    if let Some(prior) = prior {
        for row in 0..C {
            let dst = group.next_row(scratch, emit);
            dst.fill(0.0);
            for j in row..C {
                dst[j] = prior.sqrt[(row, j)];
                raw_norms2[j] += prior.sqrt[(row, j)] * prior.sqrt[(row, j)];
            }
            let last = dst.len() - 1;
            dst[last] = prior.residual[row];
        }
    }
    let mut diagonal = SVector::<f64, C>::zeros();
    if lambda > 0.0 {
        for j in 0..C {
            diagonal[j] = damping_diagonal(raw_norms2[j]);
            let dst = group.next_row(scratch, emit);
            dst.fill(0.0);
            dst[j] = (lambda * diagonal[j]).sqrt();
        }
    }
    diagonal
}

/// Adds `Σ |column|²` of the `R × N` matrix to `out`.
pub(crate) fn add_matrix_column_norms2<const R: usize, const N: usize>(m: &SMatrix<f64, R, N>, out: &mut [f64]) {
    for (j, o) in out.iter_mut().enumerate().take(N) {
        *o += m.column(j).norm_squared();
    }
}

/// Costs accumulated over a chunk.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Costs {
    /// `Σ |r_i|²`.
    pub(crate) data: f64,
    /// Point and group prior terms.
    pub(crate) prior: f64,
}

/// Receives what the elimination of a chunk produces.
pub(crate) trait EliminationSink {
    /// One reduced row `[A_g | a]` (`G + 1` values).
    fn reduced_row(&mut self, row: &[f64]);
    /// The triangular rows `[R_cc | R_cg | z_c]` of group `k` (row-major,
    /// `C` rows of width `C + G + 1`).
    fn group_done(&mut self, k: usize, top: &[f64]);
}

/// Eliminates the points and groups of one chunk at `state` with damping
/// `lambda` (0: undamped). `caches` are the caches of the chunk's points.
/// `global_norms2`, if given, accumulates `Σ |d_global column|²` (the data
/// part of the global damping diagonal).
#[allow(clippy::too_many_arguments)]
pub(crate) fn eliminate_chunk<const G: usize, const C: usize, const P: usize, const R: usize, Pr, S>(
    problem: &Pr,
    chunk: &Chunk,
    state: &State<G, C, P>,
    caches: &mut [Pr::PointCache],
    lambda: f64,
    dims: Dims,
    bufs: ElimBuffers<'_>,
    mut global_norms2: Option<&mut [f64]>,
    sink: &mut S,
) -> Result<Costs, Failure>
where
    Pr: Problem<G, C, P, R>,
    S: EliminationSink,
{
    let ElimBuffers {
        point: point_buf,
        group: group_buf,
        scratch,
    } = bufs;
    let pw = dims.point_width();
    let mut group = GroupRows::<C>::new(group_buf, dims.group_width());
    let mut costs = Costs::default();
    for k in chunk.groups.clone() {
        let c = &state.groups[k];
        group.reset();
        let mut raw_norms2 = [0.0; C];
        for i in problem.group_points(k) {
            let cache = &mut caches[i - chunk.points.start];
            let p = &state.points[i];
            let lin = problem
                .linearize(i, &state.global, c, p, cache)
                .map_err(|e| Failure::Linearize {
                    point: i,
                    message: e.to_string(),
                })?;
            if !lin.is_finite() {
                return Err(Failure::NonFinite { point: i });
            }
            costs.data += lin.residual.norm_squared();
            let prior = problem.point_prior(i).map(|pr| PriorRows::new(&pr, p));
            if let Some(prior) = &prior {
                costs.prior += prior.residual.norm_squared();
            }
            if lambda > 0.0 {
                add_matrix_column_norms2(&lin.d_group, &mut raw_norms2);
                if let Some(out) = global_norms2.as_deref_mut() {
                    add_matrix_column_norms2(&lin.d_global, out);
                }
            }
            let (rows, _) = assemble_point(&lin, Tail::Global, prior.as_ref(), lambda, point_buf);
            if !eliminate_point::<P>(point_buf, rows, pw, scratch) {
                return Err(Failure::Singular(BlockId::Point(i)));
            }
            for r in P..rows {
                group
                    .next_row(scratch, &mut |row| sink.reduced_row(row))
                    .copy_from_slice(&point_buf[r * pw + P..(r + 1) * pw]);
            }
        }
        let prior = problem.group_prior(k).map(|pr| PriorRows::new(&pr, c));
        if let Some(prior) = &prior {
            costs.prior += prior.residual.norm_squared();
        }
        push_group_prior_and_damping(
            &mut group,
            prior.as_ref(),
            raw_norms2,
            lambda,
            scratch,
            &mut |row| sink.reduced_row(row),
        );
        let top = group
            .finish(scratch, &mut |row| sink.reduced_row(row))
            .ok_or(Failure::Singular(BlockId::Group(k)))?;
        sink.group_done(k, top);
    }
    Ok(costs)
}

/// Collects reduced rows and multiplies them into the lower triangle of the
/// chunk's augmented reduced matrix `[S b; bᵀ ρ] += AᵀA` by one GEMM whenever
/// the buffer is full (and at the end).
pub(crate) struct NormalSink<'a> {
    rows: &'a mut [f64],
    width: usize,
    capacity: usize,
    filled: usize,
    /// `(G + 1) × (G + 1)`, column-major; lower triangle accumulated.
    pub(crate) normal: &'a mut [f64],
}

impl<'a> NormalSink<'a> {
    pub(crate) fn new(rows: &'a mut [f64], width: usize, normal: &'a mut [f64]) -> Self {
        let capacity = rows.len() / width;
        Self {
            rows,
            width,
            capacity,
            filled: 0,
            normal,
        }
    }

    /// Multiplies the buffered rows in.
    pub(crate) fn flush(&mut self) {
        if self.filled == 0 {
            return;
        }
        let w = self.width;
        let a = MatRef::from_row_major_slice(&self.rows[..self.filled * w], self.filled, w);
        let dst = MatMut::from_column_major_slice_mut(self.normal, w, w);
        matmul(
            dst,
            BlockStructure::TriangularLower,
            Accum::Add,
            a.transpose(),
            BlockStructure::Rectangular,
            a,
            BlockStructure::Rectangular,
            1.0,
            Par::Seq,
        );
        self.filled = 0;
    }
}

impl EliminationSink for NormalSink<'_> {
    fn reduced_row(&mut self, row: &[f64]) {
        if self.filled == self.capacity {
            self.flush();
        }
        let w = self.width;
        self.rows[self.filled * w..(self.filled + 1) * w].copy_from_slice(row);
        self.filled += 1;
    }

    fn group_done(&mut self, _k: usize, _top: &[f64]) {}
}
