//! One solve of the touch problem and its estimate: the robust start, the
//! balls re-seeded on the other side of their contacts
//! ([`crate::mirror`]), the loss asked for, then the checks of the
//! estimate ([`SolverRun::solve`]).

use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use parcal_dataset::Dataset;
use parcal_kinematics::{N_PARAMS, ParamCovariance, Params, Pose, Vec3, params};
use parcal_solver::{
    Iterate, IterationRecord, Monitor, Solution, SolverOptions, SpectrumDiagnostics, State, Status,
    group_sigmas, solve_with_caches,
};

use crate::fit::{BallMisfit, misfit_balls};
use crate::instruments::InstrumentResult;
use crate::layout::kinematic_params;
use crate::mirror::{Mirrored, SETTLED, WrongSide, remaining, wrong_side};
use crate::problem::{ActuatorScales, CalibrationProblem, ContactObservations};
use crate::reliability::Reliability;
use crate::robust::START_TOLERANCE;
use crate::setup::{MirrorStart, Setup};
use crate::verdict::{GLOBAL_TEST_LEVEL, GlobalTest, at_minimum, rows_and_unknowns};
use crate::{CalibrateError, CalibrationOptions};

/// The parts of a solution that do not depend on the point block size.
pub(super) struct Estimate {
    pub(super) params: Params,
    pub(super) covariance: Option<ParamCovariance>,
    pub(super) global: DVector<f64>,
    pub(super) global_covariance: Option<DMatrix<f64>>,
    pub(super) centres: Vec<Vec3>,
    pub(super) centre_sigmas: Option<Vec<Vec3>>,
    /// With a per-ball radius: the radii and their sigmas.
    pub(super) radii: Option<Vec<f64>>,
    pub(super) radius_sigmas: Option<Vec<f64>>,
    /// The balls that fit their contacts far worse than the noise allows.
    pub(super) ball_misfits: Vec<BallMisfit>,
    pub(super) status: Status,
    pub(super) history: Vec<IterationRecord>,
    pub(super) residual_rows: usize,
    pub(super) spectrum: Option<SpectrumDiagnostics>,
    /// Balls re-seeded on the other side of their contacts.
    pub(super) mirrored: Vec<Mirrored>,
    /// The global test at the final state.
    pub(super) global_test: Option<GlobalTest>,
    /// The observations' checks at the final state.
    pub(super) reliability: Option<Reliability>,
    /// The poses and points calibrated with the touches.
    pub(super) instruments: Option<InstrumentResult>,
}

/// What a solve needs besides the problem.
pub(super) struct SolverRun<'a> {
    pub(super) setup: &'a Setup,
    pub(super) dataset: &'a Dataset,
    pub(super) options: &'a CalibrationOptions,
    pub(super) solver: &'a SolverOptions,
}

