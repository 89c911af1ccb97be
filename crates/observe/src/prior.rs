//! The a priori knowledge (paper eq. 7) as Gaussian priors.
//!
//! The paper stacks prior rows `p − m` under the observations, weighted by
//! the prior covariance. Here each prior is whitened once:
//! `r = L⁻¹ (p − m)` with `Σ = L Lᵀ`, so `rᵀ r = (p − m)ᵀ Σ⁻¹ (p − m)` and
//! `dr/dp = L⁻¹`.
//!
//! - [`KinematicPrior`]: the 33 canonical parameters, either as the paper
//!   states it ([`KinematicPrior::paper`]: design mean, every sigma 0.1) or
//!   with the design tolerances put on the 45 input-frame coordinates and
//!   propagated through the canonicalisation ([`KinematicPrior::propagated`]:
//!   a full 33 x 33 covariance). docs/paper-scenario.md section 4 explains why the second is
//!   the one consistent with a real machine.
//! - [`DiagonalPrior`]: independent Gaussians, for the ball centres (3) and
//!   the contact angles (2).

use nalgebra::{SMatrix, SVector};
use parcal_kinematics::frames::{N_INPUT_COORDINATES, parameter_jacobian};
use parcal_kinematics::{Geometry, ParamCovariance, Params, PriorSigma, params};

use crate::ObserveError;
use crate::error::check_sigma;

/// A Cholesky pivot `L_kk²` below this fraction of the largest variance
/// counts as a rank deficiency: rounding makes a singular covariance's
/// pivots ~1e-16 of its scale, while a full-rank prior's are far above.
const RANK_PIVOT_RATIO: f64 = 1e-12;

/// The 45 input-coordinate variances of `sigmas` in the order of
/// [`parcal_kinematics::frames::input_coordinates`] (mm²), refusing a
/// negative, zero or non-finite sigma.
fn input_variances(sigmas: &PriorSigma) -> Result<SVector<f64, N_INPUT_COORDINATES>, ObserveError> {
    check_sigma("base prior sigma", sigmas.base, false)?;
    check_sigma("platform prior sigma", sigmas.platform, false)?;
    check_sigma("tool prior sigma", sigmas.tool, false)?;
    check_sigma("leg prior sigma", sigmas.leg, false)?;
    Ok(sigmas.per_input_coordinate().map(|sigma| sigma.powi(2)))
}

/// A Gaussian prior `N(mean, covariance)` on the 33 canonical parameters,
/// with its whitening. Built only from a symmetric positive definite
/// covariance.
#[derive(Debug, Clone, PartialEq)]
pub struct KinematicPrior {
    mean: Params,
    covariance: ParamCovariance,
    /// `L⁻¹`, lower triangular, `covariance = L Lᵀ`.
    inverse_factor: ParamCovariance,
}

impl KinematicPrior {
    /// Paper eq. (7): a prior with the given mean (mm) and covariance (mm²).
    /// Refuses a covariance that is not finite, not symmetric (to 1e-12
    /// relative) or not of full rank 33 (Cholesky pivots below 1e-12 of the
    /// largest variance).
    pub fn new(mean: Params, covariance: ParamCovariance) -> Result<Self, ObserveError> {
        let refuse = ObserveError::NotPositiveDefinite {
            what: "kinematic prior covariance",
        };
        let scale = covariance.diagonal().max();
        let symmetric = (covariance - covariance.transpose()).amax() <= 1e-12 * scale;
        if !(covariance.iter().all(|v| v.is_finite()) && symmetric && scale > 0.0) {
            return Err(refuse);
        }
        let factor = covariance.cholesky().ok_or(refuse.clone())?.unpack();
        if factor.diagonal().map(|d| d * d).min() < RANK_PIVOT_RATIO * scale {
            return Err(refuse);
        }
        let inverse_factor = factor
            .solve_lower_triangular(&ParamCovariance::identity())
            .ok_or(refuse)?;
        Ok(Self {
            mean,
            covariance,
            inverse_factor,
        })
    }

