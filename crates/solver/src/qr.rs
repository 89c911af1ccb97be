//! Small dense kernels on row-major row blocks: Householder QR of the leading
//! columns, upper-triangular solves, and the square root of a prior's
//! information matrix.

use nalgebra::{Const, SMatrix, SVector};

use crate::rows::{rows, rows_mut};

/// Relative size below which a diagonal entry of a triangular factor counts as
/// zero: `|R_jj| ≤ RANK_TOLERANCE · |column j|` means column `j` depends on
/// the columns before it.
pub(crate) const RANK_TOLERANCE: f64 = 1e-10;

/// A row holds its `NARROW` last columns.
const NARROW_IN_ROW: &str = "the narrow columns lie in the row";

/// Householder factorisation of the leading `K` columns of the `m × n`
/// row-major block `a` (row stride `n`), the reflections applied to those
/// `K` columns and to the last `NARROW` columns: afterwards the upper
/// triangle holds `R`, and below the diagonal of column `i` the reflector
/// `v_i` (unit diagonal implicit), with `H_i = I − τ_i v_i v_iᵀ` and `τ_i`
/// in `tau`. Returns the number of reflectors, `min(K, m)`.
///
/// Each reflector makes two passes over the rows below it, every column it
/// reflects here at once: the first scales `v_j` and sums each column's
/// `s_c = a_jc + Σ_r v_r a_rc`, the second subtracts `τ_j s_c v_r` and sums
/// the next reflector's `σ = Σ_r a_r,j+1²`. Each sum runs over the rows in
/// order, as one column at a time would take it (the same bits), and the
/// columns' sums are independent chains side by side instead of one after
/// another.
#[inline(always)]
fn householder_panel<const K: usize, const NARROW: usize>(
    a: &mut [f64],
    m: usize,
    n: usize,
    tau: &mut [f64; K],
) -> usize {
    let kk = K.min(m);
    let first_narrow = n - NARROW;
    let below_diagonal = |a: &[f64], j: usize| -> f64 {
        rows(&a[(j + 1) * n..m * n], n).fold(0.0, |s, row| s + row[j] * row[j])
    };
    let mut sigma = if kk > 0 { below_diagonal(a, 0) } else { 0.0 };
    for j in 0..kk {
        let (top, below) = a[j * n..m * n].split_at_mut(n);
        let alpha = top[j];
        if sigma == 0.0 {
            tau[j] = 0.0;
            if j + 1 < kk {
                sigma = below_diagonal(a, j + 1);
            }
            continue;
        }
        let norm = (alpha * alpha + sigma).sqrt();
        let beta = if alpha > 0.0 { -norm } else { norm };
        // H = I − τ v vᵀ with v = (1, x₁…/(α − β)), H x = β e₁.
        tau[j] = (beta - alpha) / beta;
        let inv = 1.0 / (alpha - beta);
        // The sums of the panel's columns after j, and of the narrow ones:
        // every panel column's, so that the loops have fixed lengths and
        // the sums stay in registers (those up to j are not used).
        let mut panel = *top.first_chunk::<K>().expect("the panel lies in the row");
        let mut tail = *top[first_narrow..]
            .first_chunk::<NARROW>()
            .expect(NARROW_IN_ROW);
        for row in rows_mut(below, n) {
            // The panel's values read before `v` is stored in their midst
            // (a wide load over a narrower store waits for it).
            let x = *row.first_chunk::<K>().expect("the panel lies in the row");
            let v = x[j] * inv;
            row[j] = v;
            for (s, x) in panel.iter_mut().zip(&x) {
                *s += v * x;
            }
            let x = row[first_narrow..]
                .first_chunk::<NARROW>()
                .expect(NARROW_IN_ROW);
            for (s, x) in tail.iter_mut().zip(x) {
                *s += v * x;
            }
        }
        top[j] = beta;
        for c in j + 1..K {
            panel[c] *= tau[j];
            top[c] -= panel[c];
        }
        let top = top[first_narrow..]
            .first_chunk_mut::<NARROW>()
            .expect(NARROW_IN_ROW);
        for (y, s) in top.iter_mut().zip(&mut tail) {
            *s *= tau[j];
            *y -= *s;
        }
        // Row j + 1 holds the next reflector's diagonal, outside its σ.
        let mut below = rows_mut(below, n);
        if let Some(row) = below.next() {
            reflect_row(row, j, first_narrow, &panel, &tail);
        }
        let mut next = 0.0;
        for row in below {
            reflect_row(row, j, first_narrow, &panel, &tail);
            if j + 1 < kk {
                next += row[j + 1] * row[j + 1];
            }
        }
        sigma = next;
    }
    kk
}