impl SolverRun<'_> {
    /// Solves `problem` from the set-up's initial state, the design's
    /// forward kinematics (`poses`) warm-starting the first iteration, in
    /// stages: a redescending loss first solves with Huber's
    /// ([`crate::robust::start`]) to a looser tolerance; balls found on
    /// the wrong side of their contacts are re-seeded
    /// ([`SolverRun::solve_reseeding`]); the loss asked for resumes from
    /// there ([`SolverRun::resume`]); the estimate and its checks follow
    /// ([`SolverRun::estimate`]). The stages share the iteration and time
    /// limits.
    pub(super) fn solve<const G: usize, const P: usize, const R: usize, O>(
        &self,
        problem: &mut CalibrationProblem<'_, O, G>,
        poses: Vec<Pose>,
        observer: &mut dyn FnMut(&IterationRecord),
        rows_per_contact: usize,
    ) -> Result<Estimate, CalibrateError>
    where
        O: ContactObservations<R, P> + MirrorStart,
    {
        let started = Instant::now();
        let mut caches = poses;
        let loss = problem.loss;
        let start = crate::robust::start(loss);
        let first_stage = match start {
            Some(start) => {
                problem.loss = start;
                SolverOptions {
                    step_tolerance: self.solver.step_tolerance.max(START_TOLERANCE),
                    ..self.solver.clone()
                }
            }
            None => self.solver.clone(),
        };
        let (mut solution, mirrored) =
            self.solve_reseeding(problem, &mut caches, &first_stage, started, observer)?;
        if start.is_some() {
            problem.loss = loss;
            solution = self.resume(&*problem, solution, &mut caches, started, observer);
        }
        self.estimate(&*problem, solution, caches, mirrored, rows_per_contact)
    }

    /// The first solve, with `options`. Once Gauss-Newton has settled
    /// ([`SETTLED`]), every iterate is checked for balls on the wrong side
    /// of their contacts ([`crate::mirror`]); if there are, the run stops
    /// there, re-seeds them ([`SolverRun::reseed`]) and resumes (once: the
    /// re-seeded balls' warm starts are those of that iterate), both
    /// solves together within the iteration and time limits.
    fn solve_reseeding<const G: usize, const P: usize, const R: usize, O>(
        &self,
        problem: &mut CalibrationProblem<'_, O, G>,
        caches: &mut Vec<Pose>,
        options: &SolverOptions,
        started: Instant,
        mut observer: &mut dyn FnMut(&IterationRecord),
    ) -> Result<(Solution<G, P>, Vec<Mirrored>), CalibrateError>
    where
        O: ContactObservations<R, P> + MirrorStart,
    {
        let mut watch = WrongSideWatch {
            run: self,
            observer: &mut *observer,
            found: Ok(Vec::new()),
        };
        let solution = solve_with_caches(
            &*problem,
            self.setup.initial_state(self.dataset),
            caches,
            options,
            &mut watch,
        );
        let wrong = watch.found?;
        let Status::Stopped { iteration } = solution.status else {
            return Ok((solution, Vec::new()));
        };
        // The stopped iterate's state is the next start (moved, not
        // copied).
        let Solution {
            mut state,
            history: first,
            ..
        } = solution;
        let mirrored = wrong
            .into_iter()
            .map(|(side, tips)| self.reseed(problem, &mut state, side, &tips, iteration))
            .collect::<Result<Vec<_>, _>>()?;
        let rest = remaining(options, iteration, started);
        let mut solution = solve_with_caches(&*problem, state, caches, &rest, &mut observer);
        solution.history.splice(0..0, first);
        Ok((solution, mirrored))
    }

    /// Re-seeds the ball of `side` (found at Gauss-Newton iteration
    /// `iteration`) in `state`: its centre at the mirror image of its
    /// centre fit, its prior's mean (if any) at the mirror fit of its
    /// design-FK contact points, each contact's angles toward its tip
    /// `tips` from the new centre.
    fn reseed<const G: usize, const P: usize, const R: usize, O>(
        &self,
        problem: &mut CalibrationProblem<'_, O, G>,
        state: &mut State<G, P>,
        side: WrongSide,
        tips: &[Vec3],
        iteration: usize,
    ) -> Result<Mirrored, CalibrateError>
    where
        O: ContactObservations<R, P> + MirrorStart,
    {
        let setup = self.setup;
        let k = side.ball;
        let initial_centre =
            problem
                .observations
                .mirror_start(setup, self.dataset, self.options.weighting, k)?;
        if let Some(priors) = &mut problem.ball_priors {
            priors[k]
                .mean
                .fixed_rows_mut::<3>(0)
                .copy_from(&initial_centre);
        }
        state.groups[k]
            .fixed_rows_mut::<3>(0)
            .copy_from(&side.mirror.centre);
        if let Some(range) = setup.layout.centre(k) {
            state
                .global
                .rows_mut(range.start, 3)
                .copy_from(&side.mirror.centre);
            if let (Some(global), Some(_)) = (&mut problem.global_prior, &problem.ball_priors) {
                global
                    .mean
                    .rows_mut(range.start, 3)
                    .copy_from(&initial_centre);
            }
        }
        for (i, tip) in setup.groups[k].clone().zip(tips) {
            let row = setup.order[i] as usize;
            state.points[i] = problem
                .observations
                .angles_toward(i, &(tip - side.mirror.centre))
                .map_err(|source| CalibrateError::Observation { row, source })?;
        }
        Ok(Mirrored {
            ball: k,
            id: self.dataset.artefacts.balls[k].id.clone(),
            initial_centre,
            iteration,
            side,
        })
    }

    /// After a robust start (`solution`, with Huber's loss), the loss
    /// asked for, from Huber's estimate, within the rest of the iteration
    /// and time limits; a start that did not end at an estimate (it
    /// failed or diverged) is returned as it is.
    fn resume<const G: usize, const P: usize, const R: usize, O>(
        &self,
        problem: &CalibrationProblem<'_, O, G>,
        solution: Solution<G, P>,
        caches: &mut Vec<Pose>,
        started: Instant,
        mut observer: &mut dyn FnMut(&IterationRecord),
    ) -> Solution<G, P>
    where
        O: ContactObservations<R, P> + MirrorStart,
    {
        if !matches!(
            solution.status,
            Status::Converged | Status::IterationLimit | Status::TimeLimit
        ) {
            return solution;
        }
        let Solution {
            state,
            history: first,
            ..
        } = solution;
        let rest = remaining(self.solver, first.len(), started);
        let mut solution = solve_with_caches(problem, state, caches, &rest, &mut observer);
        solution.history.splice(0..0, first);
        solution
    }

    /// The estimate of a solve and its checks: the balls' misfits, the
    /// global test, every observation's check in one pass that also gives
    /// the balls' sigmas (a pass of their own when the run is not at a
    /// minimum, [`at_minimum`]), the radii of a per-ball radius, the poses'
    /// and points' part.
    fn estimate<const G: usize, const P: usize, const R: usize, O>(
        &self,
        problem: &CalibrationProblem<'_, O, G>,
        solution: Solution<G, P>,
        mut caches: Vec<Pose>,
        mirrored: Vec<Mirrored>,
        rows_per_contact: usize,
    ) -> Result<Estimate, CalibrateError>
    where
        O: ContactObservations<R, P> + MirrorStart,
    {
        let setup = self.setup;
        // The checks, the balls' misfits among them, judge a minimum only
        // ([`at_minimum`]).
        let judged = at_minimum(&solution.status);
        let ball_misfits = solution
            .group_costs
            .as_deref()
            .filter(|_| judged)
            .map_or_else(Vec::new, |costs| self.misfits(costs));
        let layout = &setup.layout;
        let state = &solution.state;
        let (rows, unknowns) = rows_and_unknowns(problem, setup.order.len(), problem.global_rows());
        let global_test = solution.history.last().and_then(|record| {
            GlobalTest::new(
                record.cost,
                rows.saturating_sub(unknowns),
                GLOBAL_TEST_LEVEL,
            )
        });
        let prior_rows = rows - rows_per_contact * setup.order.len() - problem.global_rows();
        // The checks' pass gives the balls' sigmas too; without it, a pass
        // of their own.
        let groups_per_chunk = self.solver.groups_per_chunk;
        let (reliability, group_sigmas) = match (&solution.covariance, solution.history.last()) {
            (Some(covariance), Some(last)) if judged => {
                let (reliability, sigmas) = Reliability::new(
                    problem,
                    state,
                    covariance,
                    &mut caches,
                    groups_per_chunk,
                    &setup.order,
                    &problem.global_observation_ids(),
                    last.prior_cost,
                    prior_rows,
                    &problem.tested_effects(),
                )?;
                (Some(reliability), Some(sigmas))
            }
            (Some(covariance), _) => {
                let sigmas =
                    group_sigmas(problem, state, covariance, &mut caches, groups_per_chunk);
                (None, sigmas.ok())
            }
            _ => (None, None),
        };
        let ball_sigmas = group_sigmas
            .as_deref()
            .zip(solution.covariance.as_ref())
            .map(|(groups, global)| layout.ball_sigmas(global, groups));
        let centre_sigmas = ball_sigmas.as_ref().map(|sigmas| {
            sigmas
                .iter()
                .map(|s| s.fixed_rows::<3>(0).into_owned())
                .collect()
        });
        // A per-ball radius is each ball's last unknown.
        let radius_unknown = G == 4;
        let radii = radius_unknown.then(|| {
            layout
                .ball_values(&state.global, &state.groups)
                .iter()
                .map(|v| v[G - 1])
                .collect()
        });
        let radius_sigmas = ball_sigmas
            .as_ref()
            .filter(|_| radius_unknown)
            .map(|sigmas| sigmas.iter().map(|s| s[G - 1]).collect());
        // The poses are not needed past the checks: their memory is the
        // room of what follows.
        drop(caches);
        let instruments = problem
            .instruments
            .as_ref()
            .map(|i| i.result(&state.global))
            .transpose()?;
        Ok(Estimate {
            instruments,
            global_test,
            reliability,
            params: kinematic_params(&state.global),
            centres: layout.ball_centres(&state.global, &state.groups),
            centre_sigmas,
            radii,
            radius_sigmas,
            covariance: solution
                .covariance
                .as_ref()
                .map(|c| c.fixed_view::<N_PARAMS, N_PARAMS>(0, 0).into_owned()),
            global: solution.state.global,
            global_covariance: solution.covariance,
            ball_misfits,
            status: solution.status,
            history: solution.history,
            residual_rows: setup.order.len() * rows_per_contact,
            spectrum: solution.spectrum,
            mirrored,
        })
    }

    /// The balls whose data costs (`costs`, one per ball) are far worse
    /// than the noise allows ([`crate::fit`]).
    fn misfits(&self, costs: &[f64]) -> Vec<BallMisfit> {
        let balls = &self.dataset.artefacts.balls;
        misfit_balls(
            |b| balls[b].id.clone(),
            costs,
            self.setup.groups.iter().map(|g| g.len()),
        )
    }

    /// The `misfits` that are on the wrong side of their contacts at the
    /// parameters `params`, scales `scales` and centres `centres`
    /// ([`crate::mirror`]), with
    /// their contact points at those parameters; `caches`: the contacts'
    /// poses there (warm starts).
    fn wrong_sides(
        &self,
        params: &Params,
        scales: &ActuatorScales,
        centres: &[Vec3],
        misfits: &[BallMisfit],
        caches: &[Pose],
    ) -> Result<Vec<(WrongSide, Vec<Vec3>)>, CalibrateError> {
        let (setup, dataset) = (self.setup, self.dataset);
        if misfits.is_empty() {
            return Ok(Vec::new());
        }
        let geometry = params::from_params(params);
        let mut wrong = Vec::new();
        for misfit in misfits {
            let k = misfit.ball;
            let group = setup.groups[k].clone();
            let rows = &setup.order[group.clone()];
            let actuators = rows
                .iter()
                .map(|&row| scales.extensions(&dataset.measurements.q[row as usize]));
            let found = wrong_side(
                &geometry,
                actuators,
                &caches[group],
                dataset.artefacts.balls[k].radius,
                &centres[k],
            )
            .map_err(|source| CalibrateError::ForwardKinematics {
                row: rows[0] as usize,
                source,
            })?;
            if let Some((side, mirror, tips)) = found {
                let chi_square = misfit.chi_square;
                wrong.push((
                    WrongSide {
                        ball: k,
                        chi_square,
                        side,
                        mirror,
                    },
                    tips,
                ));
            }
        }
        Ok(wrong)
    }
}

