//! The common shape of an observation block: `R` residual rows of one
//! contact and their derivatives with respect to the three levels of
//! unknowns of a calibration,
//!
//! ```text
//!            p (33, global)   C_i (3, per ball)   r_i (1, per ball)   θ_ij (P, per contact)
//! c_ij  [    d_tip J_f        d_centre            d_radius            d_angles           ]
//! ```
//!
//! The radius column is used when each ball's radius is an unknown (one
//! calibration error per ball); when the calibrated radius is data, the
//! column is ignored.
//!
//! Every block sees the parameters only through the tool tip `T = f(q, p)`
//! (paper eq. 2), so its parameter Jacobian is `dc/dT J_f` by the chain
//! rule: the block keeps `d_tip = dc/dT` (R x 3) and the 33 columns are
//! formed, or applied, through the tip's derivatives
//! ([`BlockJacobians::d_params`]; a calibration applies them without
//! forming them). All sizes are known at compile time. The radius block ([`crate::RadiusBlock`]) has `R = 1, P = 0`, the
//! coordinate block ([`crate::CoordinateBlock`]) `R = 3, P = 2`.

use nalgebra::{SMatrix, SVector};
use parcal_kinematics::N_PARAMS;

use crate::{Tip, Whitening};

/// Residual and Jacobian blocks of one observation (mm; per mm, per mm, per
/// rad), raw or whitened ([`BlockJacobians::whiten`]: then dimensionless,
/// per mm, per mm, per rad).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlockJacobians<const R: usize, const P: usize> {
    /// The residual `c` (R rows).
    pub residual: SVector<f64, R>,
    /// `dc/dT` with respect to the tool tip (R x 3); `dc/dp = dc/dT J_f`.
    pub d_tip: SMatrix<f64, R, 3>,
    /// `dc/dC` with respect to the ball centre (R x 3).
    pub d_centre: SMatrix<f64, R, 3>,
    /// `dc/dr` with respect to the ball's radius (R x 1).
    pub d_radius: SVector<f64, R>,
    /// `dc/dθ` with respect to the contact's angles (R x P).
    pub d_angles: SMatrix<f64, R, P>,
}

/// The radius block's shape (paper eq. 9): one row, no angles.
pub type RadiusJacobians = BlockJacobians<1, 0>;
/// The coordinate block's shape (paper eq. 10): three rows, two angles.
pub type CoordinateJacobians = BlockJacobians<3, 2>;

impl<const R: usize, const P: usize> BlockJacobians<R, P> {
    /// `dc/dp = dc/dT J_f` (R x 33), formed in full at the block's `tip`.
    pub fn d_params(&self, tip: &Tip) -> SMatrix<f64, R, N_PARAMS> {
        self.d_tip * tip.d_params()
    }

    /// Paper eq. (5), the weighting `W^-1/2`: the block whitened by the
    /// observation covariance `W = L Lᵀ`, `r_w = L⁻¹ c`, `J_w = L⁻¹ J`, so
    /// that the least-squares cost `r_wᵀ r_w = cᵀ W⁻¹ c`.
    pub fn whiten(&self, weight: &impl Whitening<R>) -> Self {
        Self {
            residual: weight.whiten(&self.residual),
            d_tip: weight.whiten(&self.d_tip),
            d_centre: weight.whiten(&self.d_centre),
            d_radius: weight.whiten(&self.d_radius),
            d_angles: weight.whiten(&self.d_angles),
        }
    }
}
