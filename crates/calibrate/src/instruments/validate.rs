//! A calibration judged on measurements it was not fitted on.
//!
//! The calibrated geometry and scales are held; each session of the new
//! data is seen either through the frames the calibration identified for
//! it (same label), or, with `reference = N`, through its nuisance re-fitted
//! on its first `N` rows: its instrument frame (always: a moved instrument
//! or a new origin), its body origin (a re-mounted marker body, when
//! machine.json's session model has `body_origin_sigma`) and its leg
//! offsets (re-homing, with `leg_offset_sigma`), each with its prior. The
//! remaining rows are predicted: for a pose, the leg-length residual
//! `|T E_i − B_i| − L_i` (mm); for a point, its coordinates' residual.
//!
//! The predicted residual of a row, to first order, is
//!
//! ```text
//! δr = G δθ − J_n K ε_ref + ε,   G = J_θ − J_n K B,   K = (AᵀA + Λ)⁻¹ Aᵀ,
//! ```
//!
//! `θ` the calibration's parameters (covariance `Σ_θ` from
//! calibration.json), `J_θ`, `J_n` the row's derivatives with respect to
//! them and to the re-fitted nuisance, `A`, `B` the whitened derivatives of
//! the reference rows, `Λ` the nuisance prior, `ε` the row's noise. Its
//! covariance over the predicted rows is
//!
//! ```text
//! C = D + U Uᵀ,   U = [G Σ_θ^{1/2}, J_n (K Kᵀ)^{1/2}],
//! ```
//!
//! `D` the rows' noise (block-diagonal, a pose's six rows or a point's
//! three); its diagonal gives the predicted RMS, and `rᵀ C⁻¹ r`, chi-square
//! with one degree of freedom per row, the verdict ([`crate::prediction`]).
//! A rejected validation with reference rows looks for what changed: each
//! other choice of the optional groups (a group machine.json does not
//! declare re-fitted without prior) is re-fitted, and those whose
//! residuals pass the test are its [`Explanation`]s.

use nalgebra::{DMatrix, DVector, Isometry3, Vector6};
use parcal_dataset::{Calibration, Dataset, Points, Poses, SessionModel, Tracker};
use parcal_kinematics::params::TOOL_OFFSET;
use parcal_kinematics::{ForwardOptions, Geometry, N_PARAMS, PARAM_NAMES, Params, params};
use parcal_observe::FrameCorrection;
use parcal_solver::GlobalObservations;

use crate::CalibrateError;
use crate::instruments::InstrumentTable;
use crate::instruments::model::InstrumentModel;
use crate::instruments::rows::InstrumentRows;
use crate::instruments::start::{forward_poses, frame_start};
use crate::layout::{ParameterGroup, ParameterLayout};
use crate::prediction::{self, PredictionTest};

/// Iterations of the nuisance re-fit (Gauss–Newton from the frames' start).
const REFIT_ITERATIONS: usize = 30;
/// The re-fit has converged when its step is below this (relative).
const REFIT_TOLERANCE: f64 = 1e-12;

/// What validation needs of a calibration (calibration.json).
#[derive(Debug, Clone)]
pub struct Calibrated {
    /// The canonical kinematic parameters.
    pub params: Params,
    /// The actuator scales (mm per unit).
    pub scales: [f64; 6],
    /// Each calibrated session's frames.
    pub sessions: Vec<CalibratedSession>,
    /// The parameters' names.
    pub names: Vec<String>,
    /// Their values (the frames': corrections of the calibration's
    /// references, [`crate::instruments::model`]).
    pub values: DVector<f64>,
    /// Their covariance.
    pub covariance: DMatrix<f64>,
    /// Its global test `(Ω, r)`, if it has one: the prediction test's
    /// reference ([`crate::prediction`]).
    pub global_test: Option<(f64, usize)>,
    /// The unit its actuators read in (its scales are mm per unit).
    pub unit: String,
}

