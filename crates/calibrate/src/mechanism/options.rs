//! How a mechanism calibration runs: the touches' observation equation,
//! the loss, the tests' level, data snooping, the solver's method, its
//! iteration limit and the time budget.

use std::time::{Duration, Instant};

use parcal_solver::{Loss, Method, SolverOptions};

use crate::options::{LEVENBERG_MARQUARDT_ITERATIONS, Observation};

use crate::hypothesis::{MAX_REMOVALS, SNOOPING_LEVEL};

use super::error::MechanismCalibrationError;

/// The largest iteration limit (a calibration of this size converges in a
/// few steps; more is a mistake, not a need).
pub const MAX_ITERATIONS: usize = 1000;

/// Options of [`calibrate_mechanism`](super::calibrate_mechanism).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct MechanismOptions {
    /// How each ball touch is observed: its radius row (paper eq. 9,
    /// [`BallTouch::row`]) or its three coordinates with its two contact
    /// angles (eq. 10, [`BallTouch::coordinate_rows`]; point samples are
    /// then refused).
    ///
    /// [`BallTouch::row`]: parcal_observe::mechanism::BallTouch::row
    /// [`BallTouch::coordinate_rows`]: parcal_observe::mechanism::BallTouch::coordinate_rows
    pub observation: Observation,
    /// The loss on the observations ([`Loss::Squared`], or a robust one,
    /// which replaces data snooping).
    pub loss: Loss,
    /// Whether to snoop: remove the worst observation beyond the
    /// family-wise limit and calibrate again, until none is
    /// ([`crate::snooping`] for the method).
    pub snoop: bool,
    /// The level `α` of the global test (two-sided) and the family-wise
    /// level of the w-tests (Bonferroni over the data rows).
    pub alpha: f64,
    /// The most observations snooping removes.
    pub max_removals: usize,
    /// The solver's iteration limit (of each fit, when snooping fits
    /// again).
    pub max_iterations: usize,
    /// The solver's method: Gauss-Newton (the paper's eq. 5), or
    /// Levenberg-Marquardt, whose damped steps never raise the cost.
    pub method: Method,
    /// The wall-clock budget of the whole calibration, every fit of data
    /// snooping included: once it has passed, the fit stops at its
    /// current iterate ([`Status::TimeLimit`](parcal_solver::Status),
    /// rejected); `None`, no budget.
    pub time_limit: Option<Duration>,
}

impl Default for MechanismOptions {
    /// The radius observation, least squares, no snooping, `α` = 0.05, at
    /// most 10 removals, Gauss-Newton with at most 50 iterations, no time
    /// budget.
    fn default() -> Self {
        Self {
            observation: Observation::Radius,
            loss: Loss::Squared,
            snoop: false,
            alpha: SNOOPING_LEVEL,
            max_removals: MAX_REMOVALS,
            max_iterations: 50,
            method: Method::GaussNewton,
            time_limit: None,
        }
    }
}

impl MechanismOptions {
    /// These options with the touches observed by `observation`.
    pub fn with_observation(mut self, observation: Observation) -> Self {
        self.observation = observation;
        self
    }

    /// These options with data snooping on or off.
    pub fn with_snooping(mut self, snoop: bool) -> Self {
        self.snoop = snoop;
        self
    }

    /// These options with the loss `loss`.
    pub fn with_loss(mut self, loss: Loss) -> Self {
        self.loss = loss;
        self
    }

    /// These options with the iteration limit `limit`, if one is given
    /// (the default's otherwise).
    pub fn with_max_iterations(mut self, limit: Option<usize>) -> Self {
        if let Some(limit) = limit {
            self.max_iterations = limit;
        }
        self
    }

    /// These options with Levenberg-Marquardt (initial `λ` 1e-3, as the
    /// hexapod's own calibration) and its iteration limit, 200, the
    /// hexapod's too; a later [`with_max_iterations`](Self::with_max_iterations) sets
    /// another.
    pub fn levenberg_marquardt(mut self) -> Self {
        self.method = Method::LevenbergMarquardt {
            initial_lambda: 1e-3,
        };
        self.max_iterations = LEVENBERG_MARQUARDT_ITERATIONS;
        self
    }

    /// These options with the time budget `limit` (none if `None`).
    pub fn with_time_limit(mut self, limit: Option<Duration>) -> Self {
        self.time_limit = limit;
        self
    }

    /// The solver's options of a fit that starts when the calibration
    /// that began at `started` has used part of its time budget.
    pub(crate) fn solver_options(&self, started: Instant) -> SolverOptions {
        SolverOptions {
            method: self.method,
            max_iterations: self.max_iterations,
            time_limit: self
                .time_limit
                .map(|limit| limit.saturating_sub(started.elapsed())),
            ..SolverOptions::default()
        }
    }

    /// These options with the level `alpha`.
    pub fn with_alpha(mut self, alpha: f64) -> Self {
        self.alpha = alpha;
        self
    }

    /// Refuses a level outside (0, 1), an iteration limit outside
    /// 1..=[`MAX_ITERATIONS`], more removals than observations could
    /// need ([`super::data::MAX_OBSERVATIONS`]), snooping with a robust
    /// loss, and a Levenberg-Marquardt `λ` that is not positive and
    /// finite.
    pub fn validate(&self) -> Result<(), MechanismCalibrationError> {
        let invalid = |what: &str, reason: String| {
            Err(MechanismCalibrationError::InvalidData {
                what: format!("options.{what}"),
                reason,
            })
        };
        if !(self.alpha > 0.0 && self.alpha < 1.0) {
            return invalid("alpha", format!("{} is not a level in (0, 1)", self.alpha));
        }
        if !(1..=MAX_ITERATIONS).contains(&self.max_iterations) {
            return invalid(
                "max_iterations",
                format!("{} is not in 1..={MAX_ITERATIONS}", self.max_iterations),
            );
        }
        if self.max_removals > super::data::MAX_OBSERVATIONS {
            return invalid(
                "max_removals",
                format!(
                    "{} is more than the most observations a calibration holds ({})",
                    self.max_removals,
                    super::data::MAX_OBSERVATIONS
                ),
            );
        }
        if let Method::LevenbergMarquardt { initial_lambda } = self.method
            && !(initial_lambda > 0.0 && initial_lambda.is_finite())
        {
            return invalid(
                "method",
                format!(
                    "a Levenberg-Marquardt lambda of {initial_lambda}, not positive and finite"
                ),
            );
        }
        if self.snoop && !self.loss.is_squared() {
            return invalid(
                "snoop",
                "data snooping with a robust loss: the loss replaces it".to_string(),
            );
        }
        Ok(())
    }
}
