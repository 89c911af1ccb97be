//! One calibration run: set up, solve, judge the priors, and the record of
//! the result (calibration.json).

use std::collections::BTreeMap;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use parcal_dataset::{
    Actuator, CalibratedMachine, CentreEstimate, Dataset, GeometryRecord, Machine, ParameterTable,
};
use parcal_kinematics::{
    Geometry, N_PARAMS, PARAM_NAMES, ParamCovariance, Params, Pose, Vec3, params,
};
use parcal_observe::KinematicPrior;
use parcal_solver::{
    Iterate, IterationRecord, Monitor, Solution, SolverOptions, SpectrumDiagnostics, Status,
    group_sigmas, solve_with_caches,
};

use crate::conflict::{ConflictTest, PaperPriorInconsistency, paper_prior_consistency};
use crate::fit::{BallMisfit, misfit_balls};
use crate::layout::kinematic_params;
use crate::layout::{ParameterGroup, ParameterLayout};
use crate::mirror::{SETTLED, WrongSide, wrong_side};
use crate::mixed::InstrumentResult;
use crate::problem::{ActuatorScales, CalibrationProblem, ContactObservations};
use crate::reliability::Reliability;
use crate::robust::START_TOLERANCE;
use crate::setup::{MirrorStart, Observations, Setup, kinematic_prior};
use crate::verdict::{GLOBAL_TEST_LEVEL, GlobalTest, Verdict, at_minimum, rows_and_unknowns};
use crate::{CalibrateError, CalibrationOptions, Method, PriorMode, RadiusModel};

/// The outcome of one calibration.
#[non_exhaustive]
pub struct CalibrationRun {
    /// What the run was asked to do.
    pub options: CalibrationOptions,
    /// The design geometry as given (machine.json's frames): where the
    /// accuracy maps place their targets.
    pub design: Geometry,
    /// machine.json as given (recorded in calibration.json's `design`).
    pub machine: Machine,
    /// The design's canonical parameters (the initial estimate).
    pub initial_params: Params,
    /// The a priori knowledge on the parameters, if any.
    pub prior: Option<KinematicPrior>,
    /// Identified parameters (canonical frames).
    pub params: Params,
    /// Posterior covariance of the 33 (inverse of the undamped reduced
    /// matrix at the final state); `None` when the run did not converge or
    /// the matrix is not positive definite.
    pub covariance: Option<ParamCovariance>,
    /// The identified global block ([`CalibrationRun::layout`]): the 33,
    /// the tied balls' unknowns, the scales and the instrument groups.
    pub global: DVector<f64>,
    /// Its posterior covariance (the 33's is its leading block).
    pub global_covariance: Option<DMatrix<f64>>,
    /// artefacts.json's ball ids, in its order.
    pub ball_ids: Vec<String>,
    /// Identified ball centres (canonical base frame).
    pub centres: Vec<Vec3>,
    /// Marginal sigmas of the centres (with the parameters' uncertainty).
    pub centre_sigmas: Option<Vec<Vec3>>,
    /// Identified ball radii, when each ball's radius was an unknown
    /// ([`crate::RadiusModel::PerBall`]).
    pub radii: Option<Vec<f64>>,
    /// Their marginal sigmas.
    pub radius_sigmas: Option<Vec<f64>>,
    /// Balls whose contacts fit far worse than the noise allows
    /// ([`crate::fit`]) at the final iterate of a converged run
    /// ([`crate::verdict::at_minimum`]); empty when none is, or when the
    /// run did not converge.
    pub ball_misfits: Vec<BallMisfit>,
    /// Balls that a settled iterate showed on the wrong side of their
    /// contacts, re-seeded at the mirror image of their centre fit before
    /// the calibration resumed ([`crate::mirror`]).
    pub mirrored: Vec<Mirrored>,
    /// How the solver's run ended.
    pub status: Status,
    /// One record per iterate at which a step was computed, then the final
    /// iterate's ([`CalibrationRun::iterations`]).
    pub history: Vec<IterationRecord>,
    /// Whitened residual rows (contacts x rows per contact).
    pub residual_rows: usize,
    /// measurements.csv row of each contact in the solver's (by-ball) order.
    pub rows: Vec<u32>,
    /// Spectrum of the reduced matrix at the end.
    pub spectrum: Option<SpectrumDiagnostics>,
    /// Prior-data conflict tests (kinematic parameters, ball centres) of a
    /// converged run ([`crate::verdict::at_minimum`]).
    pub conflicts: Vec<ConflictTest>,
    /// The global block: the kinematic parameters, then the centres of the
    /// balls tied by calibrated distances, then the groups of the poses and
    /// points if any ([`crate::mixed`]).
    pub layout: ParameterLayout,
    /// The calibrated distances (artefacts.json) used as observations.
    pub distances_used: usize,
    /// The poses and points calibrated with the touches, if the dataset
    /// has any ([`crate::mixed`]).
    pub instruments: Option<InstrumentResult>,
    /// Paper mode: the check of the diagonal prior against the propagated
    /// design tolerances ([`crate::conflict::paper_prior_consistency`]).
    pub prior_consistency: Option<PaperPriorInconsistency>,
    /// The global test at the final state ([`crate::verdict`]).
    pub global_test: Option<GlobalTest>,
    /// Every observation's check at the final state of a run that converged
    /// ([`crate::verdict::at_minimum`]); `None` otherwise.
    pub reliability: Option<Reliability>,
    /// When this is the Levenberg-Marquardt run made after a Gauss-Newton
    /// run ran away: how that run ended ([`calibrate`]).
    pub gauss_newton: Option<RunAway>,
}

