//! Why a calibration could not be set up or evaluated. Line numbers are those
//! of measurements.csv (the header is line 1).

use parcal_kinematics::KinematicsError;
use parcal_observe::ObserveError;

use crate::sphere_fit::SphereFitError;

#[derive(Debug, Clone, thiserror::Error)]
pub enum CalibrateError {
    #[error("machine.json: the design geometry is degenerate: {0}")]
    Design(KinematicsError),
    #[error("measurements.csv line {}: forward kinematics failed: {source}", row + 2)]
    ForwardKinematics { row: usize, source: KinematicsError },
    #[error("measurements.csv line {}: {source}", row + 2)]
    Observation { row: usize, source: ObserveError },
    #[error("ball {ball}: no initial centre: {source}")]
    CentreFit {
        ball: String,
        source: SphereFitError,
    },
    #[error("machine.json prior_sigma: the a priori covariance is unusable: {0}")]
    Prior(ObserveError),
}
