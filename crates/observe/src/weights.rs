//! The observation covariance `W` of paper eq. (5) and its whitening.
//!
//! Three independent repeatabilities perturb each contact (docs/paper-scenario.md section 3):
//! the actuator values (`σ_a` per actuator), the tool positioning (`σ_t` per
//! axis) and the ball radius (`σ_r`, along the contact direction). At the
//! tip they give
//!
//! ```text
//! Σ_tip = σ_a² J_q J_qᵀ + σ_t² I,                   J_q = dT/dq,
//! radius row (eq. 9):       w = n0ᵀ Σ_tip n0 + σ_r²,
//! coordinate rows (eq. 10): W = Σ_tip + σ_r² u0 u0ᵀ,
//! ```
//!
//! with `n0 = u0` the contact's initial direction from its ball centre. The
//! alternative [`WeightModel::Diagonal`] is the plain
//! `σ² = σ_a² + σ_t² + σ_r²` per row.
//!
//! **`W` is computed once, at the initial estimate (design parameters,
//! initial centres and directions), and held fixed during the iterations**,
//! as the reference implementation does: the weights then do not move with
//! the unknowns, and the cost is a fixed quadratic form of the residuals.
//!
//! Whitening uses the inverse Cholesky factor: `W = L Lᵀ`, `r_w = L⁻¹ c`,
//! `J_w = L⁻¹ J`, so `r_w` has covariance `I`. It is stored compactly: one
//! number for the radius row, the six of the lower-triangular `L⁻¹` for the
//! coordinate rows.

use nalgebra::{Matrix3, Matrix3x6, SMatrix};
use parcal_kinematics::Vec3;

use crate::ObserveError;
use crate::error::check_sigma;

/// One-sigma repeatabilities of a contact (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Repeatability {
    /// `σ_a`: each actuator value, independently.
    pub actuator: f64,
    /// `σ_t`: the tool positioning, each axis independently.
    pub tool: f64,
    /// `σ_r`: the ball's calibrated radius, treated as independent per
    /// contact (paper eq. 5); 0 when each ball's radius is an unknown with
    /// its own prior instead (its error is then shared by the ball's
    /// contacts, not drawn per contact).
    pub radius: f64,
}

impl Repeatability {
    /// `(σ_a², σ_t², σ_r²)` (mm²), refusing negative or non-finite sigmas.
    fn variances(&self) -> Result<(f64, f64, f64), ObserveError> {
        let actuator = check_sigma("actuator repeatability", self.actuator, true)?;
        let tool = check_sigma("tool repeatability", self.tool, true)?;
        let radius = check_sigma("radius repeatability", self.radius, true)?;
        Ok((actuator.powi(2), tool.powi(2), radius.powi(2)))
    }
}

/// How the observation covariance is modelled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum WeightModel {
    /// The repeatabilities propagated through the kinematics (the default).
    #[default]
    Propagated,
    /// The plain diagonal `σ² = σ_a² + σ_t² + σ_r²` per row.
    Diagonal,
}

/// The tip covariance `Σ_tip = σ_a² J_q J_qᵀ + σ_t² I` (mm²) of the
/// actuator and tool repeatabilities, with `d_q = J_q = dT/dq` (3 x 6).
pub fn tip_covariance(
    repeatability: &Repeatability,
    d_q: &Matrix3x6<f64>,
) -> Result<Matrix3<f64>, ObserveError> {
    let (actuator, tool, _) = repeatability.variances()?;
    let covariance = actuator * d_q * d_q.transpose() + tool * Matrix3::identity();
    Ok((covariance + covariance.transpose()) / 2.0)
}

/// Paper eqs. (5), (9): the variance `w` (mm²) of the radius row of a
/// contact with tip derivative `d_q = dT/dq` and initial unit direction
/// `n0` from the ball centre; `n0ᵀ Σ_tip n0 + σ_r²`, or `σ_a² + σ_t² + σ_r²`
/// for [`WeightModel::Diagonal`].
pub fn radius_variance(
    model: WeightModel,
    repeatability: &Repeatability,
    d_q: &Matrix3x6<f64>,
    n0: &Vec3,
) -> Result<f64, ObserveError> {
    let (actuator, tool, radius) = repeatability.variances()?;
    Ok(match model {
        WeightModel::Propagated => n0.dot(&(tip_covariance(repeatability, d_q)? * n0)) + radius,
        WeightModel::Diagonal => actuator + tool + radius,
    })
}

