//! A probe touching a plane: the bed of a printer.
//!
//! The controller lowers the probe at commanded `(x, y)` until it
//! triggers, and reports the commanded height `z_t` it was at (RepRapFirmware's
//! `G30 S-1`): the commanded position `x_c = (x, y, z_t)`, with readings
//! `q = g(p_c, x_c)` from the configured parameters `p_c`. The effector
//! then truly is at `x = f(p, q)`, and the probe triggers when it is the
//! trigger height `h` above the bed (G31 Z, an unknown of the calibration
//! with a prior). The bed is the plane `z = 0` of the mechanism's pose
//! frame, its tilt being among the parameters (the delta's `tilt_x`,
//! `tilt_y`), so
//!
//! ```text
//! e = z(f(p, g(p_c, x_c))) − h,     r = e / σ,
//! dr/dp = (dx/dp|_q)[z, ·] / σ,     dr/dh = −1 / σ,
//! ```
//!
//! `σ` the probe's repeatability, `dx/dp|_q = −G_x⁻¹ G_p`.

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};

use super::commanded::{Rows, check_sigma, reached};

/// One probe reading (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ProbeHeight {
    /// The commanded position at the trigger `(x, y, z_t)` in the
    /// controller's coordinates (mm).
    pub commanded: [f64; 3],
    /// The probe's repeatability `σ` (mm).
    pub sigma: f64,
}

/// A probe reading's whitened row.
#[derive(Debug, Clone, PartialEq)]
pub struct ProbeRow {
    /// The row `r` and `dr/dp`.
    pub rows: Rows,
    /// `dr/dh`, the derivative with respect to the trigger height.
    pub d_trigger_height: f64,
}

impl ProbeHeight {
    /// The whitened row at true parameters `params`, configured parameters
    /// `configured` and trigger height `trigger_height` (module doc).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        trigger_height: f64,
    ) -> Result<ProbeRow, MechanismError> {
        check_sigma("probe sigma", self.sigma)?;
        let (pose, jacobian) = reached(mechanism, params, configured, &self.commanded)?;
        let residual = (pose[2] - trigger_height) / self.sigma;
        let d_params = DMatrix::from_rows(&[jacobian.row(2) / self.sigma]);
        Ok(ProbeRow {
            rows: Rows {
                residual: DVector::from_element(1, residual),
                d_params,
            },
            d_trigger_height: -1.0 / self.sigma,
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
        for commanded in [[0.0, 0.0, 0.05], [80.0, -30.0, 0.2], [-60.0, 70.0, -0.1]] {
            let probe = ProbeHeight {
                commanded,
                sigma: 0.01,
            };
            let at =
                |p: &[f64], h: f64| probe.evaluate(&delta, p, configured.as_slice(), h).unwrap();
            let analytic = at(truth.as_slice(), 0.7);
            let numeric = differences(&delta, &truth, 1e-4, |p| at(p, 0.7).rows.residual);
            assert_matches(&analytic.rows.d_params, &numeric);
            let dh = (at(truth.as_slice(), 0.7 + 1e-4).rows.residual[0]
                - at(truth.as_slice(), 0.7 - 1e-4).rows.residual[0])
                / 2e-4;
            assert!((dh - analytic.d_trigger_height).abs() < 1e-6, "{dh}");
        }
    }

    #[test]
    fn a_correct_controller_reads_the_trigger_height() {
        // Configured = true: the effector is where it was commanded, and
        // the residual is (z_t − h) / σ.
        let (delta, configured, _) = delta();
        let probe = ProbeHeight {
            commanded: [30.0, 40.0, 0.75],
            sigma: 0.01,
        };
        let row = probe
            .evaluate(&delta, configured.as_slice(), configured.as_slice(), 0.7)
            .unwrap();
        assert!(
            (row.rows.residual[0] - 5.0).abs() < 1e-8,
            "{}",
            row.rows.residual
        );
        let bad = ProbeHeight {
            sigma: 0.0,
            ..probe
        };
        let error = bad
            .evaluate(&delta, configured.as_slice(), configured.as_slice(), 0.7)
            .unwrap_err();
        assert!(error.to_string().contains("probe sigma"), "{error}");
    }
}
