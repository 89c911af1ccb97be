//! The instrument stage of a calibration: the poses and points of a
//! dataset without ball touches set up ([`setup`]) and solved
//! (`solve`); [`crate::calibrate`] makes its
//! [`crate::CalibrationRun`] of them. Also calibration.json's records of
//! the calibrated machine and of every session.

use nalgebra::{DMatrix, DVector, Dyn, Isometry3};
use parcal_dataset::{
    Actuator, CalibratedMachine, Dataset, FrameRecord, GeometryRecord, Machine, SessionRecord,
};
use parcal_kinematics::{Geometry, N_PARAMS, ParamCovariance, Params, Vec3, params};
use parcal_observe::KinematicPrior;
use parcal_solver::{
    GaussianPrior, IterationRecord, SpectrumDiagnostics, State, Status, solve as solve_problem,
};

use crate::instruments::model::{InstrumentModel, ModelValues};
use crate::instruments::observations::{
    group_priors, groups, initial_block, model_and_rows, residuals,
};
use crate::instruments::problem::InstrumentProblem;
use crate::instruments::result::{InstrumentResult, ParameterInformation};
use crate::layout::{ParameterGroup, ParameterLayout};
use crate::observation::ObservationId;
use crate::reliability::Reliability;
use crate::setup::{design_geometry, kinematic_prior};
use crate::verdict::{GLOBAL_TEST_LEVEL, GlobalTest, at_minimum, rows_and_unknowns};
use crate::{CalibrateError, CalibrationOptions};

/// A calibration of poses and points alone, solved: the shared parts of a
/// [`crate::CalibrationRun`] and its [`InstrumentResult`].
pub(crate) struct InstrumentEstimate {
    /// The design geometry as given (machine.json's frames).
    pub(crate) design: Geometry,
    /// The design's canonical parameters.
    pub(crate) initial_params: Params,
    /// The kinematic prior on the 33 (the options' mode), if any.
    pub(crate) kinematic_prior: Option<KinematicPrior>,
    /// The global block.
    pub(crate) layout: ParameterLayout,
    /// The identified global block.
    pub(crate) global: DVector<f64>,
    /// Its posterior covariance.
    pub(crate) global_covariance: Option<DMatrix<f64>>,
    /// The identified kinematic parameters (the held tool without points).
    pub(crate) params: Params,
    /// Their covariance ([`kinematic_covariance`]).
    pub(crate) covariance: Option<ParamCovariance>,
    /// How the solver's run ended.
    pub(crate) status: Status,
    /// One record per iteration.
    pub(crate) history: Vec<IterationRecord>,
    /// Whitened residual rows (6 per pose, 3 per point).
    pub(crate) residual_rows: usize,
    /// Spectrum of the normal matrix at the end.
    pub(crate) spectrum: Option<SpectrumDiagnostics>,
    /// The global test at the final state.
    pub(crate) global_test: Option<GlobalTest>,
    /// Every row's check at a least-squares minimum.
    pub(crate) reliability: Option<Reliability>,
    /// The poses' and points' own results.
    pub(crate) instruments: InstrumentResult,
}

/// An instrument calibration ready to solve: the problem at its initial
/// estimate.
pub struct InstrumentSetup<'a> {
    /// The design geometry as given (machine.json's frames).
    pub design: Geometry,
    /// The problem.
    pub problem: InstrumentProblem<'a>,
    /// The initial global block: the design's parameters and scales, the
    /// frames at their start ([`crate::instruments::start`]), every
    /// correction and offset zero.
    pub initial: DVector<f64>,
}