/// Paper eqs. (5), (10): the covariance `W` (3 x 3, mm²) of the coordinate
/// rows of a contact with tip derivative `d_q = dT/dq` and initial unit
/// direction `u0`; `Σ_tip + σ_r² u0 u0ᵀ`, or `(σ_a² + σ_t² + σ_r²) I` for
/// [`WeightModel::Diagonal`].
pub fn coordinate_covariance(
    model: WeightModel,
    repeatability: &Repeatability,
    d_q: &Matrix3x6<f64>,
    u0: &Vec3,
) -> Result<Matrix3<f64>, ObserveError> {
    let (actuator, tool, radius) = repeatability.variances()?;
    Ok(match model {
        WeightModel::Propagated => {
            tip_covariance(repeatability, d_q)? + radius * u0 * u0.transpose()
        }
        WeightModel::Diagonal => (actuator + tool + radius) * Matrix3::identity(),
    })
}

/// Whitening of `R` observation rows: multiplies by `L⁻¹`, where
/// `W = L Lᵀ` is their covariance.
pub trait Whitening<const R: usize> {
    /// `L⁻¹ m` for any number of columns `C`.
    fn whiten<const C: usize>(&self, m: &SMatrix<f64, R, C>) -> SMatrix<f64, R, C>;
}

/// The whitening of a radius row: `1/√w`, kept in single precision
/// ([`CoordinateWhitening`] says why).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadiusWhitening {
    inverse_sigma: f32,
}

impl Default for RadiusWhitening {
    /// Unit weight (variance 1 mm²).
    fn default() -> Self {
        Self { inverse_sigma: 1.0 }
    }
}

impl RadiusWhitening {
    /// From the row's variance `w` (mm², [`radius_variance`]); refuses a
    /// variance that is not positive and finite, or whose `1/√w` is not in
    /// single precision.
    pub fn from_variance(variance: f64) -> Result<Self, ObserveError> {
        // A variance that is not positive and finite leaves no positive,
        // finite `1/√w` (NaN, zero or infinity), in double precision or in
        // single.
        let inverse_sigma = variance.sqrt().recip() as f32;
        if positive_single(inverse_sigma) {
            Ok(Self { inverse_sigma })
        } else {
            Err(ObserveError::NotPositiveDefinite {
                what: "radius observation variance",
            })
        }
    }

    /// The row's standard deviation `√w` (mm), of its whitening.
    pub fn sigma(&self) -> f64 {
        self.inverse_sigma().recip()
    }

    /// `1/√w` (1/mm).
    fn inverse_sigma(&self) -> f64 {
        f64::from(self.inverse_sigma)
    }
}

impl Whitening<1> for RadiusWhitening {
    fn whiten<const C: usize>(&self, m: &SMatrix<f64, 1, C>) -> SMatrix<f64, 1, C> {
        m * self.inverse_sigma()
    }
}

/// Whether a value rounded to single precision is positive and finite (a
/// whitening's scale: not overflowed to infinity nor underflowed to zero).
fn positive_single(x: f32) -> bool {
    x.is_finite() && x > 0.0
}

/// The whitening of three coordinate rows: the lower-triangular `L⁻¹`,
/// packed by rows `[l00, l10, l11, l20, l21, l22]`.
///
/// Kept in single precision: 24 bytes a contact instead of 48, held for
/// every contact through the whole calibration. A weight is a statistical
/// statement, propagated from repeatabilities known to a few per cent;
/// rounding it by a relative 6e-8 changes each whitened row by about as much,
/// far below the rows' noise and below what the stopping rule leaves
/// undone. Every product is formed in double precision.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoordinateWhitening {
    inverse_factor: [f32; 6],
}

impl Default for CoordinateWhitening {
    /// Unit weight (covariance `I` mm²).
    fn default() -> Self {
        Self {
            inverse_factor: [1.0, 0.0, 1.0, 0.0, 0.0, 1.0],
        }
    }
}

