//! What the machine reaches when its controller commands a position, and
//! the whitened rows every observation kind returns.

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError, pose_jacobian_at_fixed_readings};

/// The number of pose coordinates these kinds need: a position `(x, y, z)`.
pub const POSE_COORDINATES: usize = 3;

/// Whitened residual rows and their Jacobian with respect to the
/// mechanism's parameters (and, for some kinds, other unknowns).
#[derive(Debug, Clone, PartialEq)]
pub struct Rows {
    /// Whitened residuals `e / σ`.
    pub residual: DVector<f64>,
    /// `d(e / σ)/dp` (rows × parameters).
    pub d_params: DMatrix<f64>,
}

/// Where the machine with true parameters `params` is when its controller,
/// configured with `configured`, commands `commanded`: the pose
/// `x = f(p, g(p_c, x_c))` and `dx/dp` at fixed readings (module doc).
pub fn reached(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    commanded: &[f64; 3],
) -> Result<(DVector<f64>, DMatrix<f64>), MechanismError> {
    let readings = mechanism.inverse(configured, commanded)?;
    let pose = mechanism.forward(params, readings.as_slice(), commanded)?;
    let jacobian = pose_jacobian_at_fixed_readings(mechanism, params, pose.as_slice())?;
    Ok((pose, jacobian))
}

/// Refuses a standard deviation that is not finite and positive.
pub(crate) fn check_sigma(what: &'static str, sigma: f64) -> Result<(), MechanismError> {
    if sigma.is_finite() && sigma > 0.0 {
        Ok(())
    } else {
        Err(MechanismError::NonFinite {
            what: format!("{what} {sigma} (a standard deviation must be finite and positive)"),
        })
    }
}
