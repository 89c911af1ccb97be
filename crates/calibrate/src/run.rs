//! One calibration run of any hexapod dataset: ball touches (with poses
//! and points beside them, if any) set up, solved and their priors judged,
//! or poses and points alone through the instrument stage
//! ([`crate::instruments::run`]); the one result type ([`result`]) and its
//! record, calibration.json ([`record`]).

use std::time::Instant;

use parcal_dataset::Dataset;
use parcal_kinematics::{PARAM_NAMES, Vec3};
use parcal_solver::{IterationRecord, SolverOptions};

use crate::conflict::{ConflictTest, paper_prior_consistency};
use crate::layout::{centre_name, radius_name};
use crate::problem::CalibrationProblem;
use crate::run_away::{RunAway, rerun_iterations};
use crate::setup::{Observations, Setup, kinematic_prior};
use crate::verdict::at_minimum;
use crate::{CalibrateError, CalibrationOptions, PriorMode, RadiusModel};

mod record;
mod result;
mod solve;

pub use result::{CalibratedBalls, CalibrationRun};
use solve::SolverRun;

/// Calibrates `dataset` (docs/paper-scenario.md section 4): its ball
/// touches with the poses and points beside them, if any; or, without
/// touches, its poses and points alone (the instrument stage,
/// [`crate::instruments::run`], least squares only). `observer` sees each
/// iteration. The dataset is validated first ([`crate::validate`]).
///
/// A Gauss-Newton run that runs away is made again with
/// Levenberg-Marquardt ([`RunAway`] says when); [`CalibrationRun::gauss_newton`]
/// keeps how the first run ended.
pub fn calibrate(
    dataset: &Dataset,
    options: &CalibrationOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<CalibrationRun, CalibrateError> {
    if !dataset.has_touches() && !dataset.tracker.is_empty() {
        return instruments_alone(dataset, options, observer);
    }
    let started = Instant::now();
    let run = calibrate_once(dataset, options, observer)?;
    let costs: Vec<f64> = run.history.iter().map(|record| record.cost).collect();
    let squared = options.loss.is_squared();
    let Some(run_away) = RunAway::of(options.method, &run.status, &costs, squared) else {
        return Ok(run);
    };
    let mut lm = options.clone().levenberg_marquardt();
    lm.max_iterations = rerun_iterations(options.max_iterations);
    // What is left of the budget.
    lm.time_limit = options
        .time_limit
        .map(|limit| limit.saturating_sub(started.elapsed()));
    let mut again = calibrate_once(dataset, &lm, observer)?;
    again.gauss_newton = Some(run_away);
    Ok(again)
}

/// The calibration of the poses and points of `dataset`, which has no
/// ball touches: the instrument stage's solution as a run whose touch
/// parts are empty.
fn instruments_alone(
    dataset: &Dataset,
    options: &CalibrationOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<CalibrationRun, CalibrateError> {
    let solved = crate::instruments::run::solve(dataset, options, observer)?;
    Ok(CalibrationRun {
        options: options.clone(),
        design: solved.design,
        machine: dataset.machine.clone(),
        initial_params: solved.initial_params,
        prior: solved.kinematic_prior,
        params: solved.params,
        covariance: solved.covariance,
        global: solved.global,
        global_covariance: solved.global_covariance,
        balls: CalibratedBalls::default(),
        status: solved.status,
        history: solved.history,
        residual_rows: solved.residual_rows,
        rows: Vec::new(),
        spectrum: solved.spectrum,
        conflicts: Vec::new(),
        layout: solved.layout,
        distances_used: 0,
        instruments: Some(solved.instruments),
        prior_consistency: None,
        global_test: solved.global_test,
        reliability: solved.reliability,
        gauss_newton: None,
    })
}

/// The touch problem of `observations` with `G` unknowns per ball, the
/// dataset's poses and points attached as global observations
/// ([`crate::mixed`]).
fn touch_problem<'a, O, const G: usize>(
    setup: &'a Setup,
    dataset: &'a Dataset,
    options: &CalibrationOptions,
    observations: O,
) -> Result<CalibrationProblem<'a, O, G>, CalibrateError> {
    let mut problem = setup.problem::<_, G>(dataset, options, observations);
    // The instrument rows are weighed at the initial global block, built
    // only when there are such rows.
    if !dataset.tracker.is_empty() {
        problem.attach_instruments(dataset, &setup.initial_state::<G, 0>(dataset).global)?;
    }
    Ok(problem)
}

