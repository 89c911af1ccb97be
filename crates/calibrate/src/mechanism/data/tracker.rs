//! A tracker: an instrument at one placement, measuring tool points in its
//! own frame, with what changed before it measured (the machine re-homed,
//! the body on the platform turned or moved) and those changes' priors.

#[cfg(doc)]
use parcal_observe::mechanism::TrackerPoint;

/// An instrument at one placement, measuring tool points in its own frame
/// ([`TrackerPoint`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Tracker {
    /// Its label.
    pub label: String,
    /// Whether the machine was re-homed before it measured: each
    /// actuator's zero offset is then an unknown of the global block;
    /// otherwise the actuators read as for the other observations.
    pub rehomed: bool,
    /// The standard deviations of the offsets' priors about zero (the
    /// actuators' extension, mm, where their scales are the mechanism's
    /// parameters, else the readings' unit), when re-homed: one for every actuator, or one per
    /// actuator; `None`: no prior.
    pub offset_sigmas: Option<Vec<f64>>,
    /// Whether the body its poses see was turned on the platform before it
    /// measured: the rotation `φ` about the body frame the other trackers
    /// see is then three unknowns of the global block (`C_B,k = (Exp(ω_B +
    /// φ), τ_B + ρ)`).
    pub body_turned: bool,
    /// The standard deviation of `φ`'s prior about zero (rad), when
    /// turned; `None`: no prior.
    pub body_rotation_sigma: Option<f64>,
    /// Whether the body was moved on the platform before it measured: the
    /// origin shift `ρ` is then three unknowns of the global block.
    pub body_moved: bool,
    /// The standard deviation of `ρ`'s prior about zero (mm), when moved;
    /// `None`: no prior.
    pub body_origin_sigma: Option<f64>,
}

impl Tracker {
    /// A tracker labelled `label`, the actuators read as for the other
    /// observations.
    pub fn new(label: impl Into<String>) -> Self {
        Self {
            label: label.into(),
            rehomed: false,
            offset_sigmas: None,
            body_turned: false,
            body_rotation_sigma: None,
            body_moved: false,
            body_origin_sigma: None,
        }
    }

    /// A tracker labelled `label` that measured after the machine was
    /// re-homed, each actuator's offset with the prior `N(0, sigma²)`
    /// (`None`: no prior).
    pub fn rehomed(label: impl Into<String>, offset_sigma: Option<f64>) -> Self {
        Self {
            rehomed: true,
            offset_sigmas: offset_sigma.map(|sigma| vec![sigma]),
            ..Self::new(label)
        }
    }

    /// A tracker labelled `label` that measured after the machine was
    /// re-homed, actuator `i`'s offset with the prior `N(0, sigmas[i]²)`
    /// (actuators of different units or scales).
    pub fn rehomed_each(label: impl Into<String>, sigmas: Vec<f64>) -> Self {
        Self {
            rehomed: true,
            offset_sigmas: Some(sigmas),
            ..Self::new(label)
        }
    }

    /// The prior sigma of actuator `i`'s offset, if any.
    pub(crate) fn offset_sigma(&self, i: usize) -> Option<f64> {
        let sigmas = self.offset_sigmas.as_ref()?;
        sigmas.get(i).or(sigmas.first()).copied()
    }

    /// This tracker after the body on the platform was turned, the
    /// rotation's prior `N(0, sigma² I)` (`None`: no prior).
    pub fn with_body_turned(mut self, sigma: Option<f64>) -> Self {
        self.body_turned = true;
        self.body_rotation_sigma = sigma;
        self
    }

    /// This tracker after the body on the platform was moved, the origin
    /// shift's prior `N(0, sigma² I)` (`None`: no prior).
    pub fn with_body_moved(mut self, sigma: Option<f64>) -> Self {
        self.body_moved = true;
        self.body_origin_sigma = sigma;
        self
    }
}
