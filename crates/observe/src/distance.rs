//! The distance observation: a calibrated centre-to-centre distance of two
//! balls (a ball plate or a ball bar),
//!
//! ```text
//! c_ab = L_ab − |C_a − C_b|,                                  1 row,
//! dc/dC_a = −nᵀ,   dc/dC_b = nᵀ,   n = (C_a − C_b) / |C_a − C_b|,
//! ```
//!
//! whitened by the distance's calibration uncertainty `σ_ab`:
//! `c_w = c / σ_ab`. Unknowns: the two centres only; a distance is
//! invariant under rigid motions, so it holds in any frame the centres are
//! expressed in. It is not in the paper (Sato et al. 2004 use the balls'
//! radii alone); it ties the balls' relative positions to a length standard.

use nalgebra::{RowVector3, SVector};
use parcal_kinematics::Vec3;

use crate::ObserveError;
use crate::error::check_sigma;
use crate::radius::unit_offset;

/// A calibrated distance between the centres of two balls.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceBlock {
    /// The calibrated distance `L_ab` (mm).
    pub length: f64,
    /// Its standard uncertainty `σ_ab` (mm).
    pub sigma: f64,
}

/// The whitened residual of a distance and its derivatives with respect to
/// the two centres (dimensionless; per mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DistanceJacobians {
    /// `c_w = (L_ab − |C_a − C_b|) / σ_ab`.
    pub residual: SVector<f64, 1>,
    /// `dc_w/dC_a = −nᵀ / σ_ab`.
    pub d_first: RowVector3<f64>,
    /// `dc_w/dC_b = nᵀ / σ_ab`.
    pub d_second: RowVector3<f64>,
}

impl DistanceBlock {
    /// The whitened block at the centres `first` (`C_a`) and `second`
    /// (`C_b`), mm in one frame. Refuses a sigma that is not positive and
    /// finite, and coincident centres, where `n` is undefined.
    pub fn evaluate(&self, first: &Vec3, second: &Vec3) -> Result<DistanceJacobians, ObserveError> {
        let sigma = check_sigma("distance uncertainty", self.sigma, false)?;
        let (unit, distance) = unit_offset(
            first,
            second,
            "direction between the two ball centres of a distance",
        )?;
        let normal = (unit / sigma).transpose();
        Ok(DistanceJacobians {
            residual: SVector::<f64, 1>::new((self.length - distance) / sigma),
            d_first: -normal,
            d_second: normal,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_support::{assert_close, central_difference};

    const BLOCK: DistanceBlock = DistanceBlock {
        length: 100.0,
        sigma: 2e-3,
    };

    #[test]
    fn derivatives_match_central_differences() {
        let a = Vec3::new(10.0, -40.0, 3.0);
        let b = Vec3::new(-80.0, 25.0, -1.5);
        let block = BLOCK.evaluate(&a, &b).unwrap();
        let expected = (BLOCK.length - (a - b).norm()) / BLOCK.sigma;
        assert!((block.residual[0] - expected).abs() < 1e-12);
        let by_first = central_difference(&a, 1e-5, |a| BLOCK.evaluate(a, &b).unwrap().residual);
        assert_close(&block.d_first, &by_first, 1e-6, "dc/dC_a");
        let by_second = central_difference(&b, 1e-5, |b| BLOCK.evaluate(&a, b).unwrap().residual);
        assert_close(&block.d_second, &by_second, 1e-6, "dc/dC_b");
    }

    #[test]
    fn refuses_coincident_centres_and_bad_sigmas() {
        let a = Vec3::new(1.0, 2.0, 3.0);
        let error = BLOCK.evaluate(&a, &a).unwrap_err();
        assert!(matches!(error, ObserveError::DegenerateDirection { .. }));
        for sigma in [0.0, -1.0, f64::NAN] {
            let block = DistanceBlock { length: 1.0, sigma };
            let error = block.evaluate(&a, &Vec3::zeros()).unwrap_err();
            assert!(
                matches!(error, ObserveError::InvalidSigma { .. }),
                "{sigma}"
            );
        }
    }
}