impl CalibrationRun {
    /// Whether the solver converged.
    pub fn converged(&self) -> bool {
        matches!(self.status, Status::Converged)
    }

    /// The run's verdict ([`crate::verdict`]).
    /// With a robust loss, the test of data snooping is replaced by the
    /// number of observations it down-weighted ([`crate::robust`]).
    pub fn verdict(&self) -> Verdict {
        let outlier = self
            .reliability
            .as_ref()
            .is_some_and(|r| match &r.down_weighted {
                Some(down_weighted) => crate::robust::too_many(down_weighted),
                None => r.fails_snooping(crate::hypothesis::SNOOPING_LEVEL),
            });
        Verdict::new(&self.status, self.global_test, outlier)
    }

    /// Gauss-Newton iterations (linear solves; Levenberg-Marquardt: steps
    /// tried): one per record but the final iterate's, and that iterate's
    /// own when the run converged there (its step certified convergence
    /// and was not applied, as in Ceres). The independent reference
    /// implementation applies that last step and records one more iterate;
    /// both count the same solves.
    pub fn iterations(&self) -> usize {
        self.history.len().saturating_sub(1) + usize::from(self.converged())
    }

    /// The names of the global block's parameters
    /// ([`ParameterLayout::names`] with the balls' ids and the sessions'
    /// labels).
    pub fn names(&self) -> Vec<String> {
        let sessions = self
            .instruments
            .as_ref()
            .map_or(&[][..], |i| &i.model.sessions[..]);
        self.layout.names(&self.ball_ids, sessions)
    }

    /// Marginal sigmas of the parameters.
    pub fn sigmas(&self) -> Option<Params> {
        self.covariance.map(|c| c.diagonal().map(f64::sqrt))
    }

    /// Condition number of the posterior covariance (ratio of the extreme
    /// eigenvalues of the reduced matrix); infinite when the data and prior
    /// leave a direction undetermined.
    pub fn condition_number(&self) -> Option<f64> {
        let spectrum = self.spectrum.as_ref()?;
        (!spectrum.eigenvalues.is_empty()).then(|| spectrum.condition_number())
    }

    /// RMS of the whitened residuals at the final iterate (1 at the noise
    /// level).
    pub fn residual_rms(&self) -> f64 {
        self.history.last().map_or(f64::NAN, |r| {
            (r.data_cost / self.residual_rows as f64).sqrt()
        })
    }

    /// The global block's covariance as calibration.json records it: none
    /// when the run did not converge (its covariance at the last iterate is
    /// no posterior accuracy), and then no sigma either.
    fn posterior(&self) -> Option<&DMatrix<f64>> {
        self.global_covariance.as_ref().filter(|_| self.converged())
    }

