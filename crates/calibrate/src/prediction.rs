//! Are a validation's residuals as large as the calibration predicts? The
//! chi-square test of the predicted rows against their full predicted
//! covariance.
//!
//! The `n` predicted residuals `r` of a validation are correlated through
//! the errors they share (the calibration's parameters, the re-fitted
//! nuisance): their predicted covariance is
//!
//! ```text
//! C = D + U Uᵀ,
//! ```
//!
//! `D` the rows' own noise (block-diagonal: a pose's six rows, a point's
//! three, a touch's one) and `U` the common errors, one column per
//! direction of their covariance (`U = G Σ_θ^{1/2}` for the parameters,
//! [`crate::instruments::validate`] and [`crate::validate_touches`] give
//! `G`). Under the model and the stated covariances `T = rᵀ C⁻¹ r ~ χ²(n)`
//! (Koch, "Parameter Estimation and Hypothesis Testing in Linear Models",
//! 1999, section 2.4.1: the quadratic form of a normal vector in its
//! inverse covariance). With `D = L Lᵀ`, `z = L⁻¹ r` (the whitened
//! residuals) and `V = L⁻¹ U`, the Woodbury identity gives
//!
//! ```text
//! T = zᵀz − yᵀ (I + VᵀV)⁻¹ y,   y = Vᵀ z,
//! ```
//!
//! so `C` (`n × n`) is never formed. `D` is positive definite (every row's
//! covariance passed its Cholesky factorisation when the rows were
//! weighed), hence so is `C ⪰ D`: `T` has `n` degrees of freedom, no rank
//! to decide, and `I + VᵀV` has eigenvalues at least 1, so its Cholesky
//! factorisation cannot fail. A covariance read from calibration.json may
//! have eigenvalues slightly below zero (rounding): [`square_root`] takes
//! them as zero.
//!
//! The stated noise may be off by a common factor: the calibration's own
//! global test estimates it, `s₀² = Ω / r` ([`crate::verdict`]). Since the
//! predicted covariance is the stated one (the calibration's covariance
//! and the rows' noise both scale with that factor), and the new rows are
//! independent of the calibration's, the prediction's variance factor
//! against the calibration's,
//!
//! ```text
//! F = (T / n) / (Ω / r) ~ F(n, r),
//! ```
//!
//! asks whether the new data fit the calibration as well as its own data
//! did, whatever the common factor (Koch 1999, section 4.3.3: the ratio of
//! two independent variance estimates). Without the calibration's global
//! test (a file written before it), `s₀² = 1` is taken as known: `T / n ~
//! χ²(n) / n`, the limit `r → ∞`. The test is two-sided at
//! [`GLOBAL_TEST_LEVEL`], the calibration's convention: `F` above the upper
//! quantile rejects (the calibration does not predict these data), below
//! the lower one it is accepted and said (the predicted covariance is
//! pessimistic).

use nalgebra::{Cholesky, DMatrix, DVector, Dyn, Matrix, Matrix3, Matrix3xX, Storage, U1, Vector3};

use statrs::distribution::{ContinuousCDF, FisherSnedecor};

use crate::verdict::{GLOBAL_TEST_LEVEL, GlobalTest, Outcome};

/// `T = rᵀ C⁻¹ r` from the whitened residuals `z = L⁻¹ r` and the whitened
/// common errors `V = L⁻¹ U` (module doc).
pub fn statistic(z: &DVector<f64>, v: &DMatrix<f64>) -> f64 {
    let mut products = RowProducts::new(v.ncols());
    products.add(v, &z.column(0));
    let (zz, vv, vz) = products.sums();
    WhitenedCovariance::from_gram(&vv).inner(zz, &vz, &vz)
}

/// The products `zᵀz`, `AᵀA` and `Aᵀz` of rows of `[A z]` given a few at a
/// time, summed [`RowProducts::BLOCK`] rows at a time: each sum runs down
/// columns of a block that stays in cache, where summing an observation's
/// few rows at a time would pay a call a product, and summing down the
/// whole of `A` would stream it from memory once a product.
pub(crate) struct RowProducts {
    /// `zᵀz` so far.
    zz: f64,
    /// `AᵀA` so far.
    aa: DMatrix<f64>,
    /// `Aᵀz` so far.
    az: DVector<f64>,
    /// The rows of `A` not yet summed (the first `filled`).
    block: DMatrix<f64>,
    /// Their `z`.
    block_z: DVector<f64>,
    /// How many rows `block` holds.
    filled: usize,
}