/// Sets up the calibration of the poses and points of `dataset` (it must
/// have no ball touches: [`crate::calibrate`] takes touches with poses and
/// points): validation, the frames' start, the layout, the
/// weights at the initial estimate, the prior.
pub fn setup<'a>(
    dataset: &'a Dataset,
    options: &CalibrationOptions,
) -> Result<InstrumentSetup<'a>, CalibrateError> {
    crate::validate(dataset)?;
    if dataset.has_touches() {
        return Err(CalibrateError::HasTouches);
    }
    let design = design_geometry(dataset);
    let canonical = design.canonicalize().map_err(CalibrateError::Design)?;
    let design_params = params::to_params(&canonical.geometry);
    let machine = &dataset.machine;
    // Poses alone measure the body frame, not the tool: it leaves the
    // layout (points observe it).
    let layout = if dataset.tracker.points.is_empty() {
        ParameterLayout::without_tool(groups(dataset))
    } else {
        ParameterLayout::with_groups(groups(dataset))
    };
    let initial = initial_block(&layout, &design_params, &machine.actuator.scale);
    let (model, rows) = model_and_rows(dataset, &canonical.geometry, layout, &initial)?;
    let prior = prior(dataset, &design, &design_params, &model.layout, options)?;
    Ok(InstrumentSetup {
        design,
        problem: InstrumentProblem { model, rows, prior },
        initial,
    })
}