impl Calibrated {
    /// From a calibration of instrument measurements; refuses one without
    /// sessions (a ball-touch calibration) or without a covariance.
    pub fn from_record(calibration: &Calibration) -> Result<Self, CalibrateError> {
        let refuse = |reason: &str| CalibrateError::Calibration {
            reason: reason.to_owned(),
        };
        if calibration.sessions.is_empty() {
            return Err(refuse(
                "it has no session: it is not a calibration of poses or points",
            ));
        }
        let n = calibration.parameters.names.len();
        if calibration.covariance.len() != n {
            return Err(refuse(
                "it has no covariance (the calibration did not converge)",
            ));
        }
        let c = &calibration.canonical;
        let geometry =
            Geometry::from_arrays(&c.base_joints, &c.platform_joints, &c.tool, &c.leg_lengths);
        Ok(Self {
            params: params::to_params(&geometry),
            scales: calibration.calibrated_scales(),
            sessions: calibration
                .sessions
                .iter()
                .map(|s| CalibratedSession {
                    label: s.label.clone(),
                    tracker_frame: s.tracker_frame.isometry(),
                    body_frame: s.body_frame.isometry(),
                })
                .collect(),
            names: calibration.parameters.names.clone(),
            values: DVector::from_column_slice(&calibration.parameters.values),
            covariance: DMatrix::from_fn(n, n, |i, j| calibration.covariance[i][j]),
            global_test: calibration
                .global_test
                .as_ref()
                .map(|t| (t.cost, t.redundancy)),
            unit: calibration.actuator_unit().to_string(),
        })
    }
}

/// A calibrated session's frames (canonical frames).
#[derive(Debug, Clone, PartialEq)]
pub struct CalibratedSession {
    /// Its label.
    pub label: String,
    /// Its instrument frame (canonical base → instrument).
    pub tracker_frame: Isometry3<f64>,
    /// Its body frame (body → canonical platform).
    pub body_frame: Isometry3<f64>,
}

impl Calibrated {
    /// The value of the parameter `name`, if the calibration has it.
    pub fn value(&self, name: &str) -> Option<f64> {
        let k = self.names.iter().position(|n| n == name)?;
        Some(self.values[k])
    }

    /// The frame correction `(ω, τ)` of the parameters `prefix.wx` …
    /// `prefix.tz`, if the calibration has them.
    fn correction(&self, prefix: &str) -> Option<FrameCorrection> {
        let mut p = Vector6::zeros();
        for (k, c) in ["wx", "wy", "wz", "tx", "ty", "tz"].iter().enumerate() {
            p[k] = self.value(&format!("{prefix}.{c}"))?;
        }
        Some(FrameCorrection::from_params(&p))
    }
}

/// The outcome of a validation.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct Validation {
    /// Predicted poses.
    pub poses: usize,
    /// Predicted points.
    pub points: usize,
    /// Predicted ball touches ([`crate::validate_touches`]).
    pub contacts: usize,
    /// Rows per session used to re-fit its nuisance (0: the calibration's
    /// frames).
    pub reference: usize,
    /// The re-fitted groups, by name.
    pub refitted: Vec<String>,
    /// Each candidate nuisance model (its groups' names joined by ` + `)
    /// with its expected prediction RMS (mm, `expected_prediction_error`);
    /// empty when there was one candidate or no re-fit.
    pub selection: Vec<(String, f64)>,
    /// Observed residuals of the predicted rows (mm): six leg lengths per
    /// pose, then three coordinates per point; or the distance of each
    /// touch to its ball's surface.
    pub residuals: Vec<f64>,
    /// Their predicted standard deviations (mm).
    pub predicted_sigmas: Vec<f64>,
    /// `rᵀ C⁻¹ r`: the residuals in their full predicted covariance
    /// ([`crate::prediction`]).
    pub statistic: f64,
    /// The calibration's global test `(Ω, r)`, if it has one.
    pub calibration_test: Option<(f64, usize)>,
    /// When the test rejects and the nuisance was re-fitted: the other
    /// nuisance models whose residuals would pass it, the least predicted
    /// RMS first.
    pub explanations: Vec<Explanation>,
    /// The balls (artefacts.json ids) whose reference touches fit their
    /// centre's mirror image about as well, and whose other touches chose
    /// the mirror image ([`crate::mirror::located_side`]).
    pub mirrored_balls: Vec<String>,
}

/// A nuisance model that explains a rejected validation: re-fitted with it,
/// the predicted rows pass the test.
#[derive(Debug, Clone, PartialEq)]
pub struct Explanation {
    /// The groups re-fitted besides the instrument frames.
    pub groups: Vec<SessionGroup>,
    /// Those of them machine.json's session model does not declare.
    pub undeclared: Vec<SessionGroup>,
    /// The residual RMS with them re-fitted (mm).
    pub rms: f64,
    /// The RMS then predicted (mm).
    pub predicted_rms: f64,
    /// The test then.
    pub test: PredictionTest,
}

/// A group a session may re-fit besides its instrument frame (machine.json's
/// `session_model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SessionGroup {
    /// A shift of the body frame's origin: a re-mounted marker body.
    BodyOrigin,
    /// A turn of the body frame: a re-mounted marker body.
    BodyRotation,
    /// A zero offset of each leg: re-homing.
    LegOffsets,
}

