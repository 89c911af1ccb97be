//! Local unknowns taken out of held-out rows: projected out
//! ([`project_out`]), or located by reference rows and the other rows
//! predicted from them ([`predict_from_reference`]).
//!
//! Projecting out a local unknown `u` of three coordinates (a pose, a
//! centre) from `m` residuals `r` with `dr/du = J` (rank 3), `dr/dp = G_p`
//! and noise covariance `Σ`: `N_⊥` is an orthonormal basis of the left
//! nullspace of `J` (`N_⊥ᵀ J = 0`), the last `m − 3` columns of `Q` of
//! `J = QR` (Householder: smooth in `J`), and
//!
//! ```text
//! r' = N_⊥ᵀ r,   G = N_⊥ᵀ G_p,   D = N_⊥ᵀ Σ N_⊥:
//! ```
//!
//! no error of `u` moves `r'` to first order, so that `r'` does not
//! depend on how `u` was fitted, nor `G` on how the fit moves with `θ`
//! (`dr'/dθ = N_⊥ᵀ (G_p + J du/dθ) = N_⊥ᵀ G_p`).

use nalgebra::{DMatrix, DVector};

use super::super::observation::{HeldOut, ObservationRef};
use super::rows::{PredictedRows, widened};

/// Residuals with local unknowns `u` (a pose, a centre, or the centres
/// of tied balls; module doc).
pub(super) struct LocalRows<'a> {
    /// `r` (`m`).
    pub(super) residuals: DVector<f64>,
    /// `J = dr/du` (`m × 3`, or 3 columns a ball).
    pub(super) d_local: &'a DMatrix<f64>,
    /// `G_p = dr/dp` (`m × n`).
    pub(super) d_params: &'a DMatrix<f64>,
    /// `Σ = Cov(r)` (`m × m`).
    pub(super) noise: DMatrix<f64>,
}

/// `local`'s rows with its local unknowns projected out (module doc), the
/// derivative widened to `g` columns; `None` when `J` is not of full
/// column rank (the rows do not locate the unknowns).
pub(super) fn project_out(
    observation: HeldOut,
    local: &LocalRows,
    g: usize,
) -> Option<PredictedRows> {
    let j = local.d_local;
    let (m, u) = (j.nrows(), j.ncols());
    let spread = (j.transpose() * j).symmetric_eigenvalues();
    // False for a rank below u, and for a value that is not a number.
    let located = spread.min() > 1e-12 * spread.max();
    if m < u || !located {
        return None;
    }
    let mut q_t = DMatrix::identity(m, m);
    j.clone().qr().q_tr_mul(&mut q_t);
    let basis_t = q_t.rows(u, m - u);
    Some(PredictedRows {
        observation,
        residuals: basis_t * &local.residuals,
        noise: basis_t * &local.noise * basis_t.transpose(),
        d_global: widened(&(basis_t * local.d_params), g),
        row_observations: Vec::new(),
        mirrored_balls: Vec::new(),
    })
}

/// `local`'s rows but its `reference` rows (increasing), predicted from
/// these (module doc), each named by its observation in `sources` (one
/// for each of `local`'s rows): with the rows split into the reference's
/// (`J_r`, noise `Σ_rr`) and the others' (`J_o`), the local unknowns' weighted
/// fit on the reference rows `K = (J_rᵀ Σ_rr⁻¹ J_r)⁻¹ J_rᵀ Σ_rr⁻¹`, and
/// `A = [−J_o K | I]` on them,
///
/// ```text
/// r' = A r = r_o − J_o K r_r,   G = A G_p,   D = A Σ Aᵀ:
/// ```
///
/// `A J = J_o − J_o K J_r = 0`, so that no error of the unknowns moves
/// `r'` to first order (nor `G`), as in [`project_out`], and `D` carries
/// the fit's error and the noise common to reference and other rows (a
/// ball's radius). `None` when the reference rows do not locate the
/// unknowns.
pub(super) fn predict_from_reference(
    observation: HeldOut,
    local: &LocalRows,
    reference: &[usize],
    sources: &[(ObservationRef, usize)],
    g: usize,
) -> Option<PredictedRows> {
    let m = local.residuals.len();
    let others: Vec<usize> = (0..m)
        .filter(|i| reference.binary_search(i).is_err())
        .collect();
    let j_r = local.d_local.select_rows(reference);
    let weight = (local.noise.select_rows(reference))
        .select_columns(reference)
        .cholesky()?
        .inverse();
    let normal = j_r.transpose() * &weight * &j_r;
    let spread = normal.symmetric_eigenvalues();
    // False for a rank below the unknowns', and for a value that is not a
    // number.
    let located = spread.min() > 1e-12 * spread.max();
    if !located {
        return None;
    }
    let gain = normal.try_inverse()? * j_r.transpose() * weight;
    let fitted = -(local.d_local.select_rows(&others) * gain);
    let mut a = DMatrix::zeros(others.len(), m);
    for (column, &r) in fitted.column_iter().zip(reference) {
        a.set_column(r, &column);
    }
    for (i, &o) in others.iter().enumerate() {
        a[(i, o)] = 1.0;
    }
    Some(PredictedRows {
        observation,
        residuals: &a * &local.residuals,
        noise: &a * &local.noise * a.transpose(),
        d_global: widened(&(&a * local.d_params), g),
        row_observations: others.iter().map(|&o| sources[o]).collect(),
        mirrored_balls: Vec::new(),
    })
}
