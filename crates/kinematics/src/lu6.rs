//! LU factorisation of the 6 x 6 closure Jacobian, with solves by `A` and by
//! `A^T` from one factorisation (the forward kinematics step needs the first,
//! the tip derivatives the second).
//!
//! Threshold pivoting: the rows are first tried in the previous
//! factorisation's order, and partial pivoting takes over only when that
//! order would pivot on a small entry. Fixed-size arrays and plain index
//! loops (iterator adapters over the shrinking ranges defeat unrolling
//! here): nothing allocates. A matrix whose smallest pivot is below
//! [`SINGULAR_PIVOT_RATIO`] of its largest counts as singular (a singular
//! configuration of the mechanism).

#![allow(
    clippy::needless_range_loop,
    reason = "index arithmetic of the factorisation reads best"
)]

use nalgebra::Vector6;

use crate::KinematicsError;

/// Ratio of the smallest to the largest pivot below which `A` is singular.
pub const SINGULAR_PIVOT_RATIO: f64 = 1e-12;

/// A pivot in the trial row order is kept if it is at least this fraction of
/// the largest entry below it in its column ([`Lu6::factor_in_place`]).
pub const THRESHOLD: f64 = 0.25;

/// The pivots of the six steps `step::<0>(args)` .. `step::<5>(args)` of a
/// factorisation, in order: each step with constant loop bounds, unrolled
/// by the compiler.
macro_rules! each_column {
    ($step:ident($($arg:expr),*)) => {
        [
            $step::<0>($($arg),*),
            $step::<1>($($arg),*),
            $step::<2>($($arg),*),
            $step::<3>($($arg),*),
            $step::<4>($($arg),*),
            $step::<5>($($arg),*),
        ]
    };
}

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
    /// The row order: row `k` of `P A` is row `permutation()[k]` of `A`.
    pub(crate) fn permutation(&self) -> [u8; 6] {
        self.permutation
    }

    /// The packed factors and the row order, to be written in place by
    /// the lanes ([`crate::forward_batch`]), which factorise as [`Lu6`] does.
    pub(crate) fn factors_mut(&mut self) -> (&mut [[f64; 6]; 6], &mut [u8; 6]) {
        (&mut self.lu, &mut self.permutation)
    }

    /// Factorises the matrix with these rows, refusing a (nearly) singular
    /// one.
    #[inline]
    pub fn factor(rows: [[f64; 6]; 6]) -> Result<Self, KinematicsError> {
        let mut factor = Self::default();
        factor.factor_in_place(rows)?;
        Ok(factor)
    }

    /// [`Lu6::factor`] into `self` (whose factors are unspecified after an
    /// error): the forward kinematics' hot path, where returning the
    /// 300-byte factorisation by value cost a copy per factorisation.
    ///
    /// The rows are first tried in the order of `self`'s permutation (the
    /// previous factorisation's: the closure Jacobians of one forward
    /// kinematics, and of the contacts of one ball, differ little), kept if
    /// every pivot is at least [`THRESHOLD`] times the largest entry below
    /// it in its column (threshold pivoting, as sparse LU codes do: a step
    /// multiplies the entries by at most `1 + 1 / THRESHOLD`). Otherwise
    /// partial pivoting starts again from `rows`. The trial exchanges no
    /// rows, which is what a partial pivoting step costs most, and in a
    /// calibration few trials fall back. The factors, equal up to rounding,
    /// thus depend on the factorisation before: a sequence of
    /// factorisations into the same `Lu6` is reproducible, and a
    /// calibration's passes start each chunk of balls from a new one.
    #[inline]
    pub fn factor_in_place(&mut self, rows: [[f64; 6]; 6]) -> Result<(), KinematicsError> {
        let order = self.permutation;
        let lu = &mut self.lu;
        for (row, &k) in lu.iter_mut().zip(&order) {
            *row = rows[usize::from(k)];
        }
        let mut accepted = true;
        let pivots = each_column!(eliminate_in_order(lu, &mut accepted));
        if accepted {
            return check_pivots(&pivots);
        }
        let mut lu = rows;
        let mut permutation = [0, 1, 2, 3, 4, 5];
        let pivots = each_column!(eliminate_column(&mut lu, &mut permutation));
        check_pivots(&pivots)?;
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
        let [x] = self.solve_transpose_each(&[*b]);
        x
    }

    /// [`Lu6::solve_transpose`] of each of `K` right-hand sides, side by
    /// side: each column's sums are those of a solve alone, in the same
    /// order (the same bits), and the columns' independent chains of
    /// latency overlap.
    pub fn solve_transpose_each<const K: usize>(&self, b: &[Vector6<f64>; K]) -> [Vector6<f64>; K] {
        let lu = &self.lu;
        let mut z = [[0.0; K]; 6];
        for i in 0..6 {
            for c in 0..K {
                z[i][c] = (b[c][i] - (0..i).map(|j| lu[j][i] * z[j][c]).sum::<f64>()) * lu[i][i];
            }
        }
        for i in (0..6).rev() {
            for c in 0..K {
                z[i][c] -= (i + 1..6).map(|j| lu[j][i] * z[j][c]).sum::<f64>();
            }
        }
        let mut x = [Vector6::zeros(); K];
        for (k, &row) in self.permutation.iter().enumerate() {
            for c in 0..K {
                x[c][usize::from(row)] = z[k][c];
            }
        }
        x
    }
}