impl RowProducts {
    /// The rows a block holds.
    const BLOCK: usize = 256;

    /// No rows yet, of `columns` columns.
    pub(crate) fn new(columns: usize) -> Self {
        Self {
            zz: 0.0,
            aa: DMatrix::zeros(columns, columns),
            az: DVector::zeros(columns),
            block: DMatrix::zeros(Self::BLOCK, columns),
            block_z: DVector::zeros(Self::BLOCK),
            filled: 0,
        }
    }

    /// The rows `a` of `A`, `z` of `z`.
    pub(crate) fn add<S, T>(&mut self, a: &Matrix<f64, Dyn, Dyn, S>, z: &Matrix<f64, Dyn, U1, T>)
    where
        S: Storage<f64, Dyn, Dyn>,
        T: Storage<f64, Dyn, U1>,
    {
        for i in 0..a.nrows() {
            if self.filled == Self::BLOCK {
                self.flush();
            }
            self.block.row_mut(self.filled).copy_from(&a.row(i));
            self.block_z[self.filled] = z[i];
            self.filled += 1;
        }
    }

    /// The block's rows added to the sums.
    fn flush(&mut self) {
        let (a, z) = (
            self.block.rows(0, self.filled),
            self.block_z.rows(0, self.filled),
        );
        self.zz += z.norm_squared();
        self.aa.gemm_tr(1.0, &a, &a, 1.0);
        self.az.gemv_tr(1.0, &a, &z, 1.0);
        self.filled = 0;
    }

    /// `(zᵀz, AᵀA, Aᵀz)` over every row added.
    pub(crate) fn sums(mut self) -> (f64, DMatrix<f64>, DVector<f64>) {
        self.flush();
        (self.zz, self.aa, self.az)
    }
}

/// The predicted covariance `I + V Vᵀ` of whitened rows, known by the Gram
/// matrix `VᵀV` of their common errors: its inverse is applied by the
/// Woodbury identity (module doc),
///
/// ```text
/// xᵀ (I + V Vᵀ)⁻¹ y = xᵀ y − (Vᵀ x)ᵀ (I + VᵀV)⁻¹ (Vᵀ y),
/// ```
///
/// from the products `xᵀ y`, `Vᵀ x` and `Vᵀ y` alone, so that neither `V`
/// (`n × m`) nor `x` and `y` need be kept.
pub struct WhitenedCovariance {
    /// The Cholesky factor of the capacitance `I + VᵀV`.
    capacitance: Option<Cholesky<f64, Dyn>>,
}

impl WhitenedCovariance {
    /// The covariance `I + V Vᵀ` of whitened rows whose common errors have
    /// the Gram matrix `gram = VᵀV`.
    pub fn from_gram(gram: &DMatrix<f64>) -> Self {
        let capacitance = DMatrix::identity(gram.nrows(), gram.ncols()) + gram;
        Self {
            capacitance: capacitance.cholesky(),
        }
    }

    /// `xᵀ (I + V Vᵀ)⁻¹ y` from `xy = xᵀ y`, `vx = Vᵀ x` and `vy = Vᵀ y`.
    pub fn inner(&self, xy: f64, vx: &DVector<f64>, vy: &DVector<f64>) -> f64 {
        let correction =
            (self.capacitance.as_ref()).map_or(0.0, |factor| vx.dot(&factor.solve(vy)));
        xy - correction
    }
}

