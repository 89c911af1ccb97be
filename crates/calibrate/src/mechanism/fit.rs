//! One fit of a mechanism calibration: the solver from the priors' means,
//! then, at a least-squares minimum, every row's redundancy number and
//! normalised residual ([`parcal_solver::redundancy`]) and the global
//! test's numbers ([`crate::verdict::rows_and_unknowns`]).
//!
//! The touches are observed as the options say: by their radius rows
//! ([`super::problem`], whose points are rows: a point sample's rows and a
//! touch's row are gathered back into their observation's check) or by
//! their coordinates ([`super::coordinate_problem`], a touch's point its
//! three rows).
//!
//! A Gauss-Newton fit that runs away is made again with
//! Levenberg-Marquardt ([`RunAway`], as the hexapod's own calibration
//! does): a blunder or a start far from the solution, where full steps
//! overshoot to where the machine's kinematics fails.

use std::time::Instant;

use nalgebra::{DMatrix, DVector, SVector, Vector3};
use parcal_dataset::mechanism::{RowCheck, TRIGGER_HEIGHT};
use parcal_solver::{
    BlockId, GlobalObservations, IterationRecord, Loss, Problem, Solution, SolverOptions, State,
    Status, group_sigmas, redundancy, solve_with_caches,
};
use rayon::prelude::*;

use crate::mirror::remaining;
use crate::options::Observation;
use crate::run_away::{RunAway, rerun_iterations};
use crate::verdict::{at_minimum, rows_and_unknowns};

use super::checks::ObservationChecks;
use super::coordinate_problem::CoordinateProblem;
use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::mirror::{MirroredBall, WrongSideWatch};
use super::observation::{ObservationKind, ObservationRef};
use super::options::MechanismOptions;
use super::problem::{FitProblem, MechanismProblem, Start, group_size};
use super::trackers::Trackers;
use super::warm_start::WarmStart;

/// What one fit gives (module doc).
pub(crate) struct Fit {
    /// The global block at the end (the fit's frame).
    pub global: DVector<f64>,
    /// The point samples' poses at the end.
    pub poses: Vec<[f64; 3]>,
    /// The balls' centres at the end.
    pub centres: Vec<[f64; 3]>,
    /// Their marginal standard deviations, when the solver gave them.
    pub centre_sigmas: Option<Vec<[f64; 3]>>,
    /// The balls' radii: estimated where calibrated with a sigma, else
    /// as given.
    pub radii: Vec<f64>,
    /// The estimated radii's marginal standard deviations (`None` for an
    /// exact radius), when the solver gave them.
    pub radius_sigmas: Option<Vec<Option<f64>>>,
    /// How the solver ended.
    pub status: Status,
    /// Its linear solves.
    pub iterations: usize,
    /// `Cov(g)` of the global block, when the solver gave one.
    pub covariance: Option<DMatrix<f64>>,
    /// The prior information `Λ_g` on the global block.
    pub prior_information: DMatrix<f64>,
    /// `Ω`, the weighted sum of squares at the end, priors included.
    pub cost: Option<f64>,
    /// Rows (data, priors) less unknowns.
    pub redundancy: usize,
    /// Every observation's numbers, at a least-squares minimum.
    pub checks: Option<ObservationChecks>,
    /// The balls found on the wrong side of their touches and re-seeded.
    pub mirrored: Vec<MirroredBall>,
    /// The number of data rows.
    pub data_rows: usize,
    /// The w-tests' family: one per global row and per point (a point's
    /// rows are one test: a sample's and a radius row are one row each,
    /// a touch's three coordinate rows one observation).
    pub tests: usize,
    /// The trackers' references and places in the global block.
    pub trackers: Trackers,
    /// When this is the Levenberg-Marquardt fit made after a Gauss-Newton
    /// fit ran away: how that one ended.
    pub gauss_newton: Option<RunAway>,
}

