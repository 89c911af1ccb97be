//! The predicted rows of one held-out observation, or of observations
//! predicted together ([`PredictedRows`]): their residual rows `r`
//! (observation's units), their own noise covariance `D_i`, and their
//! derivative `G_i = dr/dθ` with respect to the calibration's global block
//! `θ = (p, h)` (the parameters, then the trigger height); a derivative
//! over the parameters alone widened to the global block ([`widened`]).

use nalgebra::{DMatrix, DVector};

use super::super::observation::{HeldOut, ObservationRef};

/// The predicted rows of one held-out observation, or of one ball's
/// touches (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct PredictedRows {
    /// What they are of.
    pub observation: HeldOut,
    /// `r`, its residual rows in the observation's units.
    pub residuals: DVector<f64>,
    /// `D_i`, their own noise covariance.
    pub noise: DMatrix<f64>,
    /// `G_i = dr/dθ` (rows × the global block).
    pub d_global: DMatrix<f64>,
    /// The observation each row predicts alone and its row there, when
    /// each row does (rows predicted from reference observations,
    /// [`predict_from_reference`](super::projection::predict_from_reference)); empty when a row combines several (a
    /// projection) or is one of an observation's own rows.
    pub row_observations: Vec<(ObservationRef, usize)>,
    /// The balls (their indices) located at the mirror image of their
    /// reference touches' fit, which all their touches chose
    /// ([`located_side`](crate::mirror::located_side)).
    pub mirrored_balls: Vec<usize>,
}

/// `d_params` with zero columns appended up to `g`.
pub(super) fn widened(d_params: &DMatrix<f64>, g: usize) -> DMatrix<f64> {
    let mut wide = DMatrix::zeros(d_params.nrows(), g);
    wide.columns_mut(0, d_params.ncols()).copy_from(d_params);
    wide
}
