//! The Gram update `N += AᵀA` of a chunk's reduced rows, on the lower
//! triangle of `N`.
//!
//! A kernel of its own rather than a library GEMM: faer's product (through
//! the `private-gemm-x86` crate) reserves packing space of twice the
//! last-level cache on every thread that multiplies, whatever the size of
//! the product, and that reservation alone exceeds an address-space limit
//! of a few hundred MiB (docs/reliability.md, "Address space").

use crate::rows::rows;

/// Output rows of a tile: one AVX-512 or two AVX2 registers per column.
const TILE_ROWS: usize = 8;
/// Output columns of a tile: with [`TILE_ROWS`], 32 sums in registers.
const TILE_COLUMNS: usize = 4;
/// Rows of `A` streamed past all tiles before the next block: 64 rows of
/// `G + 1 = 34` values (17 KiB) stay in the L1 cache meanwhile.
const ROW_BLOCK: usize = 64;

/// `N += AᵀA` on the lower triangle (`i ≥ j`) of the `w × w` column-major
/// `normal`; `a` is `m × w` row-major. The upper triangle is not touched.
///
/// Every entry is summed over the rows in order, `N_ij + a_0i a_0j +
/// a_1i a_1j + …`, each product added by a fused multiply-add (one
/// rounding), so the tiling, the row blocks and the build give the same
/// bits. Compiled three times: for AVX-512 and for AVX2, each with FMA,
/// chosen at run time where the machine has them, and for any x86-64
/// (whose fused multiply-add is the C library's `fma`, slow on a machine
/// without the instruction).
#[allow(
    unsafe_code,
    reason = "the AVX-512 and AVX2 builds, called after the feature check"
)]
pub(crate) fn add_gram_lower(normal: &mut [f64], a: &[f64], m: usize, w: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        let fma = std::arch::is_x86_feature_detected!("fma");
        if fma && std::arch::is_x86_feature_detected!("avx512f") {
            // SAFETY: the machine runs AVX-512F and FMA.
            return unsafe { add_gram_lower_avx512(normal, a, m, w) };
        }
        if fma && std::arch::is_x86_feature_detected!("avx2") {
            // SAFETY: the machine runs AVX2 and FMA.
            return unsafe { add_gram_lower_avx2(normal, a, m, w) };
        }
    }
    add_gram_lower_in::<Portable>(normal, a, m, w);
}

/// [`add_gram_lower`] compiled for AVX-512.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,fma")]
fn add_gram_lower_avx512(normal: &mut [f64], a: &[f64], m: usize, w: usize) {
    add_gram_lower_in::<simd::Avx512>(normal, a, m, w);
}

/// [`add_gram_lower`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn add_gram_lower_avx2(normal: &mut [f64], a: &[f64], m: usize, w: usize) {
    add_gram_lower_in::<simd::Avx2>(normal, a, m, w);
}

/// How a build adds a full tile, [`TILE_ROWS`] × `J`: with the same
/// fused multiply-adds in the same order as [`add_tile`], in vector
/// registers where the build has them.
trait FullTile {
    /// [`add_tile`]`::<TILE_ROWS, J>`.
    fn add<const J: usize>(normal: &mut [f64], block: &[f64], w: usize, i: usize, j: usize);
}

/// Any x86-64: [`add_tile`] itself.
struct Portable;

impl FullTile for Portable {
    #[inline(always)]
    fn add<const J: usize>(normal: &mut [f64], block: &[f64], w: usize, i: usize, j: usize) {
        add_tile::<TILE_ROWS, J>(normal, block, w, i, j);
    }
}

/// The body of [`add_gram_lower`], inlined into each of its builds (every
/// call below is direct, so that the tiles are compiled for the build's
/// registers): the rows in blocks of [`ROW_BLOCK`], each block over the
/// lower triangle a column block of [`TILE_COLUMNS`] at a time (narrower at
/// the right edge).
#[inline(always)]
fn add_gram_lower_in<T: FullTile>(normal: &mut [f64], a: &[f64], m: usize, w: usize) {
    assert!(
        a.len() >= m * w && normal.len() >= w * w,
        "A is m × w, N is w × w"
    );
    for block in a[..m * w].chunks(ROW_BLOCK * w) {
        let mut j = 0;
        while j < w {
            j += match w - j {
                TILE_COLUMNS.. => add_column_block::<TILE_COLUMNS, T>(normal, block, w, j),
                2.. => add_column_block::<2, T>(normal, block, w, j),
                _ => add_column_block::<1, T>(normal, block, w, j),
            };
        }
    }
}

