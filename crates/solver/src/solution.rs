//! What the solver returns.

use nalgebra::{DMatrix, SVector};

use crate::diagnostics::SpectrumDiagnostics;
use crate::problem::State;

/// One line of the residual history. With a robust loss
/// ([`Problem::loss`](crate::Problem::loss)) the costs are those of the rows
/// as weighted at this iterate (the reweighted problem's), not the loss.
#[derive(Clone, Debug, PartialEq)]
pub struct IterationRecord {
    /// Total cost at the iterate before the step (`data_cost +
    /// global_observation_cost + prior_cost`).
    pub cost: f64,
    /// `Σ |r_i|²` over the points.
    pub data_cost: f64,
    /// `|r_o|²` of the global observations
    /// ([`Problem::global_observations`](crate::Problem::global_observations);
    /// 0 without them).
    pub global_observation_cost: f64,
    /// Sum of the prior terms.
    pub prior_cost: f64,
    /// `|δ|` over all unknowns of the step computed at this iterate. For the
    /// final iterate of a converged run, the step below the tolerance that
    /// certified convergence and was not applied; when the reduced system
    /// alone certified it (a Gauss–Newton step of least squares below the
    /// sigma tolerance, whose back-substitution is then not made), the
    /// norm of its global part `|δg|`; 0 when no step was computed there.
    pub step_norm: f64,
    /// The same step in standard deviations, `√(δᵀHδ)` (`H` the undamped
    /// normal matrix, priors included): no unknown, nor any linear function
    /// of them, moves by more than this many of its posterior standard
    /// deviations (Cauchy–Schwarz: `|aᵀδ| ≤ √(aᵀH⁻¹a) √(δᵀHδ)`); the
    /// linearised cost falls by its square. 0 when no step was computed.
    pub step_sigmas: f64,
    /// The damping `λ` of the step (0 for Gauss–Newton).
    pub lambda: f64,
    /// Whether the step was taken: the next record, if any, is at its trial
    /// point. A rejected Levenberg–Marquardt step leaves the iterate
    /// unchanged, and the next record has the same cost with a larger `λ`.
    /// A step that ends the run (singular reduced matrix, divergence, a
    /// failed evaluation) is not taken: the run ends at the iterate it
    /// started from. Every other Gauss–Newton step is taken.
    pub accepted: bool,
}

/// Which small block was found singular.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlockId {
    /// The block of this point.
    Point(usize),
    /// The block of this group (after eliminating its points).
    Group(usize),
}

/// How a run ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Status {
    /// The step computed at the returned state is below the step tolerance,
    /// or (undamped) below the sigma tolerance
    /// ([`SolverOptions::sigma_tolerance`](crate::SolverOptions::sigma_tolerance));
    /// it was not applied, so that the state, its cost, the covariance and
    /// the group sigmas all belong to the one iterate the test certified.
    Converged,
    /// `max_iterations` linear solves without convergence.
    IterationLimit,
    /// The options' `time_limit` passed before convergence: the run ends at
    /// the iterate it had reached, evaluated as at the iteration limit.
    TimeLimit,
    /// Gauss–Newton: the cost became non-finite, exceeded
    /// `divergence_ratio × initial`, or one step multiplied it by more than
    /// `step_divergence_ratio`; any method: a step or linearisation became
    /// non-finite, or (LM) the damping grew without bound.
    ///
    /// In every variant, `iteration` counts the linear solves done before the
    /// event (0: at the initial state); for Gauss–Newton it is the index of
    /// the iterate at which the event was found.
    Diverged {
        /// Linear solves before the event.
        iteration: usize,
        /// What happened, with numbers.
        reason: String,
    },
    /// Gauss–Newton: the reduced `G × G` matrix is not numerically positive
    /// definite at this iterate.
    Singular {
        /// Linear solves before the event.
        iteration: usize,
        /// Spectrum of the reduced matrix and its weakest directions.
        diagnostics: Box<SpectrumDiagnostics>,
    },
    /// Gauss–Newton: a point block, or a group block after eliminating its
    /// points, has (numerically) dependent columns at this iterate: that
    /// point's or group's unknowns are not determined by its residuals and
    /// priors.
    SingularBlock {
        /// Linear solves before the event.
        iteration: usize,
        /// The block.
        block: BlockId,
    },
    /// The problem's `linearize` or `global_observations` returned an error
    /// (at iterate 0 also: a non-finite residual or Jacobian).
    ProblemFailed {
        /// Linear solves before the event.
        iteration: usize,
        /// The point (the smallest failing index); `None`: the global
        /// observations.
        point: Option<usize>,
        /// The error's message.
        message: String,
    },
    /// The [`Monitor`](crate::Monitor) stopped the run at the returned state,
    /// before a step was computed there (no record for it in the history).
    Stopped {
        /// Linear solves before the event.
        iteration: usize,
    },
    /// The problem's structure does not match the initial state (group ranges
    /// not a partition, wrong numbers of blocks, non-finite initial values,
    /// zero `groups_per_chunk`), or the covariance given to
    /// [`redundancy`](crate::redundancy) is not `G × G` positive definite.
    /// Nothing was evaluated.
    InvalidProblem {
        /// What is wrong.
        message: String,
    },
}

/// The result of [`solve`](crate::solve).
#[derive(Clone, Debug)]
pub struct Solution<const C: usize, const P: usize> {
    /// The last iterate whose cost was evaluated and acceptable (finite; never
    /// NaN). After a divergent step, the iterate it started from.
    pub state: State<C, P>,
    /// How the run ended.
    pub status: Status,
    /// One record per linear solve whose step was taken or rejected, and one
    /// for the final iterate when the run ends at an evaluated iterate (its
    /// `step_norm`: the converged step, or 0).
    pub history: Vec<IterationRecord>,
    /// Inverse of the undamped reduced matrix at the final state (the marginal
    /// covariance of the global block, given unit-variance whitened
    /// residuals); `None` if it is not positive definite or the run did not
    /// end with `Converged`, `IterationLimit` or `TimeLimit`.
    pub covariance: Option<DMatrix<f64>>,
    /// Marginal standard deviations of each group block (including the global
    /// uncertainty; zero for a fixed group); present whenever `covariance`
    /// is, unless [`SolverOptions::group_sigmas`](crate::SolverOptions::group_sigmas)
    /// is off.
    pub group_sigmas: Option<Vec<SVector<f64, C>>>,
    /// Each group's data cost `Σ |r_i|²` over its points at the final state
    /// (whitened: a goodness-of-fit statistic per group); present when the
    /// run ended with `Converged`, `IterationLimit` or `TimeLimit`.
    pub group_costs: Option<Vec<f64>>,
    /// Spectrum of the undamped reduced matrix at the final state: for
    /// `Converged`, `IterationLimit`, `TimeLimit` and `Singular`.
    pub spectrum: Option<SpectrumDiagnostics>,
}
