//! The transformed-coordinate observation (paper eq. 10, simulations II and
//! IV): the touched point is the point of its ball in the contact's direction,
//!
//! ```text
//! c_ij = C_i + r_i u(θ_ij) − f(q_ij, p),                     3 rows,
//! dc/dp = −J_f,   dc/dC = I,   dc/dθ = r_i du/dθ,
//! ```
//!
//! with the direction `u(θ)` of the contact's chart ([`crate::DirectionChart`]).
//! Unknowns: the 33 parameters, the ball centre `C_i` and the contact's two
//! angles `θ_ij`; the calibrated radius `r_i` is data.

use nalgebra::{Matrix3, Vector2};
use parcal_kinematics::Vec3;

use crate::{CoordinateJacobians, DirectionChart};

/// The coordinate observation of one contact on a ball of calibrated radius
/// `radius` (mm), its direction charted about the contact's initial
/// direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoordinateBlock {
    /// The ball's calibrated radius `r_i` (mm).
    pub radius: f64,
    /// The contact's direction chart (about the initial direction `u0`).
    pub chart: DirectionChart,
}

impl CoordinateBlock {
    /// Paper eq. (10): `c = C + r u(θ) − T` (mm) at the tool tip `tip`
    /// (`T = f(q, p)`), the ball centre `centre` (mm, canonical base frame)
    /// and the contact's angles `angles` (rad), with `dc/dT = −I` (so
    /// `dc/dp = −J_f`), `dc/dC = I` and `dc/dθ = r du/dθ` (mm/rad).
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
            d_angles: self.radius * derivative,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{Contact, assert_close, central_difference};

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
        }
    }
}
