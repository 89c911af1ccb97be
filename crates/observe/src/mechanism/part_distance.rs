//! The distance between two commanded positions, measured on a printed or
//! reference part (a calliper across a printed square, a ball bar).
//!
//! With `x_1 = f(p, g(p_c, c_1))` and `x_2 = f(p, g(p_c, c_2))` the
//! positions the machine truly reaches ([`reached`]), `d` the
//! measured distance and `σ` its standard deviation:
//!
//! ```text
//! e = |x_1 − x_2| − d,     r = e / σ,
//! dr/dp = uᵀ (dx_1/dp − dx_2/dp) / σ,     u = (x_1 − x_2) / |x_1 − x_2|.
//! ```

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};

use super::commanded::{Rows, check_sigma, reached};

/// One measured distance (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PartDistance {
    /// The first commanded position (mm).
    pub first: [f64; 3],
    /// The second commanded position (mm).
    pub second: [f64; 3],
    /// The measured distance `d` (mm).
    pub distance: f64,
    /// Its standard deviation `σ` (mm).
    pub sigma: f64,
}

impl PartDistance {
    /// The whitened row at true parameters `params` and configured
    /// parameters `configured` (module doc). An error if the two positions
    /// coincide (no direction).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
    ) -> Result<Rows, MechanismError> {
        check_sigma("distance sigma", self.sigma)?;
        let (first, d_first) = reached(mechanism, params, configured, &self.first)?;
        let (second, d_second) = reached(mechanism, params, configured, &self.second)?;
        let offset = first - second;
        let length = offset.norm();
        if length == 0.0 || length.is_nan() {
            return Err(MechanismError::Unreachable {
                reason: "the two positions of a distance coincide".to_string(),
            });
        }
        let u = offset / length;
        let d_params = (u.transpose() * (d_first - d_second)) / self.sigma;
        Ok(Rows {
            residual: DVector::from_element(1, (length - self.distance) / self.sigma),
            d_params: DMatrix::from_row_slice(1, d_params.len(), d_params.as_slice()),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::test_support::{assert_matches, delta, differences};

    #[test]
    fn derivatives_match_central_differences() {
        let (delta, configured, truth) = delta();
        let distance = PartDistance {
            first: [-50.0, -40.0, 10.0],
            second: [60.0, 45.0, 10.0],
            distance: 139.0,
            sigma: 0.02,
        };
        let at = |p: &[f64]| distance.evaluate(&delta, p, configured.as_slice()).unwrap();
        let analytic = at(truth.as_slice());
        let numeric = differences(&delta, &truth, 1e-4, |p| at(p).residual);
        assert_matches(&analytic.d_params, &numeric);
        // A machine as configured reaches the commanded positions.
        let exact = at(configured.as_slice());
        let commanded = (110.0f64.powi(2) + 85.0f64.powi(2)).sqrt();
        assert!((exact.residual[0] * 0.02 - (commanded - 139.0)).abs() < 1e-9);
    }
}