/// Calibrates the poses and points of `dataset` (it must have no ball
/// touches): [`setup`], then the solver from the initial estimate, then
/// the checks of a run at a least-squares minimum. `observer` sees each
/// iteration. Least squares only: a robust loss ([`crate::robust`])
/// applies to ball touches.
pub(crate) fn solve(
    dataset: &Dataset,
    options: &CalibrationOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<InstrumentEstimate, CalibrateError> {
    if !options.loss.is_squared() {
        return Err(CalibrateError::RobustLoss {
            loss: options.loss,
            reason: "to a calibration of poses and points alone: only to ball touches (with \
                     or without poses and points)",
        });
    }
    let InstrumentSetup {
        design,
        problem,
        initial,
    } = setup(dataset, options)?;
    let solver_options = options.solver_options();
    let state = State {
        global: initial.clone(),
        groups: Vec::new(),
        points: Vec::new(),
    };
    let solution = solve_problem(&problem, state, &solver_options, observer);
    let (n_rows, unknowns) = rows_and_unknowns(&problem, 0, problem.rows.len());
    let reliability = match (&solution.covariance, solution.history.last()) {
        (Some(covariance), Some(last)) if at_minimum(&solution.status) => {
            let tracker = problem.rows.tracker;
            let observations: Vec<ObservationId> = (0..tracker.poses.len())
                .map(ObservationId::Pose)
                .chain((0..tracker.points.len()).map(ObservationId::Point))
                .collect();
            Some(
                Reliability::new(
                    &problem,
                    &solution.state,
                    covariance,
                    &mut Vec::new(),
                    solver_options.groups_per_chunk,
                    &[],
                    &observations,
                    last.prior_cost,
                    n_rows - problem.rows.len(),
                    &[],
                )?
                .0,
            )
        }
        _ => None,
    };
    let global_test = solution.history.last().and_then(|record| {
        GlobalTest::new(
            record.cost,
            n_rows.saturating_sub(unknowns),
            GLOBAL_TEST_LEVEL,
        )
    });
    let InstrumentProblem { model, rows, prior } = problem;
    let initial_params = params::to_params(
        &design
            .canonicalize()
            .map_err(CalibrateError::Design)?
            .geometry,
    );
    let kinematic_prior = kinematic_prior(dataset, &design, &initial_params, options.prior)?;
    let global = solution.state.global;
    let values = model.values(&global);
    let (leg_residuals, point_residuals) = residuals(&rows, &model, &values)?;
    let mut whitened = parcal_solver::GlobalObservations::zeros(0, 0);
    rows.evaluate(&model, &values, &mut whitened)?;
    let data = whitened
        .jacobian
        .row_iter()
        .fold(DVector::zeros(global.len()), |sum, row| {
            sum + row.transpose().component_mul(&row.transpose())
        });
    let covariance = solution.covariance.as_ref().and_then(|covariance| {
        kinematic_covariance(
            model.layout.kinematic().len(),
            covariance,
            kinematic_prior.as_ref(),
        )
    });
    let information = ParameterInformation {
        prior_sigmas: prior_sigmas(prior.as_ref(), model.layout.kinematic().len(), global.len()),
        data,
    };
    Ok(InstrumentEstimate {
        design,
        initial_params,
        kinematic_prior,
        layout: model.layout.clone(),
        params: values.params,
        covariance,
        global,
        global_covariance: solution.covariance,
        status: solution.status,
        history: solution.history,
        residual_rows: rows.len(),
        spectrum: solution.spectrum,
        global_test,
        reliability,
        instruments: InstrumentResult {
            model,
            initial,
            leg_residuals,
            point_residuals,
            information: Some(information),
        },
    })
}

/// The prior on the global block: the kinematic prior of the options'
/// mode (without the tool, its marginal on the joints and legs: the
/// leading block of its covariance), the scales about their design values
/// (machine.json's `scale_sigma`), the later sessions' body origins and
/// leg offsets about zero (`session_model`); none on the frames.
/// `PriorMode::None`: no prior.
fn prior(
    dataset: &Dataset,
    design: &Geometry,
    design_params: &parcal_kinematics::Params,
    layout: &ParameterLayout,
    options: &CalibrationOptions,
) -> Result<Option<GaussianPrior<Dyn>>, CalibrateError> {
    let Some(kinematic) = kinematic_prior(dataset, design, design_params, options.prior)? else {
        return Ok(None);
    };
    let n = layout.size();
    let mut mean = DVector::zeros(n);
    let mut information = DMatrix::zeros(n, n);
    let k = layout.kinematic().len();
    mean.rows_mut(0, k).copy_from(&kinematic.mean().rows(0, k));
    let kinematic_information = if layout.has_tool() {
        DMatrix::from_column_slice(k, k, kinematic.information().as_slice())
    } else {
        kinematic
            .covariance()
            .view((0, 0), (k, k))
            .into_owned()
            .cholesky()
            .ok_or(CalibrateError::Prior(
                parcal_observe::ObserveError::NotPositiveDefinite {
                    what: "kinematic prior covariance",
                },
            ))?
            .inverse()
    };
    information
        .view_mut((0, 0), (k, k))
        .copy_from(&kinematic_information);
    group_priors(dataset, layout, &mut mean, &mut information);
    Ok(Some(GaussianPrior::new(mean, information)))
}

/// The posterior covariance of the 33 kinematic parameters from the
/// global block's `covariance`, whose first `a` columns are the kinematic
/// parameters: its leading block; without the tool in the layout (poses
/// alone, `a` = 30), the 30's block with the tool's rows from the
/// kinematic prior `prior` conditional on the 30, which the data do not
/// change: `C_ta = K P`, `C_tt = Σ_tt − K Σ_at + K P Kᵀ`,
/// `K = Σ_ta Σ_aa⁻¹` (`P` the 30's posterior covariance, `Σ` the
/// prior's). That is the covariance of the tool's conditional prior
/// mean `μ_t + K (â − μ_a)`; the held design tool differs from it by
/// `K (â − μ_a)`. `None` with the tool left out and no prior.
fn kinematic_covariance(
    a: usize,
    covariance: &DMatrix<f64>,
    prior: Option<&KinematicPrior>,
) -> Option<ParamCovariance> {
    if a == N_PARAMS {
        return Some(
            covariance
                .fixed_view::<N_PARAMS, N_PARAMS>(0, 0)
                .into_owned(),
        );
    }
    let sigma = prior?.covariance();
    let t = N_PARAMS - a;
    let sigma_aa = sigma.view((0, 0), (a, a)).into_owned();
    let sigma_ta = sigma.view((a, 0), (t, a)).into_owned();
    let gain = sigma_aa
        .cholesky()?
        .solve(&sigma_ta.transpose())
        .transpose();
    let p = covariance.view((0, 0), (a, a)).into_owned();
    let c_ta = &gain * &p;
    let c_tt = sigma.view((a, a), (t, t)) - &gain * sigma_ta.transpose() + &c_ta * gain.transpose();
    let mut out = ParamCovariance::zeros();
    out.view_mut((0, 0), (a, a)).copy_from(&p);
    out.view_mut((a, 0), (t, a)).copy_from(&c_ta);
    out.view_mut((0, a), (a, t)).copy_from(&c_ta.transpose());
    out.view_mut((a, a), (t, t)).copy_from(&c_tt);
    Some(out)
}

/// Each of the `n` parameters' prior sigma under `prior`, whose first
/// `kinematic` are the kinematic parameters (infinite without a prior on
/// it). The prior's information is block-diagonal by group; the kinematic
/// block is full: its marginal sigmas are those of its inverse.
fn prior_sigmas(prior: Option<&GaussianPrior<Dyn>>, kinematic: usize, n: usize) -> DVector<f64> {
    let mut sigmas = DVector::from_element(n, f64::INFINITY);
    let Some(prior) = prior else {
        return sigmas;
    };
    let block = prior
        .information
        .view((0, 0), (kinematic, kinematic))
        .into_owned();
    if let Some(covariance) = block.try_inverse() {
        for k in 0..kinematic {
            sigmas[k] = covariance[(k, k)].sqrt();
        }
    }
    for k in kinematic..n {
        let information = prior.information[(k, k)];
        if information > 0.0 {
            sigmas[k] = information.sqrt().recip();
        }
    }
    sigmas
}

impl InstrumentModel {
    /// The identified geometry in the first session's frames: base joints
    /// in its instrument frame, platform joints and tool in its body frame.
    pub fn machine_in_first_session(&self, values: &ModelValues) -> Geometry {
        let (f, b) = (
            self.tracker_frame(values, 0),
            self.body_frame(values, 0).inverse(),
        );
        let g = &values.geometry;
        let moved = |frame: &Isometry3<f64>, p: &Vec3| frame.transform_point(&(*p).into()).coords;
        Geometry {
            base: g.base.map(|p| moved(&f, &p)),
            platform: g.platform.map(|p| moved(&b, &p)),
            tool: moved(&b, &g.tool),
            legs: g.legs,
        }
    }

    /// calibration.json's `machine` at `values`, the global block's
    /// marginal sigmas `sigma` giving the scales' (`design`: machine.json).
    pub fn calibrated_machine(
        &self,
        values: &ModelValues,
        sigma: &DVector<f64>,
        design: &Machine,
    ) -> CalibratedMachine {
        let scale_sigma = self
            .layout
            .range(ParameterGroup::ActuatorScales)
            .map(|r| std::array::from_fn(|i| sigma[r.start + i]));
        CalibratedMachine {
            geometry: geometry_record(&self.machine_in_first_session(values)),
            actuator: Actuator {
                unit: design.actuator.unit.clone(),
                scale: values.scales,
                scale_sigma,
            },
        }
    }

    /// calibration.json's `sessions` at `values`: each session's instrument
    /// frame, body frame and leg offsets.
    pub fn session_records(&self, values: &ModelValues) -> Vec<SessionRecord> {
        (0..self.sessions.len())
            .map(|k| SessionRecord {
                label: self.sessions[k].clone(),
                tracker_frame: FrameRecord::of(&self.tracker_frame(values, k)),
                body_frame: FrameRecord::of(&self.body_frame(values, k)),
                leg_offsets: values.offsets[k],
            })
            .collect()
    }
}

/// A geometry as calibration.json holds it.
pub(crate) fn geometry_record(g: &Geometry) -> GeometryRecord {
    GeometryRecord {
        base_joints: g.base.map(Into::into),
        platform_joints: g.platform.map(Into::into),
        tool: g.tool.into(),
        leg_lengths: g.legs,
    }
}