    /// calibration.json's `parameters` and `covariance`: the global block's
    /// [`ParameterLayout::recorded`] parameters (the balls' unknowns are in
    /// `ball_centres`); the covariance empty without one (and when the
    /// run did not converge).
    fn parameter_table(&self) -> (ParameterTable, Vec<Vec<f64>>) {
        let names = self.names();
        let columns = self.layout.recorded();
        let sigmas = self.posterior().map_or_else(
            || DVector::zeros(self.global.len()),
            |c| c.diagonal().map(f64::sqrt),
        );
        let table = ParameterTable {
            names: columns.iter().map(|&k| names[k].clone()).collect(),
            values: columns.iter().map(|&k| self.global[k]).collect(),
            sigma: columns.iter().map(|&k| sigmas[k]).collect(),
        };
        let covariance = self.posterior().map_or_else(Vec::new, |c| {
            columns
                .iter()
                .map(|&a| columns.iter().map(|&b| c[(a, b)]).collect())
                .collect()
        });
        (table, covariance)
    }

    /// calibration.json's `machine`: with poses or points, the machine in
    /// the first session's frames
    /// ([`crate::instruments::InstrumentModel::calibrated_machine`]); with
    /// touches alone and unknown scales, the canonical geometry with the
    /// calibrated scales; else none (the design's actuators hold).
    fn calibrated_machine(&self) -> Option<CalibratedMachine> {
        if let Some(i) = &self.instruments {
            let values = i.model.values(&i.global);
            return Some(
                i.model
                    .calibrated_machine(&values, &i.sigmas(), &self.machine),
            );
        }
        let range = self.layout.range(ParameterGroup::ActuatorScales)?;
        let sigma = |k: usize| self.posterior().map_or(0.0, |c| c[(k, k)].sqrt());
        Some(CalibratedMachine {
            geometry: geometry_record(&params::from_params(&self.params)),
            actuator: Actuator {
                unit: self.machine.actuator.unit.clone(),
                scale: std::array::from_fn(|i| self.global[range.start + i]),
                scale_sigma: Some(std::array::from_fn(|i| sigma(range.start + i))),
            },
        })
    }

    /// The calibration.json record of this run, with `status`, the sentence
    /// of its status (`parcal_report::sentences::status`); a run that did
    /// not converge records no posterior covariance or sigma.
    pub fn record(&self, status: String) -> parcal_dataset::Calibration {
        let geometry = params::from_params(&self.params);
        let (parameters, covariance) = self.parameter_table();
        let converged = self.converged();
        let centre_sigmas = self.centre_sigmas.as_ref().filter(|_| converged);
        let radius_sigmas = self.radius_sigmas.as_ref().filter(|_| converged);
        let ball_centres = self
            .ball_ids
            .iter()
            .enumerate()
            .map(|(k, id)| {
                let sigma = centre_sigmas.map_or(Vec3::zeros(), |s| s[k]);
                let radius = self.radii.as_ref().map(|r| r[k]);
                (
                    id.clone(),
                    CentreEstimate {
                        centre: self.centres[k].into(),
                        sigma: sigma.into(),
                        radius,
                        radius_sigma: radius.map(|_| radius_sigmas.map_or(0.0, |s| s[k])),
                    },
                )
            })
            .collect();
        let rows = self.residual_rows as f64;
        let iterations = self
            .history
            .iter()
            .map(|r| parcal_dataset::IterationSummary {
                cost: r.cost,
                step_norm: r.step_norm,
                residual_rms: (r.data_cost / rows).sqrt(),
            })
            .collect();
        let mut options = BTreeMap::new();
        options.insert(
            "observation".to_string(),
            self.options.observation.to_string().into(),
        );
        options.insert(
            "weights".to_string(),
            format!("{:?}", self.options.weighting)
                .to_lowercase()
                .into(),
        );
        let method = match self.options.method {
            Method::GaussNewton => "gauss-newton",
            Method::LevenbergMarquardt { .. } => "levenberg-marquardt",
        };
        options.insert("method".to_string(), method.into());
        options.insert("radius".to_string(), self.options.radius.to_string().into());
        options.insert("loss".to_string(), self.options.loss.to_string().into());
        parcal_dataset::Calibration {
            canonical: geometry_record(&geometry),
            parameters,
            covariance,
            ball_centres,
            prior: self.options.prior.to_string(),
            iterations,
            converged: self.converged(),
            status,
            options,
            machine: self.calibrated_machine(),
            sessions: self.instruments.as_ref().map_or_else(Vec::new, |i| {
                i.model.session_records(&i.model.values(&i.global))
            }),
            verdict: String::new(),
            reasons: Vec::new(),
            warnings: Vec::new(),
            global_test: None,
            provenance: None,
            removed_observations: Vec::new(),
            down_weighted_observations: Vec::new(),
            design: Some(self.machine.clone()),
            diagnostics: None,
        }
    }
}

