//! The common errors of the entered data that the systematic tests look
//! for ([`crate::systematic`]): each moves the whitened rows linearly by `t
//! c` ([`parcal_solver::effects`]).

/// A common error of the entered data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Effect {
    /// Every ball's entered radius off by `t` mm (the nominal radius for
    /// the calibrated one, an uncompensated stylus): artefacts.json's
    /// radii, the ball touches' model.
    BallRadius,
    /// Every calibrated distance off by the factor `1 + t` (the plate's
    /// temperature, its calibration's scale): artefacts.json's distances.
    DistanceScale,
}

impl Effect {
    /// Its name in sentences and in calibration.json.
    pub fn name(self) -> &'static str {
        match self {
            Self::BallRadius => "ball radius",
            Self::DistanceScale => "distance scale",
        }
    }

    /// The unit of `t`.
    pub fn unit(self) -> &'static str {
        match self {
            Self::BallRadius => "mm",
            Self::DistanceScale => "1",
        }
    }
}
