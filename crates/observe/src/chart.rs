//! The per-contact direction chart of the transformed-coordinate observation
//! (paper eq. 10).
//!
//! A contact direction `u` (unit vector from the ball centre to the contact
//! point) lies on the lower hemisphere, near the pole where ordinary
//! spherical angles are singular. Each contact therefore gets its own chart:
//! tangent coordinates `θ = (θ1, θ2)` of the exponential map of the sphere
//! about a reference direction `u0` (the initial estimate of the contact's
//! direction), with an orthonormal tangent basis `(e1, e2)` of `u0`:
//!
//! ```text
//! v = θ1 e1 + θ2 e2,   φ = |v| = |θ|,
//! u(θ) = cos φ u0 + (sin φ / φ) v,                          u(0) = u0,
//! du/dθ = s(φ) (E − u0 θᵀ) + b(φ) v θᵀ,                      E = [e1 e2],
//! s(φ) = sin φ / φ,   b(φ) = s'(φ) / φ = (φ cos φ − sin φ) / φ³.
//! ```
//!
//! The chart is regular for |θ| < π, and the angles stay near 0 during a
//! calibration (they move by the contact's direction error, ~mrad).

use nalgebra::{Matrix3x2, UnitVector3, Vector2};
use parcal_kinematics::Vec3;

use crate::ObserveError;

/// Below this `φ` (rad) `cos φ`, `s` and `b` come from their Taylor series
/// (truncation ~φ⁸/10⁴ < 10⁻²⁰ there); above it from the closed forms,
/// whose rounding (~ε/φ² for `b`) is then below 10⁻¹¹. The angles of a
/// calibration stay below it after the first iterations, so that the chart
/// then costs no trigonometric call.
const SERIES_BELOW: f64 = 1e-2;

/// `cos φ`, `s(φ) = sin φ / φ` and `b(φ) = (φ cos φ − sin φ) / φ³` from
/// `p2 = φ²`, exact for every `φ >= 0`. Below the switch, Horner forms in
/// `φ²` whose coefficients are constants: no square root and no division
/// on the path every contact takes twice per iteration (the nested
/// quotients `φ²/2 (1 − φ²/12 (…))` would cost nine divisions, and
/// `φ = |θ|` a square root).
fn trig_terms(p2: f64) -> (f64, f64, f64) {
    if p2 < SERIES_BELOW * SERIES_BELOW {
        let cos = 1.0 + p2 * (-1.0 / 2.0 + p2 * (1.0 / 24.0 - p2 * (1.0 / 720.0)));
        let s = 1.0 + p2 * (-1.0 / 6.0 + p2 * (1.0 / 120.0 - p2 * (1.0 / 5040.0)));
        let b = -1.0 / 3.0 + p2 * (1.0 / 30.0 + p2 * (-1.0 / 840.0 + p2 * (1.0 / 45360.0)));
        (cos, s, b)
    } else {
        let phi = p2.sqrt();
        let (sin, cos) = phi.sin_cos();
        (cos, sin / phi, (phi * cos - sin) / (phi * phi * phi))
    }
}

/// The unit vector along `direction`, refusing a zero or non-finite one
/// (which `nalgebra`'s `Unit::try_new` lets through as NaN): the reference
/// direction `u0` of a chart.
pub fn unit_direction(direction: &Vec3) -> Result<UnitVector3<f64>, ObserveError> {
    let length = direction.norm();
    if !(length.is_finite() && length > 0.0) {
        return Err(ObserveError::DegenerateDirection {
            what: "chart reference direction",
            length,
        });
    }
    Ok(UnitVector3::new_unchecked(direction / length))
}

/// Tangent coordinates of the exponential map of the unit sphere about `u0`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionChart {
    u0: Vec3,
    e1: Vec3,
    e2: Vec3,
}

impl DirectionChart {
    /// The chart about the direction of `reference` (any non-zero finite
    /// vector; it is normalised, [`unit_direction`]).
    pub fn new(reference: &Vec3) -> Result<Self, ObserveError> {
        Ok(Self::about(&unit_direction(reference)?))
    }