impl SessionGroup {
    /// Every group, in the order the model selection tries them.
    pub const ALL: [Self; 3] = [Self::BodyOrigin, Self::BodyRotation, Self::LegOffsets];

    /// Its name: `body origin`, `body rotation`, `leg offsets`.
    pub fn name(self) -> &'static str {
        match self {
            Self::BodyOrigin => "body origin",
            Self::BodyRotation => "body rotation",
            Self::LegOffsets => "leg offsets",
        }
    }

    /// The machine.json field that declares it.
    pub fn setting(self) -> &'static str {
        match self {
            Self::BodyOrigin => "session_model.body_origin_sigma",
            Self::BodyRotation => "session_model.body_rotation_sigma",
            Self::LegOffsets => "session_model.leg_offset_sigma",
        }
    }

    /// What it models, as a condition on the session.
    pub fn cause(self) -> &'static str {
        match self {
            Self::BodyOrigin | Self::BodyRotation => "the marker body was re-mounted",
            Self::LegOffsets => "the legs were re-homed",
        }
    }

    /// Its prior sigma in `model`, if declared (mm, rad).
    fn sigma(self, model: &SessionModel) -> Option<f64> {
        match self {
            Self::BodyOrigin => model.body_origin_sigma,
            Self::BodyRotation => model.body_rotation_sigma,
            Self::LegOffsets => model.leg_offset_sigma,
        }
    }

    /// Its parameters in session `session`.
    fn parameters(self, session: usize) -> ParameterGroup {
        match self {
            Self::BodyOrigin => ParameterGroup::BodyOrigin { session },
            Self::BodyRotation => ParameterGroup::BodyRotation { session },
            Self::LegOffsets => ParameterGroup::LegOffsets { session },
        }
    }
}

impl Validation {
    /// The test of [`Validation::statistic`] with one degree of freedom per
    /// predicted row against the calibration's variance factor
    /// ([`crate::prediction`]).
    pub fn test(&self) -> Option<PredictionTest> {
        PredictionTest::new(self.statistic, self.residuals.len(), self.calibration_test)
    }

    /// Whether the calibration predicts these data: the test does not
    /// reject.
    pub fn accepted(&self) -> bool {
        self.test().is_none_or(|t| !t.rejects())
    }

    /// RMS of the observed residuals (mm).
    pub fn rms(&self) -> f64 {
        rms(&self.residuals)
    }

    /// Largest absolute residual (mm).
    pub fn max(&self) -> f64 {
        self.residuals.iter().fold(0.0, |m, r| m.max(r.abs()))
    }

    /// The RMS the calibration's covariance and the noise model predict.
    pub fn predicted_rms(&self) -> f64 {
        rms(&self.predicted_sigmas)
    }

    /// RMS of each leg's residual over the predicted poses (mm).
    pub fn per_leg_rms(&self) -> [f64; 6] {
        std::array::from_fn(|i| {
            let leg: Vec<f64> = (0..self.poses).map(|j| self.residuals[6 * j + i]).collect();
            rms(&leg)
        })
    }
}

fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len().max(1) as f64).sqrt()
}

