//! A contact's `dT/dp |_q` (3 × parameters) as a linear map
//! ([`ParamsJacobian`]).
//!
//! What a calibration takes of it is a combination of its rows, `hᵀ dT/dp`
//! (a touch's radius row `uᵀ dT/dp / σ`, a coordinate row eliminated of its
//! angles), and its product with a vector, `dT/dp · v` (a step of the
//! parameters). A mechanism whose forward kinematics leaves the derivative
//! in factored form hands over those factors with the two products
//! ([`JacobianForm`]) instead of the 3 × n matrix. The hexapod's `J_f =
//! −K dφ/dp + dT/dp |_x` is held as `Kᵀ` (6 × 3), `R` and the leg
//! directions `n_i`: 45 values instead of 99 entries, and a combination
//! of rows costs the product `y = Kᵀ h` and a sparse row per leg
//! ([`crate::derivatives`]). Any other mechanism's is [`DENSE`].

use nalgebra::{DMatrix, DVector, Vector3};

/// How a [`ParamsJacobian`]'s values stand for `dT/dp |_q`: its two
/// products over them. The values' layout is the form's own; a form is a
/// `static`, told apart from others by its address.
#[derive(Debug)]
pub struct JacobianForm {
    /// Its name.
    pub name: &'static str,
    /// `hᵀ dT/dp` into `out`, one value per parameter.
    pub combine: fn(values: &[f64], h: &Vector3<f64>, out: &mut [f64]),
    /// `dT/dp · v`, `v` one value per parameter.
    pub apply: fn(values: &[f64], v: &[f64]) -> Vector3<f64>,
}

/// The matrix itself, its entries column-major (entry `(a, k)` at `a + 3 k`).
pub static DENSE: JacobianForm = JacobianForm {
    name: "dense",
    combine: dense_combine,
    apply: dense_apply,
};

/// `hᵀ J` of a dense `J`: three products a column.
fn dense_combine(values: &[f64], h: &Vector3<f64>, out: &mut [f64]) {
    for (o, column) in out.iter_mut().zip(values.chunks_exact(3)) {
        *o = h[0] * column[0] + h[1] * column[1] + h[2] * column[2];
    }
}

/// `J v` of a dense `J`, column by column.
fn dense_apply(values: &[f64], v: &[f64]) -> Vector3<f64> {
    let mut product = Vector3::zeros();
    for (v, column) in v.iter().zip(values.chunks_exact(3)) {
        product += Vector3::new(column[0], column[1], column[2]) * *v;
    }
    product
}

/// A contact's `dT/dp |_q` (module doc): `columns` parameters, held as
/// `values` laid out by its `form`. The default is the dense 3 × 0 matrix,
/// a placeholder to be overwritten.
#[derive(Debug, Clone)]
pub struct ParamsJacobian {
    form: &'static JacobianForm,
    columns: usize,
    values: Vec<f64>,
}

impl Default for ParamsJacobian {
    fn default() -> Self {
        Self::zeros(0)
    }
}

impl PartialEq for ParamsJacobian {
    /// The same form, size and values (not the same matrix held two ways).
    fn eq(&self, other: &Self) -> bool {
        std::ptr::eq(self.form, other.form)
            && self.columns == other.columns
            && self.values == other.values
    }
}

impl From<DMatrix<f64>> for ParamsJacobian {
    /// The dense `matrix` (3 rows).
    ///
    /// # Panics
    /// If `matrix` has other than 3 rows.
    fn from(matrix: DMatrix<f64>) -> Self {
        assert_eq!(matrix.nrows(), 3, "dT/dp has the tool point's 3 rows");
        Self {
            form: &DENSE,
            columns: matrix.ncols(),
            values: matrix.data.into(),
        }
    }
}

impl ParamsJacobian {
    /// The dense zero matrix of `columns` parameters.
    pub fn zeros(columns: usize) -> Self {
        Self {
            form: &DENSE,
            columns,
            values: vec![0.0; 3 * columns],
        }
    }

    /// `dT/dp` of `columns` parameters held as the values `len` values of
    /// `form`, zero, to be written ([`ParamsJacobian::values_mut`]).
    pub fn factored(form: &'static JacobianForm, columns: usize, len: usize) -> Self {
        Self {
            form,
            columns,
            values: vec![0.0; len],
        }
    }

    /// Whether this is room for `len` values of `form` over `columns`
    /// parameters.
    pub fn fits(&self, form: &JacobianForm, columns: usize, len: usize) -> bool {
        std::ptr::eq(self.form, form) && self.columns == columns && self.values.len() == len
    }

    /// Its values, in its form's layout, to be written.
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// Its number of columns: the parameters.
    pub fn ncols(&self) -> usize {
        self.columns
    }

    /// `hᵀ dT/dp` into `out`.
    ///
    /// # Panics
    /// If `out` holds other than one value per parameter.
    pub fn combine(&self, h: &Vector3<f64>, out: &mut [f64]) {
        assert_eq!(out.len(), self.columns, "a value per parameter");
        (self.form.combine)(&self.values, h, out);
    }

    /// `hᵀ dT/dp` as a new vector.
    pub fn combination(&self, h: &Vector3<f64>) -> DVector<f64> {
        let mut row = DVector::zeros(self.columns);
        self.combine(h, row.as_mut_slice());
        row
    }

    /// `dT/dp · v`.
    ///
    /// # Panics
    /// If `v` holds other than one value per parameter.
    pub fn apply(&self, v: &[f64]) -> Vector3<f64> {
        assert_eq!(v.len(), self.columns, "a value per parameter");
        (self.form.apply)(&self.values, v)
    }

    /// The 3 × n matrix, its own values when it is dense.
    pub fn into_dense(self) -> DMatrix<f64> {
        if std::ptr::eq(self.form, &DENSE) {
            DMatrix::from_vec(3, self.columns, self.values)
        } else {
            self.to_dense()
        }
    }

    /// The 3 × n matrix: row `a` the combination of the base-frame axis `a`.
    pub fn to_dense(&self) -> DMatrix<f64> {
        let mut dense = DMatrix::zeros(3, self.columns);
        for a in 0..3 {
            let row = self.combination(&Vector3::ith(a, 1.0));
            dense.row_mut(a).tr_copy_from(&row);
        }
        dense
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dense form's products are the matrix's, and its dense matrix
    /// is itself.
    #[test]
    fn the_dense_form_is_the_matrix() {
        let matrix = DMatrix::from_fn(3, 5, |i, j| ((3 * j + i) as f64 * 0.7).sin());
        let jacobian = ParamsJacobian::from(matrix.clone());
        assert_eq!(jacobian.ncols(), 5);
        assert_eq!(jacobian.to_dense(), matrix);
        let h = Vector3::new(0.3, -1.2, 2.0);
        let expected = matrix.tr_mul(&h);
        assert!((jacobian.combination(&h) - expected).amax() < 1e-15);
        let v = [1.0, -0.5, 0.25, 2.0, -3.0];
        let expected = &matrix * DVector::from_column_slice(&v);
        assert!((jacobian.apply(&v) - expected).amax() < 1e-15);
        assert!(jacobian.fits(&DENSE, 5, 15));
        assert!(!jacobian.fits(&DENSE, 4, 12));
        assert_eq!(ParamsJacobian::default().ncols(), 0);
    }
}