/// A row below reflector `j` of [`householder_panel`], `v = row[j]`, less
/// `v s_c` in the panel's columns after `j` (`panel[c]`, `τ_j` applied)
/// and in the narrow columns from `first_narrow` on (`tail`).
#[inline(always)]
fn reflect_row<const K: usize, const NARROW: usize>(
    row: &mut [f64],
    j: usize,
    first_narrow: usize,
    panel: &[f64; K],
    tail: &[f64; NARROW],
) {
    let v = row[j];
    for (c, s) in panel.iter().enumerate() {
        if c > j {
            row[c] -= s * v;
        }
    }
    let x = row[first_narrow..]
        .first_chunk_mut::<NARROW>()
        .expect(NARROW_IN_ROW);
    for (x, s) in x.iter_mut().zip(tail) {
        *x -= s * v;
    }
}

/// Trailing columns reflected together: their part of `w = v_jᵀ A_t` stays
/// in registers while the rows stream past, instead of a scratch row loaded
/// and stored once per row.
const BLOCK: usize = 16;

/// `A[:, c..c + B] −= τ v_j (v_jᵀ A[:, c..c + B])` for reflector `j` of
/// [`householder_panel`] (`v_j` = 1 at row `j`, the panel's column `j`
/// below it); the sums run over the rows in order, so any `B` gives the
/// same bits. Returns `B`, the columns done.
#[inline(always)]
fn reflect_columns<const B: usize>(
    a: &mut [f64],
    m: usize,
    n: usize,
    j: usize,
    c: usize,
    tau: f64,
) -> usize {
    const IN_ROW: &str = "the block lies in the row";
    let (top, below) = a[j * n..m * n].split_at_mut(n);
    let top = top[c..].first_chunk_mut::<B>().expect(IN_ROW);
    let mut w = *top;
    for row in rows(below, n) {
        let (v, x) = (row[j], row[c..].first_chunk::<B>().expect(IN_ROW));
        for t in 0..B {
            w[t] += v * x[t];
        }
    }
    for (y, x) in top.iter_mut().zip(&mut w) {
        *x *= tau;
        *y -= *x;
    }
    for row in rows_mut(below, n) {
        let v = row[j];
        let x = row[c..].first_chunk_mut::<B>().expect(IN_ROW);
        for t in 0..B {
            x[t] -= v * w[t];
        }
    }
    B
}

/// Sets the reflectors below the diagonal to exact zeros.
#[inline(always)]
fn clear_reflectors(a: &mut [f64], m: usize, n: usize, kk: usize) {
    // Column by column: a few entries a row, which a fill would hand to
    // `memset`, one call a row.
    for j in 0..kk {
        for row in rows_mut(&mut a[(j + 1) * n..m * n], n) {
            row[j] = 0.0;
        }
    }
}

