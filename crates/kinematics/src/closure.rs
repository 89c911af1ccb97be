//! The leg closure equations (paper eq. 1) and their derivative with respect
//! to the pose.
//!
//! For leg `i`, with `a_i = R E_i` and the leg vector
//! `d_i = a_i + t - B_i` of length `L_i = |d_i|` and direction `n_i`,
//!
//! ```text
//! phi_i(pose, p, q) = |B_i - (R E_i + t)| - (l_i + q_i) = 0,   i = 1..6.
//! ```
//!
//! A pose increment is `t <- t + dt`, `R <- exp([w]x) R`; then
//! `d phi_i = n_i . dt + (a_i x n_i) . w`, which gives the 6 x 6 closure
//! Jacobian `A` (rows `[n_i^T, (a_i x n_i)^T]`).

use nalgebra::{Matrix3, Vector6};

use crate::{Geometry, KinematicsError, Pose, Vec3, lu6::Lu6};

/// The legs of a geometry at one pose.
#[derive(Debug, Clone, Default)]
pub struct Legs {
    /// Rotation matrix `R` of the pose.
    pub rotation: Matrix3<f64>,
    /// `a_i = R E_i`: platform joints rotated into the base frame.
    pub rotated: [Vec3; 6],
    /// Unit leg directions `n_i`, from base joint to platform joint.
    pub direction: [Vec3; 6],
    /// Leg lengths `L_i`.
    pub length: [f64; 6],
}

impl Legs {
    /// Evaluates the legs of `geometry` at `pose`.
    pub fn at(geometry: &Geometry, pose: &Pose) -> Self {
        let mut legs = Self::default();
        legs.evaluate(geometry, pose);
        legs
    }

    /// Evaluates the legs of `geometry` at `pose` in place.
    #[inline]
    pub fn evaluate(&mut self, geometry: &Geometry, pose: &Pose) {
        self.rotation = *pose.rotation.to_rotation_matrix().matrix();
        let t = pose.translation.vector;
        for i in 0..6 {
            self.rotated[i] = self.rotation * geometry.platform[i];
            let d = self.rotated[i] + t - geometry.base[i];
            self.length[i] = d.norm();
            self.direction[i] = d * self.length[i].recip();
        }
    }

    /// Closure residuals `phi_i = L_i - (l_i + q_i)` (mm).
    pub fn residual(&self, geometry: &Geometry, q: &[f64; 6]) -> Vector6<f64> {
        Vector6::from_fn(|i, _| self.length[i] - (geometry.legs[i] + q[i]))
    }

    /// The rows of the closure Jacobian `A = d phi / d(t, w)`: row `i` is
    /// `[n_i^T, (a_i x n_i)^T]`.
    pub fn closure_rows(&self) -> [[f64; 6]; 6] {
        std::array::from_fn(|i| {
            let n = self.direction[i];
            let m = self.rotated[i].cross(&n);
            [n.x, n.y, n.z, m.x, m.y, m.z]
        })
    }

    /// The LU factorisation of `A`; an error at a singular configuration.
    #[inline]
    pub fn factor(&self) -> Result<Lu6, KinematicsError> {
        Lu6::factor(self.closure_rows())
    }

    /// [`Legs::factor`] into `factor` ([`Lu6::factor_in_place`]: no copy of
    /// the factorisation on the forward kinematics' hot path).
    #[inline]
    pub fn factor_into(&self, factor: &mut Lu6) -> Result<(), KinematicsError> {
        factor.factor_in_place(self.closure_rows())
    }
}
