//! The iteration: Gauss–Newton (full steps) or Levenberg–Marquardt (damped,
//! gain-ratio acceptance, Nielsen's `λ` update), and the final evaluation
//! (covariance, group sigmas, spectrum).

use std::mem::swap;

use nalgebra::{DMatrix, DVector};

use crate::context::Context;
use crate::diagnostics::SpectrumDiagnostics;
use crate::eliminate::Failure;
use crate::monitor::{Iterate, Monitor, Verdict};
use crate::options::{Method, SolverOptions};
use crate::problem::{Problem, State};
use crate::reduced::{ReducedSystem, ScaledCholesky};
use crate::solution::{IterationRecord, Solution, Status};

/// LM gives up when `λ` grows beyond this.
const MAX_LAMBDA: f64 = 1e32;
/// An LM step with at least this gain ratio divides `λ` by 3 (and reuses the
/// trial point's system, built with that damping); a weaker accepted step
/// follows Nielsen's `λ · max(1/3, 1 − (2ρ − 1)³)`.
const GOOD_GAIN: f64 = 0.75;

/// Solves the problem from `initial`; `observer` sees every history record
/// as it is made. Never panics on bad numerics; see [`Status`] for how a run
/// can end, and [`Solution`] for what is returned.
pub fn solve<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    initial: State<C, P>,
    options: &SolverOptions,
    mut observer: &mut dyn FnMut(&IterationRecord),
) -> Solution<C, P> {
    solve_with_caches(problem, initial, &mut Vec::new(), options, &mut observer)
}

/// [`solve`] with the points' caches given (e.g. warm starts computed with
/// the initial estimate) instead of [`Problem::initial_cache`] (empty: from
/// `initial_cache`), and a [`Monitor`] that sees each iterate and may stop
/// the run there. On return `caches` holds those of the run's last pass over
/// the points: the warm starts of a follow-up run from the solution.
pub fn solve_with_caches<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    initial: State<C, P>,
    caches: &mut Vec<Pr::PointCache>,
    options: &SolverOptions,
    monitor: &mut dyn Monitor<C, P, Pr::PointCache>,
) -> Solution<C, P> {
    let invalid = |state, message: String| Solution {
        state,
        status: Status::InvalidProblem { message },
        history: Vec::new(),
        covariance: None,
        group_sigmas: None,
        group_costs: None,
        spectrum: None,
    };
    if let Method::LevenbergMarquardt { initial_lambda } = options.method
        && !(initial_lambda > 0.0 && initial_lambda <= MAX_LAMBDA)
    {
        return invalid(
            initial,
            format!("initial_lambda must be in (0, 1e32], got {initial_lambda}"),
        );
    }
    match Context::new(problem, &initial, caches, options.groups_per_chunk) {
        Ok(ctx) => Run {
            ctx,
            options,
            monitor,
            history: Vec::new(),
        }
        .run(initial),
        Err(message) => invalid(initial, message),
    }
}

/// `a += b`.
fn add_into<const C: usize, const P: usize>(a: &mut State<C, P>, b: &State<C, P>) {
    a.global += &b.global;
    for (x, y) in a.groups.iter_mut().zip(&b.groups) {
        *x += y;
    }
    for (x, y) in a.points.iter_mut().zip(&b.points) {
        *x += y;
    }
}

/// How a run ends when a pass over the points fails after `solves` linear
/// solves: a non-finite evaluation is the problem's failure at the initial
/// state and a divergence after a step.
fn status_of(failure: Failure, solves: usize) -> Status {
    let at = |point: Option<usize>| match point {
        Some(point) => format!("point {point}"),
        None => "the global observations".to_string(),
    };
    match failure {
        Failure::Linearize { point, message } => Status::ProblemFailed {
            iteration: solves,
            point,
            message,
        },
        Failure::NonFinite { point } if solves == 0 => Status::ProblemFailed {
            iteration: 0,
            point,
            message: "non-finite residual or Jacobian".into(),
        },
        Failure::NonFinite { point } => Status::Diverged {
            iteration: solves,
            reason: format!("non-finite residual or Jacobian at {}", at(point)),
        },
        Failure::Singular(block) => Status::SingularBlock {
            iteration: solves,
            block,
        },
    }
}