/// `T = rᵀ C⁻¹ r` when the common errors are of two kinds (module doc):
/// `global`, the whitened `V_g` every row shares (`n × m`), and, per
/// group of consecutive rows (a ball's touches, its re-fitted centre), the
/// whitened `V_k` of that group alone: `local[i]` is row `i`'s row of it
/// and `starts` the first row of each group, in order (the last group
/// ends at `n`). `V = [V_g, V_1, ..., V_K]` has `m + 3 K` columns; its
/// capacitance `M = I + VᵀV` couples each group's block `M_kk = I +
/// V_kᵀV_k` to the global one alone (`M_gk = V_gᵀV_k`), so that, the
/// groups eliminated (a Schur complement),
///
/// ```text
/// yᵀ M⁻¹ y = Σ_k y_kᵀ M_kk⁻¹ y_k + ȳᵀ S⁻¹ ȳ,
/// S = M_gg − Σ_k M_gk M_kk⁻¹ M_gkᵀ,   ȳ = y_g − Σ_k M_gk M_kk⁻¹ y_k,
/// ```
///
/// `y = Vᵀz`: [`statistic`]'s value without forming `V` (`n × 3K`) or
/// `M`. `M ⪰ I`, so `M_kk` and `S` are too, and their Cholesky
/// factorisations cannot fail.
///
/// # Panics
/// If `local` and `global` differ in rows, or `starts` is not increasing
/// from 0 within them.
pub fn grouped_statistic(
    z: &DVector<f64>,
    global: &DMatrix<f64>,
    local: &[Vector3<f64>],
    starts: &[usize],
) -> f64 {
    let (n, m) = global.shape();
    assert_eq!(local.len(), n, "a local row for each row");
    assert!(
        starts.first().is_none_or(|&s| s == 0) && starts.is_sorted() && starts.last() <= Some(&n),
        "groups of consecutive rows from the first"
    );
    let mut products = RowProducts::new(m);
    products.add(global, &z.column(0));
    let (_, gram, mut reduced) = products.sums();
    let mut schur = DMatrix::identity(m, m) + gram;
    let mut local_part = 0.0;
    let ends = starts.iter().skip(1).copied().chain([n]);
    // `M_gkᵀ` (3 × m) and `M_kk⁻¹ M_gkᵀ`, room kept from group to group.
    let (mut coupling, mut solved) = (Matrix3xX::zeros(m), Matrix3xX::zeros(m));
    for (start, end) in starts.iter().copied().zip(ends) {
        let rows = global.rows(start, end - start);
        let (mut block, mut y_k) = (Matrix3::identity(), Vector3::zeros());
        coupling.fill(0.0);
        for (j, v) in local[start..end].iter().enumerate() {
            block += v * v.transpose();
            coupling.ger(1.0, v, &rows.row(j).transpose(), 1.0);
            y_k += v * z[start + j];
        }
        let Some(factor) = block.cholesky() else {
            return f64::NAN;
        };
        let solved_y = factor.solve(&y_k);
        local_part += y_k.dot(&solved_y);
        // S −= M_gk M_kk⁻¹ M_gkᵀ, ȳ −= M_gk M_kk⁻¹ y_k.
        solved.copy_from(&coupling);
        factor.solve_mut(&mut solved);
        schur.gemm_tr(-1.0, &coupling, &solved, 1.0);
        reduced.gemv_tr(-1.0, &coupling, &solved_y, 1.0);
    }
    let global_part = schur
        .cholesky()
        .map_or(f64::NAN, |factor| reduced.dot(&factor.solve(&reduced)));
    z.dot(z) - local_part - global_part
}

/// A square root `F` of the symmetric positive semi-definite `covariance`,
/// `F Fᵀ = covariance`: `Q Λ^{1/2}` of its eigendecomposition, negative
/// eigenvalues (rounding) taken as zero.
pub fn square_root(covariance: &DMatrix<f64>) -> DMatrix<f64> {
    let symmetric = (covariance + covariance.transpose()) * 0.5;
    let eigen = symmetric.symmetric_eigen();
    let mut root = eigen.eigenvectors;
    for (k, lambda) in eigen.eigenvalues.iter().enumerate() {
        root.column_mut(k).scale_mut(lambda.max(0.0).sqrt());
    }
    root
}