/// A geometry as calibration.json holds it.
fn geometry_record(geometry: &Geometry) -> GeometryRecord {
    GeometryRecord {
        base_joints: geometry.base.map(Into::into),
        platform_joints: geometry.platform.map(Into::into),
        tool: geometry.tool.into(),
        leg_lengths: geometry.legs,
    }
}

/// Calibrates `dataset` (docs/paper-scenario.md section 4). `observer` sees each iteration.
/// The dataset is validated first ([`crate::validate`]).
///
/// A Gauss-Newton run that runs away (it ends diverged, or failed after
/// its first step, or at its iteration limit after a step raised the cost
/// more than `RUNAWAY_RISE`-fold, or with a cost above its first, or
/// with a robust loss: a blunder or a start far from the solution, where
/// full steps overshoot) is made again with Levenberg-Marquardt, whose
/// steps never raise the cost; [`CalibrationRun::gauss_newton`] keeps how
/// the first run ended.
pub fn calibrate(
    dataset: &Dataset,
    options: &CalibrationOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<CalibrationRun, CalibrateError> {
    let started = Instant::now();
    let run = calibrate_once(dataset, options, observer)?;
    let costs = run.history.first().zip(run.history.last());
    let overshot = run
        .history
        .windows(2)
        .any(|pair| pair[1].cost > RUNAWAY_RISE * pair[0].cost);
    let ran_away = matches!(options.method, Method::GaussNewton)
        && costs.is_some()
        && match run.status {
            Status::Diverged { .. } => true,
            // A full step to where the machine's forward kinematics fails
            // (large tilts): Levenberg-Marquardt rejects such a step.
            Status::ProblemFailed { iteration, .. } => iteration > 0,
            // Or ended above where it started; or, with a robust loss,
            // did not settle at all (its reweighting can keep full steps
            // from settling where damped ones do).
            Status::IterationLimit => {
                overshot
                    || costs.is_some_and(|(first, last)| last.cost > first.cost)
                    || !options.loss.is_squared()
            }
            _ => false,
        };
    if !ran_away {
        return Ok(run);
    }
    let mut lm = options.clone().levenberg_marquardt();
    // What is left of the budget.
    lm.time_limit = options
        .time_limit
        .map(|limit| limit.saturating_sub(started.elapsed()));
    let mut again = calibrate_once(dataset, &lm, observer)?;
    let (first, last) = costs.expect("checked above");
    again.gauss_newton = Some(RunAway {
        status: run.status,
        initial_cost: first.cost,
        final_cost: last.cost,
        iterations: run.history.len().saturating_sub(1),
    });
    Ok(again)
}

/// The rise of the cost in one Gauss-Newton step that marks a run that
/// did not converge as run away ([`calibrate`]).
pub const RUNAWAY_RISE: f64 = 10.0;

/// How a Gauss-Newton run that ran away ended ([`calibrate`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RunAway {
    /// Its status.
    pub status: Status,
    /// Its cost at the start.
    pub initial_cost: f64,
    /// Its cost at its end.
    pub final_cost: f64,
    /// Its iterations.
    pub iterations: usize,
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
        method: options.method,
        max_iterations: options.max_iterations,
        step_tolerance: options.step_tolerance,
        sigma_tolerance: options.sigma_tolerance,
        time_limit: options.time_limit,
        // The checks' pass gives them ([`SolverRun::solve`]).
        group_sigmas: false,
        ..SolverOptions::default()
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
            PARAM_NAMES.iter().map(|s| s.to_string()),
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
        ball_ids,
        centres: solved.centres,
        centre_sigmas: solved.centre_sigmas,
        radii: solved.radii,
        radius_sigmas: solved.radius_sigmas,
        ball_misfits: solved.ball_misfits,
        mirrored: solved.mirrored,
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
    let (mut names, mut d, mut prior, mut posterior) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut chi_square = 0.0;
    for (k, ball) in dataset.artefacts.balls.iter().enumerate() {
        for (c, axis) in ["x", "y", "z"].iter().enumerate() {
            let difference = centres[k][c] - setup.initial_centres[k][c];
            names.push(format!("centre {}.{axis}", ids[k]));
            d.push(difference);
            prior.push(ball.centre_sigma.powi(2));
            posterior.push(sigmas[k][c].powi(2));
            chi_square += (difference / ball.centre_sigma).powi(2);
        }
    }
    ConflictTest::new("ball centres", names, &d, &prior, &posterior, chi_square)
}