impl CoordinateWhitening {
    /// From the rows' covariance `W` (mm², [`coordinate_covariance`]; its
    /// lower triangle is read); refuses a `W` that is not symmetric positive
    /// definite.
    pub fn from_covariance(covariance: &Matrix3<f64>) -> Result<Self, ObserveError> {
        let refuse = ObserveError::NotPositiveDefinite {
            what: "coordinate observation covariance",
        };
        if !covariance.iter().all(|v| v.is_finite()) {
            return Err(refuse);
        }
        let factor = covariance.cholesky().ok_or(refuse.clone())?.unpack();
        let inverse = factor
            .solve_lower_triangular(&Matrix3::identity())
            .ok_or(refuse)?;
        Self::from_inverse_factor(&inverse)
    }

    /// From `L⁻¹` itself (its lower triangle is read); refuses one that is
    /// not finite with a positive diagonal, in single precision too.
    pub fn from_inverse_factor(inverse: &Matrix3<f64>) -> Result<Self, ObserveError> {
        let inverse_factor = [(0, 0), (1, 0), (1, 1), (2, 0), (2, 1), (2, 2)]
            .map(|(row, column)| inverse[(row, column)] as f32);
        let [l00, _, l11, _, _, l22] = inverse_factor;
        if !(inverse_factor.iter().all(|v| v.is_finite())
            && [l00, l11, l22].into_iter().all(positive_single))
        {
            return Err(ObserveError::NotPositiveDefinite {
                what: "coordinate observation whitening",
            });
        }
        Ok(Self { inverse_factor })
    }

    /// Of the covariance `σ² I` (mm²): `L⁻¹ = I / σ`; refuses a `σ` whose
    /// `1/σ` is not finite and positive, in single precision too.
    pub fn isotropic(sigma: f64) -> Result<Self, ObserveError> {
        Self::from_inverse_factor(&Matrix3::from_diagonal_element(sigma.recip()))
    }

    /// The variance `uᵀ W u = |Lᵀ u|²` (mm²) of the rows along the unit
    /// vector `u`: a radius row's of the same contact (eq. 9's `w` of
    /// eq. 10's `W`).
    pub fn variance_along(&self, u: &Vec3) -> f64 {
        // Lᵀ u = (L⁻¹)⁻ᵀ u, the solution x of (L⁻¹)ᵀ x = u.
        self.inverse_factor()
            .transpose()
            .solve_upper_triangular(u)
            .map_or(f64::INFINITY, |x| x.norm_squared())
    }

    /// The rows' covariance `W = L Lᵀ` (mm²).
    pub fn covariance(&self) -> Matrix3<f64> {
        // `L⁻¹` is lower triangular with a positive diagonal: invertible.
        let factor = self
            .inverse_factor()
            .solve_lower_triangular(&Matrix3::identity())
            .unwrap_or_else(|| Matrix3::from_element(f64::NAN));
        factor * factor.transpose()
    }

    /// `L⁻¹` as a matrix (1/mm).
    pub fn inverse_factor(&self) -> Matrix3<f64> {
        let [l00, l10, l11, l20, l21, l22] = self.inverse_factor.map(f64::from);
        Matrix3::new(l00, 0.0, 0.0, l10, l11, 0.0, l20, l21, l22)
    }
}

