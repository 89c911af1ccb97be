//! Step policies: what the iteration makes of a step, apart from the loop
//! that computes it (as Ceres keeps its trust-region strategy out of the
//! minimiser). Gauss–Newton takes every full step and ends the run where a
//! step cannot be taken; Levenberg–Marquardt judges each step by its gain
//! ratio and adapts the damping `λ`.

use crate::diagnostics::SpectrumDiagnostics;
use crate::eliminate::Failure;
use crate::options::SolverOptions;
use crate::reduced::ReducedSystem;

/// LM gives up when `λ` grows beyond this.
pub(crate) const MAX_LAMBDA: f64 = 1e32;
/// An LM step with at least this gain ratio divides `λ` by 3 (and reuses the
/// trial point's system, built with that damping); a weaker accepted step
/// follows Nielsen's `λ · max(1/3, 1 − (2ρ − 1)³)`.
const GOOD_GAIN: f64 = 0.75;

/// The costs of a step whose trial point was evaluated.
pub(crate) struct Trial {
    /// The cost at the run's initial state.
    pub(crate) initial_cost: f64,
    /// The cost at the iterate the step starts from.
    pub(crate) cost: f64,
    /// The decrease of the linearised cost predicted for the step.
    pub(crate) predicted_decrease: f64,
    /// The cost at the trial point.
    pub(crate) trial_cost: f64,
}

/// Why a step cannot be judged by its cost.
pub(crate) enum Unusable<'s> {
    /// The reduced matrix at the iterate (this system) is not numerically
    /// positive definite: no step.
    Singular(&'s ReducedSystem),
    /// The step is not finite.
    NonFinite { step_norm: f64 },
    /// The pass over the points at the trial point failed.
    Failed(Failure),
}

/// What a policy makes of a step.
pub(crate) enum Response {
    /// Move to the trial point. `keep_trial_system`: the trial point's
    /// system (built with [`StepPolicy::trial_lambda`]) is the next one to
    /// solve; otherwise it is built again with [`StepPolicy::lambda`].
    Accept { keep_trial_system: bool },
    /// Stay at the iterate and solve again with the policy's new `λ`.
    Reject,
    /// End the run at the iterate.
    End(Ending),
}

/// Why a run ends at an iterate.
pub(crate) enum Ending {
    /// The reduced matrix is not positive definite there.
    Singular(SpectrumDiagnostics),
    /// The iteration diverged.
    Diverged(String),
    /// A pass over the points failed at the trial point.
    Failed(Failure),
}

/// Decides on each step and on the damping of the next.
pub(crate) trait StepPolicy {
    /// `λ` of the systems solved at the iterate (0: undamped).
    fn lambda(&self) -> f64;
    /// `λ` to build a trial point's system with: the one the policy solves
    /// there if the step is accepted.
    fn trial_lambda(&self) -> f64;
    /// A step and its trial point's costs.
    fn judge(&mut self, trial: &Trial) -> Response;
    /// A step that cannot be judged by its cost.
    fn unusable(&mut self, why: Unusable<'_>) -> Response;
}

/// Gauss–Newton (Sato et al. 2004, eq. 5): the full step, always; the run
/// ends where there is none, and when the cost diverges.
pub(crate) struct GaussNewton {
    /// Diverged when the cost exceeds this times the initial cost.
    divergence_ratio: f64,
    /// Diverged when one step multiplies the cost by more than this.
    step_divergence_ratio: f64,
}

impl GaussNewton {
    pub(crate) fn new(options: &SolverOptions) -> Self {
        Self {
            divergence_ratio: options.divergence_ratio,
            step_divergence_ratio: options.step_divergence_ratio,
        }
    }
}

impl StepPolicy for GaussNewton {
    fn lambda(&self) -> f64 {
        0.0
    }

    fn trial_lambda(&self) -> f64 {
        0.0
    }

    fn judge(&mut self, trial: &Trial) -> Response {
        let (cost, initial) = (trial.trial_cost, trial.initial_cost);
        if !cost.is_finite() || cost > self.divergence_ratio * initial {
            return Response::End(Ending::Diverged(format!(
                "cost {cost:e} exceeds {:e} × initial cost {initial:e}",
                self.divergence_ratio
            )));
        }
        if cost > self.step_divergence_ratio * trial.cost {
            return Response::End(Ending::Diverged(format!(
                "a step raised the cost from {:e} to {cost:e}, more than {:e} times",
                trial.cost, self.step_divergence_ratio
            )));
        }
        Response::Accept {
            keep_trial_system: true,
        }
    }

    fn unusable(&mut self, why: Unusable<'_>) -> Response {
        Response::End(match why {
            Unusable::Singular(system) => Ending::Singular(SpectrumDiagnostics::of_symmetric(
                &system.matrix,
                system.size(),
            )),
            Unusable::NonFinite { step_norm } => {
                Ending::Diverged(format!("non-finite step (|δ| = {step_norm})"))
            }
            Unusable::Failed(failure) => Ending::Failed(failure),
        })
    }
}

/// Levenberg–Marquardt: a step is accepted if the cost decreases (gain
/// ratio `ρ > 0`); `λ` follows Nielsen (`λ·max(1/3, 1 − (2ρ−1)³)` on
/// acceptance, `λ·ν, ν ← 2ν` on rejection), except that a good step
/// (`ρ ≥ 0.75`) divides it by 3 and keeps the trial point's system, built
/// with that `λ`. A step that cannot be judged counts as a rejection.
pub(crate) struct LevenbergMarquardt {
    lambda: f64,
    /// Nielsen's growth factor of `λ` on rejection.
    nu: f64,
}

impl LevenbergMarquardt {
    pub(crate) fn new(initial_lambda: f64) -> Self {
        Self {
            lambda: initial_lambda,
            nu: 2.0,
        }
    }

    /// Rejects the step: `λ ← λν`, `ν ← 2ν`; the run ends when `λ` exceeds
    /// [`MAX_LAMBDA`].
    fn reject(&mut self) -> Response {
        self.lambda *= self.nu;
        self.nu *= 2.0;
        if self.lambda > MAX_LAMBDA {
            return Response::End(Ending::Diverged(format!(
                "damping λ exceeded {MAX_LAMBDA:e}"
            )));
        }
        Response::Reject
    }
}

impl StepPolicy for LevenbergMarquardt {
    fn lambda(&self) -> f64 {
        self.lambda
    }

    fn trial_lambda(&self) -> f64 {
        self.lambda * (1.0 / 3.0)
    }

    fn judge(&mut self, trial: &Trial) -> Response {
        let gain = if trial.trial_cost.is_finite() && trial.predicted_decrease > 0.0 {
            (trial.cost - trial.trial_cost) / trial.predicted_decrease
        } else {
            f64::NAN
        };
        if gain.is_nan() || gain <= 0.0 {
            return self.reject();
        }
        self.nu = 2.0;
        let keep_trial_system = gain >= GOOD_GAIN;
        self.lambda = if keep_trial_system {
            self.trial_lambda()
        } else {
            self.lambda * (1.0 / 3.0f64).max(1.0 - (2.0 * gain - 1.0).powi(3))
        };
        Response::Accept { keep_trial_system }
    }

    fn unusable(&mut self, _why: Unusable<'_>) -> Response {
        self.reject()
    }
}
