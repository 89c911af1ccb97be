//! What a design minimises, as a function of the posterior covariance
//! `Σ_pp` of the 33 parameters it predicts.
//!
//! With `(P J)_k` the registered tip Jacobians of the accuracy map's `N`
//! points (`parcal_accuracy::registered_jacobians`, docs/paper-scenario.md section 5), the
//! registered tip variance at point `k` is `v_k = trace((P J)_k Σ_pp (P J)_kᵀ)`.
//!
//! - [`Criterion::Registered`] (the default): the mean registered variance
//!   `(1/N) Σ_k v_k = trace(A Σ_pp)`, `A = (1/N) Σ_k (P J)_kᵀ (P J)_k`: the
//!   square of the registered RMS a user gets.
//! - [`Criterion::D`]: `ln det Σ_pp` (D_s-optimality for `p`, the ball
//!   centres being nuisances).
//! - [`Criterion::A`]: `trace Σ_pp` (mm², parameters of mixed meaning
//!   weighted alike).
//! - [`Criterion::G`]: the worst point of the map, `max_k v_k`.
//!
//! Adding a touch with row `h` changes the covariance of all unknowns by
//! Sherman–Morrison, `Σ' = Σ − s sᵀ / d`, `s = Σ h`, `d = 1 + hᵀ Σ h`, so
//! with `s_p` the parameter part of `s` and `A = F Fᵀ`:
//!
//! ```text
//! registered, A:  decrease = |Fᵀ s_p|² / d              (F Fᵀ = A, or I)
//! D:              decrease = −ln(1 − |Fᵀ s_p|² / d)      (F Fᵀ = Σ_pp⁻¹)
//! G:              v_k' = v_k − |(P J)_k s_p|² / d
//! ```
//!
//! The D decrease grows with `|Fᵀ s_p|² / d`, so every criterion but G ranks
//! the candidates by that ratio; G ranks by the registered ratio and
//! evaluates its exact decrease for the best [`G_SHORTLIST`].

use nalgebra::{SMatrix, SymmetricEigen};
use parcal_kinematics::N_PARAMS;

/// A 33 x 33 matrix.
pub type Square = SMatrix<f64, N_PARAMS, N_PARAMS>;
/// A registered tip Jacobian.
pub type MapJacobian = SMatrix<f64, 3, N_PARAMS>;

/// Candidates ranked best by the registered criterion whose exact G
/// decrease is evaluated at each step.
pub const G_SHORTLIST: usize = 64;

/// The optimality criterion (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Criterion {
    /// Mean registered tip variance over the accuracy map.
    #[default]
    Registered,
    /// `ln det Σ_pp`.
    D,
    /// `trace Σ_pp`.
    A,
    /// Worst registered tip variance over the map.
    G,
}

/// The map's registered Jacobians and their mean `A` with a factor `F`.
#[derive(Debug, Clone)]
pub struct MapWeights {
    /// `(P J)_k`, map order.
    pub jacobians: Vec<MapJacobian>,
    /// `A = (1/N) Σ_k (P J)_kᵀ (P J)_k`.
    pub mean: Square,
    /// `F` with `F Fᵀ = A` (from the eigen-decomposition: `A` is only
    /// semi-definite, the registration removes six directions).
    pub factor: Square,
}

impl MapWeights {
    /// From the registered Jacobians of the map.
    pub fn new(jacobians: Vec<MapJacobian>) -> Self {
        let n = jacobians.len().max(1) as f64;
        let mean = jacobians
            .iter()
            .fold(Square::zeros(), |sum, j| sum + j.transpose() * j)
            / n;
        let eigen = SymmetricEigen::new(mean);
        let roots = eigen.eigenvalues.map(|v| v.max(0.0).sqrt());
        let factor = eigen.eigenvectors * Square::from_diagonal(&roots);
        Self {
            jacobians,
            mean,
            factor,
        }
    }

    /// The registered tip variances `v_k` of `covariance` (mm²).
    pub fn variances(&self, covariance: &Square) -> Vec<f64> {
        self.jacobians
            .iter()
            .map(|j| (j * covariance).component_mul(j).sum().max(0.0))
            .collect()
    }
}

/// The predicted figures of a covariance of the 33 parameters.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct CriterionValues {
    /// Registered RMS over the map, `sqrt(trace(A Σ_pp))` (um).
    pub registered_rms_um: f64,
    /// Largest registered tip sigma over the map, `sqrt(max_k v_k)` (um).
    pub registered_max_um: f64,
    /// `ln det Σ_pp` (Σ in mm²).
    pub d: f64,
    /// `trace Σ_pp` (mm²).
    pub a: f64,
}

impl CriterionValues {
    /// The figures of `covariance`; `None` when it is not positive definite.
    pub fn of(covariance: &Square, map: &MapWeights) -> Option<Self> {
        let d = log_det(covariance)?;
        let worst = map.variances(covariance).into_iter().fold(0.0, f64::max);
        Some(Self {
            registered_rms_um: registered_rms_um(covariance, map),
            registered_max_um: worst.sqrt() * 1e3,
            d,
            a: covariance.trace(),
        })
    }

    /// The value `criterion` minimises.
    pub fn value(&self, criterion: Criterion) -> f64 {
        match criterion {
            Criterion::Registered => self.registered_rms_um,
            Criterion::G => self.registered_max_um,
            Criterion::D => self.d,
            Criterion::A => self.a,
        }
    }
}

impl Criterion {
    /// `CriterionValues::of(covariance, map)?.value(self)`, computing only
    /// this criterion's figure (only G needs every map point's variance).
    pub fn of(self, covariance: &Square, map: &MapWeights) -> Option<f64> {
        let d = log_det(covariance)?;
        Some(match self {
            Criterion::Registered => registered_rms_um(covariance, map),
            Criterion::D => d,
            Criterion::A => covariance.trace(),
            Criterion::G => CriterionValues::of(covariance, map)?.registered_max_um,
        })
    }
}

/// `ln det Σ`; `None` when `Σ` is not positive definite.
fn log_det(covariance: &Square) -> Option<f64> {
    let cholesky = covariance.cholesky()?;
    Some(2.0 * cholesky.l().diagonal().map(f64::ln).sum())
}

/// `sqrt(trace(A Σ))` in um.
fn registered_rms_um(covariance: &Square, map: &MapWeights) -> f64 {
    (map.mean * covariance).trace().max(0.0).sqrt() * 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_factor_reproduces_the_mean() {
        let jacobians: Vec<MapJacobian> = (0..10)
            .map(|k| MapJacobian::from_fn(|r, c| ((k * 7 + r * 3 + c) as f64 * 0.37).sin()))
            .collect();
        let map = MapWeights::new(jacobians);
        let error = (map.factor * map.factor.transpose() - map.mean).amax();
        assert!(error < 1e-12 * map.mean.amax(), "{error:e}");
        // trace(A Σ) is the mean of the variances.
        let covariance = Square::from_fn(|r, c| if r == c { 2.0 } else { 0.1 });
        let values = CriterionValues::of(&covariance, &map).unwrap();
        let mean = map.variances(&covariance).iter().sum::<f64>() / 10.0;
        assert!(
            (values.registered_rms_um - mean.sqrt() * 1e3).abs() < 1e-9 * values.registered_rms_um
        );
        // Each criterion alone is its figure among all of them.
        for criterion in [
            Criterion::Registered,
            Criterion::D,
            Criterion::A,
            Criterion::G,
        ] {
            assert_eq!(
                criterion.of(&covariance, &map),
                Some(values.value(criterion))
            );
        }
    }
}
