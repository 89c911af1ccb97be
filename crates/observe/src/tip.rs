//! The tool tip at one contact, `T = f(q, p)` (paper eq. 2), with the two
//! derivatives every block needs: `J_f = dT/dp` (the observation Jacobian)
//! and `J_q = dT/dq` (the propagation of the actuator repeatability).

use nalgebra::{Matrix3x6, SMatrix};
use parcal_kinematics::{ForwardSolution, Geometry, N_PARAMS, Vec3, tip_jacobians};

use crate::ObserveError;

/// The tool tip of a canonical geometry at one forward-kinematics solution.
#[derive(Debug, Clone, PartialEq)]
pub struct Tip {
    /// `T = f(q, p)`, in the canonical base frame (mm).
    pub position: Vec3,
    /// `J_f = dT/dp` at fixed `q` (3 x 33, mm/mm).
    pub d_params: SMatrix<f64, 3, N_PARAMS>,
    /// `J_q = dT/dq` at fixed `p` (3 x 6, mm/mm).
    pub d_q: Matrix3x6<f64>,
}

impl Tip {
    /// A tip whose derivatives are not computed (zero): for evaluations that
    /// need only the residual and the centre and angle blocks, the parameter
    /// derivative being taken along one direction instead
    /// ([`crate::RadiusBlock::along`], [`crate::CoordinateBlock::along`]).
    pub fn position_only(position: Vec3) -> Self {
        Self {
            position,
            d_params: SMatrix::zeros(),
            d_q: Matrix3x6::zeros(),
        }
    }

    /// Paper eq. (2): the tip `T = R E_T + t` of `geometry` (canonical) at
    /// `solution` (forward kinematics of that geometry at the contact's `q`),
    /// with its analytic derivatives (mm).
    pub fn at(geometry: &Geometry, solution: &ForwardSolution) -> Result<Self, ObserveError> {
        let jacobians = tip_jacobians(geometry, &solution.legs)?;
        Ok(Self {
            position: geometry.tool_tip(&solution.pose),
            d_params: jacobians.d_params,
            d_q: jacobians.d_q,
        })
    }
}
