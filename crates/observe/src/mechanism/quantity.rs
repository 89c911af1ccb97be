//! A quantity of the machine measured directly: a known function of the
//! parameters `f(p)` ([`Mechanism::quantity`]), such as a cable robot's
//! line length at the encoder zero measured with a tape.
//!
//! With `v` the measured value and `σ` its standard deviation:
//!
//! ```text
//! e = f(p) − v,     r = e / σ,     dr/dp = ∇f(p)ᵀ / σ.
//! ```

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};

use super::commanded::{Rows, check_sigma};

/// One measured quantity (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeasuredQuantity {
    /// The quantity's index among [`Mechanism::quantities`].
    pub quantity: usize,
    /// The measured value `v` (the quantity's unit).
    pub value: f64,
    /// Its standard deviation `σ`.
    pub sigma: f64,
}

impl MeasuredQuantity {
    /// The whitened row at parameters `params` (module doc).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
    ) -> Result<Rows, MechanismError> {
        check_sigma("quantity sigma", self.sigma)?;
        let f = mechanism.quantity(self.quantity, params)?;
        Ok(Rows {
            residual: DVector::from_element(1, (f.value - self.value) / self.sigma),
            d_params: DMatrix::from_row_slice(
                1,
                f.gradient.len(),
                (f.gradient / self.sigma).as_slice(),
            ),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::test_support::differences;
    use parcal_kinematics::cable::CableRobot;
    use parcal_kinematics::mechanism::design;

    #[test]
    fn derivatives_match_central_differences() {
        let robot = CableRobot::typical();
        let mut p = design(&robot);
        for (k, v) in p.iter_mut().enumerate() {
            *v += 3.0 * (k as f64).sin();
        }
        for quantity in 0..4 {
            let measured = MeasuredQuantity {
                quantity,
                value: 1600.0,
                sigma: 10.0,
            };
            let at = |p: &[f64]| measured.evaluate(&robot, p).unwrap();
            let analytic = at(p.as_slice());
            // Steps of 1e-2 mm on lengths of ~2000 mm (rows per 10 mm):
            // truncation and rounding both below 1e-11.
            let numeric = differences(&robot, &p, 1e-2, |p| at(p).residual);
            let error = (&analytic.d_params - &numeric).amax();
            assert!(error < 1e-9, "{error:e}");
            let length = robot.quantity(quantity, p.as_slice()).unwrap().value;
            assert!((analytic.residual[0] - (length - 1600.0) / 10.0).abs() < 1e-12);
        }
        let beyond = MeasuredQuantity {
            quantity: 4,
            value: 1.0,
            sigma: 1.0,
        };
        let error = beyond.evaluate(&robot, p.as_slice()).unwrap_err();
        assert!(error.to_string().contains("quantity 4"), "{error}");
        let bad = MeasuredQuantity {
            quantity: 0,
            value: 1.0,
            sigma: -1.0,
        };
        let error = bad.evaluate(&robot, p.as_slice()).unwrap_err();
        assert!(error.to_string().contains("quantity sigma"), "{error}");
    }
}
