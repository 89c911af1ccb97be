//! A Gauss-Newton run that runs away, made again with Levenberg-Marquardt
//! ([`RunAway`]): the rule of every calibration, the hexapod's own
//! ([`calibrate`](crate::calibrate)) and a mechanism's
//! ([`calibrate_mechanism`](crate::mechanism::calibrate_mechanism)).

use parcal_solver::{Method, Status};

use crate::options::{GAUSS_NEWTON_ITERATIONS, LEVENBERG_MARQUARDT_ITERATIONS};

/// The rise of the cost in one Gauss-Newton step that marks a run that
/// did not converge as run away ([`RunAway`]).
pub const RUNAWAY_RISE: f64 = 10.0;

/// How a Gauss-Newton run that ran away ended.
///
/// A Gauss-Newton run runs away when it ends diverged, or failed after its
/// first step (a full step to where the machine's kinematics fails: a
/// blunder or a start far from the solution, where full steps overshoot),
/// or at its iteration limit after a step raised the cost more than
/// tenfold (`RUNAWAY_RISE`), or with a cost above its first, or with a robust
/// loss (its reweighting can keep full steps from settling where damped
/// ones do). It is then made again with Levenberg-Marquardt, whose steps
/// never raise the cost, within what is left of the time limit and four
/// times its iteration limit, at most Levenberg-Marquardt's default, 200.
#[derive(Debug, Clone, PartialEq)]
pub struct RunAway {
    /// Its status.
    pub status: Status,
    /// Its cost at the start.
    pub initial_cost: f64,
    /// Its cost at its end.
    pub final_cost: f64,
    /// Its iterations: the linear solves before it ended.
    pub iterations: usize,
}

impl RunAway {
    /// The run of method `method` that ended with `status` after the
    /// iterates of costs `costs` (the solver's records, in order), when it
    /// is a Gauss-Newton run that ran away (the type's doc); `None` otherwise,
    /// and for a run without an iterate. `squared`: whether its loss is
    /// least squares.
    pub(crate) fn of(
        method: Method,
        status: &Status,
        costs: &[f64],
        squared: bool,
    ) -> Option<Self> {
        let (&first, &last) = costs.first().zip(costs.last())?;
        let overshot = costs
            .windows(2)
            .any(|pair| pair[1] > RUNAWAY_RISE * pair[0]);
        let ran_away = matches!(method, Method::GaussNewton)
            && match status {
                Status::Diverged { .. } => true,
                Status::ProblemFailed { iteration, .. } => *iteration > 0,
                Status::IterationLimit => overshot || last > first || !squared,
                _ => false,
            };
        let iterations = match status {
            Status::Diverged { iteration, .. } | Status::ProblemFailed { iteration, .. } => {
                *iteration
            }
            _ => costs.len() - 1,
        };
        ran_away.then(|| Self {
            status: status.clone(),
            initial_cost: first,
            final_cost: last,
            iterations,
        })
    }
}

/// The iteration limit of the Levenberg-Marquardt run made again after a
/// Gauss-Newton run of limit `limit` ran away: the default limits'
/// proportion, [`LEVENBERG_MARQUARDT_ITERATIONS`] damped steps for
/// [`GAUSS_NEWTON_ITERATIONS`] full ones, at most the former, so that a
/// limit given bounds the run made again too (3 allows 12).
pub(crate) fn rerun_iterations(limit: usize) -> usize {
    let ratio = LEVENBERG_MARQUARDT_ITERATIONS / GAUSS_NEWTON_ITERATIONS;
    limit
        .saturating_mul(ratio)
        .min(LEVENBERG_MARQUARDT_ITERATIONS)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_gauss_newton_run_runs_away_as_the_rule_says() {
        let gn = Method::GaussNewton;
        let failed = |iteration| Status::ProblemFailed {
            iteration,
            point: Some(3),
            message: "unreachable".into(),
        };
        let settled = [5.0, 2.0, 1.0];
        // Failed after its first step, not at its start.
        let away = RunAway::of(gn, &failed(1), &settled[..2], true).unwrap();
        assert_eq!(
            (away.initial_cost, away.final_cost, away.iterations),
            (5.0, 2.0, 1)
        );
        let later = RunAway::of(gn, &failed(4), &settled[..2], true).unwrap();
        assert_eq!(later.iterations, 4, "the solves before the failed step");
        assert!(RunAway::of(gn, &failed(0), &settled[..1], true).is_none());
        // At its limit: after a rise of more than RUNAWAY_RISE, above its
        // first cost, or with a robust loss; not when it settled lower.
        let limit = Status::IterationLimit;
        assert!(RunAway::of(gn, &limit, &[5.0, 51.0, 4.0], true).is_some());
        assert!(RunAway::of(gn, &limit, &[5.0, 49.0, 4.0], true).is_none());
        assert!(RunAway::of(gn, &limit, &[5.0, 6.0], true).is_some());
        assert!(RunAway::of(gn, &limit, &settled, false).is_some());
        assert!(RunAway::of(gn, &limit, &settled, true).is_none());
        // Never Levenberg-Marquardt, nor a run without an iterate.
        let lm = Method::LevenbergMarquardt {
            initial_lambda: 1e-3,
        };
        assert!(RunAway::of(lm, &failed(2), &settled, true).is_none());
        assert!(RunAway::of(gn, &failed(2), &[], true).is_none());
        assert_eq!((rerun_iterations(3), rerun_iterations(50)), (12, 200));
    }
}
