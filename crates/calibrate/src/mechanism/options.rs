//! How a mechanism calibration runs: the loss, the tests' level, data
//! snooping, the iteration limit.

use parcal_solver::Loss;

use crate::hypothesis::{MAX_REMOVALS, SNOOPING_LEVEL};

use super::error::MechanismCalibrationError;

/// The largest iteration limit (a calibration of this size converges in a
/// few steps; more is a mistake, not a need).
pub const MAX_ITERATIONS: usize = 1000;

/// Options of [`calibrate_mechanism`](super::calibrate_mechanism).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct MechanismOptions {
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
    /// The solver's iteration limit.
    pub max_iterations: usize,
}

impl Default for MechanismOptions {
    /// Least squares, no snooping, `α` = 0.05, at most 10 removals and 50
    /// iterations.
    fn default() -> Self {
        Self {
            loss: Loss::Squared,
            snoop: false,
            alpha: SNOOPING_LEVEL,
            max_removals: MAX_REMOVALS,
            max_iterations: 50,
        }
    }
}

impl MechanismOptions {
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

    /// These options with the level `alpha`.
    pub fn with_alpha(mut self, alpha: f64) -> Self {
        self.alpha = alpha;
        self
    }

    /// Refuses a level outside (0, 1), an iteration limit outside
    /// 1..=[`MAX_ITERATIONS`], more removals than observations could
    /// need ([`super::data::MAX_OBSERVATIONS`]), and snooping with a
    /// robust loss.
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
        if self.snoop && !self.loss.is_squared() {
            return invalid(
                "snoop",
                "data snooping with a robust loss: the loss replaces it".to_string(),
            );
        }
        Ok(())
    }
}