/// Rows `j..w` of the column block `j..j + J`, in tiles of [`TILE_ROWS`]
/// from the bottom up; the top tile reaches above the diagonal (whose
/// entries it does not store) where the matrix has rows enough, else the
/// rows left take shorter tiles. Returns `J`, the columns done.
#[inline(always)]
fn add_column_block<const J: usize, T: FullTile>(
    normal: &mut [f64],
    block: &[f64],
    w: usize,
    j: usize,
) -> usize {
    let mut end = w;
    while end - j >= TILE_ROWS {
        end -= TILE_ROWS;
        T::add::<J>(normal, block, w, end, j);
    }
    if end > j && end >= TILE_ROWS {
        T::add::<J>(normal, block, w, end - TILE_ROWS, j);
        return J;
    }
    let mut i = j;
    while i < end {
        i += match end - i {
            4.. => add_tile::<4, J>(normal, block, w, i, j),
            2.. => add_tile::<2, J>(normal, block, w, i, j),
            _ => add_tile::<1, J>(normal, block, w, i, j),
        };
    }
    J
}

/// `N[i..i + I, j..j + J] += A[:, i..i + I]ᵀ A[:, j..j + J]` over the rows of
/// `block` (row stride `w`), the tile's sums in registers; entries above the
/// diagonal (`i + s < j + t`) are summed but not stored. Returns `I`, the
/// rows done.
#[inline(always)]
fn add_tile<const I: usize, const J: usize>(
    normal: &mut [f64],
    block: &[f64],
    w: usize,
    i: usize,
    j: usize,
) -> usize {
    const IN_ROW: &str = "the tile lies in the row";
    let mut sums = [[0.0; I]; J];
    for (t, column) in sums.iter_mut().enumerate() {
        *column = *normal[(j + t) * w + i..].first_chunk::<I>().expect(IN_ROW);
    }
    for row in rows(block, w) {
        let x = row[i..].first_chunk::<I>().expect(IN_ROW);
        let y = row[j..].first_chunk::<J>().expect(IN_ROW);
        for t in 0..J {
            for s in 0..I {
                sums[t][s] = y[t].mul_add(x[s], sums[t][s]);
            }
        }
    }
    for (t, column) in sums.iter().enumerate() {
        store_lower(normal, w, i, j + t, column);
    }
    I
}

/// A tile's sums `column` of the output column `c`, rows `i..i + I`, into
/// `normal`: the rows `i + s ≥ c` only, the lower triangle.
#[inline(always)]
fn store_lower<const I: usize>(
    normal: &mut [f64],
    w: usize,
    i: usize,
    c: usize,
    column: &[f64; I],
) {
    let first = c.saturating_sub(i).min(I);
    let out = normal[c * w + i..]
        .first_chunk_mut::<I>()
        .expect("the tile lies in the row");
    // Entry by entry over the tile's fixed length: a copy of the variable
    // tail would be a call to `memcpy`.
    for (s, (o, x)) in out.iter_mut().zip(column).enumerate() {
        if s >= first {
            *o = *x;
        }
    }
}

/// The full tiles of the AVX-512 and AVX2 builds, in vector registers.
#[cfg(target_arch = "x86_64")]
#[allow(
    unsafe_code,
    reason = "AVX-512 and AVX2 intrinsics, reached only from the builds for them"
)]
mod simd {
    use std::arch::x86_64::{
        _mm256_fmadd_pd, _mm256_loadu_pd, _mm256_set1_pd, _mm256_storeu_pd, _mm512_fmadd_pd,
        _mm512_loadu_pd, _mm512_set1_pd, _mm512_storeu_pd,
    };

    use super::{FullTile, TILE_ROWS, store_lower};
    use crate::rows::rows;

    /// One AVX-512 register of eight sums per column.
    pub(super) struct Avx512;

    /// Two AVX2 registers of four sums per column.
    pub(super) struct Avx2;

    /// The tile's current sums, column by column.
    #[inline(always)]
    fn loaded<const J: usize>(
        normal: &[f64],
        w: usize,
        i: usize,
        j: usize,
    ) -> [[f64; TILE_ROWS]; J] {
        std::array::from_fn(|t| {
            *normal[(j + t) * w + i..]
                .first_chunk::<TILE_ROWS>()
                .expect("the tile lies in the row")
        })
    }