/// Applies `calibrated` to `dataset` (module doc). Without `reference`,
/// every session of `dataset` must be one of the calibration's (by label).
pub fn validate_calibration(
    dataset: &Dataset,
    calibrated: &Calibrated,
    reference: Option<usize>,
) -> Result<Validation, CalibrateError> {
    crate::validate(dataset)?;
    crate::validate::same_unit(dataset, &calibrated.unit)?;
    let tracker = &dataset.tracker;
    check_validatable(tracker, calibrated)?;
    let n_ref = reference.unwrap_or(0);
    let split = RowSplit::new(tracker, n_ref);
    match reference {
        Some(_) => split.check_left_to_predict(tracker, n_ref)?,
        None => check_known_sessions(tracker, calibrated)?,
    }
    let geometry = params::from_params(&calibrated.params);
    let forward = ForwardOptions::default();
    let reference_set = subset(tracker, &split.reference.0, &split.reference.1);
    let predicted_set = subset(tracker, &split.predicted.0, &split.predicted.1);
    let (model, global) = validation_model(
        tracker,
        calibrated,
        reference.map(|_| &reference_set),
        &geometry,
        &forward,
    )?;
    let machine = &dataset.machine;
    let home = |set: &Tracker| {
        forward_poses(
            InstrumentTable::Points,
            &set.points.q,
            &geometry,
            &calibrated.scales,
            &forward,
        )
    };
    let mut reference_rows = InstrumentRows::new(&reference_set, home(&reference_set)?, forward);
    let mut predicted = InstrumentRows::new(&predicted_set, home(&predicted_set)?, forward);
    let present = present_groups(&model, tracker.sessions.len());
    let values = model.values(&global);
    reference_rows.whiten(&model, &values, &machine.repeatability)?;
    predicted.whiten(&model, &values, &machine.repeatability)?;
    let (nuisance, selection) = match reference {
        Some(_) => select_nuisance(
            &model,
            &global,
            &reference_rows,
            &predicted,
            &present,
            &machine.session_model,
        )?,
        None => (Nuisance::default(), Vec::new()),
    };
    let predict = |nuisance: &Nuisance| {
        Prediction::new(
            calibrated,
            &model,
            &global,
            &reference_rows,
            &predicted,
            nuisance,
        )
    };
    let chosen = predict(&nuisance)?;
    let mut validation = Validation {
        poses: predicted_set.poses.len(),
        points: predicted_set.points.len(),
        contacts: 0,
        reference: n_ref,
        refitted: nuisance.names.clone(),
        selection,
        residuals: chosen.residuals,
        predicted_sigmas: chosen.sigmas,
        statistic: chosen.statistic,
        calibration_test: calibrated.global_test,
        explanations: Vec::new(),
        mirrored_balls: Vec::new(),
    };
    if reference.is_some() && !validation.accepted() {
        validation.explanations = explanations(
            &model,
            &present,
            &nuisance,
            &machine.session_model,
            calibrated,
            predict,
        );
    }
    Ok(validation)
}

/// Refuses data a calibration cannot be judged on: no poses or points, or
/// points where the calibration did not identify the tool.
fn check_validatable(tracker: &Tracker, calibrated: &Calibrated) -> Result<(), CalibrateError> {
    if tracker.is_empty() {
        return Err(CalibrateError::Calibration {
            reason: "the dataset has no measured poses or points to validate on".into(),
        });
    }
    if !tracker.points.is_empty() && calibrated.value(PARAM_NAMES[TOOL_OFFSET]).is_none() {
        return Err(CalibrateError::Calibration {
            reason: "it did not calibrate the tool (x_eT, y_eT, z_eT: its data, poses alone, do not observe it), and measured points see the tool".into(),
        });
    }
    Ok(())
}

/// The session of `tracker` labelled as calibrated session `k`'s, if any.
fn known_session<'c>(
    calibrated: &'c Calibrated,
    tracker: &Tracker,
    k: usize,
) -> Option<&'c CalibratedSession> {
    calibrated
        .sessions
        .iter()
        .find(|session| session.label == tracker.sessions[k])
}

/// Refuses a session the calibration did not see, where no reference rows
/// re-fit its frames.
fn check_known_sessions(tracker: &Tracker, calibrated: &Calibrated) -> Result<(), CalibrateError> {
    match (0..tracker.sessions.len()).find(|&k| known_session(calibrated, tracker, k).is_none()) {
        Some(k) => Err(CalibrateError::Calibration {
            reason: format!(
                "session {:?} is not one of the calibration's; give a number of reference rows to fit its frames on",
                tracker.sessions[k]
            ),
        }),
        None => Ok(()),
    }
}

/// Each session's first `n_ref` rows (poses, then points) as reference
/// rows, the others predicted: indices in file order, poses and points
/// apart.
struct RowSplit {
    reference: (Vec<usize>, Vec<usize>),
    predicted: (Vec<usize>, Vec<usize>),
    /// The rows of each session.
    rows: Vec<usize>,
}

impl RowSplit {
    fn new(tracker: &Tracker, n_ref: usize) -> Self {
        let mut rows = vec![0; tracker.sessions.len()];
        let mut assign = |sessions: &[u32]| {
            let (mut reference, mut predicted) = (Vec::new(), Vec::new());
            for (j, &s) in sessions.iter().enumerate() {
                let seen = &mut rows[s as usize];
                if *seen < n_ref {
                    reference.push(j);
                } else {
                    predicted.push(j);
                }
                *seen += 1;
            }
            (reference, predicted)
        };
        let (pose_reference, pose_predicted) = assign(&tracker.poses.session);
        let (point_reference, point_predicted) = assign(&tracker.points.session);
        Self {
            reference: (pose_reference, point_reference),
            predicted: (pose_predicted, point_predicted),
            rows,
        }
    }