    /// Paper eq. (7) as the paper states it (docs/paper-scenario.md section 4, paper mode):
    /// mean = the design's canonical parameters (mm), every parameter
    /// independent with standard deviation `sigma` (mm; the paper's 0.1).
    pub fn paper(design_canonical: &Params, sigma: f64) -> Result<Self, ObserveError> {
        let sigma = check_sigma("kinematic prior sigma", sigma, false)?;
        Self::new(
            *design_canonical,
            ParamCovariance::from_diagonal_element(sigma * sigma),
        )
    }

    /// Paper eq. (7) with the tolerances where they belong (docs/paper-scenario.md section 4,
    /// propagated mode): each of the 45 input-frame coordinates of `design`
    /// (any base and platform frames) independent with its group's sigma
    /// (mm), propagated through the canonicalisation linearised at the
    /// design, `Σ_p = G Σ_x Gᵀ` with `G = dp/dx` (33 x 45,
    /// [`parameter_jacobian`]); mean = the design's canonical parameters.
    /// The 12 directions of `x` that `G` drops are the rigid motions of the
    /// base and platform frames, so `Σ_p` has full rank 33; a degenerate
    /// design that breaks this is refused.
    pub fn propagated(design: &Geometry, sigmas: &PriorSigma) -> Result<Self, ObserveError> {
        let scaled = parameter_jacobian(design)?
            * SMatrix::from_diagonal(&input_variances(sigmas)?.map(f64::sqrt));
        let covariance = scaled * scaled.transpose();
        let mean = params::to_params(&design.canonicalize()?.geometry);
        Self::new(mean, (covariance + covariance.transpose()) / 2.0)
    }

    /// The prior mean `m` (mm).
    pub fn mean(&self) -> &Params {
        &self.mean
    }

    /// The prior covariance `Σ` (mm²).
    pub fn covariance(&self) -> &ParamCovariance {
        &self.covariance
    }

    /// The marginal standard deviations `√Σ_kk` (mm).
    pub fn sigma(&self) -> Params {
        self.covariance.diagonal().map(f64::sqrt)
    }

    /// The information matrix `Σ⁻¹ = L⁻ᵀ L⁻¹` (1/mm²).
    pub fn information(&self) -> ParamCovariance {
        self.inverse_factor.transpose() * self.inverse_factor
    }

    /// `L⁻¹` (1/mm), lower triangular: the Jacobian of
    /// [`KinematicPrior::whitened_residual`].
    pub fn inverse_factor(&self) -> &ParamCovariance {
        &self.inverse_factor
    }

    /// Paper eq. (7), the whitened prior rows: `L⁻¹ (p − m)` (dimensionless).
    pub fn whitened_residual(&self, p: &Params) -> Params {
        self.inverse_factor * (p - self.mean)
    }

    /// `(p − m)ᵀ Σ⁻¹ (p − m)`: chi-square with 33 degrees of freedom when
    /// `p` is drawn from the prior.
    pub fn chi_square(&self, p: &Params) -> f64 {
        self.whitened_residual(p).norm_squared()
    }

    /// Per-parameter normalised deviations `(p_k − m_k) / σ_k`.
    pub fn deviations(&self, p: &Params) -> Params {
        (p - self.mean).component_div(&self.sigma())
    }
}

/// Independent Gaussian priors on `N` unknowns (ball centre: 3, mm; contact
/// angles: 2, rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiagonalPrior<const N: usize> {
    mean: SVector<f64, N>,
    sigma: SVector<f64, N>,
}

/// The prior of a ball centre (mm).
pub type CentrePrior = DiagonalPrior<3>;
/// The prior of a contact's two angles (rad).
pub type AnglePrior = DiagonalPrior<2>;

