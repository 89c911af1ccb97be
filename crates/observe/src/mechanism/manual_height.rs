//! A height of the nozzle above the bed measured by hand at a commanded
//! position (a gauge block or feeler gauge under the nozzle; Klipper's
//! `DELTA_ANALYZE MANUAL_HEIGHT`).
//!
//! The model is a probe's ([`ProbeHeight`]) whose trigger height is the
//! measured height `h_m`, known, instead of the probe's unknown: with
//! `x = f(p, g(p_c, x_c))` the position the machine truly reaches,
//!
//! ```text
//! e = z(x) − h_m,     r = e / σ_h,     dr/dp = (dx/dp|_q)[z, ·] / σ_h,
//! ```
//!
//! `σ_h` the measurement's standard deviation.

use parcal_kinematics::mechanism::{Mechanism, MechanismError};

use super::commanded::{Rows, check_sigma};
use super::probe::ProbeHeight;

/// One height measured by hand (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ManualHeight {
    /// The commanded position `x_c` in the controller's coordinates (mm).
    pub commanded: [f64; 3],
    /// The nozzle's height above the bed measured there, `h_m` (mm).
    pub height: f64,
    /// Its standard deviation `σ_h` (mm).
    pub sigma: f64,
}

impl ManualHeight {
    /// The whitened row at true parameters `params` and configured
    /// parameters `configured` (module doc).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
    ) -> Result<Rows, MechanismError> {
        check_sigma("height sigma", self.sigma)?;
        let probe = ProbeHeight {
            commanded: self.commanded,
            sigma: self.sigma,
        };
        Ok(probe
            .evaluate(mechanism, params, configured, self.height)?
            .rows)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::test_support::{assert_matches, delta, differences};

    #[test]
    fn derivatives_match_central_differences() {
        let (delta, configured, truth) = delta();
        for (commanded, height) in [([0.0, 0.0, 5.0], 5.1), ([70.0, -40.0, 20.0], 19.8)] {
            let manual = ManualHeight {
                commanded,
                height,
                sigma: 0.05,
            };
            let at = |p: &[f64]| manual.evaluate(&delta, p, configured.as_slice()).unwrap();
            let analytic = at(truth.as_slice());
            let numeric = differences(&delta, &truth, 1e-4, |p| at(p).residual);
            assert_matches(&analytic.d_params, &numeric);
        }
    }

    #[test]
    fn a_correct_controller_is_at_the_height_commanded() {
        // Configured = true: the nozzle is where commanded, z above the
        // bed; the residual is (z_c − h_m) / σ, whatever the trigger height.
        let (delta, configured, _) = delta();
        let manual = ManualHeight {
            commanded: [30.0, 40.0, 2.0],
            height: 1.9,
            sigma: 0.05,
        };
        let rows = manual
            .evaluate(&delta, configured.as_slice(), configured.as_slice())
            .unwrap();
        assert!((rows.residual[0] - 2.0).abs() < 1e-8, "{}", rows.residual);
        let bad = ManualHeight {
            sigma: f64::NAN,
            ..manual
        };
        let error = bad
            .evaluate(&delta, configured.as_slice(), configured.as_slice())
            .unwrap_err();
        assert!(error.to_string().contains("height sigma"), "{error}");
    }
}
