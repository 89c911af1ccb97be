//! One fit of a mechanism calibration: the solver from the priors' means,
//! then, at a least-squares minimum, every row's redundancy number and
//! normalised residual ([`parcal_solver::redundancy`]) and the global
//! test's numbers ([`crate::verdict::rows_and_unknowns`]).
//!
//! The solver dispatches on the number `R` of actuators (a point sample's
//! rows) at compile time: [`MIN_ACTUATORS`]..=[`MAX_ACTUATORS`].

use nalgebra::{DMatrix, DVector, SVector};
use parcal_solver::{
    GlobalObservations, Method, Problem, SolverOptions, State, Status, normalised_residual,
    redundancy, solve,
};

use crate::verdict::{at_minimum, rows_and_unknowns};

use super::data::{MAX_ACTUATORS, MIN_ACTUATORS, MechanismData};
use super::error::MechanismCalibrationError;
use super::observation::{ObservationKind, ObservationRef};
use super::options::MechanismOptions;
use super::problem::MechanismProblem;

/// The numbers of one observation at the solution.
#[derive(Debug, Clone, PartialEq)]
pub struct ObservationCheck {
    /// The observation.
    pub observation: ObservationRef,
    /// Its rows' whitened residuals `e_j / σ_j` (weighted by a robust
    /// loss's `√w` when there is one).
    pub residuals: Vec<f64>,
    /// Its rows' redundancy numbers `r_j`.
    pub redundancy: Vec<f64>,
    /// Its rows' normalised residuals `w_j = e_j / √r_j` (`None` for a row
    /// no other row checks).
    pub normalised: Vec<Option<f64>>,
}

impl ObservationCheck {
    /// Its row of largest `|w_j|` and that `w_j`.
    pub fn worst(&self) -> Option<(usize, f64)> {
        self.normalised
            .iter()
            .enumerate()
            .filter_map(|(j, w)| w.map(|w| (j, w)))
            .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
    }
}

/// What one fit gives (module doc).
pub(crate) struct Fit {
    /// The global block at the end (the fit's frame).
    pub global: DVector<f64>,
    /// The point samples' poses at the end.
    pub poses: Vec<[f64; 3]>,
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
    pub checks: Option<Vec<ObservationCheck>>,
    /// The number of data rows (the w-tests' family).
    pub data_rows: usize,
}

/// One fit of `data` (validated) with `options` (module doc).
pub(crate) fn fit(
    data: &MechanismData,
    options: &MechanismOptions,
) -> Result<Fit, MechanismCalibrationError> {
    match data.mechanism.actuators().len() {
        3 => fit_with::<3>(data, options),
        4 => fit_with::<4>(data, options),
        5 => fit_with::<5>(data, options),
        6 => fit_with::<6>(data, options),
        7 => fit_with::<7>(data, options),
        8 => fit_with::<8>(data, options),
        n => Err(MechanismCalibrationError::InvalidData {
            what: format!("the {}", data.mechanism.name()),
            reason: format!(
                "it has {n} actuators; this calibration takes {MIN_ACTUATORS} to {MAX_ACTUATORS}"
            ),
        }),
    }
}