/// Householder QR of the leading `K` columns of the `m × n` row-major block
/// `a` (row stride `n`); the reflections are applied to all `n` columns.
///
/// Afterwards rows `0..min(m, K)` hold the upper-triangular factor in columns
/// `0..K` (and the transformed trailing columns), and rows `K..m` are exactly
/// zero in columns `0..K`. The reflections are orthogonal, so sums of squares
/// of every column (and `AᵀA` of the whole block) are preserved.
///
/// Each reflector `H_j = I − τ_j v_j v_jᵀ` is applied to the trailing columns
/// in turn, `A_t −= τ_j v_j (v_jᵀ A_t)`, a block of [`BLOCK`] columns at a
/// time (then blocks of 8 and 4; the last `(n − K) mod 4` columns go with
/// the panel, [`householder_panel`]): two passes over the rows per block,
/// with the block's part of `v_jᵀ A_t` in registers. A group has few columns
/// to eliminate (`K` = 3 for a ball centre) and a handful of rows, where the
/// compact-WY form (`Q = I − V T Vᵀ` and two GEMMs) spends its instructions
/// on the GEMM calls' set-up, and a pass over whole rows with `v_jᵀ A_t` in
/// a scratch row loads and stores it once a row
/// (docs/performance-iteration.md).
///
/// Compiled twice: for AVX2, chosen at run time where the machine has it
/// (the column blocks four wide instead of two), and for any x86-64. Both
/// multiply and add in the same order, so they give the same bits.
#[allow(unsafe_code, reason = "the AVX2 build, called after the feature check")]
pub(crate) fn householder_rows<const K: usize>(a: &mut [f64], m: usize, n: usize) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the machine runs AVX2.
        return unsafe { householder_rows_avx2::<K>(a, m, n) };
    }
    householder_rows_in::<K>(a, m, n);
}

/// [`householder_rows`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn householder_rows_avx2<const K: usize>(a: &mut [f64], m: usize, n: usize) {
    householder_rows_in::<K>(a, m, n);
}

/// The body of [`householder_rows`], inlined into each of its builds.
#[inline(always)]
fn householder_rows_in<const K: usize>(a: &mut [f64], m: usize, n: usize) {
    debug_assert!(a.len() >= m * n && K <= n);
    let kk = K.min(m);
    if kk == 0 {
        return;
    }
    // The last columns that no block of four takes go with the panel.
    let mut tau = [0.0; K];
    match (n - K) % 4 {
        0 => householder_panel::<K, 0>(a, m, n, &mut tau),
        1 => householder_panel::<K, 1>(a, m, n, &mut tau),
        2 => householder_panel::<K, 2>(a, m, n, &mut tau),
        _ => householder_panel::<K, 3>(a, m, n, &mut tau),
    };
    let end = n - (n - K) % 4;
    for j in 0..kk {
        if tau[j] == 0.0 {
            continue;
        }
        // Blocks of BLOCK columns, then of 8 and 4.
        let mut c = K;
        while c < end {
            c += match end - c {
                BLOCK.. => reflect_columns::<BLOCK>(a, m, n, j, c, tau[j]),
                8.. => reflect_columns::<8>(a, m, n, j, c, tau[j]),
                _ => reflect_columns::<4>(a, m, n, j, c, tau[j]),
            };
        }
    }
    clear_reflectors(a, m, n, kk);
}

/// Whether all values are finite (branch-free, so that it vectorises).
pub(crate) fn all_finite(values: &[f64]) -> bool {
    // x · 0 is ±0 for finite x and NaN otherwise; four independent lanes
    // let the compiler vectorise the sum.
    let (lanes, rest) = values.as_chunks::<4>();
    let mut acc = [0.0f64; 4];
    for lane in lanes {
        for (a, x) in acc.iter_mut().zip(lane) {
            *a += x * 0.0;
        }
    }
    for x in rest {
        acc[0] += x * 0.0;
    }
    acc.iter().sum::<f64>() == 0.0
}

/// Whether the triangular factor left by [`householder_rows`] in the leading
/// `k` columns of the `m`-row block `a` (row stride `n`) has full rank:
/// `|R_jj| > RANK_TOLERANCE · |column j|` for every `j`, with `|column j|²
/// = Σ_{i ≤ j} R_ij²` the squared norm of column `j` of the rows before the
/// factorisation (the reflections preserve it, and leave the rows below the
/// triangle zero in these columns), and not zero.
pub(crate) fn triangle_has_full_rank(a: &[f64], m: usize, n: usize, k: usize) -> bool {
    if m < k {
        return false;
    }
    (0..k).all(|j| {
        let norm2: f64 = rows(&a[..(j + 1) * n], n).map(|row| row[j] * row[j]).sum();
        let d = a[j * n + j].abs();
        norm2 > 0.0 && d > RANK_TOLERANCE * norm2.sqrt()
    })
}