/// The conflict test of the radius priors of a per-ball radius (mean: the
/// calibrated radius, sigma: artefacts.json's radius_sigma), each named
/// `radius ID`: a calibrated radius the touches contradict shows here.
fn radius_conflict(dataset: &Dataset, radii: &[f64], sigmas: &[f64]) -> ConflictTest {
    let balls = &dataset.artefacts.balls;
    let names = balls.iter().map(|ball| format!("radius {}", ball.id));
    let d: Vec<f64> = balls.iter().zip(radii).map(|(b, r)| r - b.radius).collect();
    let prior: Vec<f64> = balls.iter().map(|b| b.radius_sigma.powi(2)).collect();
    let posterior: Vec<f64> = sigmas.iter().map(|s| s * s).collect();
    let chi_square = d.iter().zip(&prior).map(|(d, v)| d * d / v).sum();
    ConflictTest::new("ball radii", names, &d, &prior, &posterior, chi_square)
}

/// The parts of a solution that do not depend on the point block size.
struct Estimate {
    params: Params,
    covariance: Option<ParamCovariance>,
    global: DVector<f64>,
    global_covariance: Option<DMatrix<f64>>,
    centres: Vec<Vec3>,
    centre_sigmas: Option<Vec<Vec3>>,
    /// With a per-ball radius: the radii and their sigmas.
    radii: Option<Vec<f64>>,
    radius_sigmas: Option<Vec<f64>>,
    /// The balls that fit their contacts far worse than the noise allows.
    ball_misfits: Vec<BallMisfit>,
    status: Status,
    history: Vec<IterationRecord>,
    residual_rows: usize,
    spectrum: Option<SpectrumDiagnostics>,
    /// Balls re-seeded on the other side of their contacts.
    mirrored: Vec<Mirrored>,
    /// The global test at the final state.
    global_test: Option<GlobalTest>,
    /// The observations' checks at the final state.
    reliability: Option<Reliability>,
    /// The poses and points calibrated with the touches.
    instruments: Option<InstrumentResult>,
}

/// What a solve needs besides the problem.
struct SolverRun<'a> {
    setup: &'a Setup,
    dataset: &'a Dataset,
    options: &'a CalibrationOptions,
    solver: &'a SolverOptions,
}