/// Watches the first solve: records go to the observer; each settled
/// iterate is checked for balls on the wrong side of their contacts, and
/// the run stops at the first that has some.
struct WrongSideWatch<'r, 'o> {
    run: &'r SolverRun<'r>,
    observer: &'o mut dyn FnMut(&IterationRecord),
    /// The balls found (with their contact points), or the failure of the
    /// check.
    found: Result<Vec<(WrongSide, Vec<Vec3>)>, CalibrateError>,
}

impl<const G: usize, const P: usize> Monitor<G, P, Pose> for WrongSideWatch<'_, '_> {
    fn record(&mut self, record: &IterationRecord) {
        (self.observer)(record);
    }

    fn inspect(&mut self, iterate: &Iterate<'_, G, P, Pose>) -> parcal_solver::Decision {
        if iterate.relative_change() > SETTLED {
            return parcal_solver::Decision::Continue;
        }
        let state = iterate.state;
        let misfits = self.run.misfits(iterate.group_costs);
        let params = kinematic_params(&state.global);
        let setup = self.run.setup;
        let scales = ActuatorScales::at(
            &setup.layout,
            &state.global,
            &self.run.dataset.machine.actuator.scale,
        );
        let centres = setup.layout.ball_centres(&state.global, &state.groups);
        self.found = self
            .run
            .wrong_sides(&params, &scales, &centres, &misfits, iterate.caches);
        match &self.found {
            Ok(wrong) if wrong.is_empty() => parcal_solver::Decision::Continue,
            _ => parcal_solver::Decision::Stop,
        }
    }
}
