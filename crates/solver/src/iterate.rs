//! The iteration: one loop that solves a step, evaluates its trial point and
//! leaves the decision to a step policy ([`crate::policy`]: Gauss–Newton or
//! Levenberg–Marquardt), and the final evaluation (covariance, group
//! sigmas, spectrum).

use std::mem::swap;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};

use crate::backsub::StepSummary;
use crate::chunked_problem::ChunkedProblem;
use crate::diagnostics::SpectrumDiagnostics;
use crate::eliminate::Failure;
use crate::local::LocalSteps;
use crate::monitor::{Decision, Iterate, Monitor};
use crate::options::{Method, SolverOptions};
use crate::policy::{
    Ending, GaussNewton, LevenbergMarquardt, MAX_LAMBDA, Response, StepPolicy, Trial, Unusable,
};
use crate::problem::{Problem, State};
use crate::reduced::{ReducedSystem, ScaledCholesky, covariance_factor};
use crate::refine::SETTLED;
use crate::solution::{IterationRecord, Solution, Status};

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
    let run = match ChunkedProblem::new(problem, &initial, caches, options.groups_per_chunk) {
        Ok(ctx) => Run {
            ctx,
            options,
            monitor,
            history: Vec::new(),
        },
        Err(message) => return invalid(initial, message),
    };
    match options.method {
        Method::GaussNewton => run.run(initial, &mut GaussNewton::new(options)),
        Method::LevenbergMarquardt { initial_lambda } => {
            run.run(initial, &mut LevenbergMarquardt::new(initial_lambda))
        }
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
pub(crate) fn status_of(failure: Failure, solves: usize) -> Status {
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

impl Ending {
    /// How a run ends here after `solves` linear solves, the step that led
    /// here counted (a singular system had none).
    fn status(self, solves: usize) -> Status {
        match self {
            Ending::Singular(diagnostics) => Status::Singular {
                iteration: solves,
                diagnostics: Box::new(diagnostics),
            },
            Ending::Diverged(reason) => Status::Diverged {
                iteration: solves + 1,
                reason,
            },
            Ending::Failed(failure) => status_of(failure, solves + 1),
        }
    }
}

impl<const C: usize, const P: usize, const R: usize, Pr> ChunkedProblem<'_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// The step `δ` of `system` (built at `state`) into `delta`, laid out
    /// like the state, from its global part `global` ([`global_step`]);
    /// `None` if there is none (the reduced matrix is not numerically
    /// positive definite).
    fn step(
        &mut self,
        state: &State<C, P>,
        system: &ReducedSystem,
        global: Option<&DVector<f64>>,
        local: Option<LocalSteps>,
        delta: &mut State<C, P>,
    ) -> Result<Option<StepSummary>, Failure> {
        match global {
            Some(dg) => self
                .back_substitute(state, system, dg, local, delta)
                .map(Some),
            None => Ok(None),
        }
    }
}

/// The step's global part `δg = −S⁻¹b` of `system`; `None` if the reduced
/// matrix is not numerically positive definite.
fn global_step(system: &ReducedSystem) -> Option<DVector<f64>> {
    let factor = ScaledCholesky::new(&system.matrix, system.size())?;
    let neg_b: Vec<f64> = system.rhs.iter().map(|b| -b).collect();
    Some(DVector::from_vec(factor.solve(&neg_b)))
}

/// The Gauss–Newton step of `system` (least squares, undamped) when the
/// reduced system alone certifies it below `tolerance` standard
/// deviations, so that its back-substitution is not needed: with `δg =
/// −S⁻¹b`, the decrease of the linearised cost is `δᵀHδ = (cost − ρ) −
/// bᵀδg`, `ρ` the cost left once the points and groups are eliminated (the
/// decrease their own steps give) and `−bᵀδg = bᵀS⁻¹b` the global block's.
/// Both are non-negative in exact arithmetic; rounding leaves their sum
/// within a few `ε · cost` of the back-substitution's `−bᵀδ`, far below
/// `tolerance²` for whitened rows. Its size is `|δg|`, the step's global
/// part: the local parts are not computed
/// ([`IterationRecord::step_norm`]).
fn certified_step(system: &ReducedSystem, dg: &DVector<f64>, tolerance: f64) -> Option<StepSize> {
    if system.lambda != 0.0 || system.loss_cost.is_some() {
        return None;
    }
    let quadratic = system.cost() - system.linear_minimum(dg.as_slice());
    let sigmas = quadratic.max(0.0).sqrt();
    (sigmas < tolerance).then(|| StepSize {
        norm: dg.norm(),
        sigmas,
    })
}

/// The local steps ([`crate::local`]) of the back-substitution of the
/// step `dg` of `system`, in a run whose initial loss was `initial_cost`:
/// up to [`SolverOptions::local_steps`] while the iteration has not
/// settled (the step's `δᵀHδ`, which the reduced system gives as in
/// [`certified_step`], at least [`SETTLED`] of the cost), each while it is
/// predicted to lower its group's cost by more than `(sigma_tolerance /
/// 10)²`. None once it has settled (the linear step then leaves each group
/// at its minimum to well within the stopping rule); none from an iterate
/// above the start, where a step has overshot and the anchors' first-order
/// predictions are no guide; none for a damped step (Levenberg–Marquardt
/// judges it against its linear model) or under a robust loss (whose
/// reweighting is the joint iteration's).
fn local_steps_of(
    system: &ReducedSystem,
    dg: &DVector<f64>,
    initial_cost: f64,
    options: &SolverOptions,
) -> Option<LocalSteps> {
    let cost = system.cost();
    let unsettled = cost - system.linear_minimum(dg.as_slice()) >= SETTLED * cost;
    let below_start = system.loss() <= initial_cost;
    let least_squares = system.loss_cost.is_none();
    let undamped = system.lambda == 0.0;
    let taken = least_squares && undamped && below_start && unsettled;
    (options.local_steps > 0 && taken).then(|| LocalSteps {
        steps: options.local_steps,
        least_decrease: (options.sigma_tolerance / 10.0).powi(2),
    })
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
    let mut ctx = ChunkedProblem::new(problem, state, caches, groups_per_chunk)
        .map_err(|message| Status::InvalidProblem { message })?;
    let system = ctx.reduce(state, lambda.max(0.0)).map_err(failed)?;
    let mut delta = state.clone();
    let summary = ctx
        .step(
            state,
            &system,
            global_step(&system).as_ref(),
            None,
            &mut delta,
        )
        .map_err(failed)?
        .ok_or_else(|| singular_at_start(&system))?;
    Ok(LinearStep {
        delta,
        cost: system.cost(),
        predicted_decrease: summary.predicted_decrease(),
    })
}

/// The size of a step: `|δ|` and `√(δᵀHδ)`
/// ([`IterationRecord::step_sigmas`]).
#[derive(Clone, Copy)]
struct StepSize {
    norm: f64,
    sigmas: f64,
}

impl StepSize {
    /// No step computed.
    const NONE: Self = Self {
        norm: 0.0,
        sigmas: 0.0,
    };
}

/// The global part of a Gauss–Newton step and the minimum of the
/// linearised cost it reaches, as [`reduced_step`] returns them.
#[derive(Clone, Debug)]
pub struct ReducedStep {
    /// The step's global part `δg = −S⁻¹b`.
    pub global: DVector<f64>,
    /// The cost at the state.
    pub cost: f64,
    /// The minimum of the linearised cost, priors included: `ρ − bᵀS⁻¹b`,
    /// `ρ` the cost left once the points and groups are eliminated (the
    /// same number as [`LinearStep`]'s `cost − predicted_decrease`, up to
    /// rounding).
    pub minimum: f64,
}

/// The Gauss–Newton step's global part at `state` and the minimum of the
/// linearised cost, from the reduced system alone: one pass over the
/// points, no back-substitution and no copy of the state. `caches` as
/// [`linear_step`] takes them. Fails with the [`Status`] that [`solve`]
/// would end with at this point.
pub fn reduced_step<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    caches: &mut Vec<Pr::PointCache>,
    groups_per_chunk: usize,
) -> Result<ReducedStep, Status> {
    let mut ctx = ChunkedProblem::new(problem, state, caches, groups_per_chunk)
        .map_err(|message| Status::InvalidProblem { message })?;
    let system = ctx.reduce(state, 0.0).map_err(|f| status_of(f, 0))?;
    let global = global_step(&system).ok_or_else(|| singular_at_start(&system))?;
    Ok(ReducedStep {
        minimum: system.linear_minimum(global.as_slice()),
        cost: system.cost(),
        global,
    })
}