/// The prediction test (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictionTest {
    /// `T = rᵀ C⁻¹ r`.
    pub statistic: f64,
    /// `n`, the predicted rows.
    pub rows: usize,
    /// The calibration's global test `(Ω, r)`, if it has one.
    pub calibration: Option<(f64, usize)>,
    /// `F = (T / n) / s₀²` (`s₀² = 1` without the calibration's test).
    pub ratio: f64,
    /// The test's level `α`.
    pub level: f64,
    /// The interval of `F` that passes: the `α/2` and `1 − α/2` quantiles
    /// of `F(n, r)`, or of `χ²(n) / n`.
    pub interval: (f64, f64),
    /// Where `F` falls.
    pub outcome: Outcome,
}

impl PredictionTest {
    /// The test of `statistic` over `rows` predicted rows against the
    /// calibration's global test `calibration` (module doc); `None` without
    /// a row.
    pub fn new(statistic: f64, rows: usize, calibration: Option<(f64, usize)>) -> Option<Self> {
        let level = GLOBAL_TEST_LEVEL;
        let calibration = calibration.filter(|&(cost, r)| r > 0 && cost > 0.0);
        let (ratio, interval) = match calibration {
            Some((cost, r)) => {
                let f = FisherSnedecor::new(rows as f64, r as f64).ok()?;
                (
                    statistic / rows as f64 / (cost / r as f64),
                    (f.inverse_cdf(level / 2.0), f.inverse_cdf(1.0 - level / 2.0)),
                )
            }
            None => {
                let chi = GlobalTest::new(statistic, rows, level)?;
                (chi.variance_factor, chi.interval)
            }
        };
        let outcome = if ratio > interval.1 {
            Outcome::TooLarge
        } else if ratio < interval.0 {
            Outcome::TooSmall
        } else {
            Outcome::Consistent
        };
        Some(Self {
            statistic,
            rows,
            calibration,
            ratio,
            level,
            interval,
            outcome,
        })
    }