/// One fit of `data` (validated) with `options` (module doc), its local
/// blocks of [`group_size`] unknowns, within what is left of the time
/// budget of the calibration that began at `started`; `observer` sees
/// each iteration, of the run made again too when the first ran away.
pub(crate) fn fit(
    data: &MechanismData,
    options: &MechanismOptions,
    started: Instant,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<Fit, MechanismCalibrationError> {
    let mut costs = Vec::new();
    let first = fit_once(data, options, started, &mut |record| {
        costs.push(record.cost);
        observer(record)
    })?;
    let status = match &first {
        Ended::Fitted(fit) => &fit.status,
        Ended::Failed(status, _) => status,
    };
    let squared = options.loss.is_squared();
    let Some(run_away) = RunAway::of(options.method, status, &costs, squared) else {
        return first.into_result();
    };
    let again = options
        .clone()
        .levenberg_marquardt()
        .with_max_iterations(Some(rerun_iterations(options.max_iterations)));
    let mut fit = fit_once(data, &again, started, observer)?.into_result()?;
    fit.gauss_newton = Some(run_away);
    Ok(fit)
}

/// How one run of the solver ended: a fit, or a status that makes the
/// calibration fail, with its error ([`failure`]).
enum Ended {
    Fitted(Box<Fit>),
    Failed(Status, MechanismCalibrationError),
}

impl Ended {
    fn into_result(self) -> Result<Fit, MechanismCalibrationError> {
        match self {
            Self::Fitted(fit) => Ok(*fit),
            Self::Failed(_, error) => Err(error),
        }
    }
}

/// [`fit`]'s one run of the solver with `options`.
fn fit_once(
    data: &MechanismData,
    options: &MechanismOptions,
    started: Instant,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<Ended, MechanismCalibrationError> {
    match group_size(data) {
        3 => fit_blocks::<3>(data, options, started, observer),
        _ => fit_blocks::<4>(data, options, started, observer),
    }
}

/// [`fit_once`] with local blocks of `C` unknowns.
fn fit_blocks<const C: usize>(
    data: &MechanismData,
    options: &MechanismOptions,
    started: Instant,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<Ended, MechanismCalibrationError> {
    match options.observation {
        Observation::Radius => {
            let mut problem = MechanismProblem::<C>::new(data, options.loss)?;
            let (state, caches) = start(&problem)?;
            solve_and_check::<C, 0, 1, _>(&mut problem, state, caches, options, started, observer)
        }
        Observation::Coordinates => {
            let (mut problem, state, caches) = CoordinateProblem::<C>::start(data, options.loss)?;
            check_global_rows(problem.base(), &state.global)?;
            solve_and_check::<C, 2, 3, _>(&mut problem, state, caches, options, started, observer)
        }
    }
}

/// [`fit_once`] of `problem` from `state` and its points' `caches`: `R`
/// rows and `P` unknowns a point.
fn solve_and_check<const C: usize, const P: usize, const R: usize, Q: FitProblem<C, P, R>>(
    problem: &mut Q,
    state: State<C, P>,
    mut caches: Vec<WarmStart>,
    options: &MechanismOptions,
    started: Instant,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<Ended, MechanismCalibrationError> {
    // The time limit is what is left of the budget now.
    let now = Instant::now();
    let solver_options = SolverOptions {
        // The checks' pass gives them (below).
        group_sigmas: false,
        ..options.solver_options(started)
    };
    let (solution, mirrored) =
        solve_reseeding(problem, state, &mut caches, &solver_options, now, observer);
    let problem = &*problem;
    let base = problem.base();
    let data = base.data();
    let points = base.n_points();
    if let Some(error) = failure(&solution.status, data) {
        return Ok(Ended::Failed(solution.status, error));
    }
    let refs = base.global_observation_refs();
    let global_rows: usize = refs.iter().map(|(_, rows)| rows).sum();
    let (rows, unknowns) = rows_and_unknowns::<C, P, R, _>(problem, points, global_rows);
    // The checks' pass gives the local blocks' sigmas too; a run that is
    // not judged makes a pass of the sigmas alone.
    let groups_per_chunk = solver_options.groups_per_chunk;
    let (checks, block_sigmas) = match &solution.covariance {
        Some(covariance) if at_minimum(&solution.status) => {
            let (checks, sigmas) = checks::<C, P, R, _>(
                problem,
                base,
                &solution.state,
                covariance,
                &refs,
                groups_per_chunk,
                caches,
            )?;
            (Some(checks), Some(sigmas))
        }
        Some(covariance) => {
            let state = &solution.state;
            let sigmas = group_sigmas(problem, state, covariance, &mut caches, groups_per_chunk);
            (None, sigmas.ok())
        }
        None => (None, None),
    };
    let samples = data.observations.samples.len();
    let balls = &data.observations.balls;
    let ball_values = |global: &DVector<f64>, blocks: &[SVector<f64, C>]| {
        ball_unknowns(base, global, &blocks[samples..])
    };
    let (centres, radii) = ball_values(&solution.state.global, &solution.state.groups);
    let (centre_sigmas, radius_sigmas) = block_sigmas
        .as_ref()
        .zip(solution.covariance.as_ref())
        .map(|(sigmas, covariance)| {
            let global = covariance.diagonal().map(f64::sqrt);
            let (centres, radii) = ball_values(&global, sigmas);
            let uncertain = (0..balls.len()).map(|b| balls[b].radius_sigma.is_some());
            let radii = radii
                .into_iter()
                .zip(uncertain)
                .map(|(s, u)| u.then_some(s));
            (centres, radii.collect())
        })
        .unzip();
    // The mechanism's part of the global block: the tied balls' unknowns
    // are reported with the balls.
    let m = base.mechanism_len();
    let mechanism_block = |matrix: &DMatrix<f64>| matrix.view((0, 0), (m, m)).into_owned();
    Ok(Ended::Fitted(Box::new(Fit {
        poses: solution.state.groups[..samples]
            .iter()
            .map(|v| [v[0], v[1], v[2]])
            .collect(),
        centres,
        centre_sigmas,
        radii,
        radius_sigmas,
        global: solution.state.global.rows(0, m).into_owned(),
        iterations: solution.history.len(),
        cost: solution.history.last().map(|record| record.cost),
        status: solution.status,
        covariance: solution.covariance.as_ref().map(mechanism_block),
        prior_information: mechanism_block(&base.prior_information()),
        redundancy: rows.saturating_sub(unknowns),
        checks,
        mirrored,
        data_rows: global_rows + R * points,
        tests: global_rows + points,
        trackers: base.trackers().clone(),
        gauss_newton: None,
    })))
}

/// The solve of `problem` from `state` (its points' caches `caches`) with
/// `options` (their time limit counted from `begun`), watched for balls on
/// the wrong side of their touches: any found at a settled iterate are
/// re-seeded there and the solve resumes, once, within what is left of
/// the limits ([`super::mirror`]); with the balls re-seeded.
fn solve_reseeding<const C: usize, const P: usize, const R: usize, Q: FitProblem<C, P, R>>(
    problem: &mut Q,
    state: State<C, P>,
    caches: &mut Vec<WarmStart>,
    options: &SolverOptions,
    begun: Instant,
    mut observer: &mut dyn FnMut(&IterationRecord),
) -> (Solution<C, P>, Vec<MirroredBall>) {
    let mut watch = WrongSideWatch::new(problem.base(), &mut *observer);
    let first = solve_with_caches::<C, P, R, _>(&*problem, state, caches, options, &mut watch);
    let found = watch.found;
    // The watch stops the solve at the iterate where it finds any.
    let Status::Stopped { iteration } = first.status else {
        return (first, Vec::new());
    };
    let Solution {
        mut state, history, ..
    } = first;
    let mut mirrored = Vec::with_capacity(found.len());
    for (ball, tips) in found {
        let centre = Vector3::from(ball.centre);
        problem.reseed(&mut state, ball.ball, &centre, &tips);
        mirrored.push(ball);
    }
    let rest = remaining(options, iteration, begun);
    let mut solution =
        solve_with_caches::<C, P, R, _>(&*problem, state, caches, &rest, &mut observer);
    solution.history.splice(0..0, history);
    (solution, mirrored)
}

/// The start of `problem` ([`MechanismProblem::start_state`]: every point
/// sample's pose and every ball's centre from its readings or touches,
/// with the points' caches there), with every global observation
/// evaluated once there, so that a commanded position the machine cannot
/// reach is named as such.
fn start<const C: usize>(
    problem: &MechanismProblem<C>,
) -> Result<(State<C, 0>, Vec<WarmStart>), MechanismCalibrationError> {
    let Start { state, caches, .. } = problem.start_state()?;
    check_global_rows(problem, &state.global)?;
    Ok((state, caches))
}

/// Evaluates every global observation of `problem` at `global` once.
fn check_global_rows<const C: usize>(
    problem: &MechanismProblem<C>,
    global: &DVector<f64>,
) -> Result<(), MechanismCalibrationError> {
    let mut rows = GlobalObservations::zeros(0, global.len());
    problem.global_observations(global, &mut rows)
}

/// Checks that every observation of `data` (validated) can be evaluated
/// at the start a fit would take ([`start`]).
pub(crate) fn check_start(data: &MechanismData) -> Result<(), MechanismCalibrationError> {
    match group_size(data) {
        3 => start(&MechanismProblem::<3>::new(data, Loss::Squared)?).map(drop),
        _ => start(&MechanismProblem::<4>::new(data, Loss::Squared)?).map(drop),
    }
}

/// Each ball's centre and radius (its calibrated radius when exact) from
/// the global block `global` for a tied ball ([`super::tied`]), from its
/// local block in `blocks` (the balls' blocks) for any other: the values,
/// or, given the global and local sigmas, their sigmas.
fn ball_unknowns<const C: usize>(
    problem: &MechanismProblem<C>,
    global: &DVector<f64>,
    blocks: &[SVector<f64, C>],
) -> (Vec<[f64; 3]>, Vec<f64>) {
    let balls = &problem.data().observations.balls;
    blocks
        .iter()
        .enumerate()
        .map(|(b, block)| {
            let unknowns = match problem.tied().column(b) {
                Some(column) => &global.as_slice()[column..],
                None => block.as_slice(),
            };
            let radius = match balls[b].radius_sigma {
                Some(_) => unknowns[3],
                None => balls[b].radius,
            };
            ([unknowns[0], unknowns[1], unknowns[2]], radius)
        })
        .unzip()
}

/// The error of a run of `data` that could not fit at all: a failed
/// evaluation (the observation it names), the unknowns not determined
/// (each combination named by its largest components), an invalid start.
/// A run that merely did not converge is a result (its verdict rejects
/// it). The solver's groups are the point samples' poses, then the balls'
/// centres.
fn failure(status: &Status, data: &MechanismData) -> Option<MechanismCalibrationError> {
    let samples = data.observations.samples.len();
    match status {
        Status::ProblemFailed {
            iteration, message, ..
        } => Some(MechanismCalibrationError::Evaluation {
            iteration: *iteration,
            message: message.clone(),
        }),
        Status::Singular { diagnostics, .. } => {
            let unseen: Vec<String> = (diagnostics.weakest.iter())
                .filter(|w| !w.identified)
                .map(|w| {
                    let components = w.dominant.iter();
                    let named =
                        components.map(|&(k, v)| format!("{v:+.2} {}", global_name(data, k)));
                    named.collect::<Vec<_>>().join(" ")
                })
                .collect();
            Some(MechanismCalibrationError::NotDetermined {
                reason: format!(
                    "{} combination(s) of the unknowns are seen by neither the data nor a prior ({}); give their parameters a prior",
                    unseen.len(),
                    unseen.join("; ")
                ),
            })
        }
        Status::SingularBlock { block, .. } => Some(MechanismCalibrationError::NotDetermined {
            reason: match block {
                BlockId::Group(k) if *k < samples => {
                    format!("the pose of point sample {k} is not determined by its readings")
                }
                BlockId::Group(k) => format!(
                    "the centre of ball {} is not determined by its touches (touch it at points not all on one circle)",
                    k - samples
                ),
                BlockId::Point(i) => format!("the solver's point {i} is singular"),
            },
        }),
        Status::InvalidProblem { .. } => Some(MechanismCalibrationError::Solver {
            status: status.clone(),
        }),
        _ => None,
    }
}

/// The name of unknown `k` of the global block of `data`'s fit: a
/// parameter of the mechanism's, the trigger height, or its place in the
/// block past them (a tracker's frame or offsets, a tied ball's centre).
fn global_name(data: &MechanismData, k: usize) -> String {
    let parameters = data.mechanism.parameters();
    match parameters.get(k) {
        Some(parameter) => parameter.name.clone(),
        None if k == parameters.len() && data.has_trigger_height() => TRIGGER_HEIGHT.to_string(),
        None => format!("global unknown {k}"),
    }
}

/// Every observation's check, and the local blocks' marginal sigmas
/// ([`checks`]).
type CheckedBlocks<const C: usize> =
    Result<(ObservationChecks, Vec<SVector<f64, C>>), MechanismCalibrationError>;

/// Every observation's residuals, redundancy numbers and normalised
/// residuals at `state`, through the solver's redundancy pass of `problem`
/// (its points started from `caches`, the solve's last pass's, freed after
/// it; `base` its radius problem, [`solve_and_check`]): the global
/// observations, then each point sample (its rows), then each touch (its
/// `R` rows), in the order of the data; with the local blocks' marginal
/// sigmas, which the pass gives as well.
fn checks<const C: usize, const P: usize, const R: usize, Q>(
    problem: &Q,
    base: &MechanismProblem<C>,
    state: &State<C, P>,
    covariance: &DMatrix<f64>,
    refs: &[(ObservationRef, usize)],
    groups_per_chunk: usize,
    mut caches: Vec<WarmStart>,
) -> CheckedBlocks<C>
where
    Q: Problem<C, P, R, PointCache = WarmStart, Error = MechanismCalibrationError>,
{
    let row = |residual: f64, redundancy: f64| RowCheck {
        residual: residual as f32,
        redundancy: redundancy as f32,
    };
    // Every row in the order of the data, each written in its place: the
    // global observations' once the pass has given them, then each point
    // sample's and each touch's as the pass gives them, a touch at its
    // place in the data (the pass's points are in the solver's order).
    let global_rows: usize = refs.iter().map(|&(_, rows)| rows).sum();
    let order = base.touch_order();
    let sample_points = base.n_points() - order.len();
    let touches = global_rows + R * sample_points;
    // Written on the threads: its pages are had on both.
    let mut rows = Vec::new();
    rows.par_extend(rayon::iter::repeat_n(
        RowCheck::default(),
        touches + R * order.len(),
    ));
    let mut point = 0usize;
    let global = redundancy::<C, P, R, _>(
        problem,
        state,
        covariance,
        &mut caches,
        groups_per_chunk,
        |checked| {
            let at = match point.checked_sub(sample_points) {
                None => global_rows + R * point,
                Some(k) => touches + R * order[k],
            };
            for (j, room) in rows[at..at + R].iter_mut().enumerate() {
                *room = row(checked.residual[j], checked.redundancy[j]);
            }
            point += 1;
        },
    )
    .map_err(|status| MechanismCalibrationError::Solver { status })?;
    // The checks below take their room.
    drop(caches);
    let global_checks = (global.global_observation_residuals.iter())
        .zip(global.global_observations.iter())
        .map(|(&e, &r)| row(e, r));
    for (room, check) in rows[..global_rows].iter_mut().zip(global_checks) {
        *room = check;
    }
    let observations = (refs.iter().copied())
        .chain((0..R * sample_points / base.actuators()).map(|index| {
            let kind = ObservationKind::Sample;
            (ObservationRef { kind, index }, base.actuators())
        }))
        .chain((0..order.len()).map(|index| {
            let kind = ObservationKind::Touch;
            (ObservationRef { kind, index }, R)
        }));
    let checks = ObservationChecks::new(rows, observations);
    debug_assert_eq!(
        checks.len(),
        refs.len() + sample_points * R / base.actuators() + order.len(),
        "the rows end where the observations' do"
    );
    Ok((checks, global.group_sigmas))
}

#[cfg(test)]
mod tests {
    use parcal_simulate::{Scenario, simulate};

    use super::*;
    use crate::CalibrationOptions;
    use crate::mechanism::problem::tests::sigmas_apart;
    use crate::mechanism::reaches::Reaches;
    use crate::options::{PriorMode, RadiusModel, Simulation};
    use crate::sphere_fit::{best_fit, mirror_fit};

    /// A simulated campaign of 1428 balls touched 7 times each (tilts up
    /// to 10 degrees), under simulation `simulation`'s model with the
    /// propagated prior (the balls' centres without one), each ball's
    /// radius exact (blocks of three): a ball's misfit moves the machine
    /// little.
    fn campaign(simulation: Simulation) -> MechanismData {
        let scenario = Scenario::scaled(1428, 7, 10f64.to_radians());
        let dataset = simulate(&scenario, 1).unwrap().dataset;
        let options = CalibrationOptions {
            radius: RadiusModel::PerContact,
            prior: PriorMode::Propagated,
            ..CalibrationOptions::simulation(simulation)
        };
        MechanismData::from_hexapod_touches(&dataset, &options).unwrap()
    }

    /// `problem` solved from its start, then again from that minimum with
    /// the first ball whose touches fit a mirror image more than 1 mm away
    /// moved there: the second solve (damped: Gauss-Newton's first step at
    /// a ball misfit by millimetres throws the machine far off) finds the
    /// ball on the wrong side once it has settled, re-seeds it and returns
    /// to the first's minimum.
    fn check_reseeding<const P: usize, const R: usize, Q: FitProblem<3, P, R>>(
        problem: &mut Q,
        state: State<3, P>,
        mut caches: Vec<WarmStart>,
    ) {
        let options = SolverOptions::default();
        let started = Instant::now();
        let mut observer = |_: &IterationRecord| {};
        let (right, found) = solve_reseeding(
            problem,
            state,
            &mut caches,
            &options,
            started,
            &mut observer,
        );
        assert_eq!(right.status, Status::Converged);
        assert!(found.is_empty(), "{found:?}");
        let base = problem.base();
        let radius = base.data().observations.balls[0].radius;
        let mirrored = |b: usize| {
            let points = Problem::<3, 0, 1>::group_points(base, b);
            let mut reaches = Reaches::default();
            base.reach(
                points.clone(),
                &right.state.global,
                &caches[points],
                &mut reaches,
            );
            let tips: Vec<Vector3<f64>> =
                (reaches.at.into_iter()).map(|r| r.unwrap().point).collect();
            let fit = best_fit(&tips, radius).unwrap();
            let mirror = mirror_fit(&tips, radius, &fit).unwrap();
            ((mirror.centre - fit.centre).norm() > 1.0).then_some((b, mirror.centre, tips))
        };
        let balls = base.data().observations.balls.len();
        let (b, mirror, tips) = (0..balls).find_map(mirrored).expect("a mirror image");
        let mut wrong = right.state.clone();
        problem.reseed(&mut wrong, b, &mirror, &tips);
        let damped = SolverOptions {
            method: parcal_solver::Method::LevenbergMarquardt {
                initial_lambda: 1e-3,
            },
            max_iterations: 200,
            ..options
        };
        let (reseeded, found) =
            solve_reseeding(problem, wrong, &mut caches, &damped, started, &mut observer);
        assert_eq!(reseeded.status, Status::Converged);
        assert_eq!(found.len(), 1, "{found:?}");
        assert_eq!(found[0].ball, b);
        let gain = found[0].gain;
        assert!(gain >= crate::mirror::MIRROR_GAIN, "{gain}");
        let covariance = right.covariance.unwrap();
        let difference = sigmas_apart(&reseeded.state.global, &right.state.global, &covariance);
        // Both stop within the solver's tolerance of their sigmas.
        assert!(
            difference < 2.0 * parcal_solver::SIGMA_TOLERANCE,
            "{difference:e}"
        );
    }

    #[test]
    fn a_ball_on_the_wrong_side_is_reseeded_and_the_fit_resumes() {
        // By its radius rows, and by its coordinates (its touches charted
        // again about their directions from the re-seeded centre).
        let data = campaign(Simulation::I);
        let mut radius = MechanismProblem::<3>::new(&data, Loss::Squared).unwrap();
        let (state, caches) = start(&radius).unwrap();
        check_reseeding::<0, 1, _>(&mut radius, state, caches);
        let data = campaign(Simulation::II);
        let (mut coordinates, state, caches) =
            CoordinateProblem::<3>::start(&data, Loss::Squared).unwrap();
        check_reseeding::<2, 3, _>(&mut coordinates, state, caches);
    }
}
