//! The transformed-coordinate observation (paper eq. 10, simulations II and
//! IV): the touched point is the point of its ball in the contact's direction,
//!
//! ```text
//! c_ij = C_i + r_i u(θ_ij) − f(q_ij, p),                     3 rows,
//! dc/dp = −J_f,   dc/dC = I,   dc/dr = u(θ),   dc/dθ = r_i du/dθ,
//! ```
//!
//! with the direction `u(θ)` of the contact's chart ([`crate::DirectionChart`]).
//! Unknowns: the 33 parameters, the ball centre `C_i`, the contact's two
//! angles `θ_ij` and, when the radius is modelled per ball, the ball's
//! radius `r_i` (otherwise the calibrated radius is data).

use nalgebra::{Matrix3, Vector2};
use parcal_kinematics::Vec3;

use crate::{CoordinateJacobians, CoordinateWhitening, DirectionChart, Whitening};

/// The coordinate observation of one contact on a ball of calibrated radius
/// `radius` (mm), its direction charted about the contact's initial
/// direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoordinateBlock {
    /// The ball's radius `r_i` (mm): the calibrated one, or the current
    /// estimate when the radius is an unknown.
    pub radius: f64,
    /// The contact's direction chart (about the initial direction `u0`).
    pub chart: DirectionChart,
}

impl CoordinateBlock {
    /// Paper eq. (10): `c = C + r u(θ) − T` (mm) at the tool tip `tip`
    /// (`T = f(q, p)`), the ball centre `centre` (mm, canonical base frame)
    /// and the contact's angles `angles` (rad), with `dc/dT = −I` (so
    /// `dc/dp = −J_f`), `dc/dC = I`, `dc/dr = u(θ)` and `dc/dθ = r du/dθ`
    /// (mm/rad).
    pub fn evaluate(
        &self,
        tip: &Vec3,
        centre: &Vec3,
        angles: &Vector2<f64>,
    ) -> CoordinateJacobians {
        let (direction, derivative) = self.chart.direction_and_derivative(angles);
        CoordinateJacobians {
            residual: centre + self.radius * direction - tip,
            d_tip: -Matrix3::identity(),
            d_centre: Matrix3::identity(),
            d_radius: direction,
            d_angles: self.radius * derivative,
        }
    }

    /// [`CoordinateBlock::evaluate`] whitened by `weight` (paper eq. 5),
    /// the numbers of `evaluate(..).whiten(weight)`: the identity blocks
    /// whitened are `∓L⁻¹` itself, so that only the residual, the radius
    /// and the angle columns are multiplied.
    #[inline]
    pub fn evaluate_whitened(
        &self,
        tip: &Vec3,
        centre: &Vec3,
        angles: &Vector2<f64>,
        weight: &CoordinateWhitening,
    ) -> CoordinateJacobians {
        let (direction, derivative) = self.chart.direction_and_derivative(angles);
        let inverse = weight.inverse_factor();
        CoordinateJacobians {
            residual: weight.whiten(&(centre + self.radius * direction - tip)),
            d_tip: -inverse,
            d_centre: inverse,
            d_radius: weight.whiten(&direction),
            d_angles: weight.whiten(&(self.radius * derivative)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Contact, assert_close, central_difference};
    use nalgebra::SVector;

    #[test]
    fn derivatives_match_central_differences_through_forward_kinematics() {
        let contact = Contact::new();
        let tip = contact.tip();
        let centre = contact.centre();
        let block = CoordinateBlock {
            radius: 5.0,
            chart: DirectionChart::new(&(tip.position - centre)).unwrap(),
        };
        // At the initial direction the residual is the radial misfit only.
        let at_zero = block.evaluate(&tip.position, &centre, &Vector2::zeros());
        let offset = tip.position - centre;
        let expected = (5.0 - offset.norm()) * offset.normalize();
        assert!((at_zero.residual - expected).norm() < 1e-13);

        let angles = Vector2::new(0.02, -0.015);
        let blocks = block.evaluate(&tip.position, &centre, &angles);
        assert!(blocks.residual.norm() > 0.05, "a non-trivial residual");

        let by_params = central_difference(&contact.params(), 1e-4, |p| {
            block
                .evaluate(&contact.tip_with(p).position, &centre, &angles)
                .residual
        });
        assert_close(&blocks.d_params(&tip), &by_params, 1e-6, "dc/dp");

        let by_centre = central_difference(&centre, 1e-5, |c| {
            block.evaluate(&tip.position, c, &angles).residual
        });
        assert_close(&blocks.d_centre, &by_centre, 1e-6, "dc/dC");

        for angles in [Vector2::zeros(), angles] {
            let analytic = block.evaluate(&tip.position, &centre, &angles).d_angles;
            let by_angles = central_difference(&angles, 1e-6, |a| {
                block.evaluate(&tip.position, &centre, a).residual
            });
            assert_close(&analytic, &by_angles, 1e-6, "dc/dθ");
            let analytic = block.evaluate(&tip.position, &centre, &angles).d_radius;
            // The residual is linear in r: a large step is exact up to rounding.
            let by_radius = central_difference(&SVector::<f64, 1>::new(5.0), 1e-2, |r| {
                CoordinateBlock {
                    radius: r[0],
                    ..block
                }
                .evaluate(&tip.position, &centre, &angles)
                .residual
            });
            assert_close(&analytic, &by_radius, 1e-9, "dc/dr");
        }
    }

    #[test]
    fn the_whitened_block_is_the_block_whitened() {
        let contact = Contact::new();
        let tip = contact.tip().position;
        let centre = contact.centre();
        let block = CoordinateBlock {
            radius: 5.0,
            chart: DirectionChart::new(&(tip - centre)).unwrap(),
        };
        // A full lower-triangular L^-1, signs mixed.
        let covariance = Matrix3::new(4.0, 1.2, -0.7, 1.2, 2.5, 0.4, -0.7, 0.4, 1.8) * 1e-6;
        let weight = CoordinateWhitening::from_covariance(&covariance).unwrap();
        for angles in [
            Vector2::zeros(),
            Vector2::new(0.02, -0.015),
            Vector2::new(-0.3, 0.1),
        ] {
            let whitened = block.evaluate_whitened(&tip, &centre, &angles, &weight);
            let reference = block.evaluate(&tip, &centre, &angles).whiten(&weight);
            // The same numbers, not merely close ones.
            assert_eq!(whitened, reference);
            assert!(
                whitened.d_tip[(2, 0)] != 0.0,
                "a full L^-1: {}",
                whitened.d_tip
            );
        }
    }
}