/// One linear step of the Schur solver, as [`linear_step`] returns it.
#[derive(Clone, Debug)]
pub struct LinearStep<const C: usize, const P: usize> {
    /// The step `δ`, laid out like the state.
    pub delta: State<C, P>,
    /// The cost at the state.
    pub cost: f64,
    /// The decrease of the linearised cost predicted for `δ`
    /// (`−2bᵀδ − δᵀHδ`, priors included).
    pub predicted_decrease: f64,
}

/// One step of the Schur solver at `state`, with Marquardt damping `lambda`
/// (0: the Gauss–Newton step): `(H + λD) δ = −b`, without applying it.
/// `caches` are the points' caches, as [`solve_with_caches`] takes them
/// (empty: from [`Problem::initial_cache`]); on return they hold those of
/// the step's last pass, the warm starts of a following step. Meant for
/// checks against [`dense_reference`](crate::dense_reference) and for
/// benchmarks. Fails with the [`Status`] that [`solve`] would end with at
/// this point.
pub fn linear_step<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    caches: &mut Vec<Pr::PointCache>,
    lambda: f64,
    groups_per_chunk: usize,
) -> Result<LinearStep<C, P>, Status> {
    let failed = |f| status_of(f, 0);
    let mut ctx = Context::new(problem, state, caches, groups_per_chunk)
        .map_err(|message| Status::InvalidProblem { message })?;
    let system = ctx.reduce(state, lambda.max(0.0)).map_err(failed)?;
    let factor =
        ScaledCholesky::new(&system.matrix, system.size()).ok_or_else(|| Status::Singular {
            iteration: 0,
            diagnostics: Box::new(SpectrumDiagnostics::of_symmetric(
                &system.matrix,
                system.size(),
            )),
        })?;
    let neg_b: Vec<f64> = system.rhs.iter().map(|b| -b).collect();
    let dg = DVector::from_vec(factor.solve(&neg_b));
    let mut delta = state.clone();
    let summary = ctx
        .back_substitute(state, &system, &dg, &mut delta)
        .map_err(failed)?;
    Ok(LinearStep {
        delta,
        cost: system.cost(),
        predicted_decrease: summary.predicted_decrease(),
    })
}

struct Run<'o, 'a, const C: usize, const P: usize, const R: usize, Pr>
where
    Pr: Problem<C, P, R>,
{
    ctx: Context<'a, C, P, R, Pr>,
    options: &'o SolverOptions,
    monitor: &'o mut dyn Monitor<C, P, Pr::PointCache>,
    history: Vec<IterationRecord>,
}

