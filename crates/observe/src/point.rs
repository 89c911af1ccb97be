//! The measured-point observation: an instrument (a laser tracker's
//! reflector, a probe) measures the tool point in its own frame,
//!
//! ```text
//! c = F₀ C_F (f(q, p)) − P,     3 rows (mm),
//! ```
//!
//! `f(q, p)` the tool tip by forward kinematics (paper eq. 2) in the
//! canonical base frame, `F = F₀ ∘ C_F` the session's instrument frame
//! ([`crate::frame`]). Its covariance is the instrument's `σ_t² I₃` plus
//! the actuators', propagated through `∂c/∂L = R_F J_q`.

use nalgebra::{Isometry3, Matrix3, Matrix3x6, SMatrix, Vector3};
use parcal_kinematics::Vec3;

use crate::frame::FrameCorrection;

/// One measured point and the frame it is seen through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PointBlock<'a> {
    /// `P`: the measured point (instrument frame).
    pub measured: &'a Vec3,
    /// `F₀`: the reference of the session's instrument frame.
    pub tracker_reference: &'a Isometry3<f64>,
    /// `C_F`.
    pub tracker: FrameCorrection,
}

/// The raw residual of a point (mm) and its derivatives.
#[derive(Debug, Clone, PartialEq)]
pub struct PointJacobians {
    /// `c = F(T) − P`.
    pub residual: Vector3<f64>,
    /// `∂c/∂T = R_F₀ Exp(ω)`: the tip's parameter and leg-length columns
    /// follow by the chain rule.
    pub d_tip: Matrix3<f64>,
    /// `∂c/∂(ω_F, τ_F)`.
    pub d_tracker: SMatrix<f64, 3, 6>,
}

impl PointBlock<'_> {
    /// The block at the tool tip `tip` (canonical base frame).
    pub fn evaluate(&self, tip: &Vec3) -> PointJacobians {
        let r_f0 = self
            .tracker_reference
            .rotation
            .to_rotation_matrix()
            .into_inner();
        let corrected = self.tracker.rotation_matrix() * tip + self.tracker.translation;
        let mut d_tracker = SMatrix::<f64, 3, 6>::zeros();
        d_tracker
            .fixed_view_mut::<3, 3>(0, 0)
            .copy_from(&(r_f0 * self.tracker.d_rotate(tip)));
        d_tracker.fixed_view_mut::<3, 3>(0, 3).copy_from(&r_f0);
        PointJacobians {
            residual: self
                .tracker_reference
                .transform_point(&corrected.into())
                .coords
                - self.measured,
            d_tip: r_f0 * self.tracker.rotation_matrix(),
            d_tracker,
        }
    }
}

/// The covariance of a point's three rows (mm²): `σ_t² I₃ + G diag(s_i²
/// σ_q²) Gᵀ`, `G = ∂c/∂T · J_q` (3 x 6, `J_q = ∂T/∂L`).
pub fn point_covariance(
    d_lengths: &Matrix3x6<f64>,
    actuator_sigma_mm: &[f64; 6],
    position_sigma: f64,
) -> Matrix3<f64> {
    let mut covariance = Matrix3::identity() * (position_sigma * position_sigma);
    for (i, s) in actuator_sigma_mm.iter().enumerate() {
        let column = d_lengths.column(i);
        covariance += column * column.transpose() * (s * s);
    }
    covariance
}

#[cfg(test)]
mod tests {
    use nalgebra::{Translation3, Vector6};
    use parcal_kinematics::rotation_zyx;

    use super::*;
    use crate::test_support::{assert_close, central_difference};

    #[test]
    fn derivatives_match_central_differences() {
        let f0 = Isometry3::from_parts(
            Translation3::new(1500.0, -200.0, 300.0),
            rotation_zyx(2.5, 0.1, -0.2),
        );
        let tip = Vec3::new(20.0, -30.0, 400.0);
        let measured = Vec3::new(1400.0, -150.0, 700.0);
        let block = |c: FrameCorrection| PointBlock {
            measured: &measured,
            tracker_reference: &f0,
            tracker: c,
        };
        let c = FrameCorrection {
            rotation: Vec3::new(0.01, -0.02, 0.03),
            translation: Vec3::new(0.4, 0.1, -0.3),
        };
        let j = block(c).evaluate(&tip);
        let expected = f0
            .transform_point(&(c.isometry().transform_point(&tip.into())))
            .coords
            - measured;
        assert!((j.residual - expected).amax() < 1e-9);
        let p = Vector6::new(0.01, -0.02, 0.03, 0.4, 0.1, -0.3);
        let d_tracker = central_difference(&p, 1e-6, |p| {
            block(FrameCorrection::from_params(p))
                .evaluate(&tip)
                .residual
        });
        assert_close(&j.d_tracker, &d_tracker, 1e-6, "dc/dC_F");
        let d_tip = central_difference(&tip, 1e-5, |t| block(c).evaluate(t).residual);
        assert_close(&j.d_tip, &d_tip, 1e-6, "dc/dT");
    }
}
