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

use nalgebra::{Matrix6, Vector6};

use crate::KinematicsError;

/// Ratio of the smallest to the largest pivot below which `A` is singular.
pub const SINGULAR_PIVOT_RATIO: f64 = 1e-12;

/// `P A = L U`: `L` unit lower triangular and `U` upper triangular, packed.
#[derive(Debug, Clone)]
pub struct Lu6 {
    lu: [[f64; 6]; 6],
    /// Row `k` of `P A` is row `permutation[k]` of `A`.
    permutation: [usize; 6],
}

impl Lu6 {
    /// Factorises `a`, refusing a (nearly) singular matrix.
    #[inline]
    pub fn factor(a: &Matrix6<f64>) -> Result<Self, KinematicsError> {
        // Row-major copy; nalgebra stores columns.
        let mut lu = [[0.0; 6]; 6];
        for (j, column) in a.column_iter().enumerate() {
            for i in 0..6 {
                lu[i][j] = column[i];
            }
        }
        let mut permutation = [0, 1, 2, 3, 4, 5];
        let (mut smallest, mut largest) = (f64::INFINITY, 0.0f64);
        for k in 0..6 {
            let mut pivot_row = k;
            for i in k + 1..6 {
                if lu[i][k].abs() > lu[pivot_row][k].abs() {
                    pivot_row = i;
                }
            }
            lu.swap(k, pivot_row);
            permutation.swap(k, pivot_row);
            let pivot = lu[k][k];
            if pivot == 0.0 || !pivot.is_finite() {
                return Err(KinematicsError::SingularJacobian);
            }
            smallest = smallest.min(pivot.abs());
            largest = largest.max(pivot.abs());
            let inverse = pivot.recip();
            for i in k + 1..6 {
                let factor = lu[i][k] * inverse;
                lu[i][k] = factor;
                for j in k + 1..6 {
                    lu[i][j] -= factor * lu[k][j];
                }
            }
        }
        let well_conditioned = smallest > SINGULAR_PIVOT_RATIO * largest;
        if !well_conditioned {
            return Err(KinematicsError::SingularJacobian);
        }
        Ok(Self { lu, permutation })
    }

    /// `x` with `A x = b`: `L y = P b`, `U x = y`.
    pub fn solve(&self, b: &Vector6<f64>) -> Vector6<f64> {
        let lu = &self.lu;
        let mut x = [0.0; 6];
        for i in 0..6 {
            x[i] = b[self.permutation[i]] - (0..i).map(|j| lu[i][j] * x[j]).sum::<f64>();
        }
        for i in (0..6).rev() {
            x[i] = (x[i] - (i + 1..6).map(|j| lu[i][j] * x[j]).sum::<f64>()) / lu[i][i];
        }
        Vector6::from(x)
    }

    /// `x` with `A^T x = b`: `U^T y = b`, `L^T z = y`, `x = P^T z`.
    pub fn solve_transpose(&self, b: &Vector6<f64>) -> Vector6<f64> {
        let lu = &self.lu;
        let mut z = [0.0; 6];
        for i in 0..6 {
            z[i] = (b[i] - (0..i).map(|j| lu[j][i] * z[j]).sum::<f64>()) / lu[i][i];
        }
        for i in (0..6).rev() {
            z[i] -= (i + 1..6).map(|j| lu[j][i] * z[j]).sum::<f64>();
        }
        let mut x = Vector6::zeros();
        for (k, &row) in self.permutation.iter().enumerate() {
            x[row] = z[k];
        }
        x
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn matrix() -> Matrix6<f64> {
        Matrix6::from_fn(|i, j| {
            ((i * 7 + j * 3) % 11) as f64 - 5.0 + if i == j { 0.5 } else { 0.0 }
        })
    }

    #[test]
    fn solves_by_the_matrix_and_its_transpose() {
        let a = matrix();
        let b = Vector6::new(1.0, -2.0, 3.0, 0.5, -0.25, 4.0);
        let lu = Lu6::factor(&a).unwrap();
        assert!((a * lu.solve(&b) - b).amax() < 1e-12);
        assert!((a.transpose() * lu.solve_transpose(&b) - b).amax() < 1e-12);
    }

    #[test]
    fn refuses_singular_matrices() {
        let mut a = matrix();
        let row = a.row(2).into_owned();
        a.set_row(4, &(row * 2.0));
        assert_eq!(
            Lu6::factor(&a).unwrap_err(),
            KinematicsError::SingularJacobian
        );
        assert!(Lu6::factor(&Matrix6::zeros()).is_err());
    }
}