    /// The chart about the unit direction `u0`, which is not normalised
    /// again: a calibration builds each contact's chart from its stored
    /// `u0` twice per iteration. The tangent basis is that of Duff et al.,
    /// "Building an orthonormal basis, revisited" (JCGT 6(1), 2017): a
    /// deterministic function of `u0` with no singular direction, and
    /// `e1 × e2 = u0`.
    #[inline]
    pub fn about(u0: &UnitVector3<f64>) -> Self {
        let u0 = u0.into_inner();
        let sign = 1.0_f64.copysign(u0.z);
        let a = -1.0 / (sign + u0.z);
        let b = u0.x * u0.y * a;
        let e1 = Vec3::new(1.0 + sign * u0.x * u0.x * a, sign * b, -sign * u0.x);
        let e2 = Vec3::new(b, sign + u0.y * u0.y * a, -u0.y);
        Self { u0, e1, e2 }
    }

    /// The reference direction `u0 = u(0)` (unit).
    pub fn reference(&self) -> Vec3 {
        self.u0
    }

    /// The tangent basis `E = [e1 e2]` (orthonormal columns, both ⟂ `u0`).
    pub fn tangent_basis(&self) -> Matrix3x2<f64> {
        Matrix3x2::from_columns(&[self.e1, self.e2])
    }

    /// Paper eq. (10), the direction: `u(θ) = cos φ u0 + (sin φ / φ) v`
    /// with `v = θ1 e1 + θ2 e2`, `φ = |θ|` (θ in rad; `u` unit).
    pub fn direction(&self, angles: &Vector2<f64>) -> Vec3 {
        let (cos, s, _) = trig_terms(angles.norm_squared());
        cos * self.u0 + s * (self.tangent_basis() * angles)
    }

    /// Paper eq. (10), the direction's derivative `du/dθ` (3 x 2, per rad):
    /// `s(φ) (E − u0 θᵀ) + b(φ) v θᵀ`, exact for every θ including 0.
    pub fn derivative(&self, angles: &Vector2<f64>) -> Matrix3x2<f64> {
        self.direction_and_derivative(angles).1
    }

    /// [`DirectionChart::direction`] and [`DirectionChart::derivative`]
    /// together, from one evaluation of `φ` and its trigonometric terms.
    #[inline]
    pub fn direction_and_derivative(&self, angles: &Vector2<f64>) -> (Vec3, Matrix3x2<f64>) {
        let (cos, s, b) = trig_terms(angles.norm_squared());
        let basis = self.tangent_basis();
        let v = basis * angles;
        let direction = cos * self.u0 + s * v;
        let derivative = s * (basis - self.u0 * angles.transpose()) + b * v * angles.transpose();
        (direction, derivative)
    }