/// Solves `U x = y` in place (`y` → `x`) for the upper-triangular `k × k`
/// matrix in the leading columns of the row-major block `u` (row stride `n`).
/// `y` has `k` rows of `cols` values each, row-major (stride `cols`).
/// Inlined, so that a caller's compile-time sizes unroll it.
#[inline(always)]
pub(crate) fn solve_upper_in_place(u: &[f64], n: usize, k: usize, y: &mut [f64], cols: usize) {
    for j in (0..k).rev() {
        let (head, tail) = y.split_at_mut((j + 1) * cols);
        let yj = &mut head[j * cols..];
        for l in j + 1..k {
            let ujl = u[j * n + l];
            for (a, b) in yj.iter_mut().zip(&tail[(l - j - 1) * cols..(l - j) * cols]) {
                *a -= ujl * b;
            }
        }
        let inv = 1.0 / u[j * n + j];
        for a in yj.iter_mut() {
            *a *= inv;
        }
    }
}

/// An upper-triangular `U` with `UᵀU = information`, from a Cholesky
/// factorisation that tolerates semi-definite matrices: a pivot that is not
/// positive (relative to the largest diagonal entry) leaves its row of `U`
/// zero, which is exact for a positive semi-definite matrix (its Schur
/// complements are semi-definite, so a zero pivot has a zero column below
/// it). Negative information is thereby treated as zero. Reads the lower
/// triangle only.
pub(crate) fn information_sqrt<const N: usize>(
    information: &SMatrix<f64, N, N>,
) -> SMatrix<f64, N, N> {
    let scale = (0..N)
        .map(|j| information[(j, j)].abs())
        .fold(0.0, f64::max);
    let mut l = SMatrix::<f64, N, N>::zeros();
    for j in 0..N {
        let mut d = information[(j, j)];
        for k in 0..j {
            d -= l[(j, k)] * l[(j, k)];
        }
        if d.is_nan() || d <= 1e-14 * scale {
            continue;
        }
        let ljj = d.sqrt();
        l[(j, j)] = ljj;
        for i in j + 1..N {
            let mut x = information[(i, j)];
            for k in 0..j {
                x -= l[(i, k)] * l[(j, k)];
            }
            l[(i, j)] = x / ljj;
        }
    }
    l.transpose()
}

/// The prior rows of one block at `x`: the square root `U` of the information
/// and the whitened prior residual `e = U (x − mean)`, with `|e|²` the prior
/// cost.
pub(crate) struct PriorRows<const N: usize> {
    pub(crate) sqrt: SMatrix<f64, N, N>,
    pub(crate) residual: SVector<f64, N>,
}

impl<const N: usize> PriorRows<N> {
    pub(crate) fn new(prior: &crate::GaussianPrior<Const<N>>, x: &SVector<f64, N>) -> Self {
        let sqrt = information_sqrt(&prior.information);
        let residual = sqrt * (x - prior.mean);
        Self { sqrt, residual }
    }

    /// `Uᵀ e = information · (x − mean)`: the prior's part of the gradient.
    pub(crate) fn gradient(&self) -> SVector<f64, N> {
        self.sqrt.tr_mul(&self.residual)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    }

    /// [`householder_rows`] (or, `portable`, the build for any x86-64) of
    /// the leading `k` columns, `k` as a run-time value.
    fn qr(a: &mut [f64], m: usize, n: usize, k: usize, portable: bool) {
        let run: fn(&mut [f64], usize, usize) = match (k, portable) {
            (1, false) => householder_rows::<1>,
            (2, false) => householder_rows::<2>,
            (3, false) => householder_rows::<3>,
            (4, false) => householder_rows::<4>,
            (1, true) => householder_rows_in::<1>,
            (3, true) => householder_rows_in::<3>,
            _ => unreachable!("no test factorises {k} columns"),
        };
        run(a, m, n);
    }