impl SolverRun<'_> {
    /// Solves `problem` from the set-up's initial state, the design's
    /// forward kinematics (`poses`) warm-starting the first iteration. Once
    /// Gauss-Newton has settled ([`SETTLED`]), every iterate is checked for
    /// balls on the wrong side of their contacts ([`crate::mirror`]); if
    /// there are, the run stops there, re-seeds them and resumes (once: the
    /// re-seeded balls' warm starts are those of that iterate).
    fn solve<const G: usize, const P: usize, const R: usize, O>(
        &self,
        problem: &mut CalibrationProblem<'_, O, G>,
        poses: Vec<Pose>,
        mut observer: &mut dyn FnMut(&IterationRecord),
        rows_per_contact: usize,
    ) -> Result<Estimate, CalibrateError>
    where
        O: ContactObservations<R, P> + MirrorStart,
    {
        let setup = self.setup;
        let started = Instant::now();
        let mut caches = poses;
        let mut watch = WrongSideWatch {
            run: self,
            observer: &mut *observer,
            found: Ok(Vec::new()),
        };
        // A redescending loss starts from a robust estimate of Huber's
        // ([`crate::robust::start`]), solved to a looser tolerance.
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
        let mut solution = solve_with_caches(
            &*problem,
            setup.initial_state(self.dataset),
            &mut caches,
            &first_stage,
            &mut watch,
        );
        let wrong = watch.found?;
        let mut mirrored = Vec::with_capacity(wrong.len());
        if let Status::Stopped { iteration } = solution.status {
            // The stopped iterate's state is the next start (moved, not
            // copied).
            let Solution {
                mut state,
                history: first,
                ..
            } = solution;
            for (side, tips) in wrong {
                let k = side.ball;
                let initial_centre = problem.observations.mirror_start(
                    setup,
                    self.dataset,
                    self.options.weighting,
                    k,
                )?;
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
                    if let (Some(global), Some(_)) =
                        (&mut problem.global_prior, &problem.ball_priors)
                    {
                        global
                            .mean
                            .rows_mut(range.start, 3)
                            .copy_from(&initial_centre);
                    }
                }
                for (i, tip) in setup.groups[k].clone().zip(&tips) {
                    let row = setup.order[i] as usize;
                    state.points[i] = problem
                        .observations
                        .angles_toward(i, &(tip - side.mirror.centre))
                        .map_err(|source| CalibrateError::Observation { row, source })?;
                }
                mirrored.push(Mirrored {
                    ball: k,
                    id: self.dataset.artefacts.balls[k].id.clone(),
                    initial_centre,
                    iteration,
                    side,
                });
            }
            // Both solves together within the iteration and time limits.
            let rest = SolverOptions {
                max_iterations: first_stage.max_iterations.saturating_sub(iteration),
                time_limit: first_stage
                    .time_limit
                    .map(|limit| limit.saturating_sub(started.elapsed())),
                ..first_stage.clone()
            };
            solution = solve_with_caches(&*problem, state, &mut caches, &rest, &mut observer);
            solution.history.splice(0..0, first);
        }
        if start.is_some() {
            problem.loss = loss;
            if matches!(
                solution.status,
                Status::Converged | Status::IterationLimit | Status::TimeLimit
            ) {
                // The rest of the iteration and time limits, from Huber's
                // estimate (where a limit stopped it, if one did).
                let Solution {
                    state,
                    history: first,
                    ..
                } = solution;
                let rest = SolverOptions {
                    max_iterations: self.solver.max_iterations.saturating_sub(first.len()),
                    time_limit: self
                        .solver
                        .time_limit
                        .map(|limit| limit.saturating_sub(started.elapsed())),
                    ..self.solver.clone()
                };
                solution = solve_with_caches(&*problem, state, &mut caches, &rest, &mut observer);
                solution.history.splice(0..0, first);
            }
        }
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
        let (rows, unknowns) =
            rows_and_unknowns(&*problem, setup.order.len(), problem.global_rows());
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
                    &*problem,
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
                    group_sigmas(&*problem, state, covariance, &mut caches, groups_per_chunk);
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
            .map(|i| i.result(&state.global, solution.covariance.as_ref()))
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
        misfit_balls(
            self.dataset.artefacts.balls.iter().map(|b| b.id.as_str()),
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

/// A ball re-seeded at the mirror image of its centre fit.
#[derive(Debug, Clone, PartialEq)]
pub struct Mirrored {
    /// Its index (artefacts.json order).
    pub ball: usize,
    /// artefacts.json's id.
    pub id: String,
    /// Its new initial centre (the mirror fit of its design-FK contact
    /// points).
    pub initial_centre: Vec3,
    /// The Gauss-Newton iterations before it was found (the first settled
    /// iterate that showed it, [`SETTLED`]).
    pub iteration: usize,
    /// What that iterate showed.
    pub side: WrongSide,
}
