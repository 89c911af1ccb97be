//! How the solver iterates.

use std::time::Duration;

/// The iteration.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Method {
    /// Plain Gauss–Newton (Sato et al. 2004, eq. 5): the full step of the
    /// normal equations, no damping, no line search. It may diverge, and is
    /// allowed to. The default.
    #[default]
    GaussNewton,
    /// Levenberg–Marquardt with Marquardt's diagonal scaling: the normal
    /// matrix `H` is replaced by `H + λ·D`, `D = clamp(diag H, 1e-6, 1e32)`,
    /// the damping applied as extra rows at every level (point, group,
    /// global). Steps are accepted on a cost decrease; `λ` follows Nielsen's
    /// rule, except that a step with gain ratio ≥ 0.75 divides it by 3 (see the
    /// crate documentation).
    LevenbergMarquardt {
        /// The starting `λ` (dimensionless thanks to the diagonal scaling;
        /// `1e-4`…`1e-2` is typical).
        initial_lambda: f64,
    },
}

/// The default [`SolverOptions::sigma_tolerance`].
pub const SIGMA_TOLERANCE: f64 = 1e-3;

/// Iteration control.
#[derive(Clone, Debug, PartialEq)]
pub struct SolverOptions {
    /// Gauss–Newton or Levenberg–Marquardt.
    pub method: Method,
    /// Maximum number of linear solves (for LM, rejected steps count too).
    /// Zero evaluates the initial state only (cost, covariance, spectrum).
    pub max_iterations: usize,
    /// Converged when `|δ| / (|x| + 1) < step_tolerance`, norms over all
    /// unknowns: the run ends at `x`, without applying `δ`.
    pub step_tolerance: f64,
    /// Converged, too, when an undamped step is below this many standard
    /// deviations, `√(δᵀHδ) < sigma_tolerance`: it would move no unknown,
    /// nor any linear function of them (a centre, a predicted pose error),
    /// by more than `sigma_tolerance` of its posterior standard deviation,
    /// and the cost by less than `sigma_tolerance²`
    /// ([`IterationRecord::step_sigmas`](crate::IterationRecord::step_sigmas));
    /// the run ends at `x`. 0: off (the step tolerance alone). Damped
    /// (Levenberg–Marquardt) steps are judged by the step tolerance alone:
    /// a short damped step does not say the minimum is near.
    pub sigma_tolerance: f64,
    /// Gauss–Newton: diverged when the cost exceeds `divergence_ratio ×
    /// initial cost`.
    pub divergence_ratio: f64,
    /// Gauss–Newton: diverged when one step multiplies the cost by more
    /// than this (a full step that overshot by orders of magnitude, from
    /// which the iteration would seldom recover; the run ends at the
    /// iterate the step started from). Levenberg–Marquardt rejects such a
    /// step instead. The default is well above the largest rise seen in
    /// converging calibrations (which start far from the solution).
    pub step_divergence_ratio: f64,
    /// A wall-clock budget: when it has passed, the run ends at the current
    /// iterate with [`Status::TimeLimit`](crate::Status::TimeLimit)
    /// (checked before each linear solve, so a zero budget evaluates the
    /// initial state only, as `max_iterations = 0` does). `None`: no
    /// budget. A run that ends on it depends on the machine's speed, not on
    /// its inputs alone.
    pub time_limit: Option<Duration>,
    /// Whether a run's end computes the groups' marginal sigmas
    /// ([`Solution::group_sigmas`](crate::Solution::group_sigmas), one more
    /// pass over the points). A caller that makes the redundancy pass
    /// ([`redundancy`](crate::redundancy())), which gives them as well, or
    /// [`group_sigmas`](crate::group_sigmas()) when it needs them, turns it
    /// off.
    pub group_sigmas: bool,
    /// Whether the groups that dominate a step are refined before its
    /// trial point is evaluated: local Gauss–Newton steps of their own
    /// unknowns, the global block fixed ([`crate::refine`]). Least squares
    /// with the sigma tolerance on only.
    pub refine_groups: bool,
    /// The most local steps of each group after the back-substitution of a
    /// step while the iteration has not settled: Gauss–Newton steps of its
    /// own unknowns and its points' against their rows at the new global
    /// block, predicted to first order (`crate::local`; for a problem with
    /// [`Problem::local_rows`](crate::Problem::local_rows)). 0: none.
    pub local_steps: usize,
    /// Groups per unit of parallel work. The partial reduced systems are
    /// summed in chunk order, so results depend on this number but not on the
    /// number of threads.
    pub groups_per_chunk: usize,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            method: Method::GaussNewton,
            max_iterations: 50,
            step_tolerance: 1e-10,
            sigma_tolerance: SIGMA_TOLERANCE,
            divergence_ratio: 1e6,
            step_divergence_ratio: 1e5,
            time_limit: None,
            group_sigmas: true,
            refine_groups: true,
            local_steps: 2,
            groups_per_chunk: 64,
        }
    }
}
