//! The effector's position measured at a commanded position (a laser
//! tracker's point, a touch probe on a reference), in the mechanism's
//! frame.
//!
//! With `x = f(p, g(p_c, x_c))` the position the machine truly reaches
//! ([`reached`]), `m` the measured position and `σ_k` the standard
//! deviation of its coordinate `k`:
//!
//! ```text
//! e_k = x_k − m_k,     r_k = e_k / σ_k,     dr_k/dp = (dx/dp|_q)[k, ·] / σ_k.
//! ```

use nalgebra::DVector;
use parcal_kinematics::mechanism::{Mechanism, MechanismError};

use super::commanded::{Rows, check_sigma, reached};

/// One measured position (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CommandedPoint {
    /// The commanded position `x_c` (mm).
    pub commanded: [f64; 3],
    /// The measured position `m` (mm).
    pub measured: [f64; 3],
    /// The standard deviation of each measured coordinate (mm).
    pub sigma: [f64; 3],
}

impl CommandedPoint {
    /// The three whitened rows at true parameters `params` and configured
    /// parameters `configured` (module doc).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
    ) -> Result<Rows, MechanismError> {
        for sigma in self.sigma {
            check_sigma("position sigma", sigma)?;
        }
        let (pose, mut d_params) = reached(mechanism, params, configured, &self.commanded)?;
        let residual = DVector::from_fn(3, |k, _| (pose[k] - self.measured[k]) / self.sigma[k]);
        for (k, mut row) in d_params.row_iter_mut().enumerate() {
            row /= self.sigma[k];
        }
        Ok(Rows { residual, d_params })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::test_support::{assert_matches, delta, differences};

    #[test]
    fn derivatives_match_central_differences() {
        let (delta, configured, truth) = delta();
        let point = CommandedPoint {
            commanded: [40.0, -70.0, 120.0],
            measured: [40.1, -69.8, 119.5],
            sigma: [0.01, 0.01, 0.02],
        };
        let at = |p: &[f64]| point.evaluate(&delta, p, configured.as_slice()).unwrap();
        let analytic = at(truth.as_slice());
        let numeric = differences(&delta, &truth, 1e-4, |p| at(p).residual);
        assert_matches(&analytic.d_params, &numeric);
        let exact = at(configured.as_slice());
        assert!((exact.residual[2] - (120.0 - 119.5) / 0.02).abs() < 1e-7);
    }
}
