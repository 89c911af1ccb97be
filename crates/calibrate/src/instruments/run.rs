//! One instrument calibration: set up, solve, and the record of the result
//! (calibration.json with the calibrated machine and every session).

use std::collections::BTreeMap;

use nalgebra::{DMatrix, DVector, Dyn, Isometry3};
use parcal_dataset::{
    Actuator, CalibratedMachine, Calibration, Dataset, FrameRecord, GeometryRecord,
    IterationSummary, Machine, ParameterTable, SessionRecord,
};
use parcal_kinematics::{Geometry, N_PARAMS, ParamCovariance, Vec3, params};
use parcal_observe::KinematicPrior;
use parcal_solver::{
    GaussianPrior, IterationRecord, SolverOptions, SpectrumDiagnostics, State, Status, solve,
};

use crate::instruments::model::{InstrumentModel, ModelValues};
use crate::instruments::observations::{
    group_priors, groups, initial_block, model_and_rows, residuals, rms,
};
use crate::instruments::problem::InstrumentProblem;
use crate::layout::{ParameterGroup, ParameterLayout};
use crate::observation::ObservationId;
use crate::reliability::Reliability;
use crate::setup::{design_geometry, kinematic_prior};
use crate::verdict::{GLOBAL_TEST_LEVEL, GlobalTest, Verdict, at_minimum, rows_and_unknowns};
use crate::{CalibrateError, CalibrationOptions, Method};