    /// Whether it rejects: `F` above its interval.
    pub fn rejects(&self) -> bool {
        self.outcome == Outcome::TooLarge
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic, well-spread matrix.
    fn matrix(rows: usize, cols: usize, seed: f64) -> DMatrix<f64> {
        DMatrix::from_fn(rows, cols, |i, j| {
            ((i * cols + j) as f64 * 0.731 + seed).sin()
        })
    }

    #[test]
    fn the_statistic_is_the_dense_quadratic_form() {
        let (n, k) = (9, 4);
        let l = matrix(n, n, 0.3).lower_triangle() + DMatrix::identity(n, n) * 3.0;
        let u = matrix(n, k, 1.7);
        let r = DVector::from_fn(n, |i, _| (i as f64 * 1.3).cos());
        let c = &l * l.transpose() + &u * u.transpose();
        let dense = r.dot(&c.clone().cholesky().unwrap().solve(&r));
        let l_inverse = l.try_inverse().unwrap();
        let woodbury = statistic(&(&l_inverse * &r), &(&l_inverse * &u));
        assert!(
            (woodbury - dense).abs() < 1e-12 * dense,
            "{woodbury} against {dense}"
        );
    }

    /// The groups eliminated give the dense Woodbury value of `V` with
    /// each group's three columns zero outside its rows, and a group of
    /// no rows (a start repeated) adds nothing.
    #[test]
    fn the_grouped_statistic_is_the_statistic_of_the_whole_v() {
        let (n, m) = (11, 4);
        let starts = [0, 3, 3, 7];
        let global = matrix(n, m, 0.4);
        let local: Vec<Vector3<f64>> = (0..n)
            .map(|i| Vector3::from_fn(|a, _| (1.9 * (3 * i + a) as f64 + 0.2).cos()))
            .collect();
        let z = DVector::from_fn(n, |i, _| (i as f64 * 0.77).sin() * 2.0);
        let mut v = DMatrix::zeros(n, m + 3 * starts.len());
        v.columns_mut(0, m).copy_from(&global);
        for (k, &start) in starts.iter().enumerate() {
            let end = starts.get(k + 1).copied().unwrap_or(n);
            for (i, row) in local.iter().enumerate().take(end).skip(start) {
                v.view_mut((i, m + 3 * k), (1, 3))
                    .copy_from(&row.transpose());
            }
        }
        let dense = statistic(&z, &v);
        let grouped = grouped_statistic(&z, &global, &local, &starts);
        assert!(
            (grouped - dense).abs() < 1e-12 * dense,
            "{grouped} against {dense}"
        );
    }

    /// Rows given in pieces of any length, across blocks, sum to the
    /// products of the whole matrix.
    #[test]
    fn row_products_given_in_pieces_are_the_whole_products() {
        let (n, k) = (3 * RowProducts::BLOCK + 17, 5);
        let a = matrix(n, k, 0.9);
        let z = DVector::from_fn(n, |i, _| (i as f64 * 0.37).sin());
        let mut products = RowProducts::new(k);
        let mut start = 0;
        for piece in [0, 1, 7, RowProducts::BLOCK + 3, 2 * RowProducts::BLOCK]
            .into_iter()
            .cycle()
        {
            let rows = piece.min(n - start);
            products.add(&a.rows(start, rows), &z.rows(start, rows));
            start += rows;
            if start == n {
                break;
            }
        }
        let (zz, aa, az) = products.sums();
        let scale = n as f64;
        assert!((zz - z.norm_squared()).abs() < 1e-13 * scale);
        assert!((aa - a.transpose() * &a).amax() < 1e-13 * scale);
        assert!((az - a.transpose() * &z).amax() < 1e-13 * scale);
    }

    /// The inner product from `xᵀ y`, `Vᵀ x` and `Vᵀ y` is the dense
    /// `xᵀ (I + V Vᵀ)⁻¹ y`, for two different vectors.
    #[test]
    fn the_inner_product_from_the_products_is_the_dense_one() {
        let (n, k) = (13, 4);
        let v = matrix(n, k, 2.1);
        let x = DVector::from_fn(n, |i, _| (i as f64 * 0.63 + 0.2).sin());
        let y = DVector::from_fn(n, |i, _| (i as f64 * 0.41).cos());
        let covariance = DMatrix::identity(n, n) + &v * v.transpose();
        let dense = x.dot(&covariance.cholesky().unwrap().solve(&y));
        let metric = WhitenedCovariance::from_gram(&v.tr_mul(&v));
        let woodbury = metric.inner(x.dot(&y), &v.tr_mul(&x), &v.tr_mul(&y));
        assert!(
            (woodbury - dense).abs() < 1e-12 * dense.abs().max(1.0),
            "{woodbury} against {dense}"
        );
    }

    #[test]
    fn without_the_calibrations_test_it_is_the_chi_square_test() {
        // χ²(100): 2.5 % and 97.5 % quantiles 74.222 and 129.561.
        let t = PredictionTest::new(130.0, 100, None).unwrap();
        assert!((t.interval.1 * 100.0 - 129.561).abs() < 1e-3);
        assert!(t.rejects());
        assert!(!PredictionTest::new(129.0, 100, None).unwrap().rejects());
        // F(100, 200) at 97.5 %: 1.39270 (the density integrated by
        // Simpson's rule); a calibration with s₀² = 1.1 admits T / n up to
        // 1.1 times that.
        let t = PredictionTest::new(150.0, 100, Some((220.0, 200))).unwrap();
        assert!((t.interval.1 - 1.39270).abs() < 1e-4, "{:?}", t.interval);
        assert!((t.ratio - 1.5 / 1.1).abs() < 1e-12);
        assert!(!t.rejects());
        assert!(
            PredictionTest::new(154.0, 100, Some((220.0, 200)))
                .unwrap()
                .rejects()
        );
    }

    #[test]
    fn the_square_root_reproduces_the_covariance_and_floors_rounding() {
        let a = matrix(5, 3, 0.9);
        let covariance = &a * a.transpose();
        let root = square_root(&covariance);
        assert!((&root * root.transpose() - &covariance).norm() < 1e-12 * covariance.norm());
        // A rank-3 covariance pushed slightly indefinite.
        let rounded = &covariance - DMatrix::identity(5, 5) * 1e-12;
        let root = square_root(&rounded);
        assert!(root.iter().all(|v| v.is_finite()));
        assert!((&root * root.transpose() - &covariance).norm() < 1e-9);
    }
}
