//! Small dense kernels on row-major row blocks: Householder QR of the leading
//! columns, upper-triangular solves, and the square root of a prior's
//! information matrix.

use nalgebra::{Const, SMatrix, SVector};

use crate::rows::{rows, rows_mut};

/// Relative size below which a diagonal entry of a triangular factor counts as
/// zero: `|R_jj| ≤ RANK_TOLERANCE · |column j|` means column `j` depends on
/// the columns before it.
pub(crate) const RANK_TOLERANCE: f64 = 1e-10;

/// Householder factorisation of the leading `k` columns of the `m × n`
/// row-major block `a` (row stride `n`), the reflections applied to those
/// `k` columns only: afterwards the upper triangle holds `R`, and below the
/// diagonal of column `i` the reflector `v_i` (unit diagonal implicit), with
/// `H_i = I − τ_i v_i v_iᵀ` and `τ_i` in `tau`. Returns the number of
/// reflectors, `min(k, m)`.
#[inline(always)]
fn householder_panel(a: &mut [f64], m: usize, n: usize, k: usize, tau: &mut [f64]) -> usize {
    let kk = k.min(m);
    for j in 0..kk {
        // Row j and the rows below it, each cut to the panel's k columns.
        let (top, below) = a[j * n..m * n].split_at_mut(n);
        let top = &mut top[..k];
        let mut sigma = 0.0;
        for row in rows(below, n) {
            sigma += row[j] * row[j];
        }
        let alpha = top[j];
        if sigma == 0.0 {
            tau[j] = 0.0;
            continue;
        }
        let norm = (alpha * alpha + sigma).sqrt();
        let beta = if alpha > 0.0 { -norm } else { norm };
        // H = I − τ v vᵀ with v = (1, x₁…/(α − β)), H x = β e₁.
        tau[j] = (beta - alpha) / beta;
        let inv = 1.0 / (alpha - beta);
        for row in rows_mut(below, n) {
            row[j] *= inv;
        }
        top[j] = beta;
        for c in j + 1..k {
            let mut s = top[c];
            for row in rows(below, n) {
                s += row[j] * row[c];
            }
            s *= tau[j];
            top[c] -= s;
            for row in rows_mut(below, n) {
                row[c] -= s * row[j];
            }
        }
    }
    kk
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

/// Householder QR of the leading `k` columns of the `m × n` row-major block
/// `a` (row stride `n`); the reflections are applied to all `n` columns.
///
/// Afterwards rows `0..min(m, k)` hold the upper-triangular factor in columns
/// `0..k` (and the transformed trailing columns), and rows `k..m` are exactly
/// zero in columns `0..k`. The reflections are orthogonal, so sums of squares
/// of every column (and `AᵀA` of the whole block) are preserved.
///
/// Each reflector `H_j = I − τ_j v_j v_jᵀ` is applied to the trailing columns
/// in turn, `A_t −= τ_j v_j (v_jᵀ A_t)`, a block of [`BLOCK`] columns at a
/// time (then blocks of 8, 4, 2 and 1 for the rest): two passes over the
/// rows per block, with the block's part of `v_jᵀ A_t` in registers. A group
/// has few columns to eliminate (`k` = 3 for a ball centre) and a handful of
/// rows, where this cost half the instructions of the compact-WY form
/// (`Q = I − V T Vᵀ` and two GEMMs), whose GEMM calls were dominated by
/// their set-up; the column blocks cost 28 % fewer instructions than a pass
/// over whole rows with `v_jᵀ A_t` in a scratch row (docs/performance.md).
/// `scratch` grows as needed.
///
/// Compiled twice: for AVX2, chosen at run time where the machine has it
/// (the column blocks four wide instead of two), and for any x86-64. Both
/// multiply and add in the same order, so they give the same bits.
#[allow(unsafe_code, reason = "the AVX2 build, called after the feature check")]
pub(crate) fn householder_rows(
    a: &mut [f64],
    m: usize,
    n: usize,
    k: usize,
    scratch: &mut Vec<f64>,
) {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the machine runs AVX2.
        return unsafe { householder_rows_avx2(a, m, n, k, scratch) };
    }
    householder_rows_in(a, m, n, k, scratch);
}

/// [`householder_rows`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn householder_rows_avx2(a: &mut [f64], m: usize, n: usize, k: usize, scratch: &mut Vec<f64>) {
    householder_rows_in(a, m, n, k, scratch);
}

/// The body of [`householder_rows`], inlined into each of its builds.
#[inline(always)]
fn householder_rows_in(a: &mut [f64], m: usize, n: usize, k: usize, scratch: &mut Vec<f64>) {
    debug_assert!(a.len() >= m * n && k <= n);
    let kk = k.min(m);
    if kk == 0 {
        return;
    }
    if scratch.len() < kk {
        scratch.resize(kk, 0.0);
    }
    let tau = &mut scratch[..kk];
    householder_panel(a, m, n, k, tau);
    for j in 0..kk {
        if tau[j] == 0.0 {
            continue;
        }
        // Blocks of BLOCK columns, then the last columns in halving blocks.
        let mut c = k;
        while c < n {
            c += match n - c {
                BLOCK.. => reflect_columns::<BLOCK>(a, m, n, j, c, tau[j]),
                8.. => reflect_columns::<8>(a, m, n, j, c, tau[j]),
                4.. => reflect_columns::<4>(a, m, n, j, c, tau[j]),
                2.. => reflect_columns::<2>(a, m, n, j, c, tau[j]),
                _ => reflect_columns::<1>(a, m, n, j, c, tau[j]),
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
        // (9, 34, 3): 31 trailing columns, a block of each width (16, 8, 4,
        // 2 and 1); (6, 34, 4): a first column zero below the diagonal (no
        // reflector).
        for (m, n, k) in [(7, 5, 3), (9, 34, 3), (24, 37, 3), (6, 34, 4)] {
            let mut seed = 1;
            let mut a0: Vec<f64> = (0..m * n).map(|_| lcg(&mut seed)).collect();
            if k == 4 {
                for r in 1..m {
                    a0[r * n] = 0.0;
                }
            }
            assert_reflects(&a0, m, n, k);
            let mut blocked = a0.clone();
            householder_rows(&mut blocked, m, n, k, &mut Vec::new());
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
            householder_rows(&mut dispatched, m, n, k, &mut Vec::new());
            let mut portable = a0;
            householder_rows_in(&mut portable, m, n, k, &mut Vec::new());
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
        let mut w = Vec::new();
        householder_rows(&mut a, m, n, k, &mut w);
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
            householder_rows(&mut a, m, n, k, &mut Vec::new());
            assert_eq!(triangle_has_full_rank(&a, m, n, k), full, "noise {noise}");
        }
        // A zero column, and fewer rows than columns.
        let mut a = vec![1.0, 0.0, 3.0, 2.0, 0.0, 1.0, 4.0, 0.0, 5.0];
        householder_rows(&mut a, 3, 3, 2, &mut Vec::new());
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