    impl FullTile for Avx512 {
        #[inline(always)]
        fn add<const J: usize>(normal: &mut [f64], block: &[f64], w: usize, i: usize, j: usize) {
            let mut columns = loaded::<J>(normal, w, i, j);
            // SAFETY: `Avx512` is the tile of `add_gram_lower_avx512`
            // alone, compiled for AVX-512F and FMA and called where the
            // machine runs them; every load and store is of eight values
            // of an array of eight or of a row checked to hold them.
            unsafe {
                let mut sums = columns.map(|c| _mm512_loadu_pd(c.as_ptr()));
                for row in rows(block, w) {
                    let x = row[i..]
                        .first_chunk::<TILE_ROWS>()
                        .expect("the tile lies in the row");
                    let x = _mm512_loadu_pd(x.as_ptr());
                    for (t, sum) in sums.iter_mut().enumerate() {
                        *sum = _mm512_fmadd_pd(_mm512_set1_pd(row[j + t]), x, *sum);
                    }
                }
                for (column, sum) in columns.iter_mut().zip(sums) {
                    _mm512_storeu_pd(column.as_mut_ptr(), sum);
                }
            }
            for (t, column) in columns.iter().enumerate() {
                store_lower(normal, w, i, j + t, column);
            }
        }
    }

    impl FullTile for Avx2 {
        #[inline(always)]
        fn add<const J: usize>(normal: &mut [f64], block: &[f64], w: usize, i: usize, j: usize) {
            let mut columns = loaded::<J>(normal, w, i, j);
            // SAFETY: `Avx2` is the tile of `add_gram_lower_avx2` alone,
            // compiled for AVX2 and FMA and called where the machine runs
            // them; every load and store is of four values within an array
            // of eight or a row checked to hold eight.
            unsafe {
                let mut sums = columns.map(|c| {
                    [
                        _mm256_loadu_pd(c.as_ptr()),
                        _mm256_loadu_pd(c[4..].as_ptr()),
                    ]
                });
                for row in rows(block, w) {
                    let x = row[i..]
                        .first_chunk::<TILE_ROWS>()
                        .expect("the tile lies in the row");
                    let (low, high) = (
                        _mm256_loadu_pd(x.as_ptr()),
                        _mm256_loadu_pd(x[4..].as_ptr()),
                    );
                    for (t, [sum_low, sum_high]) in sums.iter_mut().enumerate() {
                        let y = _mm256_set1_pd(row[j + t]);
                        *sum_low = _mm256_fmadd_pd(y, low, *sum_low);
                        *sum_high = _mm256_fmadd_pd(y, high, *sum_high);
                    }
                }
                for (column, [low, high]) in columns.iter_mut().zip(sums) {
                    _mm256_storeu_pd(column.as_mut_ptr(), low);
                    _mm256_storeu_pd(column[4..].as_mut_ptr(), high);
                }
            }
            for (t, column) in columns.iter().enumerate() {
                store_lower(normal, w, i, j + t, column);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};

    use super::*;

    /// `N + AᵀA` entry by entry, each summed over the rows in order by
    /// fused multiply-adds.
    fn reference(normal: &[f64], a: &[f64], m: usize, w: usize) -> Vec<f64> {
        let mut out = normal.to_vec();
        for j in 0..w {
            for i in j..w {
                let mut s = normal[j * w + i];
                for k in 0..m {
                    s = a[k * w + j].mul_add(a[k * w + i], s);
                }
                out[j * w + i] = s;
            }
        }
        out
    }

    /// Uniform values in [-0.5, 0.5) with every bit of the mantissa in use,
    /// so that another order of the sums would change the result.
    fn values(n: usize, seed: u64) -> Vec<f64> {
        let mut rng = StdRng::seed_from_u64(seed);
        (0..n).map(|_| rng.random::<f64>() - 0.5).collect()
    }

    #[test]
    #[allow(unsafe_code, reason = "the AVX2 build, called after the feature check")]
    fn every_width_and_row_count_gives_the_ordered_sums_bit_for_bit() {
        // Widths across the tile edges (and G + 1 = 34); row counts across
        // the row blocks.
        for w in [1, 2, 3, 5, 8, 9, 13, 34, 40] {
            for m in [0, 1, 7, ROW_BLOCK, ROW_BLOCK + 3, 3 * ROW_BLOCK + 11] {
                let a = values(m * w, (w * 1000 + m) as u64);
                let normal = values(w * w, 7);
                let want = reference(&normal, &a, m, w);
                let mut got = normal.clone();
                add_gram_lower(&mut got, &a, m, w);
                assert_eq!(
                    got.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    want.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
                    "w = {w}, m = {m}"
                );
                // The portable build gives the same bits as the one chosen.
                let mut portable = normal.clone();
                add_gram_lower_in::<Portable>(&mut portable, &a, m, w);
                assert_eq!(portable, got, "w = {w}, m = {m}");
                // So does the AVX2 build where the AVX-512 one is chosen.
                #[cfg(target_arch = "x86_64")]
                if std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
                {
                    let mut avx2 = normal.clone();
                    // SAFETY: the machine runs AVX2 and FMA.
                    unsafe { add_gram_lower_avx2(&mut avx2, &a, m, w) };
                    assert_eq!(avx2, got, "w = {w}, m = {m}");
                }
            }
        }
    }
}
