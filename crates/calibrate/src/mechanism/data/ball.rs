//! A calibrated ball placed at an unknown centre: its radius, its
//! calibration's sigma, and what is known of its centre before the
//! touches.

/// A calibrated sphere placed at an unknown centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ball {
    /// Its calibrated radius `ρ` (mm).
    pub radius: f64,
    /// The standard deviation of its calibration (mm); `None`: exact. With
    /// one, the radius is an unknown of the fit with that prior.
    pub radius_sigma: Option<f64>,
    /// What is known of its centre before the touches (where it was
    /// placed); `None`: the touches alone locate it.
    pub centre_prior: Option<CentrePrior>,
}

/// A Gaussian prior on a ball's centre: `c ~ N(centre, σ² I)` (paper eq.
/// 7's artefact terms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CentrePrior {
    /// The centre's prior mean (mm, the mechanism's frame).
    pub centre: [f64; 3],
    /// Its standard deviation on each axis (mm).
    pub sigma: f64,
}

impl Ball {
    /// A ball of calibrated radius `radius` (mm), with its calibration's
    /// sigma or exact, and no prior on its centre.
    pub fn new(radius: f64, radius_sigma: Option<f64>) -> Self {
        Self {
            radius,
            radius_sigma,
            centre_prior: None,
        }
    }
}