    /// Refuses a session with no row left to predict after its `n_ref`
    /// reference rows.
    fn check_left_to_predict(&self, tracker: &Tracker, n_ref: usize) -> Result<(), CalibrateError> {
        match self.rows.iter().position(|&rows| rows <= n_ref) {
            Some(k) => Err(CalibrateError::Calibration {
                reason: format!(
                    "session {:?} has {} rows: none is left to predict after the {n_ref} reference rows",
                    tracker.sessions[k], self.rows[k]
                ),
            }),
            None => Ok(()),
        }
    }
}

/// The instrument model of a validation and its global block: every
/// parameter at the calibration's value, by name, but the re-fitted
/// sessions' nuisance (zero, about the frames the reference rows
/// `reference_set` start from, when there are reference rows).
fn validation_model(
    tracker: &Tracker,
    calibrated: &Calibrated,
    reference_set: Option<&Tracker>,
    geometry: &Geometry,
    forward: &ForwardOptions,
) -> Result<(InstrumentModel, DVector<f64>), CalibrateError> {
    let sessions = tracker.sessions.len();
    // The calibration's own references, so that its covariance applies to
    // its parameters as they are: B₀ = C_B⁻¹ ∘ B_first, F₀_k = F_k ∘ C_F,k⁻¹.
    let body_correction = calibrated
        .correction("body")
        .unwrap_or(FrameCorrection::IDENTITY);
    let body_reference = body_correction.isometry().inverse() * calibrated.sessions[0].body_frame;
    // The frames' start: the calibration's for a known session without
    // re-fit, the reference rows' hand-eye start otherwise.
    let start = reference_set
        .map(|set| frame_start(set, geometry, &calibrated.scales, forward))
        .transpose()?;
    let with_poses = |k: usize| tracker.poses.session.iter().any(|&s| s as usize == k);
    let mut groups = vec![ParameterGroup::ActuatorScales];
    if !tracker.poses.is_empty() {
        groups.push(ParameterGroup::BodyFrame);
    }
    for session in 0..sessions {
        groups.push(ParameterGroup::TrackerFrame { session });
        if with_poses(session) {
            groups.push(ParameterGroup::BodyOrigin { session });
            groups.push(ParameterGroup::BodyRotation { session });
        }
        groups.push(ParameterGroup::LegOffsets { session });
    }
    let layout = ParameterLayout::with_groups(groups);
    let names = layout.names(&[], &tracker.sessions);
    // The groups shared by the sessions come first.
    let shared = layout
        .range(ParameterGroup::TrackerFrame { session: 0 })
        .map_or(layout.size(), |r| r.start);
    // A kinematic parameter the calibration did not identify (the tool of
    // poses alone) is its canonical geometry's.
    let mut global = DVector::from_fn(layout.size(), |c, _| {
        let copied = reference_set.is_none() || c < shared;
        copied
            .then(|| calibrated.value(&names[c]))
            .flatten()
            .or_else(|| (c < N_PARAMS).then(|| calibrated.params[c]))
            .unwrap_or(0.0)
    });
    if let Some(r) = layout.range(ParameterGroup::ActuatorScales)
        && calibrated.value("s_1").is_none()
    {
        // A calibration with known scales: they are its machine's.
        global
            .rows_mut(r.start, 6)
            .copy_from_slice(&calibrated.scales);
    }
    let tracker_references = (0..sessions)
        .map(|k| match (&start, known_session(calibrated, tracker, k)) {
            (Some(start), _) => start.trackers[k],
            (None, Some(session)) => {
                let correction = calibrated
                    .correction(&format!("frame {}", session.label))
                    .unwrap_or(FrameCorrection::IDENTITY);
                session.tracker_frame * correction.isometry().inverse()
            }
            (None, None) => unreachable!("checked by check_known_sessions"),
        })
        .collect();
    let model = InstrumentModel {
        layout,
        sessions: tracker.sessions.clone(),
        tracker_references,
        body_reference,
        fixed_scales: calibrated.scales,
        fixed_tool: geometry.tool,
    };
    Ok((model, global))
}

/// The session groups present in `model`'s layout for some session (a
/// body group exists only for sessions with poses).
fn present_groups(model: &InstrumentModel, sessions: usize) -> Vec<SessionGroup> {
    SessionGroup::ALL
        .into_iter()
        .filter(|group| {
            (0..sessions).any(|session| model.layout.range(group.parameters(session)).is_some())
        })
        .collect()
}