/// Refuses a factorisation whose smallest pivot is below
/// [`SINGULAR_PIVOT_RATIO`] of its largest, or which has a non-finite pivot.
fn check_pivots(pivots: &[f64; 6]) -> Result<(), KinematicsError> {
    let smallest = pivots.iter().fold(f64::INFINITY, |m, p| m.min(p.abs()));
    let largest = pivots.iter().fold(0.0f64, |m, p| m.max(p.abs()));
    // `min` and `max` skip NaN: finiteness is checked on every pivot.
    let finite = pivots.iter().all(|p| p.is_finite());
    if finite && smallest > SINGULAR_PIVOT_RATIO * largest {
        Ok(())
    } else {
        Err(KinematicsError::SingularJacobian)
    }
}

/// Step `K` of the factorisation with the rows in the given order: row `K`
/// is the pivot row; clears `accepted` if its pivot is below [`THRESHOLD`]
/// times the largest entry under it. Returns the pivot.
#[inline(always)]
fn eliminate_in_order<const K: usize>(lu: &mut [[f64; 6]; 6], accepted: &mut bool) -> f64 {
    let mut below = 0.0f64;
    for row in &lu[K + 1..] {
        below = below.max(row[K].abs());
    }
    let pivot = lu[K][K];
    // Written so that a NaN pivot is not accepted.
    *accepted &= pivot.abs() >= THRESHOLD * below;
    eliminate_below::<K>(lu, pivot);
    pivot
}

/// Step `K` of the factorisation: the row with the largest entry in column
/// `K` (from row `K` down) becomes the pivot row, then the rows below it are
/// eliminated; returns the pivot (zero for a zero column, refused later).
///
/// Every index is a compile-time constant and the row exchange is a
/// branch-free select, so that the whole factorisation stays in registers:
/// exchanging rows through a run-time index stalls on store forwarding.
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
    eliminate_below::<K>(lu, pivot);
    pivot
}

