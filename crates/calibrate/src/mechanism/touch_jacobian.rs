//! A ball touch's whitened coordinate rows' derivative with respect to the
//! global block (paper eq. 10), as the solver uses it
//! ([`GlobalJacobian`]): over the parameters
//!
//! ```text
//! L⁻¹ dc/dp = (−L⁻¹) dT/dp |_q,
//! ```
//!
//! kept as its two factors, so that a combination of the three rows,
//! `aᵀ L⁻¹ dc/dp = (−L⁻ᵀ a)ᵀ dT/dp`, costs three products a column as a
//! whitened row's would, and no column of `dT/dp` is whitened or copied;
//! a tied ball's centre and radius columns (`L⁻¹ dc/dC`, `L⁻¹ dc/dρ`);
//! zero elsewhere.

use nalgebra::{DVector, Matrix3, SVector, Vector3};
use parcal_kinematics::params_jacobian::ParamsJacobian;
use parcal_observe::CoordinateJacobians;
use parcal_solver::GlobalJacobian;

/// A touch's `L⁻¹ dc/dg` (module doc).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TouchJacobian {
    /// `L⁻¹ dc/dT = −L⁻¹` ([`CoordinateJacobians::d_tip`]).
    d_tip: Matrix3<f64>,
    /// `dT/dp |_q` (3 × parameters), the global block's first columns.
    d_tip_params: ParamsJacobian,
    /// The columns of a ball tied in the global block, if any.
    tied: Option<TiedBall>,
}

/// The columns of a touch's ball whose unknowns are in the global block.
#[derive(Debug, Clone, PartialEq)]
struct TiedBall {
    /// Its centre's first column.
    column: usize,
    /// `L⁻¹ dc/dC`.
    d_centre: Matrix3<f64>,
    /// `L⁻¹ dc/dρ`, at the column after the centre's, when its radius is
    /// an unknown.
    d_radius: Option<Vector3<f64>>,
}

impl TouchJacobian {
    /// The derivative of `rows` where the machine's `dT/dp |_q` is
    /// `d_tip_params`, its ball's columns those of a ball tied at `tied`
    /// (its first column, and whether its radius is an unknown), if it is.
    /// `d_tip_params` is swapped with the one held before, which is left
    /// there as room for the next touch's.
    pub(crate) fn set(
        &mut self,
        rows: &CoordinateJacobians,
        d_tip_params: &mut ParamsJacobian,
        tied: Option<(usize, bool)>,
    ) {
        self.d_tip = rows.d_tip;
        self.tied = tied.map(|(column, uncertain)| TiedBall {
            column,
            d_centre: rows.d_centre,
            d_radius: uncertain.then_some(rows.d_radius),
        });
        std::mem::swap(&mut self.d_tip_params, d_tip_params);
    }
}

impl GlobalJacobian<3> for TouchJacobian {
    fn zeros(_global_size: usize) -> Self {
        Self {
            d_tip: Matrix3::zeros(),
            d_tip_params: ParamsJacobian::default(),
            tied: None,
        }
    }

    fn combine_rows(&self, c: &[f64; 3], out: &mut [f64]) {
        let c = Vector3::from(*c);
        let h = self.d_tip.tr_mul(&c);
        let (params, rest) = out.split_at_mut(self.d_tip_params.ncols());
        self.d_tip_params.combine(&h, params);
        rest.fill(0.0);
        if let Some(ball) = &self.tied {
            let centre = ball.d_centre.tr_mul(&c);
            out[ball.column..ball.column + 3].copy_from_slice(centre.as_slice());
            if let Some(d_radius) = &ball.d_radius {
                out[ball.column + 3] = d_radius.dot(&c);
            }
        }
    }

    fn apply(&self, v: &DVector<f64>) -> SVector<f64, 3> {
        let n = self.d_tip_params.ncols();
        let mut product = self.d_tip * self.d_tip_params.apply(&v.as_slice()[..n]);
        if let Some(ball) = &self.tied {
            product += ball.d_centre * v.fixed_rows::<3>(ball.column);
            if let Some(d_radius) = &ball.d_radius {
                product += d_radius * v[ball.column + 3];
            }
        }
        product
    }

    fn scale(&mut self, factor: f64) {
        self.d_tip *= factor;
        if let Some(ball) = &mut self.tied {
            ball.d_centre *= factor;
            if let Some(d_radius) = &mut ball.d_radius {
                *d_radius *= factor;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, Matrix3x2, OMatrix, U3};

    use super::*;

    /// The dense `R × G` rows of `jacobian` (`G` columns).
    fn dense(jacobian: &TouchJacobian, g: usize) -> OMatrix<f64, U3, nalgebra::Dyn> {
        let mut rows = OMatrix::<f64, U3, nalgebra::Dyn>::zeros(g);
        let mut row = vec![0.0; g];
        for r in 0..3 {
            jacobian.row(r, &mut row);
            rows.row_mut(r).copy_from_slice(&row);
        }
        rows
    }

    /// Rows and a `dT/dp` of `n` columns whose every derivative is
    /// distinct.
    fn rows(n: usize) -> (CoordinateJacobians, DMatrix<f64>) {
        let f = |k: usize| ((k * 37 % 101) as f64 - 50.0) / 7.0;
        let rows = CoordinateJacobians {
            residual: Vector3::new(0.3, -0.1, 0.2),
            d_tip: -Matrix3::new(2.0, 0.0, 0.0, 0.5, 1.5, 0.0, -0.3, 0.2, 3.0),
            d_centre: Matrix3::from_fn(|i, j| f(200 + 3 * j + i)),
            d_radius: Vector3::from_fn(|i, _| f(300 + i)),
            d_angles: Matrix3x2::zeros(),
        };
        (rows, DMatrix::from_fn(3, n, |i, j| f(3 * j + i)))
    }

    /// Its rows, combinations and product with a vector, against the dense
    /// rows they stand for: `−L⁻¹ dT/dp` in the parameters' columns, the
    /// tied ball's at its own, zero elsewhere; then weighed by a loss.
    #[test]
    fn the_factored_rows_are_the_dense_rows() {
        let (n, g) = (7, 15);
        for (tied, uncertain) in [(None, false), (Some(9), false), (Some(10), true)] {
            let (rows, d_tip_params) = rows(n);
            let d_params = rows.d_tip * &d_tip_params;
            let mut jacobian = TouchJacobian::zeros(g);
            let mut room = ParamsJacobian::from(d_tip_params);
            jacobian.set(&rows, &mut room, tied.map(|column| (column, uncertain)));
            // The room held before (none yet) left in its place.
            assert_eq!(room.ncols(), 0);
            let mut expected = OMatrix::<f64, U3, nalgebra::Dyn>::zeros(g);
            expected.columns_mut(0, n).copy_from(&d_params);
            if let Some(column) = tied {
                expected.columns_mut(column, 3).copy_from(&rows.d_centre);
                if uncertain {
                    expected.column_mut(column + 3).copy_from(&rows.d_radius);
                }
            }
            // Sums of three products of numbers of order 10: rounding.
            let bound = 1e-13 * expected.amax();
            assert!((dense(&jacobian, g) - &expected).amax() < bound);
            let v = DVector::from_fn(g, |j, _| (j as f64).sin());
            assert!((jacobian.apply(&v) - &expected * &v).amax() < 1e-12 * expected.amax());
            jacobian.scale(0.5);
            assert!((dense(&jacobian, g) - expected * 0.5).amax() < bound);
        }
    }
}