impl<const N: usize> DiagonalPrior<N> {
    /// Paper eq. (7) for independent unknowns: `N(mean, diag(sigma²))`;
    /// every sigma must be positive and finite.
    pub fn new(mean: SVector<f64, N>, sigma: SVector<f64, N>) -> Result<Self, ObserveError> {
        for value in sigma.iter() {
            check_sigma("prior sigma", *value, false)?;
        }
        Ok(Self { mean, sigma })
    }

    /// The same `sigma` for every component.
    pub fn isotropic(mean: SVector<f64, N>, sigma: f64) -> Result<Self, ObserveError> {
        Self::new(mean, SVector::repeat(sigma))
    }

    /// The prior mean.
    pub fn mean(&self) -> &SVector<f64, N> {
        &self.mean
    }

    /// The standard deviations.
    pub fn sigma(&self) -> &SVector<f64, N> {
        &self.sigma
    }

    /// `1 / σ_k`: the diagonal Jacobian of
    /// [`DiagonalPrior::whitened_residual`].
    pub fn inverse_sigma(&self) -> SVector<f64, N> {
        self.sigma.map(f64::recip)
    }

    /// Paper eq. (7), the whitened prior rows `(x_k − m_k) / σ_k`.
    pub fn whitened_residual(&self, x: &SVector<f64, N>) -> SVector<f64, N> {
        (x - self.mean).component_mul(&self.inverse_sigma())
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Vector2, Vector3};
    use parcal_kinematics::{PARAM_NAMES, paper};

    use super::*;

    const TOLERANCES: PriorSigma = PriorSigma {
        base: 0.1,
        platform: 0.1,
        tool: 0.1,
        leg: 0.1,
    };

    fn canonical_params(geometry: &Geometry) -> Params {
        params::to_params(&geometry.canonicalize().unwrap().geometry)
    }

    /// The parameter with the largest |deviation|: (name, deviation).
    fn largest(deviations: &Params) -> (&'static str, f64) {
        let k = deviations.iamax();
        (PARAM_NAMES[k], deviations[k])
    }

    #[test]
    fn paper_prior_is_diagonal_and_far_from_the_truth() {
        let design = canonical_params(&paper::design());
        let prior = KinematicPrior::paper(&design, 0.1).unwrap();
        // Diagonal, every variance 0.1² (compared without printing 33 x 33).
        assert!(prior.covariance() == &ParamCovariance::from_diagonal_element(0.1 * 0.1));
        assert!(prior.sigma().iter().all(|s| (s - 0.1).abs() < 1e-15));
        assert_eq!(prior.mean(), &design);

        let truth = canonical_params(&paper::truth());
        let deviations = prior.deviations(&truth);
        let chi_square = prior.chi_square(&truth);
        let (name, worst) = largest(&deviations);
        println!(
            "paper prior: chi-square of the truth {chi_square:.1} for 33 dof; largest deviation {worst:.2} sigma ({name}); z_b5 {:.2}, z_b6 {:.2}",
            deviations[8], deviations[11]
        );
        assert!((chi_square - deviations.norm_squared()).abs() < 1e-9 * chi_square);
        assert!(worst.abs() > 10.0, "largest deviation {worst}");
        // The spec names z_b5 and z_b6 (about -1.6 mm against design 0).
        assert!(deviations[8] < -10.0 && deviations[11] < -10.0);
    }

    #[test]
    fn propagated_prior_is_full_rank_and_consistent_with_the_truth() {
        let prior = KinematicPrior::propagated(&paper::design(), &TOLERANCES).unwrap();
        let covariance = prior.covariance();
        assert_eq!(covariance, &covariance.transpose());
        let eigenvalues = covariance.symmetric_eigenvalues();
        println!(
            "propagated prior: eigenvalues of the covariance from {:.3e} to {:.3e} mm²",
            eigenvalues.min(),
            eigenvalues.max()
        );
        assert!(eigenvalues.min() > 1e-8 * eigenvalues.max());
        let identity = prior.information() * covariance;
        assert!((identity - ParamCovariance::identity()).amax() < 1e-9);
        assert_eq!(prior.mean(), &canonical_params(&paper::design()));

        // Leg lengths are plain input coordinates: their tolerance passes
        // through unchanged.
        let sigma = prior.sigma();
        for leg in 0..6 {
            let k = params::leg_index(leg);
            assert!(
                (sigma[k] / 0.1 - 1.0).abs() < 1e-9,
                "{}: {}",
                PARAM_NAMES[k],
                sigma[k]
            );
        }

        let truth = canonical_params(&paper::truth());
        let chi_square = prior.chi_square(&truth);
        let (name, worst) = largest(&prior.deviations(&truth));
        println!(
            "propagated prior: chi-square of the truth {chi_square:.1} for 33 dof; largest marginal deviation {worst:.2} sigma ({name})"
        );
        assert!(
            (20.0..60.0).contains(&chi_square),
            "chi-square {chi_square}"
        );
        assert!(worst.abs() < 5.0);
    }