/// The nuisance model re-fitted on the reference rows: the frame, and of
/// the optional groups the session model allows (`present` with a sigma),
/// the choice with the least expected prediction error; with every
/// candidate's name and score (mm), when there was a choice.
fn select_nuisance(
    model: &InstrumentModel,
    global: &DVector<f64>,
    reference_rows: &InstrumentRows<'_>,
    predicted: &InstrumentRows<'_>,
    present: &[SessionGroup],
    session_model: &SessionModel,
) -> Result<(Nuisance, Vec<(String, f64)>), CalibrateError> {
    let optional: Vec<(SessionGroup, f64)> = present
        .iter()
        .filter_map(|&group| Some((group, group.sigma(session_model)?)))
        .collect();
    let candidates: Vec<Nuisance> = subsets(&optional)
        .iter()
        .map(|chosen| Nuisance::new(model, chosen))
        .collect();
    if candidates.len() == 1 {
        let only = candidates.into_iter().next().expect("one candidate");
        return Ok((only, Vec::new()));
    }
    let mut selection = Vec::with_capacity(candidates.len());
    for candidate in &candidates {
        let score = expected_prediction_error(model, global, reference_rows, predicted, candidate)?;
        selection.push((
            candidate.names.join(" + "),
            score.map_or(f64::INFINITY, f64::sqrt),
        ));
    }
    let best = (0..candidates.len())
        .min_by(|&a, &b| selection[a].1.total_cmp(&selection[b].1))
        .expect("candidates");
    let chosen = candidates.into_iter().nth(best).expect("in range");
    Ok((chosen, selection))
}

/// What changed, for a rejected validation with reference rows: every
/// other choice of the `present` groups re-fitted (a group the session
/// model does not declare, free), those whose residuals pass the test,
/// the best predicted first.
fn explanations(
    model: &InstrumentModel,
    present: &[SessionGroup],
    chosen: &Nuisance,
    session_model: &SessionModel,
    calibrated: &Calibrated,
    predict: impl Fn(&Nuisance) -> Result<Prediction, CalibrateError>,
) -> Vec<Explanation> {
    let all: Vec<(SessionGroup, f64)> = present
        .iter()
        .map(|&group| {
            let sigma = group.sigma(session_model);
            (group, sigma.unwrap_or(f64::INFINITY))
        })
        .collect();
    let mut explanations = Vec::new();
    for groups in subsets(&all) {
        let candidate = Nuisance::new(model, &groups);
        if candidate.columns == chosen.columns {
            continue;
        }
        // A model the reference rows do not determine explains nothing.
        let Ok(other) = predict(&candidate) else {
            continue;
        };
        let test = PredictionTest::new(
            other.statistic,
            other.residuals.len(),
            calibrated.global_test,
        );
        if let Some(test) = test.filter(|t| !t.rejects()) {
            let groups: Vec<SessionGroup> = groups.iter().map(|(g, _)| *g).collect();
            explanations.push(Explanation {
                undeclared: groups
                    .iter()
                    .copied()
                    .filter(|g| g.sigma(session_model).is_none())
                    .collect(),
                groups,
                rms: rms(&other.residuals),
                predicted_rms: rms(&other.sigmas),
                test,
            });
        }
    }
    explanations.sort_by(|a, b| a.predicted_rms.total_cmp(&b.predicted_rms));
    explanations
}

/// Every subset of `groups`, in the order of a bit mask (the empty one
/// first).
fn subsets(groups: &[(SessionGroup, f64)]) -> Vec<Vec<(SessionGroup, f64)>> {
    (0..1usize << groups.len())
        .map(|mask| {
            (0..groups.len())
                .filter(|k| mask & (1 << k) != 0)
                .map(|k| groups[k])
                .collect()
        })
        .collect()
}

/// The re-fitted columns of every session, their prior information and
/// the groups' names.
#[derive(Debug, Clone, Default, PartialEq)]
struct Nuisance {
    columns: Vec<usize>,
    information: Vec<f64>,
    names: Vec<String>,
}

impl Nuisance {
    /// Every session's frame and the `optional` groups with their prior
    /// sigmas (infinite: no prior).
    fn new(model: &InstrumentModel, optional: &[(SessionGroup, f64)]) -> Self {
        let mut out = Self::default();
        for (session, label) in model.sessions.iter().enumerate() {
            let mut add = |group: ParameterGroup, sigma: f64, name: String| {
                if let Some(range) = model.layout.range(group) {
                    for c in range {
                        out.columns.push(c);
                        out.information.push(1.0 / (sigma * sigma));
                    }
                    out.names.push(name);
                }
            };
            add(
                ParameterGroup::TrackerFrame { session },
                f64::INFINITY,
                format!("frame {label}"),
            );
            for &(group, sigma) in optional {
                add(
                    group.parameters(session),
                    sigma,
                    format!("{} {label}", group.name()),
                );
            }
        }
        out
    }
}