fn fit_with<const R: usize>(
    data: &MechanismData,
    options: &MechanismOptions,
) -> Result<Fit, MechanismCalibrationError> {
    let problem = MechanismProblem::new(data, options.loss);
    let start = problem.start();
    let n = problem.n_params();
    let poses = problem.start_poses(&start.as_slice()[..n])?;
    // Every global observation evaluated once at the start, so that a
    // commanded position the machine cannot reach is named as such.
    let mut rows = GlobalObservations::zeros(0, start.len());
    <MechanismProblem as Problem<1, 3, R>>::global_observations(&problem, &start, &mut rows)?;
    let groups = <MechanismProblem as Problem<1, 3, R>>::n_groups(&problem);
    let state = State {
        global: start,
        groups: vec![SVector::zeros(); groups],
        points: poses,
    };
    let solver_options = SolverOptions {
        method: Method::GaussNewton,
        max_iterations: options.max_iterations,
        ..SolverOptions::default()
    };
    let solution = solve::<1, 3, R, _>(&problem, state, &solver_options, &mut |_| {});
    if let Some(error) = failure(&solution.status) {
        return Err(error);
    }
    let refs = problem.global_observation_refs();
    let global_rows: usize = refs.iter().map(|(_, rows)| rows).sum();
    let samples = data.observations.samples.len();
    let (rows, unknowns) = rows_and_unknowns::<1, 3, R, _>(&problem, samples, global_rows);
    let checks = match &solution.covariance {
        Some(covariance) if at_minimum(&solution.status) => Some(checks::<R>(
            &problem,
            &solution.state,
            covariance,
            &refs,
            solver_options.groups_per_chunk,
        )?),
        _ => None,
    };
    Ok(Fit {
        poses: solution
            .state
            .points
            .iter()
            .map(|p| [p[0], p[1], p[2]])
            .collect(),
        global: solution.state.global,
        iterations: solution.history.len(),
        cost: solution.history.last().map(|record| record.cost),
        status: solution.status,
        covariance: solution.covariance,
        prior_information: problem.prior_information(),
        redundancy: rows.saturating_sub(unknowns),
        checks,
        data_rows: global_rows + R * samples,
    })
}

/// The error of a run that could not fit at all: a failed evaluation (the
/// observation it names), the unknowns not determined, an invalid start.
/// A run that merely did not converge is a result (its verdict rejects
/// it).
fn failure(status: &Status) -> Option<MechanismCalibrationError> {
    match status {
        Status::ProblemFailed {
            iteration, message, ..
        } => Some(MechanismCalibrationError::Evaluation {
            iteration: *iteration,
            message: message.clone(),
        }),
        Status::Singular { diagnostics, .. } => {
            let weak = diagnostics.weakest.iter().filter(|w| !w.identified).count();
            Some(MechanismCalibrationError::NotDetermined {
                reason: format!(
                    "{weak} combination(s) of the unknowns are seen by neither the data nor a prior; give their parameters a prior"
                ),
            })
        }
        Status::SingularBlock { block, .. } => Some(MechanismCalibrationError::NotDetermined {
            reason: format!("the pose of {block:?} is not determined by its readings"),
        }),
        Status::InvalidProblem { .. } => Some(MechanismCalibrationError::Solver {
            status: status.clone(),
        }),
        _ => None,
    }
}

/// Every observation's residuals, redundancy numbers and normalised
/// residuals at `state`, through the solver's redundancy pass.
fn checks<const R: usize>(
    problem: &MechanismProblem,
    state: &State<1, 3>,
    covariance: &DMatrix<f64>,
    refs: &[(ObservationRef, usize)],
    groups_per_chunk: usize,
) -> Result<Vec<ObservationCheck>, MechanismCalibrationError> {
    let mut samples = Vec::new();
    let global = redundancy::<1, 3, R, _>(
        problem,
        state,
        covariance,
        &mut Vec::new(),
        groups_per_chunk,
        |rows| samples.push((rows.residual, rows.redundancy)),
    )
    .map_err(|status| MechanismCalibrationError::Solver { status })?;
    let check = |observation, residuals: Vec<f64>, redundancy: Vec<f64>| {
        let normalised = residuals
            .iter()
            .zip(&redundancy)
            .map(|(&e, &r)| normalised_residual(e, r))
            .collect();
        ObservationCheck {
            observation,
            residuals,
            redundancy,
            normalised,
        }
    };
    let mut checks = Vec::with_capacity(refs.len() + samples.len());
    let mut row = 0;
    for &(observation, rows) in refs {
        let span = row..row + rows;
        checks.push(check(
            observation,
            global.global_observation_residuals[span.clone()].to_vec(),
            global.global_observations[span].to_vec(),
        ));
        row += rows;
    }
    for (index, (residual, redundancy)) in samples.into_iter().enumerate() {
        let observation = ObservationRef {
            kind: ObservationKind::Sample,
            index,
        };
        checks.push(check(
            observation,
            residual.iter().copied().collect(),
            redundancy.iter().copied().collect(),
        ));
    }
    Ok(checks)
}