    /// The textbook Householder QR of the leading `k` columns, entry by
    /// entry: for each reflector, every later column in turn, `s = a_jc +
    /// Σ_r v_r a_rc` over the rows in order, then `a_rc −= τ s v_r`.
    fn householder_reference(a: &mut [f64], m: usize, n: usize, k: usize) {
        for j in 0..k.min(m) {
            let sigma = (j + 1..m).fold(0.0, |s, r| s + a[r * n + j] * a[r * n + j]);
            if sigma == 0.0 {
                continue;
            }
            let alpha = a[j * n + j];
            let norm = (alpha * alpha + sigma).sqrt();
            let beta = if alpha > 0.0 { -norm } else { norm };
            let tau = (beta - alpha) / beta;
            let inv = 1.0 / (alpha - beta);
            for r in j + 1..m {
                a[r * n + j] *= inv;
            }
            a[j * n + j] = beta;
            for c in j + 1..n {
                let s = (j + 1..m).fold(a[j * n + c], |s, r| s + a[r * n + j] * a[r * n + c]);
                let s = s * tau;
                a[j * n + c] -= s;
                for r in j + 1..m {
                    a[r * n + c] -= s * a[r * n + j];
                }
            }
        }
        for r in 0..m {
            for j in 0..k.min(r) {
                a[r * n + j] = 0.0;
            }
        }
    }

    #[test]
    fn householder_preserves_gram_matrix_and_zeroes_leading_columns() {
        // (9, 34, 3): 31 trailing columns, a block of each width (16, 8 and
        // 4) and three with the panel; (7, 5, 3), (24, 37, 3), (24, 4, 3)
        // and (12, 11, 3): two, two, one and none with the panel; (6, 34,
        // 4): a first column zero below the diagonal (no reflector).
        let shapes = [
            (7, 5, 3),
            (9, 34, 3),
            (24, 37, 3),
            (24, 4, 3),
            (12, 11, 3),
            (6, 34, 4),
        ];
        for (m, n, k) in shapes {
            let mut seed = 1;
            let mut a0: Vec<f64> = (0..m * n).map(|_| lcg(&mut seed)).collect();
            if k == 4 {
                for r in 1..m {
                    a0[r * n] = 0.0;
                }
            }
            assert_reflects(&a0, m, n, k);
            let mut blocked = a0.clone();
            qr(&mut blocked, m, n, k, false);
            let mut textbook = a0;
            householder_reference(&mut textbook, m, n, k);
            assert!(
                blocked
                    .iter()
                    .zip(&textbook)
                    .all(|(x, y)| x.to_bits() == y.to_bits()),
                "{m} x {n}, k = {k}"
            );
        }
    }

    #[test]
    fn both_builds_give_the_same_bits() {
        // `householder_rows` runs the AVX2 build where the machine has it;
        // `householder_rows_in` here is the build for any x86-64.
        for (m, n, k) in [(7, 37, 3), (10, 37, 3), (256, 37, 3), (5, 4, 1)] {
            let mut seed = 3;
            let a0: Vec<f64> = (0..m * n).map(|_| lcg(&mut seed)).collect();
            let mut dispatched = a0.clone();
            qr(&mut dispatched, m, n, k, false);
            let mut portable = a0;
            qr(&mut portable, m, n, k, true);
            assert!(
                dispatched
                    .iter()
                    .zip(&portable)
                    .all(|(x, y)| x.to_bits() == y.to_bits())
            );
        }
    }