/// Eliminates column `K` below row `K` with `pivot = lu[K][K]`, storing the
/// multipliers of `L` and the pivot's reciprocal (zero for a zero pivot,
/// refused later).
#[inline(always)]
fn eliminate_below<const K: usize>(lu: &mut [[f64; 6]; 6], pivot: f64) {
    let inverse = if pivot == 0.0 { 0.0 } else { pivot.recip() };
    lu[K][K] = inverse;
    for i in K + 1..6 {
        let factor = lu[i][K] * inverse;
        lu[i][K] = factor;
        for j in K + 1..6 {
            lu[i][j] -= factor * lu[K][j];
        }
    }
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

    /// `matrix()` with row 4 twice row 2.
    fn singular() -> Matrix6<f64> {
        let mut a = matrix();
        let row = a.row(2).into_owned();
        a.set_row(4, &(row * 2.0));
        a
    }

    /// `lu` solves by `a` and by its transpose.
    fn assert_solves(lu: &Lu6, a: &Matrix6<f64>) {
        let b = Vector6::new(1.0, -2.0, 3.0, 0.5, -0.25, 4.0);
        assert!((a * lu.solve(&b) - b).amax() < 1e-12);
        assert!((a.transpose() * lu.solve_transpose(&b) - b).amax() < 1e-12);
    }

    #[test]
    fn solves_by_the_matrix_and_its_transpose() {
        let a = matrix();
        assert_solves(&Lu6::factor(rows(&a)).unwrap(), &a);
    }

    /// Side by side, each right-hand side gets the bits of its solve alone.
    #[test]
    fn transposed_solves_side_by_side_give_the_bits_of_each_alone() {
        let lu = Lu6::factor(rows(&matrix())).unwrap();
        let b: [Vector6<f64>; 3] = std::array::from_fn(|c| {
            Vector6::from_fn(|i, _| (1.0 + c as f64) / (1.0 + i as f64) - 0.3 * c as f64)
        });
        let each = lu.solve_transpose_each(&b);
        for (x, b) in each.iter().zip(&b) {
            let alone = lu.solve_transpose(b);
            assert_eq!(x.map(f64::to_bits), alone.map(f64::to_bits));
        }
    }

    /// The rows of `a` from the smallest `|a[(i, 0)]|` to the largest.
    fn by_first_entry(a: &Matrix6<f64>) -> [usize; 6] {
        let mut order = [0, 1, 2, 3, 4, 5];
        order.sort_by(|&i, &j| a[(i, 0)].abs().total_cmp(&a[(j, 0)].abs()));
        order
    }

    /// `matrix()` with its row of smallest first entry moved to row `row`.
    fn small_first_pivot_at(row: usize) -> Matrix6<f64> {
        let a = matrix();
        let mut order = [0, 1, 2, 3, 4, 5];
        order.swap(row, by_first_entry(&a)[0]);
        let b = Matrix6::from_fn(|i, j| a[(order[i], j)]);
        assert!(b[(row, 0)].abs() < THRESHOLD * a.column(0).amax());
        b
    }

    #[test]
    fn keeps_the_previous_row_order_while_its_pivots_pass_the_threshold() {
        // The identity order fails on the first pivot: partial pivoting.
        let b = small_first_pivot_at(0);
        let mut lu = Lu6::factor(rows(&b)).unwrap();
        let order = lu.permutation;
        assert_ne!(order, [0, 1, 2, 3, 4, 5]);
        assert_solves(&lu, &b);
        // A nearby matrix: the same order passes the threshold test.
        let nearby = b.map(|x| x * 1.01 + 0.003);
        lu.factor_in_place(rows(&nearby)).unwrap();
        assert_eq!(lu.permutation, order);
        assert_solves(&lu, &nearby);
    }

    #[test]
    fn falls_back_to_partial_pivoting_when_the_previous_order_fails() {
        let a = matrix();
        let mut lu = Lu6::factor(rows(&a)).unwrap();
        // Rows that put a small entry on the trial's first pivot: the rows
        // are exchanged as partial pivoting would.
        let b = small_first_pivot_at(usize::from(lu.permutation[0]));
        lu.factor_in_place(rows(&b)).unwrap();
        assert_eq!(usize::from(lu.permutation[0]), by_first_entry(&b)[5]);
        assert_solves(&lu, &b);
        // Singular matrices are refused on either path.
        assert!(lu.factor_in_place(rows(&singular())).is_err());
        assert!(lu.factor_in_place([[0.0; 6]; 6]).is_err());
        assert!(lu.factor_in_place(rows(&a)).is_ok());
        assert_solves(&lu, &a);
    }

    #[test]
    fn refuses_singular_matrices() {
        assert_eq!(
            Lu6::factor(rows(&singular())).unwrap_err(),
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
