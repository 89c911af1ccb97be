//! One calibration run of any hexapod dataset: ball touches (with poses
//! and points beside them, if any) set up, solved and their priors judged,
//! or poses and points alone through the instrument stage
//! ([`crate::instruments::run`]); the one result type and its record
//! (calibration.json).

use std::collections::BTreeMap;
use std::time::Instant;

use nalgebra::{DMatrix, DVector};
use parcal_dataset::{
    Actuator, CalibratedMachine, CentreEstimate, Dataset, Machine, ParameterTable,
};
use parcal_kinematics::{Geometry, PARAM_NAMES, ParamCovariance, Params, Vec3, params};
use parcal_observe::KinematicPrior;
use parcal_solver::{IterationRecord, SolverOptions, SpectrumDiagnostics, Status};

use crate::conflict::{ConflictTest, PaperPriorInconsistency, paper_prior_consistency};
use crate::fit::BallMisfit;
use crate::instruments::InstrumentResult;
use crate::instruments::run::geometry_record;
use crate::instruments::validate::Calibrated;
use crate::layout::{ParameterGroup, ParameterLayout};
use crate::mirror::Mirrored;
use crate::problem::CalibrationProblem;
use crate::reliability::Reliability;
use crate::setup::{Observations, Setup, kinematic_prior};
use crate::verdict::{GlobalTest, Verdict, at_minimum};
use crate::{CalibrateError, CalibrationOptions, Method, PriorMode, RadiusModel};

mod solve;

use solve::SolverRun;

/// The outcome of one calibration. What every run has (the options, the
/// design, the status and history, the global block and its covariance,
/// its layout and spectrum, the global test, the checks, the verdict) is
/// here; the touches' parts (balls, contacts, conflicts) are empty or
/// `None` for poses and points alone, and the poses' and points' parts
/// are in [`CalibrationRun::instruments`].
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
    /// Identified parameters (canonical frames; poses alone hold the
    /// design's tool).
    pub params: Params,
    /// Posterior covariance of the 33 (inverse of the undamped reduced
    /// matrix at the final state; poses alone: the tool's rows from the
    /// prior conditional on the rest, which the data do not change);
    /// `None` when the run did not converge or the matrix is not positive
    /// definite.
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
    /// Whitened residual rows: contacts x rows per contact; without
    /// touches, 6 per pose and 3 per point.
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
    /// The poses and points, if the dataset has any (with touches:
    /// [`crate::mixed`]).
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

    /// Whether the run calibrated ball touches (else poses and points
    /// alone).
    pub fn has_touches(&self) -> bool {
        !self.rows.is_empty()
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

    /// Marginal sigmas of the global block.
    pub fn global_sigmas(&self) -> Option<DVector<f64>> {
        self.global_covariance
            .as_ref()
            .map(|c| c.diagonal().map(f64::sqrt))
    }

    /// The global block's parameters after the kinematic ones and the tied
    /// balls' (the actuator scales, the frames, the sessions' nuisances),
    /// named, with their values and sigmas (zero without a covariance);
    /// none without poses and points.
    pub fn instrument_parameters(&self) -> Vec<(String, f64, f64)> {
        if self.instruments.is_none() {
            return Vec::new();
        }
        let names = self.names();
        let sigmas = self
            .global_sigmas()
            .unwrap_or_else(|| DVector::zeros(self.global.len()));
        let first = self
            .layout
            .groups()
            .iter()
            .find(|(group, _)| {
                !matches!(
                    group,
                    ParameterGroup::Kinematic
                        | ParameterGroup::BallCentre { .. }
                        | ParameterGroup::BallRadius { .. }
                )
            })
            .map_or(self.global.len(), |(_, range)| range.start);
        (first..self.global.len())
            .map(|k| (names[k].clone(), self.global[k], sigmas[k]))
            .collect()
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
        self.history.last().map_or(f64::NAN, |r| self.rms_of(r))
    }

    /// The RMS of the whitened residuals of `record` over the
    /// [`CalibrationRun::residual_rows`]: the touches' with touches (the
    /// poses and points beside them are global observations), else the
    /// poses' and points'.
    fn rms_of(&self, record: &IterationRecord) -> f64 {
        let cost = if self.has_touches() {
            record.data_cost
        } else {
            record.global_observation_cost
        };
        (cost / self.residual_rows as f64).sqrt()
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
        let sigma = |k: usize| self.posterior().map_or(0.0, |c| c[(k, k)].sqrt());
        if let Some(i) = &self.instruments {
            let values = i.model.values(&self.global);
            let sigmas = DVector::from_fn(self.global.len(), |k, _| sigma(k));
            return Some(i.model.calibrated_machine(&values, &sigmas, &self.machine));
        }
        let range = self.layout.range(ParameterGroup::ActuatorScales)?;
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
        let iterations = self
            .history
            .iter()
            .map(|r| parcal_dataset::IterationSummary {
                cost: r.cost,
                step_norm: r.step_norm,
                residual_rms: self.rms_of(r),
            })
            .collect();
        // With touches, the observation equation, the weights, the radius
        // model and the loss; poses and points alone have their one
        // observation and weighting.
        let method = match self.options.method {
            Method::GaussNewton => "gauss-newton",
            Method::LevenbergMarquardt { .. } => "levenberg-marquardt",
        };
        let mut options = BTreeMap::from([("method".to_string(), method.into())]);
        if self.has_touches() {
            let given = &self.options;
            let weights = format!("{:?}", given.weighting).to_lowercase();
            for (name, value) in [
                ("observation", given.observation.to_string()),
                ("weights", weights),
                ("radius", given.radius.to_string()),
                ("loss", given.loss.to_string()),
            ] {
                options.insert(name.to_string(), value.into());
            }
        } else {
            options.insert("observation".to_string(), "instruments".into());
        }
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
                i.model.session_records(&i.model.values(&self.global))
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

impl Calibrated {
    /// From a calibration of poses and points in memory (with or without
    /// ball touches): its numbers ([`CalibrationRun::record`]) as
    /// [`Calibrated::from_record`] reads them, with its global test.
    pub fn of_run(run: &CalibrationRun) -> Result<Self, CalibrateError> {
        let mut calibrated = Self::from_record(&run.record(String::new()))?;
        calibrated.global_test = run.global_test.map(|t| (t.cost, t.redundancy));
        Ok(calibrated)
    }
}

/// Calibrates `dataset` (docs/paper-scenario.md section 4): its ball
/// touches with the poses and points beside them, if any; or, without
/// touches, its poses and points alone (the instrument stage,
/// [`crate::instruments::run`], least squares only). `observer` sees each
/// iteration. The dataset is validated first ([`crate::validate`]).
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
    if !dataset.has_touches() && !dataset.tracker.is_empty() {
        return instruments_alone(dataset, options, observer);
    }
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
        ball_ids: Vec::new(),
        centres: Vec::new(),
        centre_sigmas: None,
        radii: None,
        radius_sigmas: None,
        ball_misfits: Vec::new(),
        mirrored: Vec::new(),
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
