//! The tool tip at one contact, `T = f(q, p)` (paper eq. 2), with the two
//! derivatives every block needs: `J_f = dT/dp` (the observation Jacobian)
//! and `J_q = dT/dq` (the propagation of the actuator repeatability).

use nalgebra::{Matrix3x6, SMatrix};
use parcal_kinematics::{ForwardSolution, Geometry, N_PARAMS, TipDerivatives, Vec3};

/// The tool tip of a canonical geometry at one forward-kinematics solution.
#[derive(Debug, Clone)]
pub struct Tip {
    /// `T = f(q, p)`, in the canonical base frame (mm).
    pub position: Vec3,
    /// `J_f = dT/dp` at fixed `q` and `J_q = dT/dq` at fixed `p`, as linear
    /// maps (mm/mm).
    pub derivatives: TipDerivatives,
}

impl Tip {
    /// Paper eq. (2): the tip `T = R E_T + t` of `geometry` (canonical) at
    /// `solution` (forward kinematics of that geometry at the contact's `q`),
    /// with its analytic derivatives.
    pub fn at(geometry: &Geometry, solution: &ForwardSolution) -> Self {
        Self {
            position: geometry.tool_tip(&solution.pose),
            derivatives: TipDerivatives::new(geometry, solution),
        }
    }

    /// `J_f = dT/dp` formed in full (3 x 33).
    pub fn d_params(&self) -> SMatrix<f64, 3, N_PARAMS> {
        self.derivatives.jacobians().d_params
    }

    /// `J_q = dT/dq` (3 x 6).
    pub fn d_q(&self) -> Matrix3x6<f64> {
        self.derivatives.d_q()
    }
}