/// One calibration with the options' method.
fn calibrate_once(
    dataset: &Dataset,
    options: &CalibrationOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<CalibrationRun, CalibrateError> {
    crate::validate(dataset)?;
    let (mut setup, observations) = Setup::new(dataset, options)?;
    let poses = std::mem::take(&mut setup.poses);
    let solver_options = SolverOptions {
        // The checks' pass gives them ([`SolverRun::solve`]).
        group_sigmas: false,
        ..options.solver_options()
    };
    let solver = SolverRun {
        setup: &setup,
        dataset,
        options,
        solver: &solver_options,
    };
    let solved = match (observations, options.radius) {
        (Observations::Radius(observations), RadiusModel::PerContact) => {
            let mut problem = touch_problem::<_, 3>(&setup, dataset, options, observations)?;
            solver.solve(&mut problem, poses, observer, 1)?
        }
        (Observations::Radius(observations), RadiusModel::PerBall) => {
            let mut problem = touch_problem::<_, 4>(&setup, dataset, options, observations)?;
            solver.solve(&mut problem, poses, observer, 1)?
        }
        (Observations::Coordinates(observations), RadiusModel::PerContact) => {
            let mut problem = touch_problem::<_, 3>(&setup, dataset, options, observations)?;
            solver.solve(&mut problem, poses, observer, 3)?
        }
        (Observations::Coordinates(observations), RadiusModel::PerBall) => {
            let mut problem = touch_problem::<_, 4>(&setup, dataset, options, observations)?;
            solver.solve(&mut problem, poses, observer, 3)?
        }
    };
    for mirrored in &solved.mirrored {
        setup.initial_centres[mirrored.ball] = mirrored.initial_centre;
    }
    // Copied once the solve, where memory peaks, is over.
    let ball_ids: Vec<String> = dataset
        .artefacts
        .balls
        .iter()
        .map(|b| b.id.clone())
        .collect();
    let mut conflicts = Vec::new();
    let judged = at_minimum(&solved.status);
    if let (Some(prior), Some(covariance), true) = (&setup.prior, &solved.covariance, judged) {
        let d = solved.params - prior.mean();
        conflicts.push(ConflictTest::new(
            "kinematic parameters",
            |k| PARAM_NAMES[k].to_string(),
            d.as_slice(),
            prior.covariance().diagonal().as_slice(),
            covariance.diagonal().as_slice(),
            prior.chi_square(&solved.params),
        ));
    }
    if let (PriorMode::Paper, Some(sigmas), true) = (options.prior, &solved.centre_sigmas, judged) {
        conflicts.push(centre_conflict(
            dataset,
            &setup,
            &solved.centres,
            sigmas,
            &ball_ids,
        ));
    }
    if let (Some(radii), Some(sigmas), true) = (&solved.radii, &solved.radius_sigmas, judged) {
        conflicts.push(radius_conflict(dataset, radii, sigmas));
    }
    let prior_consistency = match (options.prior, &setup.prior) {
        (PriorMode::Paper, Some(paper)) => {
            let tolerances = kinematic_prior(
                dataset,
                &setup.design,
                &setup.initial_params,
                PriorMode::Propagated,
            )?;
            tolerances.and_then(|t| paper_prior_consistency(paper, &t))
        }
        _ => None,
    };
    Ok(CalibrationRun {
        gauss_newton: None,
        global_test: solved.global_test,
        reliability: solved.reliability,
        prior_consistency,
        options: options.clone(),
        design: setup.design,
        machine: dataset.machine.clone(),
        initial_params: setup.initial_params,
        prior: setup.prior,
        params: solved.params,
        covariance: solved.covariance,
        global: solved.global,
        global_covariance: solved.global_covariance,
        balls: CalibratedBalls {
            ids: ball_ids,
            centres: solved.centres,
            centre_sigmas: solved.centre_sigmas,
            radii: solved.radii,
            radius_sigmas: solved.radius_sigmas,
            misfits: solved.ball_misfits,
            mirrored: solved.mirrored,
        },
        status: solved.status,
        history: solved.history,
        residual_rows: solved.residual_rows,
        spectrum: solved.spectrum,
        conflicts,
        distances_used: dataset.artefacts.distances.len(),
        instruments: solved.instruments,
        layout: setup.layout,
        rows: setup.order,
    })
}

/// The conflict test of the paper-mode centre priors (mean: the initial
/// estimate, sigma: artefacts.json's centre_sigma).
fn centre_conflict(
    dataset: &Dataset,
    setup: &Setup,
    centres: &[Vec3],
    sigmas: &[Vec3],
    ids: &[String],
) -> ConflictTest {
    let (mut d, mut prior, mut posterior) = (Vec::new(), Vec::new(), Vec::new());
    let mut chi_square = 0.0;
    for (k, ball) in dataset.artefacts.balls.iter().enumerate() {
        for c in 0..3 {
            let difference = centres[k][c] - setup.initial_centres[k][c];
            d.push(difference);
            prior.push(ball.centre_sigma.powi(2));
            posterior.push(sigmas[k][c].powi(2));
            chi_square += (difference / ball.centre_sigma).powi(2);
        }
    }
    let name = |j: usize| centre_name(&ids[j / 3], j % 3);
    ConflictTest::new("ball centres", name, &d, &prior, &posterior, chi_square)
}

/// The conflict test of the radius priors of a per-ball radius (mean: the
/// calibrated radius, sigma: artefacts.json's radius_sigma), each named
/// `radius ID`: a calibrated radius the touches contradict shows here.
fn radius_conflict(dataset: &Dataset, radii: &[f64], sigmas: &[f64]) -> ConflictTest {
    let balls = &dataset.artefacts.balls;
    let name = |k: usize| radius_name(&balls[k].id);
    let d: Vec<f64> = balls.iter().zip(radii).map(|(b, r)| r - b.radius).collect();
    let prior: Vec<f64> = balls.iter().map(|b| b.radius_sigma.powi(2)).collect();
    let posterior: Vec<f64> = sigmas.iter().map(|s| s * s).collect();
    let chi_square = d.iter().zip(&prior).map(|(d, v)| d * d / v).sum();
    ConflictTest::new("ball radii", name, &d, &prior, &posterior, chi_square)
}