/// The expected mean square of a prediction row's residual (mm²) with
/// the nuisance model `nuisance` re-fitted on the reference rows: the
/// reference rows' residual variance after the re-fit, `RSS / (m − p)`
/// (`m` rows, `p` re-fitted parameters), plus the mean over the predicted
/// rows of the re-fitted nuisance's variance propagated to them,
/// `J_n (AᵀA + Λ)⁻¹ J_nᵀ`. It uses the reference rows' residuals and the
/// predicted rows' geometry only, never their residuals. `None`: the
/// reference rows do not determine the model.
fn expected_prediction_error(
    model: &InstrumentModel,
    global: &DVector<f64>,
    reference: &InstrumentRows,
    predicted: &InstrumentRows,
    nuisance: &Nuisance,
) -> Result<Option<f64>, CalibrateError> {
    let mut g = global.clone();
    let Ok(Some(fit)) = refit(
        model,
        reference,
        &mut g,
        &nuisance.columns,
        &nuisance.information,
    ) else {
        return Ok(None);
    };
    let values = model.values(&g);
    let residual = reference.raw(model, &values)?.residual;
    let dof = residual.len().saturating_sub(nuisance.columns.len());
    if dof == 0 {
        return Ok(None);
    }
    let variance = residual.norm_squared() / dof as f64;
    let j_n = predicted
        .raw(model, &values)?
        .jacobian
        .select_columns(&nuisance.columns);
    let propagated = (&j_n * &fit.covariance).component_mul(&j_n).sum() / j_n.nrows().max(1) as f64;
    Ok(Some(variance + propagated))
}

/// A re-fitted nuisance: `(AᵀA + Λ)⁻¹`, `K` and the reference rows'
/// whitened Jacobian `B` on the held columns (module doc).
struct Refit {
    covariance: DMatrix<f64>,
    gain: DMatrix<f64>,
    held: DMatrix<f64>,
}

/// Gauss–Newton on the `nuisance` columns of the global block over the
/// reference rows, the other columns held; `prior`: the information of
/// each nuisance column (zero-mean about the start). `None` without
/// nuisance.
fn refit(
    model: &InstrumentModel,
    rows: &InstrumentRows,
    global: &mut DVector<f64>,
    nuisance: &[usize],
    prior: &[f64],
) -> Result<Option<Refit>, CalibrateError> {
    if nuisance.is_empty() {
        return Ok(None);
    }
    let mean: Vec<f64> = nuisance.iter().map(|&c| global[c]).collect();
    let lambda = DMatrix::from_diagonal(&DVector::from_column_slice(prior));
    let mut out = GlobalObservations::zeros(0, 0);
    for _ in 0..REFIT_ITERATIONS {
        rows.evaluate(model, &model.values(global), &mut out)?;
        let a = out.jacobian.select_columns(nuisance);
        let x = DVector::from_iterator(nuisance.len(), nuisance.iter().map(|&c| global[c]));
        let offset = &x - DVector::from_column_slice(&mean);
        let normal = a.transpose() * &a + &lambda;
        let rhs = -(a.transpose() * &out.residual + &lambda * offset);
        let step = normal
            .clone()
            .cholesky()
            .ok_or_else(|| CalibrateError::Calibration {
                reason: "the reference rows do not determine the session's frames and offsets"
                    .into(),
            })?
            .solve(&rhs);
        for (k, &c) in nuisance.iter().enumerate() {
            global[c] += step[k];
        }
        if step.norm() < REFIT_TOLERANCE * (1.0 + x.norm()) {
            break;
        }
    }
    rows.evaluate(model, &model.values(global), &mut out)?;
    let a = out.jacobian.select_columns(nuisance);
    let held: Vec<usize> = (0..global.len())
        .filter(|c| !nuisance.contains(c))
        .collect();
    let b = out.jacobian.select_columns(&held);
    let normal = a.transpose() * &a + lambda;
    let inverse = normal
        .try_inverse()
        .ok_or_else(|| CalibrateError::Calibration {
            reason: "the reference rows do not determine the session's frames and offsets".into(),
        })?;
    Ok(Some(Refit {
        gain: &inverse * a.transpose(),
        covariance: inverse,
        held: b,
    }))
}

/// The predicted rows with a nuisance model re-fitted: their residuals,
/// predicted sigmas and `rᵀ C⁻¹ r` (module doc).
struct Prediction {
    residuals: Vec<f64>,
    sigmas: Vec<f64>,
    statistic: f64,
}