/// How a run ends at its initial state when `system`, built there, is
/// singular.
fn singular_at_start(system: &ReducedSystem) -> Status {
    let diagnostics = SpectrumDiagnostics::of_symmetric(&system.matrix, system.size());
    Ending::Singular(diagnostics).status(0)
}

struct Run<'o, 'a, const C: usize, const P: usize, const R: usize, Pr>
where
    Pr: Problem<C, P, R>,
{
    ctx: ChunkedProblem<'a, C, P, R, Pr>,
    options: &'o SolverOptions,
    monitor: &'o mut dyn Monitor<C, P, Pr::PointCache>,
    history: Vec<IterationRecord>,
}

impl<const C: usize, const P: usize, const R: usize, Pr> Run<'_, '_, C, P, R, Pr>
where
    Pr: Problem<C, P, R>,
{
    /// Records the step solved from `system` (its `λ`; 0 if none).
    fn record(&mut self, system: &ReducedSystem, step: StepSize, accepted: bool) {
        let record = IterationRecord {
            cost: system.cost(),
            data_cost: system.data_cost,
            global_observation_cost: system.global_observation_cost,
            prior_cost: system.prior_cost,
            step_norm: step.norm,
            step_sigmas: step.sigmas,
            lambda: system.lambda,
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
    ) -> Decision {
        self.monitor.inspect(&Iterate {
            state: x,
            solves: self.history.len(),
            cost: system.loss(),
            previous_cost,
            group_costs: &system.group_costs,
            caches: self.ctx.caches,
        })
    }

    /// The solution at `state`, without the final evaluation; with the
    /// spectrum when the reduced matrix was found singular.
    fn end(self, state: State<C, P>, status: Status) -> Solution<C, P> {
        let spectrum = match &status {
            Status::Singular { diagnostics, .. } => Some((**diagnostics).clone()),
            _ => None,
        };
        Solution {
            state,
            status,
            history: self.history,
            covariance: None,
            group_sigmas: None,
            group_costs: None,
            spectrum,
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

    /// The iteration from `initial`, each step judged by `policy`.
    fn run(mut self, initial: State<C, P>, policy: &mut impl StepPolicy) -> Solution<C, P> {
        let options = self.options;
        let started = Instant::now();
        let mut x = initial;
        let mut trial = x.clone();
        let mut system = match self.ctx.reduce(&x, policy.lambda()) {
            Ok(s) => s,
            Err(f) => return self.fail(x, 0, f),
        };
        let initial_cost = system.loss();
        if !initial_cost.is_finite() {
            return self.diverged(x, 0, format!("initial cost is {initial_cost}"));
        }
        // The cost of the iterate before `x`, and whether the monitor has
        // not seen `x` yet (a rejection keeps the iterate).
        let mut previous_cost = None;
        let mut new_iterate = true;
        loop {
            let solves = self.history.len();
            if solves >= options.max_iterations {
                return self.finish(x, system, StepSize::NONE, Status::IterationLimit);
            }
            if options
                .time_limit
                .is_some_and(|limit| started.elapsed() >= limit)
            {
                return self.finish(x, system, StepSize::NONE, Status::TimeLimit);
            }
            if !system.is_finite() {
                return self.diverged(x, solves, "non-finite reduced system".into());
            }
            if new_iterate {
                new_iterate = false;
                if self.inspect(&x, &system, previous_cost) == Decision::Stop {
                    return self.end(x, Status::Stopped { iteration: solves });
                }
            }
            let global = global_step(&system);
            if let Some(step) = global
                .as_ref()
                .and_then(|dg| certified_step(&system, dg, options.sigma_tolerance))
            {
                return self.finish(x, system, step, Status::Converged);
            }
            // The step into `trial` and the policy's response; the trial
            // point's system if it was built.
            let local =
                (global.as_ref()).and_then(|dg| local_steps_of(&system, dg, initial_cost, options));
            let stepped = self
                .ctx
                .step(&x, &system, global.as_ref(), local, &mut trial);
            let (step, response, next) = match stepped {
                Err(f) => return self.fail(x, solves, f),
                Ok(None) => (
                    StepSize::NONE,
                    policy.unusable(Unusable::Singular(&system)),
                    None,
                ),
                Ok(Some(summary)) => {
                    add_into(&mut trial, &x);
                    let step = StepSize {
                        norm: summary.delta_norm2.sqrt(),
                        sigmas: summary.sigmas(),
                    };
                    let step_norm = step.norm;
                    if !(step_norm.is_finite() && trial.is_finite()) {
                        let response = policy.unusable(Unusable::NonFinite { step_norm });
                        (step, response, None)
                    } else if step_norm / (summary.state_norm2.sqrt() + 1.0)
                        < options.step_tolerance
                        || (system.lambda == 0.0 && step.sigmas < options.sigma_tolerance)
                    {
                        // The step from `x` is below a tolerance: `x` is
                        // the solution, and everything reported is evaluated
                        // there (its system is at hand; applying the step
                        // would cost one more pass for a change below the
                        // tolerance).
                        return self.finish(x, system, step, Status::Converged);
                    } else {
                        if options.refine_groups {
                            self.ctx.refine_groups(
                                &mut trial,
                                system.cost(),
                                step.sigmas * step.sigmas,
                                options.sigma_tolerance,
                            );
                        }
                        match self.ctx.reduce(&trial, policy.trial_lambda()) {
                            Ok(next) => {
                                let response = policy.judge(&Trial {
                                    initial_cost,
                                    cost: system.loss(),
                                    predicted_decrease: summary.predicted_decrease(),
                                    trial_cost: next.loss(),
                                });
                                (step, response, Some(next))
                            }
                            Err(f) => (step, policy.unusable(Unusable::Failed(f)), None),
                        }
                    }
                }
            };
            let accepted = matches!(response, Response::Accept { .. });
            self.record(&system, step, accepted);
            match response {
                Response::Accept { keep_trial_system } => {
                    swap(&mut x, &mut trial);
                    previous_cost = Some(system.loss());
                    new_iterate = true;
                    system = match next {
                        Some(next) if keep_trial_system => next,
                        _ => match self.ctx.reduce(&x, policy.lambda()) {
                            Ok(s) => s,
                            Err(f) => return self.fail(x, solves + 1, f),
                        },
                    };
                }
                Response::Reject => {
                    system = match self.ctx.reduce(&x, policy.lambda()) {
                        Ok(s) => s,
                        Err(f) => return self.fail(x, solves + 1, f),
                    };
                }
                Response::End(ending) => return self.end(x, ending.status(solves)),
            }
        }
    }

    /// The final record (with `step`, the size of the step computed there
    /// and not applied, [`StepSize::NONE`] if none), covariance, group
    /// sigmas and spectrum at `state`.
    fn finish(
        mut self,
        state: State<C, P>,
        mut system: ReducedSystem,
        step: StepSize,
        status: Status,
    ) -> Solution<C, P> {
        let solves = self.history.len();
        if system.lambda > 0.0 {
            system = match self.ctx.reduce(&state, 0.0) {
                Ok(s) => s,
                Err(f) => return self.fail(state, solves, f),
            };
        }
        self.record(&system, step, true);
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
            .filter(|_| self.options.group_sigmas)
            .and_then(|cov| covariance_factor(cov, system.size()).ok())
            .and_then(|(_, factor)| self.ctx.group_sigmas(&state, factor.as_slice()).ok());
        let mut solution = self.end(state, status);
        solution.covariance = covariance;
        solution.group_sigmas = group_sigmas;
        solution.group_costs = Some(system.group_costs);
        solution.spectrum = spectrum;
        solution
    }
}
