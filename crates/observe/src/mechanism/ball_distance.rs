//! A calibrated distance between the centres of two touched balls (a ball
//! plate's certificate, a ball bar), the distance observation of
//! [`DistanceBlock`] written as this module's other kinds are, predicted
//! less measured:
//!
//! ```text
//! r = (|c_a − c_b| − L) / σ,     dr/dc_a = uᵀ / σ,     dr/dc_b = −uᵀ / σ,
//! u = (c_a − c_b) / |c_a − c_b|.
//! ```
//!
//! Its unknowns are the two balls' centres only: no parameter of the
//! mechanism enters, and a distance holds in any frame. It ties the two
//! balls together, so that their touches measure the machine's lengths
//! against a length standard over the distance between them, where one
//! ball's radius does so over its own size.

use nalgebra::RowVector3;
use parcal_kinematics::Vec3;

use crate::ObserveError;
use crate::distance::DistanceBlock;

/// One calibrated distance between two balls (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallDistance {
    /// The index of the first ball.
    pub first: usize,
    /// The index of the second ball.
    pub second: usize,
    /// The calibrated distance `L` between their centres (mm).
    pub distance: f64,
    /// Its standard deviation `σ` (mm).
    pub sigma: f64,
}

/// A ball distance's whitened row and its derivatives with respect to the
/// two centres (module doc).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BallDistanceRow {
    /// `r`.
    pub residual: f64,
    /// `dr/dc_a`.
    pub d_first: RowVector3<f64>,
    /// `dr/dc_b`.
    pub d_second: RowVector3<f64>,
}

impl BallDistance {
    /// The whitened row at the centres `first` (`c_a`) and `second`
    /// (`c_b`) (module doc). Refuses a sigma that is not positive and
    /// finite, and coincident centres, where `u` is undefined.
    pub fn evaluate(&self, first: &Vec3, second: &Vec3) -> Result<BallDistanceRow, ObserveError> {
        let block = DistanceBlock {
            length: self.distance,
            sigma: self.sigma,
        };
        // The block's residual is measured less predicted: the negation.
        let j = block.evaluate(first, second)?;
        Ok(BallDistanceRow {
            residual: -j.residual[0],
            d_first: -j.d_first,
            d_second: -j.d_second,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{assert_close, central_difference};

    const BAR: BallDistance = BallDistance {
        first: 0,
        second: 3,
        distance: 120.0,
        sigma: 1e-3,
    };

    #[test]
    fn the_row_is_predicted_less_measured_and_its_derivatives_match_differences() {
        let a = Vec3::new(60.0, -20.0, 12.7);
        let b = Vec3::new(-55.0, 15.0, 12.7);
        let row = BAR.evaluate(&a, &b).unwrap();
        let expected = ((a - b).norm() - BAR.distance) / BAR.sigma;
        assert!((row.residual - expected).abs() < 1e-9, "{}", row.residual);
        let residual = |a: &Vec3, b: &Vec3| {
            nalgebra::SVector::<f64, 1>::new(BAR.evaluate(a, b).unwrap().residual)
        };
        let by_first = central_difference(&a, 1e-5, |a| residual(a, &b));
        assert_close(&row.d_first, &by_first, 1e-5, "dr/dc_a");
        let by_second = central_difference(&b, 1e-5, |b| residual(&a, b));
        assert_close(&row.d_second, &by_second, 1e-5, "dr/dc_b");
    }

    #[test]
    fn coincident_centres_and_bad_sigmas_are_refused() {
        let a = Vec3::new(1.0, 2.0, 3.0);
        assert!(matches!(
            BAR.evaluate(&a, &a),
            Err(ObserveError::DegenerateDirection { .. })
        ));
        let bad = BallDistance { sigma: 0.0, ..BAR };
        assert!(matches!(
            bad.evaluate(&a, &Vec3::zeros()),
            Err(ObserveError::InvalidSigma { .. })
        ));
    }
}
