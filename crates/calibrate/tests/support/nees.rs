//! The normalised estimation error squared of an estimate against the
//! truth.

use nalgebra::{DMatrix, DVector};

/// `eᵀ Cov⁺ e` over the covariance's range, and its rank (eigenvalues
/// above 1e-9 of the largest: the gauge directions' are rounding noise).
pub fn nees(error: &DVector<f64>, covariance: &DMatrix<f64>) -> (f64, usize) {
    let eigen = covariance.clone().symmetric_eigen();
    let largest = eigen.eigenvalues.max();
    let mut nees = 0.0;
    let mut rank = 0;
    for (k, &lambda) in eigen.eigenvalues.iter().enumerate() {
        if lambda > 1e-9 * largest {
            rank += 1;
            nees += eigen.eigenvectors.column(k).dot(error).powi(2) / lambda;
        }
    }
    (nees, rank)
}