/// The outcome of an instrument calibration.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct InstrumentRun {
    /// What the run was asked to do.
    pub options: CalibrationOptions,
    /// The design geometry as given (machine.json's frames).
    pub design: Geometry,
    /// The global block's meaning.
    pub model: InstrumentModel,
    /// The initial global block.
    pub initial: DVector<f64>,
    /// The identified global block.
    pub global: DVector<f64>,
    /// The prior on the global block, if any.
    pub prior: Option<GaussianPrior<Dyn>>,
    /// The posterior covariance of the global block (inverse of the
    /// undamped normal matrix at the final state); `None` when the run did
    /// not converge or the matrix is not positive definite.
    pub covariance: Option<DMatrix<f64>>,
    /// How the solver's run ended.
    pub status: Status,
    /// One record per iteration.
    pub history: Vec<IterationRecord>,
    /// Whitened residual rows (6 per pose, 3 per point).
    pub residual_rows: usize,
    /// Spectrum of the normal matrix at the end.
    pub spectrum: Option<SpectrumDiagnostics>,
    /// Each pose's leg-length residuals `|T E_i − B_i| − L_i` at the
    /// identified state (mm).
    pub leg_residuals: Vec<[f64; 6]>,
    /// Each point's residual `F(T) − P` at the identified state (mm).
    pub point_residuals: Vec<Vec3>,
    /// machine.json as given (the design machine, recorded in
    /// calibration.json's `design`).
    pub machine: Machine,
    /// The kinematic prior on the 33 (the options' mode), if any: the
    /// tool's when the layout leaves it out
    /// ([`InstrumentRun::kinematic_covariance`]).
    pub kinematic_prior: Option<KinematicPrior>,
    /// The information the data alone give each parameter at the
    /// identified state, `diag(JᵀJ)` of the whitened rows (zero: the data
    /// do not observe it; the tool, which poses alone do not observe, is
    /// not in their layout at all).
    pub data_information: DVector<f64>,
    /// The global test at the final state ([`crate::verdict`]).
    pub global_test: Option<GlobalTest>,
    /// Every row's check at the final state of a run that converged or reached its iteration limit ([`crate::reliability`]).
    pub reliability: Option<Reliability>,
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
/// touches): [`setup`], then the solver from the initial estimate.
/// `observer` sees each iteration. Least squares only: a robust loss
/// ([`crate::robust`]) applies to ball-touch calibrations.
pub fn calibrate_instruments(
    dataset: &Dataset,
    options: &CalibrationOptions,
    observer: &mut dyn FnMut(&IterationRecord),
) -> Result<InstrumentRun, CalibrateError> {
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
    let solver_options = SolverOptions {
        method: options.method,
        max_iterations: options.max_iterations,
        step_tolerance: options.step_tolerance,
        sigma_tolerance: options.sigma_tolerance,
        time_limit: options.time_limit,
        ..SolverOptions::default()
    };
    let state = State {
        global: initial.clone(),
        groups: Vec::new(),
        points: Vec::new(),
    };
    let solution = solve(&problem, state, &solver_options, observer);
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
    let canonical = params::to_params(
        &design
            .canonicalize()
            .map_err(CalibrateError::Design)?
            .geometry,
    );
    let kinematic_prior = kinematic_prior(dataset, &design, &canonical, options.prior)?;
    let global = solution.state.global;
    let values = model.values(&global);
    let (leg_residuals, point_residuals) = residuals(&rows, &model, &values)?;
    let mut whitened = parcal_solver::GlobalObservations::zeros(0, 0);
    rows.evaluate(&model, &values, &mut whitened)?;
    let data_information = whitened
        .jacobian
        .row_iter()
        .fold(DVector::zeros(global.len()), |sum, row| {
            sum + row.transpose().component_mul(&row.transpose())
        });
    Ok(InstrumentRun {
        reliability,
        global_test,
        data_information,
        options: options.clone(),
        design,
        residual_rows: rows.len(),
        model,
        initial,
        global,
        prior,
        covariance: solution.covariance,
        status: solution.status,
        history: solution.history,
        spectrum: solution.spectrum,
        leg_residuals,
        point_residuals,
        machine: dataset.machine.clone(),
        kinematic_prior,
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

impl InstrumentRun {
    /// Whether the solver converged.
    pub fn converged(&self) -> bool {
        matches!(self.status, Status::Converged)
    }

    /// The run's verdict ([`crate::verdict`]).
    pub fn verdict(&self) -> Verdict {
        let outlier = self
            .reliability
            .as_ref()
            .is_some_and(|r| r.fails_snooping(crate::hypothesis::SNOOPING_LEVEL));
        Verdict::new(&self.status, self.global_test, outlier)
    }

    /// The model at the identified state.
    pub fn values(&self) -> ModelValues {
        self.model.values(&self.global)
    }

    /// The names of the global block's parameters.
    pub fn names(&self) -> Vec<String> {
        self.model.layout.names(&[], &self.model.sessions)
    }

    /// The posterior covariance of the 33 kinematic parameters: the
    /// global covariance's leading block; without the tool in the layout
    /// (poses alone), the 30's block with the tool's rows from the
    /// kinematic prior conditional on the 30, which the data do not
    /// change: `C_ta = K P`, `C_tt = Σ_tt − K Σ_at + K P Kᵀ`,
    /// `K = Σ_ta Σ_aa⁻¹` (`P` the 30's posterior covariance, `Σ` the
    /// prior's). That is the covariance of the tool's conditional prior
    /// mean `μ_t + K (â − μ_a)`; the held design tool differs from it by
    /// `K (â − μ_a)`. `None` without a covariance, or with the tool left
    /// out and no prior.
    pub fn kinematic_covariance(&self) -> Option<ParamCovariance> {
        let covariance = self.covariance.as_ref()?;
        let a = self.model.layout.kinematic().len();
        if a == N_PARAMS {
            return Some(
                covariance
                    .fixed_view::<N_PARAMS, N_PARAMS>(0, 0)
                    .into_owned(),
            );
        }
        let sigma = self.kinematic_prior.as_ref()?.covariance();
        let t = N_PARAMS - a;
        let sigma_aa = sigma.view((0, 0), (a, a)).into_owned();
        let sigma_ta = sigma.view((a, 0), (t, a)).into_owned();
        let gain = sigma_aa
            .cholesky()?
            .solve(&sigma_ta.transpose())
            .transpose();
        let p = covariance.view((0, 0), (a, a)).into_owned();
        let c_ta = &gain * &p;
        let c_tt =
            sigma.view((a, a), (t, t)) - &gain * sigma_ta.transpose() + &c_ta * gain.transpose();
        let mut out = ParamCovariance::zeros();
        out.view_mut((0, 0), (a, a)).copy_from(&p);
        out.view_mut((a, 0), (t, a)).copy_from(&c_ta);
        out.view_mut((0, a), (a, t)).copy_from(&c_ta.transpose());
        out.view_mut((a, a), (t, t)).copy_from(&c_tt);
        Some(out)
    }

    /// Marginal posterior sigmas of the global block.
    pub fn sigmas(&self) -> Option<DVector<f64>> {
        self.covariance
            .as_ref()
            .map(|c| c.diagonal().map(f64::sqrt))
    }

    /// Each parameter's prior sigma (infinite without a prior on it).
    pub fn prior_sigmas(&self) -> DVector<f64> {
        let n = self.global.len();
        match &self.prior {
            // The prior's information is block-diagonal by group; the
            // kinematic block is full: its marginal sigmas are those of
            // its inverse.
            Some(prior) => {
                let mut sigmas = DVector::from_element(n, f64::INFINITY);
                let kinematic = self.model.layout.kinematic().len();
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
            None => DVector::from_element(n, f64::INFINITY),
        }
    }

    /// RMS of the whitened residuals at the final iterate (1 at the noise
    /// level).
    pub fn residual_rms(&self) -> f64 {
        self.history.last().map_or(f64::NAN, |r| {
            (r.global_observation_cost / self.residual_rows as f64).sqrt()
        })
    }

    /// RMS of the poses' leg-length residuals (mm), or `None` without
    /// poses.
    pub fn leg_rms(&self) -> Option<f64> {
        rms(self.leg_residuals.iter().flatten().copied())
    }

    /// RMS of the points' residual coordinates (mm), or `None` without
    /// points.
    pub fn point_rms(&self) -> Option<f64> {
        rms(self.point_residuals.iter().flat_map(|p| p.iter().copied()))
    }

    /// The calibration.json record of this run, with `status`, the
    /// sentence of its status.
    /// A run that did not converge records no covariance and no sigma (0):
    /// its covariance at the last iterate is no posterior accuracy.
    pub fn record(&self, status: String) -> Calibration {
        let values = self.values();
        let posterior = self.covariance.as_ref().filter(|_| self.converged());
        let sigma = posterior.map_or_else(
            || DVector::zeros(self.global.len()),
            |c| c.diagonal().map(f64::sqrt),
        );
        let covariance = posterior
            .map(|c| c.row_iter().map(|r| r.iter().copied().collect()).collect())
            .unwrap_or_default();
        let iterations = self
            .history
            .iter()
            .map(|r| IterationSummary {
                cost: r.cost,
                step_norm: r.step_norm,
                residual_rms: (r.global_observation_cost / self.residual_rows as f64).sqrt(),
            })
            .collect();
        let method = match self.options.method {
            Method::GaussNewton => "gauss-newton",
            Method::LevenbergMarquardt { .. } => "levenberg-marquardt",
        };
        let options = BTreeMap::from([
            ("observation".to_string(), "instruments".into()),
            ("method".to_string(), method.into()),
        ]);
        Calibration {
            canonical: record(&values.geometry),
            parameters: ParameterTable {
                names: self.names(),
                values: self.global.iter().copied().collect(),
                sigma: sigma.iter().copied().collect(),
            },
            covariance,
            ball_centres: BTreeMap::new(),
            prior: self.options.prior.to_string(),
            iterations,
            converged: self.converged(),
            status,
            options,
            machine: Some(
                self.model
                    .calibrated_machine(&values, &sigma, &self.machine),
            ),
            sessions: self.model.session_records(&values),
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

    /// The identified geometry in the first session's frames
    /// ([`InstrumentModel::machine_in_first_session`]).
    pub fn machine_in_first_session(&self, values: &ModelValues) -> Geometry {
        self.model.machine_in_first_session(values)
    }
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
            geometry: record(&self.machine_in_first_session(values)),
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
                tracker_frame: frame(&self.tracker_frame(values, k)),
                body_frame: frame(&self.body_frame(values, k)),
                leg_offsets: values.offsets[k],
            })
            .collect()
    }
}

fn record(g: &Geometry) -> GeometryRecord {
    GeometryRecord {
        base_joints: g.base.map(Into::into),
        platform_joints: g.platform.map(Into::into),
        tool: g.tool.into(),
        leg_lengths: g.legs,
    }
}

fn frame(isometry: &Isometry3<f64>) -> FrameRecord {
    let q = isometry.rotation.coords;
    FrameRecord {
        translation: isometry.translation.vector.into(),
        rotation: [q.x, q.y, q.z, q.w],
    }
}
