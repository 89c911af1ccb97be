//! LU factorisation with partial pivoting of the 6 x 6 closure Jacobian,
//! with solves by `A` and by `A^T` from one factorisation (the forward
//! kinematics step needs the first, the tip derivatives the second).
//!
//! Fixed-size arrays and plain index loops (iterator adapters over the
//! shrinking ranges defeat unrolling here): nothing allocates. A matrix whose
//! smallest pivot is below [`SINGULAR_PIVOT_RATIO`] of its largest counts as
//! singular (a singular configuration of the mechanism).

#![allow(
    clippy::needless_range_loop,
    reason = "index arithmetic of the factorisation reads best"
)]

use nalgebra::Vector6;

use crate::KinematicsError;

/// Ratio of the smallest to the largest pivot below which `A` is singular.
pub const SINGULAR_PIVOT_RATIO: f64 = 1e-12;

/// `P A = L U`: `L` unit lower triangular and `U` upper triangular, packed,
/// with the diagonal of `U` stored as its reciprocal (the solves multiply).
#[derive(Debug, Clone)]
pub struct Lu6 {
    lu: [[f64; 6]; 6],
    /// Row `k` of `P A` is row `permutation[k]` of `A`.
    permutation: [u8; 6],
}

impl Default for Lu6 {
    /// The factorisation of the identity.
    fn default() -> Self {
        Self {
            // The identity is its own reciprocal diagonal.
            lu: std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j)))),
            permutation: [0, 1, 2, 3, 4, 5],
        }
    }
}

impl Lu6 {
    /// Factorises the matrix with these rows, refusing a (nearly) singular
    /// one.
    #[inline]
    pub fn factor(rows: [[f64; 6]; 6]) -> Result<Self, KinematicsError> {
        let mut factor = Self::default();
        factor.factor_in_place(rows)?;
        Ok(factor)
    }

    /// [`Lu6::factor`] into `self` (left unchanged on error): the forward
    /// kinematics' hot path, where returning the 300-byte factorisation by
    /// value cost a copy per factorisation.
    #[inline]
    pub fn factor_in_place(&mut self, rows: [[f64; 6]; 6]) -> Result<(), KinematicsError> {
        let mut lu = rows;
        let mut permutation = [0, 1, 2, 3, 4, 5];
        let mut pivots = [0.0; 6];
        // One elimination step per column, each with constant loop bounds
        // (unrolled by the compiler).
        pivots[0] = eliminate_column::<0>(&mut lu, &mut permutation);
        pivots[1] = eliminate_column::<1>(&mut lu, &mut permutation);
        pivots[2] = eliminate_column::<2>(&mut lu, &mut permutation);
        pivots[3] = eliminate_column::<3>(&mut lu, &mut permutation);
        pivots[4] = eliminate_column::<4>(&mut lu, &mut permutation);
        pivots[5] = eliminate_column::<5>(&mut lu, &mut permutation);
        let smallest = pivots.iter().fold(f64::INFINITY, |m, p| m.min(p.abs()));
        let largest = pivots.iter().fold(0.0f64, |m, p| m.max(p.abs()));
        // `min` and `max` skip NaN: finiteness is checked on every pivot.
        let finite = pivots.iter().all(|p| p.is_finite());
        if !(finite && smallest > SINGULAR_PIVOT_RATIO * largest) {
            return Err(KinematicsError::SingularJacobian);
        }
        self.lu = lu;
        self.permutation = permutation;
        Ok(())
    }

    /// `x` with `A x = b`: `L y = P b`, `U x = y`.
    pub fn solve(&self, b: &Vector6<f64>) -> Vector6<f64> {
        let lu = &self.lu;
        let mut x = [0.0; 6];
        for i in 0..6 {
            x[i] =
                b[usize::from(self.permutation[i])] - (0..i).map(|j| lu[i][j] * x[j]).sum::<f64>();
        }
        for i in (0..6).rev() {
            x[i] = (x[i] - (i + 1..6).map(|j| lu[i][j] * x[j]).sum::<f64>()) * lu[i][i];
        }
        Vector6::from(x)
    }

