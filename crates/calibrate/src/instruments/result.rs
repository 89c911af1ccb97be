//! What a calibration's poses and points give besides the global block
//! ([`crate::CalibrationRun`] holds that): the sessions' model, the rows'
//! residuals at the identified state and, for poses and points alone, the
//! information that says what determined each parameter. The same for a
//! calibration of poses and points alone and one with ball touches
//! ([`crate::mixed`]).

use nalgebra::DVector;
use parcal_kinematics::Vec3;

use crate::instruments::model::InstrumentModel;
use crate::instruments::observations::rms;

/// The poses and points of a calibration.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct InstrumentResult {
    /// The global block's meaning (its layout, the sessions, the frames'
    /// references).
    pub model: InstrumentModel,
    /// The initial global block: the design's parameters and scales, the
    /// frames at their start ([`crate::instruments::start`]), every
    /// correction and offset zero.
    pub initial: DVector<f64>,
    /// Each pose's leg-length residuals `|T E_i − B_i| − L_i` at the
    /// identified state (mm).
    pub leg_residuals: Vec<[f64; 6]>,
    /// Each point's residual `F(T) − P` at the identified state (mm).
    pub point_residuals: Vec<Vec3>,
    /// Poses and points alone: each global parameter's prior sigma and the
    /// information the data give it; `None` with ball touches, whose
    /// kinematic parameters are attributed from their prior
    /// ([`crate::CalibrationRun::prior`]).
    pub information: Option<ParameterInformation>,
}

/// What the prior and the data say of each parameter of the global block,
/// from which a report attributes it to the data, the prior or both.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct ParameterInformation {
    /// Each parameter's prior sigma: the kinematic block's marginals, the
    /// groups' own (infinite without a prior on it).
    pub prior_sigmas: DVector<f64>,
    /// The information the data alone give each parameter at the
    /// identified state, `diag(JᵀJ)` of the whitened rows (zero: the data
    /// do not observe it; the tool, which poses alone do not observe, is
    /// not in their layout at all).
    pub data: DVector<f64>,
}

impl InstrumentResult {
    /// RMS of the poses' leg-length residuals (mm), or `None` without
    /// poses.
    pub fn leg_rms(&self) -> Option<f64> {
        rms(self.leg_residuals.iter().flatten().copied())
    }

    /// RMS of the points' residual coordinates (mm), or `None` without
    /// points.
    pub fn point_rms(&self) -> Option<f64> {
        rms(self.point_residuals.iter().flat_map(|p| p.iter().copied()))
    }
}
