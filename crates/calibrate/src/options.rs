//! What a calibration run is asked to do (docs/paper-scenario.md section 4).

use std::fmt;
use std::time::Duration;

use parcal_observe::WeightModel;
use parcal_solver::{Loss, Method, SolverOptions};

/// The observation equation of every contact.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Observation {
    /// Paper eq. (9): `c = r - |f(q, p) - C|`, one row per contact.
    Radius,
    /// Paper eq. (10): `c = C + r u(angles) - f(q, p)`, three rows and two
    /// angle unknowns per contact.
    Coordinates,
}

/// How the error of each ball's calibrated radius enters the calibration.
/// The radius is calibrated once per ball (docs/paper-scenario.md section 3: one draw per
/// ball), so its error is shared by every touch of that ball.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum RadiusModel {
    /// Each ball's radius is an unknown beside its centre, with the prior
    /// `N(r_calibrated, σ_r²)` of artefacts.json (`radius`, `radius_sigma`);
    /// σ_r leaves the contacts' weights. Tied balls (calibrated distances)
    /// have their radius in the global block, next to their centre.
    #[cfg_attr(feature = "clap", value(name = "ball"))]
    PerBall,
    /// The calibrated radius is data and σ_r an independent error of every
    /// contact, in the weights (paper eq. 5 as the paper states it).
    #[cfg_attr(feature = "clap", value(name = "contact"))]
    PerContact,
}

impl RadiusModel {
    /// Ball unknowns: the centre, and the radius for [`RadiusModel::PerBall`].
    pub fn ball_unknowns(self) -> usize {
        match self {
            Self::PerBall => 4,
            Self::PerContact => 3,
        }
    }
}

impl fmt::Display for RadiusModel {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::PerBall => "ball",
            Self::PerContact => "contact",
        })
    }
}

/// The a priori knowledge (paper eq. 7).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum PriorMode {
    /// No prior (simulations I and II).
    None,
    /// The paper's form: every canonical parameter about its design value
    /// with sigma `prior_sigma`, every ball centre about its initial estimate
    /// (sigma `centre_sigma` of artefacts.json), every contact's angles about
    /// their initial values (sigma `angle_sigma` of the options).
    Paper,
    /// The design tolerances on the input-frame coordinates propagated
    /// through the canonicalisation to a full 33 x 33 prior; centre priors
    /// only for balls located in the canonical frame, angle priors only for
    /// contacts with a commanded approach direction.
    Propagated,
}

/// The paper's four simulations (section 3.1, 3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Simulation {
    #[cfg_attr(feature = "clap", value(name = "I"))]
    /// Radius observation (eq. 9), no prior.
    I,
    #[cfg_attr(feature = "clap", value(name = "II"))]
    /// Coordinate observation (eq. 10), no prior.
    II,
    #[cfg_attr(feature = "clap", value(name = "III"))]
    /// Radius observation (eq. 9) with the a priori knowledge.
    III,
    #[cfg_attr(feature = "clap", value(name = "IV"))]
    /// Coordinate observation (eq. 10) with the a priori knowledge.
    IV,
}

impl Simulation {
    /// The four, in the paper's order.
    pub const ALL: [Simulation; 4] = [Self::I, Self::II, Self::III, Self::IV];

    /// The observation equation of the simulation.
    pub fn observation(self) -> Observation {
        match self {
            Self::I | Self::III => Observation::Radius,
            Self::II | Self::IV => Observation::Coordinates,
        }
    }

    /// Whether the simulation uses a priori knowledge (III, IV).
    pub fn has_prior(self) -> bool {
        matches!(self, Self::III | Self::IV)
    }
}

impl fmt::Display for Simulation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::I => "I",
            Self::II => "II",
            Self::III => "III",
            Self::IV => "IV",
        })
    }
}

impl fmt::Display for PriorMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::None => "none",
            Self::Paper => "paper",
            Self::Propagated => "propagated",
        })
    }
}

impl fmt::Display for Observation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Radius => "radius",
            Self::Coordinates => "coordinates",
        })
    }
}