    /// `x` with `A^T x = b`: `U^T y = b`, `L^T z = y`, `x = P^T z`.
    pub fn solve_transpose(&self, b: &Vector6<f64>) -> Vector6<f64> {
        let lu = &self.lu;
        let mut z = [0.0; 6];
        for i in 0..6 {
            z[i] = (b[i] - (0..i).map(|j| lu[j][i] * z[j]).sum::<f64>()) * lu[i][i];
        }
        for i in (0..6).rev() {
            z[i] -= (i + 1..6).map(|j| lu[j][i] * z[j]).sum::<f64>();
        }
        let mut x = Vector6::zeros();
        for (k, &row) in self.permutation.iter().enumerate() {
            x[usize::from(row)] = z[k];
        }
        x
    }
}

/// Step `K` of the factorisation: the row with the largest entry in column
/// `K` (from row `K` down) becomes the pivot row, then the rows below it are
/// eliminated; returns the pivot (zero for a zero column, refused later).
///
/// Every index is a compile-time constant and the row exchange is a
/// branch-free select, so that the whole factorisation stays in registers:
/// exchanging rows through a run-time index stalls on store forwarding and
/// made this three times slower.
#[inline(always)]
fn eliminate_column<const K: usize>(lu: &mut [[f64; 6]; 6], permutation: &mut [u8; 6]) -> f64 {
    let (mut pivot_row, mut largest) = (K, lu[K][K].abs());
    for i in K + 1..6 {
        let candidate = lu[i][K].abs();
        let better = candidate > largest;
        largest = if better { candidate } else { largest };
        pivot_row = if better { i } else { pivot_row };
    }
    for i in K + 1..6 {
        let exchange = i == pivot_row;
        for j in 0..6 {
            let (top, other) = (lu[K][j], lu[i][j]);
            lu[K][j] = if exchange { other } else { top };
            lu[i][j] = if exchange { top } else { other };
        }
        let (top, other) = (permutation[K], permutation[i]);
        permutation[K] = if exchange { other } else { top };
        permutation[i] = if exchange { top } else { other };
    }
    let pivot = lu[K][K];
    let inverse = if pivot == 0.0 { 0.0 } else { pivot.recip() };
    lu[K][K] = inverse;
    for i in K + 1..6 {
        let factor = lu[i][K] * inverse;
        lu[i][K] = factor;
        for j in K + 1..6 {
            lu[i][j] -= factor * lu[K][j];
        }
    }
    pivot
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix6;

    fn rows(a: &Matrix6<f64>) -> [[f64; 6]; 6] {
        std::array::from_fn(|i| std::array::from_fn(|j| a[(i, j)]))
    }

    fn matrix() -> Matrix6<f64> {
        Matrix6::from_fn(|i, j| {
            ((i * 7 + j * 3) % 11) as f64 - 5.0 + if i == j { 0.5 } else { 0.0 }
        })
    }

    #[test]
    fn solves_by_the_matrix_and_its_transpose() {
        let a = matrix();
        let b = Vector6::new(1.0, -2.0, 3.0, 0.5, -0.25, 4.0);
        let lu = Lu6::factor(rows(&a)).unwrap();
        assert!((a * lu.solve(&b) - b).amax() < 1e-12);
        assert!((a.transpose() * lu.solve_transpose(&b) - b).amax() < 1e-12);
    }

    #[test]
    fn refuses_singular_matrices() {
        let mut a = matrix();
        let row = a.row(2).into_owned();
        a.set_row(4, &(row * 2.0));
        assert_eq!(
            Lu6::factor(rows(&a)).unwrap_err(),
            KinematicsError::SingularJacobian
        );
        assert!(Lu6::factor([[0.0; 6]; 6]).is_err());
        // NaN pivots, which `min` and `max` would skip.
        assert!(Lu6::factor([[f64::NAN; 6]; 6]).is_err());
        let mut a = matrix();
        a[(3, 3)] = f64::NAN;
        assert!(Lu6::factor(rows(&a)).is_err());
    }
}