    #[test]
    fn whitened_residual_is_the_prior_rows() {
        let prior = KinematicPrior::propagated(&paper::design(), &TOLERANCES).unwrap();
        let p = canonical_params(&paper::truth());
        let residual = prior.whitened_residual(&p);
        let direct = (p - prior.mean()).dot(&(prior.information() * (p - prior.mean())));
        assert!((residual.norm_squared() / direct - 1.0).abs() < 1e-9);
        assert_eq!(prior.whitened_residual(prior.mean()), Params::zeros());
        let l = prior.inverse_factor();
        assert_eq!(
            l.upper_triangle(),
            ParamCovariance::from_diagonal(&l.diagonal())
        );
    }

    #[test]
    fn refuses_invalid_priors() {
        let design = canonical_params(&paper::design());
        assert!(matches!(
            KinematicPrior::paper(&design, 0.0),
            Err(ObserveError::InvalidSigma { .. })
        ));
        let zero_legs = PriorSigma {
            leg: 0.0,
            ..TOLERANCES
        };
        let error = KinematicPrior::propagated(&paper::design(), &zero_legs).unwrap_err();
        assert_eq!(
            error.to_string(),
            "the leg prior sigma 0e0 mm is not a valid standard deviation (a finite number > 0)"
        );
        // Rank 32: one parameter without any uncertainty.
        let mut covariance = ParamCovariance::from_diagonal_element(0.01);
        covariance[(5, 5)] = 0.0;
        assert!(matches!(
            KinematicPrior::new(design, covariance),
            Err(ObserveError::NotPositiveDefinite { .. })
        ));
        let mut asymmetric = ParamCovariance::from_diagonal_element(0.01);
        asymmetric[(0, 1)] = 0.001;
        assert!(KinematicPrior::new(design, asymmetric).is_err());
        let mut degenerate = paper::design();
        degenerate.base[2] = degenerate.base[0] + 2.0 * (degenerate.base[1] - degenerate.base[0]);
        assert!(matches!(
            KinematicPrior::propagated(&degenerate, &TOLERANCES),
            Err(ObserveError::Kinematics(_))
        ));
    }

    #[test]
    fn diagonal_prior_whitens_each_component() {
        let prior =
            CentrePrior::new(Vector3::new(1.0, 2.0, 3.0), Vector3::new(0.1, 0.2, 0.4)).unwrap();
        let residual = prior.whitened_residual(&Vector3::new(1.1, 1.6, 3.0));
        assert!((residual - Vector3::new(1.0, -2.0, 0.0)).amax() < 1e-12);
        assert_eq!(prior.inverse_sigma(), Vector3::new(10.0, 5.0, 2.5));
        let angles = AnglePrior::isotropic(Vector2::zeros(), 0.01).unwrap();
        assert_eq!(angles.sigma(), &Vector2::repeat(0.01));
        assert_eq!(angles.mean(), &Vector2::zeros());
        assert!(CentrePrior::new(Vector3::zeros(), Vector3::new(0.1, -0.1, 0.1)).is_err());
        assert!(AnglePrior::isotropic(Vector2::zeros(), f64::INFINITY).is_err());
    }
}