impl Prediction {
    /// Re-fits `nuisance` on the `reference` rows from `global` and
    /// predicts the `predicted` rows (both weighed).
    fn new(
        calibrated: &Calibrated,
        model: &InstrumentModel,
        global: &DVector<f64>,
        reference: &InstrumentRows,
        predicted: &InstrumentRows,
        nuisance: &Nuisance,
    ) -> Result<Self, CalibrateError> {
        let mut global = global.clone();
        let fit = refit(
            model,
            reference,
            &mut global,
            &nuisance.columns,
            &nuisance.information,
        )?;
        let values = model.values(&global);
        let raw = predicted.raw(model, &values)?;
        let mut whitened = GlobalObservations::zeros(0, 0);
        predicted.evaluate(model, &values, &mut whitened)?;
        let common = CommonErrors::new(calibrated, model, &nuisance.columns, fit.as_ref());
        let u = common.factor(&raw.jacobian);
        let sigmas = (0..raw.residual.len())
            .map(|i| (u.row(i).norm_squared() + predicted.variances[i]).sqrt())
            .collect();
        Ok(Self {
            residuals: raw.residual.iter().copied().collect(),
            sigmas,
            statistic: prediction::statistic(
                &whitened.residual,
                &common.factor(&whitened.jacobian),
            ),
        })
    }
}

/// The errors the predicted rows share (module doc): the calibration's
/// parameters, held, and the re-fitted nuisance.
struct CommonErrors<'a> {
    /// The held columns.
    held: Vec<usize>,
    /// `Σ_θ^{1/2}` on them.
    theta: DMatrix<f64>,
    /// The nuisance columns.
    nuisance: &'a [usize],
    /// `K B` and `(K Kᵀ)^{1/2}` of the re-fit, if any.
    refit: Option<(DMatrix<f64>, DMatrix<f64>)>,
}

impl<'a> CommonErrors<'a> {
    fn new(
        calibrated: &Calibrated,
        model: &InstrumentModel,
        nuisance: &'a [usize],
        fit: Option<&Refit>,
    ) -> Self {
        let names = model.layout.names(&[], &model.sessions);
        let held: Vec<usize> = (0..names.len()).filter(|c| !nuisance.contains(c)).collect();
        // Σ_θ on the held columns: the calibration's covariance by name (a
        // parameter it does not have is exact: zero by definition).
        let index: Vec<Option<usize>> = held
            .iter()
            .map(|&c| calibrated.names.iter().position(|n| *n == names[c]))
            .collect();
        let sigma_theta =
            DMatrix::from_fn(held.len(), held.len(), |i, j| match (index[i], index[j]) {
                (Some(a), Some(b)) => calibrated.covariance[(a, b)],
                _ => 0.0,
            });
        Self {
            held,
            theta: prediction::square_root(&sigma_theta),
            nuisance,
            refit: fit.map(|fit| {
                (
                    &fit.gain * &fit.held,
                    prediction::square_root(&(&fit.gain * fit.gain.transpose())),
                )
            }),
        }
    }

    /// `U = [G Σ_θ^{1/2}, J_n (K Kᵀ)^{1/2}]` of rows with Jacobian
    /// `jacobian` on the global block (raw or whitened alike).
    fn factor(&self, jacobian: &DMatrix<f64>) -> DMatrix<f64> {
        let j_theta = jacobian.select_columns(&self.held);
        let Some((gain_held, refit_root)) = &self.refit else {
            return j_theta * &self.theta;
        };
        let j_n = jacobian.select_columns(self.nuisance);
        let g = j_theta - &j_n * gain_held;
        let (a, b) = (self.theta.ncols(), refit_root.ncols());
        let mut u = DMatrix::zeros(jacobian.nrows(), a + b);
        u.columns_mut(0, a).copy_from(&(g * &self.theta));
        u.columns_mut(a, b).copy_from(&(j_n * refit_root));
        u
    }
}

/// The rows `poses` and `points` of `tracker` (indices in file order), the
/// sessions kept.
pub(crate) fn subset(tracker: &Tracker, poses: &[usize], points: &[usize]) -> Tracker {
    let p = &tracker.poses;
    let t = &tracker.points;
    Tracker {
        sessions: tracker.sessions.clone(),
        poses: Poses {
            session: poses.iter().map(|&j| p.session[j]).collect(),
            q: poses.iter().map(|&j| p.q[j]).collect(),
            position: poses.iter().map(|&j| p.position[j]).collect(),
            orientation: poses.iter().map(|&j| p.orientation[j]).collect(),
        },
        points: Points {
            session: points.iter().map(|&j| t.session[j]).collect(),
            q: points.iter().map(|&j| t.q[j]).collect(),
            position: points.iter().map(|&j| t.position[j]).collect(),
        },
    }
}