impl<const C: usize, const P: usize, const R: usize, Pr> Run<'_, '_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    fn record(&mut self, system: &ReducedSystem, step_norm: f64, lambda: f64, accepted: bool) {
        let record = IterationRecord {
            cost: system.cost(),
            data_cost: system.data_cost,
            global_observation_cost: system.global_observation_cost,
            prior_cost: system.prior_cost,
            step_norm,
            lambda,
            accepted,
        };
        self.monitor.record(&record);
        self.history.push(record);
    }

    /// Shows the monitor the new iterate `x`, whose system is `system`.
    fn inspect(
        &mut self,
        x: &State<C, P>,
        system: &ReducedSystem,
        previous_cost: Option<f64>,
    ) -> Verdict {
        self.monitor.inspect(&Iterate {
            state: x,
            solves: self.history.len(),
            cost: system.cost(),
            previous_cost,
            group_costs: &system.group_costs,
            caches: self.ctx.caches,
        })
    }

    fn end(self, state: State<C, P>, status: Status) -> Solution<C, P> {
        Solution {
            state,
            status,
            history: self.history,
            covariance: None,
            group_sigmas: None,
            group_costs: None,
            spectrum: None,
        }
    }

    /// Ends the run at `state` because a pass over the points failed after
    /// `solves` linear solves.
    fn fail(self, state: State<C, P>, solves: usize, failure: Failure) -> Solution<C, P> {
        self.end(state, status_of(failure, solves))
    }

    fn diverged(self, state: State<C, P>, solves: usize, reason: String) -> Solution<C, P> {
        self.end(
            state,
            Status::Diverged {
                iteration: solves,
                reason,
            },
        )
    }

    fn run(mut self, initial: State<C, P>) -> Solution<C, P> {
        let options = self.options;
        let damped = match options.method {
            Method::GaussNewton => None,
            Method::LevenbergMarquardt { initial_lambda } => Some(initial_lambda),
        };
        let mut lambda = damped.unwrap_or(0.0);
        let mut nu = 2.0;
        let mut x = initial;
        let mut trial = x.clone();
        let mut system = match self.ctx.reduce(&x, lambda) {
            Ok(s) => s,
            Err(f) => return self.fail(x, 0, f),
        };
        let initial_cost = system.cost();
        if !initial_cost.is_finite() {
            return self.diverged(x, 0, format!("initial cost is {initial_cost}"));
        }
        // The cost of the iterate before `x`, and whether the monitor has
        // not seen `x` yet (an LM rejection keeps the iterate).
        let mut previous_cost = None;
        let mut new_iterate = true;
        loop {
            let solves = self.history.len();
            if solves >= options.max_iterations {
                return self.finish(x, system, 0.0, Status::IterationLimit);
            }
            if !system.is_finite() {
                return self.diverged(x, solves, "non-finite reduced system".into());
            }
            if new_iterate {
                new_iterate = false;
                if self.inspect(&x, &system, previous_cost) == Verdict::Stop {
                    return self.end(x, Status::Stopped { iteration: solves });
                }
            }
            let Some(factor) = ScaledCholesky::new(&system.matrix, system.size()) else {
                if damped.is_none() {
                    let diagnostics =
                        SpectrumDiagnostics::of_symmetric(&system.matrix, system.size());
                    self.record(&system, 0.0, 0.0, true);
                    let mut solution = self.end(
                        x,
                        Status::Singular {
                            iteration: solves,
                            diagnostics: Box::new(diagnostics.clone()),
                        },
                    );
                    solution.spectrum = Some(diagnostics);
                    return solution;
                }
                // LM: numerically not positive definite despite the damping.
                self.record(&system, 0.0, lambda, false);
                lambda *= nu;
                nu *= 2.0;
                if lambda > MAX_LAMBDA {
                    return self.diverged(
                        x,
                        solves + 1,
                        format!("damping λ exceeded {MAX_LAMBDA:e}"),
                    );
                }
                system = match self.ctx.reduce(&x, lambda) {
                    Ok(s) => s,
                    Err(f) => return self.fail(x, solves + 1, f),
                };
                continue;
            };
            let neg_b: Vec<f64> = system.rhs.iter().map(|b| -b).collect();
            let dg = DVector::from_vec(factor.solve(&neg_b));
            let summary = match self.ctx.back_substitute(&x, &system, &dg, &mut trial) {
                Ok(s) => s,
                Err(f) => return self.fail(x, solves, f),
            };
            add_into(&mut trial, &x);
            let step_norm = summary.delta_norm2.sqrt();
            let finite_step = step_norm.is_finite() && trial.is_finite();
            if !finite_step && damped.is_none() {
                self.record(&system, step_norm, lambda, false);
                return self.diverged(
                    x,
                    solves + 1,
                    format!("non-finite step (|δ| = {step_norm})"),
                );
            }
            let converged = finite_step
                && step_norm / (summary.state_norm2.sqrt() + 1.0) < options.step_tolerance;
            if converged {
                // The step from `x` is below the tolerance: `x` is the
                // solution, and everything reported is evaluated there (its
                // system is at hand; applying the step would cost one more
                // pass for a change below the tolerance).
                return self.finish(x, system, step_norm, Status::Converged);
            }
            if damped.is_none() {
                self.record(&system, step_norm, lambda, true);
                let next = match self.ctx.reduce(&trial, 0.0) {
                    Ok(s) => s,
                    Err(f) => return self.fail(x, solves + 1, f),
                };
                let cost = next.cost();
                if !cost.is_finite() || cost > options.divergence_ratio * initial_cost {
                    return self.diverged(
                        x,
                        solves + 1,
                        format!(
                            "cost {cost:e} exceeds {:e} × initial cost {initial_cost:e}",
                            options.divergence_ratio
                        ),
                    );
                }
                swap(&mut x, &mut trial);
                previous_cost = Some(system.cost());
                new_iterate = true;
                system = next;
                continue;
            }
            // Levenberg–Marquardt: evaluate the trial point, building its
            // system with the damping a good step gets next.
            let lambda_good = lambda * (1.0 / 3.0);
            let predicted = summary.predicted_decrease();
            let next = if finite_step {
                self.ctx.reduce(&trial, lambda_good).ok()
            } else {
                None
            };
            let gain = match &next {
                Some(n) if n.cost().is_finite() && predicted > 0.0 => {
                    (system.cost() - n.cost()) / predicted
                }
                _ => f64::NAN,
            };
            if gain > 0.0 {
                self.record(&system, step_norm, lambda, true);
                swap(&mut x, &mut trial);
                previous_cost = Some(system.cost());
                new_iterate = true;
                nu = 2.0;
                match next {
                    Some(n) if gain >= GOOD_GAIN => {
                        lambda = lambda_good;
                        system = n;
                    }
                    _ => {
                        lambda *= (1.0 / 3.0f64).max(1.0 - (2.0 * gain - 1.0).powi(3));
                        system = match self.ctx.reduce(&x, lambda) {
                            Ok(s) => s,
                            Err(f) => return self.fail(x, solves + 1, f),
                        };
                    }
                }
            } else {
                self.record(&system, step_norm, lambda, false);
                lambda *= nu;
                nu *= 2.0;
                if lambda > MAX_LAMBDA {
                    return self.diverged(
                        x,
                        solves + 1,
                        format!("damping λ exceeded {MAX_LAMBDA:e}"),
                    );
                }
                system = match self.ctx.reduce(&x, lambda) {
                    Ok(s) => s,
                    Err(f) => return self.fail(x, solves + 1, f),
                };
            }
        }
    }

    /// The final record (with `step_norm`, the norm of the step computed
    /// there and not applied, 0 if none), covariance, group sigmas and
    /// spectrum at `state`.
    fn finish(
        mut self,
        state: State<C, P>,
        mut system: ReducedSystem,
        step_norm: f64,
        status: Status,
    ) -> Solution<C, P> {
        let solves = self.history.len();
        if system.lambda > 0.0 {
            system = match self.ctx.reduce(&state, 0.0) {
                Ok(s) => s,
                Err(f) => return self.fail(state, solves, f),
            };
        }
        self.record(&system, step_norm, 0.0, true);
        let spectrum = system
            .is_finite()
            .then(|| SpectrumDiagnostics::of_symmetric(&system.matrix, system.size()));
        let covariance = system
            .is_finite()
            .then(|| ScaledCholesky::new(&system.matrix, system.size()))
            .flatten()
            .map(|f| DMatrix::from_row_slice(system.size(), system.size(), &f.inverse()));
        let group_sigmas = covariance
            .as_ref()
            .and_then(|cov| self.ctx.group_sigmas(&state, cov).ok());
        let mut solution = self.end(state, status);
        solution.covariance = covariance;
        solution.group_sigmas = group_sigmas;
        solution.group_costs = Some(system.group_costs);
        solution.spectrum = spectrum;
        solution
    }
}
