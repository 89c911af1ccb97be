//! A mechanism calibration's data in memory ([`MechanismData`]): the
//! mechanism, the parameters its controller ran with, the priors
//! ([`ParameterPrior`]), the observations, where a fit starts the balls
//! and touches; the data a mechanism's design gives, and the same data
//! with other priors or observations.

use std::fmt;
use std::sync::Arc;

use nalgebra::DMatrix;
use parcal_kinematics::mechanism::Mechanism;

use super::super::error::MechanismCalibrationError;
use super::super::touch_start::TouchStart;
use super::observations::Observations;

/// A Gaussian prior on one unknown: its mean and standard deviation;
/// without a standard deviation, no prior, the mean being only where the
/// solver starts.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ParameterPrior {
    /// The mean (the start of the solver).
    pub mean: f64,
    /// The standard deviation, `None` for no prior.
    pub sigma: Option<f64>,
}

/// A mechanism calibration's data (module doc).
#[derive(Clone)]
#[non_exhaustive]
pub struct MechanismData {
    /// The mechanism.
    pub mechanism: Arc<dyn Mechanism>,
    /// The parameters the controller ran with, `p_c`: every commanded
    /// position became readings through them.
    pub configured: Vec<f64>,
    /// Each parameter's prior (the builder's knowledge of the true
    /// machine), in the mechanism's parameter order.
    pub priors: Vec<ParameterPrior>,
    /// The correlation of the parameters' priors (`n × n`, unit
    /// diagonal; [`super::super::prior`]); `None`: independent.
    pub prior_correlation: Option<DMatrix<f64>>,
    /// The probe's trigger height `h` above the bed (mm): an unknown when
    /// there are probe heights.
    pub trigger_height: ParameterPrior,
    /// The observations.
    pub observations: Observations,
    /// Where a fit starts the balls and touches, when another set-up has
    /// located them ([`TouchStart`]); `None`: from the mechanism's start
    /// poses.
    pub touch_start: Option<TouchStart>,
    /// A printer's printable radius (mm, machine.json's), which
    /// [`Self::mechanism`] keeps the nozzle within and the calibration's
    /// record carries to what applies it (compensation, the firmware's
    /// lines); `None`: the mechanism's own limits, unrecorded.
    pub print_radius: Option<f64>,
}

impl fmt::Debug for MechanismData {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MechanismData")
            .field("mechanism", &self.mechanism.name())
            .field("configured", &self.configured)
            .field("priors", &self.priors)
            .field("prior_correlation", &self.prior_correlation)
            .field("trigger_height", &self.trigger_height)
            .field("observations", &self.observations)
            .field("touch_start", &self.touch_start.as_ref().map(|_| "given"))
            .field("print_radius", &self.print_radius)
            .finish()
    }
}

impl MechanismData {
    /// The data of `mechanism` run with `configured` parameters: each
    /// parameter's prior its design value and tolerance
    /// ([`parcal_kinematics::mechanism::Parameter`]), the trigger height
    /// without a prior, starting at 0.
    pub fn new(
        mechanism: Arc<dyn Mechanism>,
        configured: Vec<f64>,
        observations: Observations,
    ) -> Self {
        let priors = mechanism
            .parameters()
            .iter()
            .map(|p| ParameterPrior {
                mean: p.design,
                sigma: Some(p.prior_sigma),
            })
            .collect();
        Self {
            mechanism,
            configured,
            priors,
            prior_correlation: None,
            trigger_height: ParameterPrior {
                mean: 0.0,
                sigma: None,
            },
            observations,
            touch_start: None,
            print_radius: None,
        }
    }

    /// These data with their balls and touches started at `start`
    /// (checked by [`MechanismData::validate`]).
    pub fn with_touch_start(mut self, start: TouchStart) -> Self {
        self.touch_start = Some(start);
        self
    }

    /// These data with the prior sigma of every parameter of `group` set
    /// to `sigma` (`None`: no prior). An error names a group the
    /// mechanism does not have.
    pub fn with_group_sigma(
        mut self,
        group: &str,
        sigma: Option<f64>,
    ) -> Result<Self, MechanismCalibrationError> {
        let parameters = self.mechanism.parameters();
        if !parameters.iter().any(|p| p.group == group) {
            let mut groups: Vec<&str> = parameters.iter().map(|p| p.group).collect();
            groups.dedup();
            return Err(MechanismCalibrationError::InvalidData {
                what: format!("parameter group {group:?}"),
                reason: format!(
                    "the {} has no such group (its groups: {})",
                    self.mechanism.name(),
                    groups.join(", ")
                ),
            });
        }
        for (prior, parameter) in self.priors.iter_mut().zip(parameters) {
            if parameter.group == group {
                prior.sigma = sigma;
            }
        }
        Ok(self)
    }

    /// These data with every parameter's prior mean set to `means` (the
    /// design the builder aimed at), keeping the sigmas.
    pub fn with_prior_means(mut self, means: &[f64]) -> Self {
        for (prior, &mean) in self.priors.iter_mut().zip(means) {
            prior.mean = mean;
        }
        self
    }

    /// These data with the parameters' priors correlated by `correlation`
    /// (`n × n` for the `n` parameters, symmetric, unit diagonal, positive
    /// definite over the parameters with a prior; [`super::super::prior`]), their
    /// sigmas kept. [`MechanismData::validate`] checks it.
    pub fn with_prior_correlation(mut self, correlation: DMatrix<f64>) -> Self {
        self.prior_correlation = Some(correlation);
        self
    }

    /// These data with the trigger height's prior `mean ± sigma`.
    pub fn with_trigger_height(mut self, mean: f64, sigma: Option<f64>) -> Self {
        self.trigger_height = ParameterPrior { mean, sigma };
        self
    }

    /// These data with no prior on any parameter nor on any tracker's
    /// offsets or body shifts (the means kept as the solver's start).
    pub fn without_priors(mut self) -> Self {
        for prior in &mut self.priors {
            prior.sigma = None;
        }
        for tracker in &mut self.observations.trackers {
            tracker.offset_sigmas = None;
            tracker.body_rotation_sigma = None;
            tracker.body_origin_sigma = None;
        }
        self
    }

    /// [`MechanismData::without_priors`], but for the parameters of the
    /// mechanism's `group`, whose priors stay: what holds parameters that
    /// no observation sees.
    pub fn without_priors_but(self, group: &str) -> Self {
        let kept: Vec<ParameterPrior> = self.priors.clone();
        let mut data = self.without_priors();
        let parameters = data.mechanism.parameters();
        for ((prior, kept), parameter) in data.priors.iter_mut().zip(kept).zip(parameters) {
            if parameter.group == group {
                *prior = kept;
            }
        }
        data
    }

    /// Whether the trigger height is an unknown: there are probe heights.
    pub fn has_trigger_height(&self) -> bool {
        !self.observations.probes.is_empty()
    }

    /// These data with other observations, started from the mechanism's
    /// start poses.
    pub fn with_observations(&self, observations: Observations) -> Self {
        Self {
            observations,
            // Its places are the old observations'.
            touch_start: None,
            ..self.clone()
        }
    }
}