impl Whitening<3> for CoordinateWhitening {
    fn whiten<const C: usize>(&self, m: &SMatrix<f64, 3, C>) -> SMatrix<f64, 3, C> {
        let [l00, l10, l11, l20, l21, l22] = self.inverse_factor.map(f64::from);
        SMatrix::<f64, 3, C>::from_fn(|row, column| {
            let x = m.column(column);
            match row {
                0 => l00 * x[0],
                1 => l10 * x[0] + l11 * x[1],
                _ => l20 * x[0] + l21 * x[1] + l22 * x[2],
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix4, Vector2, Vector3, Vector4};

    use super::*;
    use rand::rngs::StdRng;
    use rand::{RngExt, SeedableRng};
    use rand_distr::StandardNormal;

    use crate::test_support::Contact;
    use crate::{CoordinateBlock, DirectionChart, RadiusBlock};

    /// Different sigmas, so that a swapped or missing term shows. At the
    /// test contact the eigenvalues of `J_q J_qᵀ` are 0.18, 6.7 and 7.0 and
    /// `u0ᵀ J_q J_qᵀ u0` is 1.6, so each term carries at least 18 % of the
    /// variance of some whitened row: dropping any one of them moves a
    /// whitened variance far outside the Monte Carlo tolerance below.
    const REPEATABILITY: Repeatability = Repeatability {
        actuator: 0.5e-3,
        tool: 1e-3,
        radius: 2e-3,
    };

    #[test]
    fn whitening_inverts_the_covariance() {
        // The whitening is kept in single precision: each entry of `L⁻¹`
        // within 2⁻²⁴ relative of the double-precision one, and what is
        // formed of two or three of them (`|Lᵀu|²`, `L⁻¹WL⁻ᵀ`) within a few
        // times that.
        let single = f64::from(f32::EPSILON);
        let contact = Contact::new();
        let tip = contact.tip();
        let u0 = (tip.position - contact.centre()).normalize();
        for model in [WeightModel::Propagated, WeightModel::Diagonal] {
            let w = coordinate_covariance(model, &REPEATABILITY, &tip.d_q(), &u0).unwrap();
            let inverse = CoordinateWhitening::from_covariance(&w)
                .unwrap()
                .inverse_factor();
            let identity = inverse * w * inverse.transpose();
            let whitening = CoordinateWhitening::from_covariance(&w).unwrap();
            let along = whitening.variance_along(&u0);
            let radius = radius_variance(model, &REPEATABILITY, &tip.d_q(), &u0).unwrap();
            assert!(
                (along - radius).abs() < 3.0 * single * radius,
                "{along} {radius}"
            );
            assert!(
                (identity - Matrix3::identity()).amax() < 3.0 * single,
                "{identity}"
            );
            assert_eq!(
                inverse.upper_triangle(),
                Matrix3::from_diagonal(&inverse.diagonal())
            );

            let variance = radius_variance(model, &REPEATABILITY, &tip.d_q(), &u0).unwrap();
            assert!((variance - u0.dot(&(w * u0))).abs() < 1e-18);
            let radius = RadiusWhitening::from_variance(variance).unwrap();
            assert!((radius.sigma().powi(2) / variance - 1.0).abs() < single);
        }
        // Whitening a block applies L⁻¹ to every part.
        let weight = CoordinateWhitening::from_covariance(
            &coordinate_covariance(WeightModel::Propagated, &REPEATABILITY, &tip.d_q(), &u0)
                .unwrap(),
        )
        .unwrap();
        let block = CoordinateBlock {
            radius: 5.0,
            chart: DirectionChart::new(&u0).unwrap(),
        };
        let raw = block.evaluate(&tip.position, &contact.centre(), &Vector2::new(0.01, 0.02));
        let whitened = raw.whiten(&weight);
        let l = weight.inverse_factor();
        assert!((whitened.residual - l * raw.residual).amax() < 1e-9);
        assert!((whitened.d_tip - l * raw.d_tip).amax() < 1e-9);
        assert!((whitened.d_centre - l * raw.d_centre).amax() < 1e-9);
        assert!((whitened.d_radius - l * raw.d_radius).amax() < 1e-9);
        assert!((whitened.d_angles - l * raw.d_angles).amax() < 1e-9);
    }

    #[test]
    fn diagonal_model_is_the_plain_sum() {
        let tip = Contact::new().tip();
        let u0 = Vector3::z();
        let sum: f64 = 0.25e-6 + 1e-6 + 4e-6;
        let w = coordinate_covariance(WeightModel::Diagonal, &REPEATABILITY, &tip.d_q(), &u0);
        assert!((w.unwrap() - sum * Matrix3::identity()).amax() < 1e-15 * sum);
        let w = radius_variance(WeightModel::Diagonal, &REPEATABILITY, &tip.d_q(), &u0);
        assert!((w.unwrap() - sum).abs() < 1e-15 * sum);
    }

    #[test]
    fn refuses_bad_repeatabilities_and_covariances() {
        let d_q = Matrix3x6::zeros();
        let bad = Repeatability {
            tool: -1e-3,
            ..REPEATABILITY
        };
        let error = tip_covariance(&bad, &d_q).unwrap_err();
        assert_eq!(
            error.to_string(),
            "the tool repeatability -1e-3 mm is not a valid standard deviation (a finite number >= 0)"
        );
        let zero = Repeatability {
            actuator: 0.0,
            tool: 0.0,
            radius: 0.0,
        };
        let w = coordinate_covariance(WeightModel::Propagated, &zero, &d_q, &Vector3::z()).unwrap();
        assert!(matches!(
            CoordinateWhitening::from_covariance(&w),
            Err(ObserveError::NotPositiveDefinite { .. })
        ));
        assert!(RadiusWhitening::from_variance(0.0).is_err());
        assert!(RadiusWhitening::from_variance(f64::NAN).is_err());
        let nan = Matrix3::from_diagonal_element(f64::NAN);
        assert!(CoordinateWhitening::from_covariance(&nan).is_err());
        // A whitening that single precision cannot hold: `1/σ` beyond its
        // largest number, or below its smallest.
        for sigma in [1e-40, 1e50] {
            assert!(CoordinateWhitening::isotropic(sigma).is_err(), "{sigma}");
            assert!(
                RadiusWhitening::from_variance(sigma * sigma).is_err(),
                "{sigma}"
            );
        }
        assert!(CoordinateWhitening::isotropic(1e-3).is_ok());
    }

    /// What every contact holds for its weight through a calibration
    /// (docs/performance.md, "Memory").
    #[test]
    fn a_weight_is_held_in_single_precision() {
        assert_eq!(size_of::<CoordinateWhitening>(), 24);
        assert_eq!(size_of::<RadiusWhitening>(), 4);
    }

    /// Simulated contacts: actuator noise through real forward kinematics,
    /// tool and radius noise; the whitened residuals of both blocks have unit
    /// covariance. Standard errors for n draws: sqrt(2/n) on a variance,
    /// sqrt(1/n) on a correlation; the test allows 5 of them.
    #[test]
    fn whitened_residuals_of_simulated_noise_have_unit_covariance() {
        const DRAWS: usize = 20_000;
        let contact = Contact::new();
        let p = contact.params();
        let tip = contact.tip();
        let centre = contact.centre();
        // The true ball: the exact tip on its surface in direction u0.
        let u0 = (tip.position - centre).normalize();
        let true_radius = (tip.position - centre).norm();
        let coordinate_weight = CoordinateWhitening::from_covariance(
            &coordinate_covariance(WeightModel::Propagated, &REPEATABILITY, &tip.d_q(), &u0)
                .unwrap(),
        )
        .unwrap();
        let radius_weight = RadiusWhitening::from_variance(
            radius_variance(WeightModel::Propagated, &REPEATABILITY, &tip.d_q(), &u0).unwrap(),
        )
        .unwrap();
        let chart = DirectionChart::new(&u0).unwrap();

        let mut rng = StdRng::seed_from_u64(1158);
        let mut normal = || -> f64 { rng.sample(StandardNormal) };
        // Rows 0-2 whitened coordinate residual, row 3 whitened radius residual.
        let mut second_moment = Matrix4::<f64>::zeros();
        for _ in 0..DRAWS {
            let q: [f64; 6] =
                std::array::from_fn(|i| contact.q[i] + REPEATABILITY.actuator * normal());
            let mut noisy = contact.tip_with_actuators(&p, &q);
            // The tool really stands at tip + δt while the encoders say q.
            let tool = Vector3::from_fn(|_, _| REPEATABILITY.tool * normal());
            let calibrated_radius = true_radius + REPEATABILITY.radius * normal();
            noisy.position -= tool;
            let coordinate = CoordinateBlock {
                radius: calibrated_radius,
                chart,
            }
            .evaluate(&noisy.position, &centre, &Vector2::zeros())
            .whiten(&coordinate_weight)
            .residual;
            let radius = RadiusBlock {
                radius: calibrated_radius,
            }
            .evaluate(&noisy.position, &centre)
            .unwrap()
            .whiten(&radius_weight)
            .residual;
            let r = Vector4::new(coordinate[0], coordinate[1], coordinate[2], radius[0]);
            second_moment += r * r.transpose();
        }
        let covariance = second_moment / DRAWS as f64;
        // Rows 0-2 against row 3 correlate by design: the same noise enters both.
        println!("whitened residual second moments (coordinates 0-2, radius 3): {covariance}");
        let n = DRAWS as f64;
        for i in 0..3 {
            for j in 0..3 {
                let (expected, tolerance) = if i == j {
                    (1.0, 5.0 * (2.0 / n).sqrt())
                } else {
                    (0.0, 5.0 / n.sqrt())
                };
                assert!(
                    (covariance[(i, j)] - expected).abs() < tolerance,
                    "coordinate covariance ({i}, {j}) = {}",
                    covariance[(i, j)]
                );
            }
        }
        assert!((covariance[(3, 3)] - 1.0).abs() < 5.0 * (2.0 / n).sqrt());
    }
}
