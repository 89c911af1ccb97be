//! Products with `L`, the lower-triangular factor of the global block's
//! covariance `Cov(g) = LLᵀ` (`G × G`, row-major, zeros above the
//! diagonal): `z = Lᵀu`, so that `|z|² = uᵀ Cov(g) u`. A row's leverage at
//! the global level ([`crate::redundancy`]) and a group's marginal
//! variance through its gain `K` ([`crate::covariance`]) are such forms.

/// `|Lᵀk_a|² = k_aᵀ Cov(g) k_a` of each of the `R` rows `k_a` of `rows`
/// (`R × G`, row-major), `z` room for `R × G` values
/// ([`times_factor_rows`]).
///
/// Compiled twice: for AVX2, chosen at run time where the machine has it,
/// and for any x86-64. Both multiply and add in the same order, so they
/// give the same bits.
#[allow(unsafe_code, reason = "the AVX2 build, called after the feature check")]
pub(crate) fn quadratic_forms<const R: usize>(
    factor: &[f64],
    rows: &[f64],
    z: &mut [f64],
) -> [f64; R] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the machine runs AVX2.
        return unsafe { quadratic_forms_avx2::<R>(factor, rows, z) };
    }
    quadratic_forms_in::<R>(factor, rows, z)
}

/// [`quadratic_forms`] compiled for AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn quadratic_forms_avx2<const R: usize>(factor: &[f64], rows: &[f64], z: &mut [f64]) -> [f64; R] {
    quadratic_forms_in::<R>(factor, rows, z)
}

/// The body of [`quadratic_forms`], inlined into each of its builds.
#[inline(always)]
fn quadratic_forms_in<const R: usize>(factor: &[f64], rows: &[f64], z: &mut [f64]) -> [f64; R] {
    let g = rows.len() / R;
    times_factor_rows::<R>(factor, rows, z, 0);
    std::array::from_fn(|a| norm2(&z[a * g..(a + 1) * g]))
}

/// `|a|²`, summed in order. Inlined, so that each AVX2 build has its own.
#[inline(always)]
pub(crate) fn norm2(a: &[f64]) -> f64 {
    a.iter().map(|x| x * x).sum()
}

/// Columns of `Lᵀu` at a time: as many as an AVX2 build keeps in two
/// registers per row.
const FACTOR_BLOCK: usize = 8;

/// `z_e = Lᵀu_e` ([`times_factor`], the same sums in the same order) for
/// the `R` rows `u_e` of `reduced` (`R × G`), into columns `offset..offset
/// + G` of the rows of `out` (`R` rows of `offset + G`): a block of
/// [`FACTOR_BLOCK`] columns of every row at a time, so that each row of
/// `L` is read once for all of them and the sums stay in registers. The
/// block of columns `j..` starts at row `j` of `L`: the rows above are
/// zero there, and their `±0` products leave the sums' bits as they are
/// ([`times_factor`]).
#[inline(always)]
pub(crate) fn times_factor_rows<const R: usize>(
    factor: &[f64],
    reduced: &[f64],
    out: &mut [f64],
    offset: usize,
) {
    let g = reduced.len() / R;
    let mut j = 0;
    while j + FACTOR_BLOCK <= g {
        factor_block::<R, FACTOR_BLOCK>(factor, reduced, out, offset, j);
        j += FACTOR_BLOCK;
    }
    while j < g {
        factor_block::<R, 1>(factor, reduced, out, offset, j);
        j += 1;
    }
}

/// Columns `j..j + B` of [`times_factor_rows`].
#[inline(always)]
fn factor_block<const R: usize, const B: usize>(
    factor: &[f64],
    reduced: &[f64],
    out: &mut [f64],
    offset: usize,
    j: usize,
) {
    let g = reduced.len() / R;
    let mut sums = [[0.0; B]; R];
    for (i, row) in factor.chunks_exact(g).enumerate().skip(j) {
        let l: &[f64; B] = row[j..j + B].try_into().expect("B columns");
        for (e, sum) in sums.iter_mut().enumerate() {
            let u = reduced[e * g + i];
            for (s, l) in sum.iter_mut().zip(l) {
                *s += l * u;
            }
        }
    }
    let width = offset + g;
    for (e, sum) in sums.iter().enumerate() {
        out[e * width + offset + j..e * width + offset + j + B].copy_from_slice(sum);
    }
}

/// `z = Lᵀu` for the lower-triangular `L` (`G × G`, row-major, zeros above
/// the diagonal) with `Cov(g) = LLᵀ`, so that `|z|² = uᵀ Cov(g) u`; by
/// whole rows of `L` (`z += L[i, ..] u_i`, lanes independent, every row of
/// one length), whose zeros add `±0` to sums that are never `−0`: the
/// bits of the lower triangle's products alone. Inlined, so that each
/// AVX2 build has its own.
#[inline(always)]
pub(crate) fn times_factor(factor: &[f64], u: &[f64], z: &mut [f64]) {
    let g = u.len();
    z.fill(0.0);
    for (row, &ui) in factor.chunks_exact(g).zip(u) {
        for (z, l) in z.iter_mut().zip(row) {
            *z += l * ui;
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::DMatrix;

    use super::*;

    /// `|Lᵀk|²` of each row is `kᵀ Cov(g) k` with `Cov(g) = LLᵀ`, for sizes
    /// with and without a partial block of columns.
    #[test]
    fn quadratic_forms_are_those_of_the_covariance() {
        for g in [1, 7, 8, 9, 33] {
            let factor = DMatrix::from_fn(g, g, |i, k| {
                if k <= i {
                    (1.0 + ((3 * i + 5 * k) % 7) as f64) / (1.0 + k as f64)
                } else {
                    0.0
                }
            });
            let covariance = &factor * factor.transpose();
            let rows = DMatrix::from_fn(4, g, |a, j| ((a * 11 + j * 5) % 9) as f64 - 4.0);
            let row_major: Vec<f64> = rows.transpose().as_slice().to_vec();
            let factor_rows: Vec<f64> = factor.transpose().as_slice().to_vec();
            let mut z = vec![f64::NAN; 4 * g];
            let forms = quadratic_forms::<4>(&factor_rows, &row_major, &mut z);
            for (a, form) in forms.iter().enumerate() {
                let k = rows.row(a).transpose();
                let expected = (k.transpose() * &covariance * &k)[(0, 0)];
                assert!(
                    (form - expected).abs() <= 1e-12 * expected.abs(),
                    "G = {g}, row {a}: {form} against {expected}"
                );
            }
        }
    }
}