/// Everything a calibration run needs besides the dataset.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationOptions {
    /// The observation equation of every contact.
    pub observation: Observation,
    /// The a priori knowledge (paper eq. 7).
    pub prior: PriorMode,
    /// How the observation covariance W is formed; the propagated model is
    /// evaluated at the initial estimate and held fixed.
    pub weighting: WeightModel,
    /// Each ball's radius an unknown, or its error independent per contact.
    pub radius: RadiusModel,
    /// Gauss-Newton (paper eq. 5) or Levenberg-Marquardt.
    pub method: Method,
    /// Sigma of the per-contact angle prior (rad): the paper's 0.01 in paper
    /// mode; in propagated mode it applies only to contacts with a commanded
    /// approach direction.
    pub angle_sigma: f64,
    /// Iterations before giving up (linear solves; for Levenberg-Marquardt
    /// rejected steps count too).
    pub max_iterations: usize,
    /// Converged when `|dx| / (|x| + 1) < step_tolerance` over all unknowns.
    pub step_tolerance: f64,
    /// Converged, too, when a Gauss-Newton step would move no unknown by
    /// more than this many of its standard deviations
    /// ([`parcal_solver::SolverOptions::sigma_tolerance`]).
    pub sigma_tolerance: f64,
    /// A wall-clock budget for the whole run (every solve it makes); the
    /// run ends with `Status::TimeLimit` when it has passed. `None`: none.
    pub time_limit: Option<Duration>,
    /// The loss of each observation ([`crate::robust`]): least squares
    /// (the default), or Huber's or Cauchy's with `k` in units of the
    /// observation's standard deviation, by iteratively reweighted least
    /// squares. Each observation is weighed by its scaled residual `u =
    /// |e| / √d`, `d` its degrees of freedom: a contact has one (the
    /// coordinate observation's angles absorb two of its three rows), a
    /// distance one, a pose six, a point three; priors are never weighed.
    pub loss: Loss,
}

/// Default iteration limit of Gauss-Newton.
pub const GAUSS_NEWTON_ITERATIONS: usize = 50;
/// Default iteration limit of Levenberg-Marquardt: its damping must fall
/// below the weakest relative eigenvalue of the problem (~3e-7 for the
/// near-rigid tilt of the paper scenario) before that direction moves
/// freely, which takes it ~60 steps on the paper scenario.
pub const LEVENBERG_MARQUARDT_ITERATIONS: usize = 200;

/// Default iteration limit of a robust loss: iteratively reweighted least
/// squares converges linearly (each step solves the problem weighted at
/// the iterate it starts from), Huber's in ~50 steps on the paper scenario.
pub const ROBUST_ITERATIONS: usize = 200;

impl CalibrationOptions {
    /// The solver's options these ask for: the method, the iteration and
    /// time limits and the two stopping tolerances; the rest the solver's
    /// defaults.
    pub fn solver_options(&self) -> SolverOptions {
        SolverOptions {
            method: self.method,
            max_iterations: self.max_iterations,
            step_tolerance: self.step_tolerance,
            sigma_tolerance: self.sigma_tolerance,
            time_limit: self.time_limit,
            ..SolverOptions::default()
        }
    }

    /// These options with the loss `loss`, and for a robust one an
    /// iteration limit of at least [`ROBUST_ITERATIONS`].
    pub fn with_loss(self, loss: Loss) -> Self {
        let max_iterations = if loss.is_squared() {
            self.max_iterations
        } else {
            self.max_iterations.max(ROBUST_ITERATIONS)
        };
        Self {
            loss,
            max_iterations,
            ..self
        }
    }

    /// These options with Levenberg-Marquardt (initial `λ` 1e-3) and its
    /// iteration limit.
    pub fn levenberg_marquardt(self) -> Self {
        Self {
            method: Method::LevenbergMarquardt {
                initial_lambda: 1e-3,
            },
            max_iterations: LEVENBERG_MARQUARDT_ITERATIONS,
            ..self
        }
    }

    /// The paper's simulation `sim` as the paper states it (paper-mode prior
    /// for III and IV, Gauss-Newton, propagated weights, the radius error
    /// per contact in the weights of eq. 5).
    pub fn simulation(sim: Simulation) -> Self {
        let prior = if sim.has_prior() {
            PriorMode::Paper
        } else {
            PriorMode::None
        };
        Self {
            observation: sim.observation(),
            prior,
            radius: RadiusModel::PerContact,
            ..Self::default()
        }
    }
}

impl Default for CalibrationOptions {
    /// Transformed coordinates with the propagated prior (simulation IV as
    /// parcal recommends it), each ball's radius an unknown, Gauss-Newton.
    fn default() -> Self {
        Self {
            observation: Observation::Coordinates,
            prior: PriorMode::Propagated,
            weighting: WeightModel::Propagated,
            radius: RadiusModel::PerBall,
            method: Method::GaussNewton,
            angle_sigma: 0.01,
            max_iterations: GAUSS_NEWTON_ITERATIONS,
            step_tolerance: 1e-10,
            sigma_tolerance: parcal_solver::SIGMA_TOLERANCE,
            time_limit: None,
            loss: Loss::Squared,
        }
    }
}