    /// The chart's inverse (the logarithm of the sphere about `u0`): the
    /// angles `θ` with `u(θ)` the direction of `direction` (any non-zero
    /// finite vector), `|θ| = atan2(|Eᵀu|, u·u0) ∈ [0, π]` along `Eᵀu`;
    /// `θ = 0` for `u0` itself (and for `−u0`, where the chart is singular).
    pub fn angles_of(&self, direction: &Vec3) -> Vector2<f64> {
        let tangent = self.tangent_basis().transpose() * direction;
        let sine = tangent.norm();
        if sine == 0.0 {
            return Vector2::zeros();
        }
        let phi = sine.atan2(self.u0.dot(direction));
        tangent * (phi / sine)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::assert_close;

    const STEP: f64 = 1e-6;

    fn finite_difference(chart: &DirectionChart, angles: &Vector2<f64>) -> Matrix3x2<f64> {
        let mut jacobian = Matrix3x2::zeros();
        for k in 0..2 {
            let mut step = Vector2::zeros();
            step[k] = STEP;
            let column = (chart.direction(&(angles + step)) - chart.direction(&(angles - step)))
                / (2.0 * STEP);
            jacobian.set_column(k, &column);
        }
        jacobian
    }

    fn charts() -> Vec<DirectionChart> {
        [
            Vec3::new(0.0, 0.0, -1.0),
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(0.3, -0.2, -0.9),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(-0.2, 0.7, -1e-17),
            Vec3::new(0.0, -1.0, 0.0),
        ]
        .iter()
        .map(|u| DirectionChart::new(u).unwrap())
        .collect()
    }

    #[test]
    fn tangent_basis_is_orthonormal_and_right_handed_everywhere() {
        for chart in charts() {
            let (u0, e1, e2) = (chart.u0, chart.e1, chart.e2);
            for (value, expected) in [
                (u0.norm(), 1.0),
                (e1.norm(), 1.0),
                (e2.norm(), 1.0),
                (e1.dot(&e2), 0.0),
                (e1.dot(&u0), 0.0),
                (e2.dot(&u0), 0.0),
            ] {
                assert!((value - expected).abs() < 1e-15, "{chart:?}");
            }
            assert!((e1.cross(&e2) - u0).norm() < 1e-15, "{chart:?}");
        }
    }

    #[test]
    fn direction_is_the_exponential_map() {
        for chart in charts() {
            assert_eq!(chart.direction(&Vector2::zeros()), chart.u0);
            let angles = Vector2::new(0.3, -0.4);
            let u = chart.direction(&angles);
            // Unit, at angle |θ| = 0.5 from u0, towards E θ.
            assert!((u.norm() - 1.0).abs() < 1e-15);
            assert!((u.dot(&chart.u0) - 0.5_f64.cos()).abs() < 1e-15);
            let towards = chart.tangent_basis() * angles;
            assert!((u.dot(&towards) - 0.5 * 0.5_f64.sin()).abs() < 1e-15);
        }
    }

    #[test]
    fn derivative_matches_central_differences() {
        let chart = DirectionChart::new(&Vec3::new(0.3, -0.2, -0.9)).unwrap();
        for angles in [
            Vector2::zeros(),
            Vector2::new(1e-9, -0.7e-9),
            Vector2::new(0.0, 0.99 * SERIES_BELOW),
            Vector2::new(1.01 * SERIES_BELOW, 0.0),
            Vector2::new(0.02, 0.005),
            Vector2::new(-0.6, 0.9),
        ] {
            let analytic = chart.derivative(&angles);
            assert_close(
                &analytic,
                &finite_difference(&chart, &angles),
                1e-6,
                "du/dθ",
            );
        }
    }

    #[test]
    fn series_and_closed_forms_agree_at_the_switch() {
        // Both are accurate to better than 1e-12 near the switch, so a wrong
        // series coefficient shows here.
        for phi in [0.5 * SERIES_BELOW, SERIES_BELOW, 5.0 * SERIES_BELOW] {
            let p2 = phi * phi;
            let series = (
                1.0 - p2 / 6.0 + p2 * p2 / 120.0 - p2 * p2 * p2 / 5040.0,
                -1.0 / 3.0 + p2 / 30.0 - p2 * p2 / 840.0 + p2 * p2 * p2 / 45360.0,
            );
            let closed = (
                phi.sin() / phi,
                (phi * phi.cos() - phi.sin()) / (phi * phi * phi),
            );
            let (cos, s, b) = trig_terms(p2);
            for (value, reference) in [(s, closed.0), (b, closed.1)] {
                assert!((value / reference - 1.0).abs() < 1e-10, "φ = {phi}");
            }
            for (value, reference) in [(s, series.0), (b, series.1)] {
                assert!((value / reference - 1.0).abs() < 1e-12, "φ = {phi}");
            }
            // The cosine's series is exact to rounding on both sides.
            assert!((cos - phi.cos()).abs() < 2e-16, "φ = {phi}");
        }
        assert_eq!(trig_terms(0.0), (1.0, 1.0, -1.0 / 3.0));
    }

    #[test]
    fn angles_of_inverts_the_direction() {
        for chart in charts() {
            for angles in [
                Vector2::new(0.0, 0.0),
                Vector2::new(1e-9, -3e-9),
                Vector2::new(0.004, -0.007),
                Vector2::new(-0.6, 0.9),
                Vector2::new(2.5, -1.2),
            ] {
                let u = chart.direction(&angles);
                assert_close(&chart.angles_of(&(7.5 * u)), &angles, 1e-12, "log of exp");
            }
        }
    }

    #[test]
    fn refuses_a_degenerate_reference() {
        for bad in [
            Vec3::zeros(),
            Vec3::new(f64::NAN, 0.0, 1.0),
            Vec3::new(0.0, f64::INFINITY, 1.0),
        ] {
            assert!(matches!(
                DirectionChart::new(&bad),
                Err(ObserveError::DegenerateDirection { .. })
            ));
        }
    }
}
