//! Rigid frames estimated as small corrections of a reference: the
//! instrument frame of a session and the platform body frame.
//!
//! A correction `C = (Exp(ω), τ)` acts in the canonical frames, where the
//! kinematic parameters live: `C(x) = Exp(ω) x + τ`. The instrument frame
//! is `F = F₀ ∘ C_F` (the correction on the base side), the body frame
//! `B = C_B ∘ B₀` (on the platform side), `F₀`, `B₀` fixed references. The
//! rotation is charted by its rotation vector `ω` (`Exp` the exponential
//! map of SO(3)); derivatives along `ω` use the right Jacobian
//! `J_r(ω)`, `Exp(ω + δ) ≈ Exp(ω) Exp(J_r(ω) δ)` (Barfoot, "State
//! Estimation for Robotics", 2017, eq. 7.77).

use nalgebra::{Isometry3, Matrix3, Translation3, UnitQuaternion, Vector3, Vector6};
use parcal_kinematics::Vec3;

/// The skew-symmetric matrix `[v]×` with `[v]× x = v × x`.
pub fn skew(v: &Vec3) -> Matrix3<f64> {
    v.cross_matrix()
}

/// The right Jacobian of SO(3) at `ω`:
/// `J_r = I − (1 − cos θ)/θ² [ω]× + (θ − sin θ)/θ³ [ω]×²`, `θ = |ω|`
/// (its Taylor series below θ = 1e-4).
pub fn right_jacobian(omega: &Vec3) -> Matrix3<f64> {
    let theta2 = omega.norm_squared();
    let w = skew(omega);
    let (a, b) = if theta2 < 1e-8 {
        (0.5 - theta2 / 24.0, 1.0 / 6.0 - theta2 / 120.0)
    } else {
        let theta = theta2.sqrt();
        (
            (1.0 - theta.cos()) / theta2,
            (theta - theta.sin()) / (theta2 * theta),
        )
    };
    Matrix3::identity() - a * w + b * w * w
}

/// A frame correction `C(x) = Exp(ω) x + τ`, its six parameters in the
/// order `ω_x, ω_y, ω_z, τ_x, τ_y, τ_z` (rad, mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameCorrection {
    /// `ω` (rad).
    pub rotation: Vec3,
    /// `τ` (mm).
    pub translation: Vec3,
}

impl FrameCorrection {
    /// No correction.
    pub const IDENTITY: Self = Self {
        rotation: Vector3::new(0.0, 0.0, 0.0),
        translation: Vector3::new(0.0, 0.0, 0.0),
    };

    /// From the six parameters `[ω, τ]`.
    pub fn from_params(p: &Vector6<f64>) -> Self {
        Self {
            rotation: p.fixed_rows::<3>(0).into_owned(),
            translation: p.fixed_rows::<3>(3).into_owned(),
        }
    }

    /// `Exp(ω)`.
    pub fn rotation_matrix(&self) -> Matrix3<f64> {
        UnitQuaternion::from_scaled_axis(self.rotation)
            .to_rotation_matrix()
            .into_inner()
    }

    /// The correction as an isometry.
    pub fn isometry(&self) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(self.translation),
            UnitQuaternion::from_scaled_axis(self.rotation),
        )
    }

    /// `d(Exp(ω) v)/dω = −Exp(ω) [v]× J_r(ω)`.
    pub fn d_rotate(&self, v: &Vec3) -> Matrix3<f64> {
        -self.rotation_matrix() * skew(v) * right_jacobian(&self.rotation)
    }

    /// `d(Exp(ω)ᵀ v)/dω = [Exp(ω)ᵀ v]× J_r(ω)`.
    pub fn d_rotate_back(&self, v: &Vec3) -> Matrix3<f64> {
        let u = self.rotation_matrix().transpose() * v;
        skew(&u) * right_jacobian(&self.rotation)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{assert_close, central_difference};

    #[test]
    fn rotation_derivatives_match_central_differences() {
        let v = Vec3::new(120.0, -40.0, 15.0);
        for omega in [
            Vec3::new(0.3, -0.2, 0.5),
            Vec3::new(1e-6, 2e-6, -1e-6),
            Vec3::zeros(),
        ] {
            let c = FrameCorrection {
                rotation: omega,
                translation: Vec3::zeros(),
            };
            let at = |w: &Vec3| FrameCorrection { rotation: *w, ..c };
            let forward = central_difference(&omega, 1e-6, |w| at(w).rotation_matrix() * v);
            assert_close(&c.d_rotate(&v), &forward, 1e-7, "d Exp(w) v / dw");
            let back =
                central_difference(&omega, 1e-6, |w| at(w).rotation_matrix().transpose() * v);
            assert_close(&c.d_rotate_back(&v), &back, 1e-7, "d Exp(w)^T v / dw");
        }
    }
}