    /// Householder on the first `k` columns of the `m x n` row-major `a0`
    /// keeps the Gram matrix `AᵀA` and zeroes below the diagonal.
    fn assert_reflects(a0: &[f64], m: usize, n: usize, k: usize) {
        let mut a = a0.to_vec();
        qr(&mut a, m, n, k, false);
        for i in 0..n {
            for j in 0..n {
                let g0: f64 = (0..m).map(|r| a0[r * n + i] * a0[r * n + j]).sum();
                let g1: f64 = (0..m).map(|r| a[r * n + i] * a[r * n + j]).sum();
                assert!((g0 - g1).abs() < 1e-14, "{m} {n} {k}: {g0} {g1}");
            }
        }
        for r in 0..m {
            for j in 0..k.min(r) {
                assert_eq!(a[r * n + j], 0.0);
            }
        }
    }

    #[test]
    fn householder_handles_short_and_zero_columns() {
        // Fewer rows than reflectors, a zero column, and no trailing columns.
        for (m, n, k) in [(2, 5, 3), (4, 3, 3), (1, 4, 2), (5, 4, 1)] {
            let mut seed = 7;
            let mut a0: Vec<f64> = (0..m * n).map(|_| lcg(&mut seed)).collect();
            for r in 0..m {
                a0[r * n] = 0.0;
            }
            assert_reflects(&a0, m, n, k);
        }
    }

    #[test]
    fn rank_is_judged_against_the_columns_norms_before_the_factorisation() {
        // Column 2 of the 6 x 5 block is 2 c_0 - c_1 (plus `noise` in one
        // row): dependent without it, independent with a relative 1e-6.
        for (noise, full) in [(0.0, false), (1e-6, true)] {
            let (m, n, k) = (6, 5, 3);
            let mut seed = 11;
            let mut a: Vec<f64> = (0..m * n).map(|_| lcg(&mut seed)).collect();
            for r in 0..m {
                a[r * n + 2] = 2.0 * a[r * n] - a[r * n + 1];
            }
            a[3 * n + 2] += noise;
            qr(&mut a, m, n, k, false);
            assert_eq!(triangle_has_full_rank(&a, m, n, k), full, "noise {noise}");
        }
        // A zero column, and fewer rows than columns.
        let mut a = vec![1.0, 0.0, 3.0, 2.0, 0.0, 1.0, 4.0, 0.0, 5.0];
        qr(&mut a, 3, 3, 2, false);
        assert!(!triangle_has_full_rank(&a, 3, 3, 2));
        assert!(!triangle_has_full_rank(&[1.0, 2.0, 3.0], 1, 3, 2));
    }

    #[test]
    fn finiteness_check() {
        assert!(all_finite(&[1.0, -2.0, 0.0, f64::MAX, f64::MIN_POSITIVE]));
        assert!(!all_finite(&[1.0, f64::NAN]));
        assert!(!all_finite(&[f64::NEG_INFINITY, 1.0]));
    }

    #[test]
    fn upper_solve_inverts() {
        // U = [[2, 1], [0, 4]], y = [[3, 1], [8, 0]] → x = [[0.5, 0.5], [2, 0]]
        let u = [2.0, 1.0, 9.0, 0.0, 4.0, 9.0];
        let mut y = [3.0, 1.0, 8.0, 0.0];
        solve_upper_in_place(&u, 3, 2, &mut y, 2);
        assert_eq!(y, [0.5, 0.5, 2.0, 0.0]);
    }

    #[test]
    fn information_sqrt_of_definite_and_semidefinite() {
        let a = SMatrix::<f64, 3, 3>::new(4.0, 2.0, 0.0, 2.0, 5.0, 1.0, 0.0, 1.0, 3.0);
        let u = information_sqrt(&a);
        assert!((u.transpose() * u - a).norm() < 1e-14);
        let v = SVector::<f64, 3>::new(1.0, -2.0, 0.5);
        let b = v * v.transpose();
        let u = information_sqrt(&b);
        assert!((u.transpose() * u - b).norm() < 1e-14);
        let z = SMatrix::<f64, 3, 3>::from_diagonal(&SVector::<f64, 3>::new(1.0, 0.0, 2.0));
        let u = information_sqrt(&z);
        assert!((u.transpose() * u - z).norm() < 1e-14);
    }
}
