//! What a calibration buys, and how it compares with the truth in
//! simulation: the accuracy maps of docs/paper-scenario.md section 5 before and after, the
//! identified values against the true ones, and the normalised estimation
//! error squared (NEES).

use parcal_accuracy::{
    AccuracyError, AccuracyMap, CanonicalTargets, MapGrid, predicted, true_error_at,
};
use parcal_dataset::Dataset;
use parcal_kinematics::{Geometry, Params, Pose, Vec3, params};

use parcal_calibrate::{CalibrationRun, ParamCovariance};

/// The true machine of a simulated dataset (truth.json's geometry and
/// ball centres, [`parcal_dataset::Truth`], in canonical frames).
pub struct TrueMachine {
    /// As given (truth.json's frames: those of machine.json).
    pub input: Geometry,
    /// In its own canonical frames.
    pub canonical: Geometry,
    /// Its canonical parameters.
    pub params: Params,
    /// True ball centres in the true canonical base frame.
    pub centres: Vec<Vec3>,
    /// Maps machine.json's base frame to the true canonical base frame.
    pub base_from_input: Pose,
}

impl TrueMachine {
    /// The truth of `dataset`, if it has one (`None` for a real machine).
    pub fn of(dataset: &Dataset) -> Option<Result<Self, parcal_kinematics::KinematicsError>> {
        let t = dataset.truth.as_ref()?;
        let g = &t.geometry;
        let input =
            Geometry::from_arrays(&g.base_joints, &g.platform_joints, &g.tool, &g.leg_lengths);
        Some(input.canonicalize().map(|canonical| {
            let centres = t
                .ball_centres
                .iter()
                .map(|c| {
                    canonical
                        .base_from_input
                        .transform_point(&(*c).into())
                        .coords
                })
                .collect();
            Self {
                params: params::to_params(&canonical.geometry),
                canonical: canonical.geometry,
                input,
                centres,
                base_from_input: canonical.base_from_input,
            }
        }))
    }

    /// NEES of an estimate: `(p^ - p)^T Sigma^-1 (p^ - p)` (expectation 33
    /// when the covariance is honest).
    pub fn nees(&self, estimate: &Params, covariance: &ParamCovariance) -> Option<f64> {
        let error = estimate - self.params;
        let information = covariance.cholesky()?.inverse();
        Some(error.dot(&(information * error)))
    }
}

/// The accuracy maps of one parameter set.
pub struct Accuracy {
    /// `J_f Sigma_p J_f^T` with the set's covariance (design-mapped targets).
    pub predicted: AccuracyMap,
    /// The true machine commanded by the model (simulation only): targets
    /// placed with the truth's own frame transforms, i.e. the same physical
    /// grid (docs/paper-scenario.md section 5; the reference implementation's choice).
    pub true_error: Option<AccuracyMap>,
}

/// The accuracy maps of `model` with `covariance` on the paper's grid, the
/// targets placed by the `design` geometry (machine.json's frames).
pub fn accuracy(
    design: &Geometry,
    truth: Option<&TrueMachine>,
    model: &Params,
    covariance: &ParamCovariance,
    grid: &MapGrid,
) -> Result<Accuracy, AccuracyError> {
    let predicted = predicted(design, model, covariance, grid)?;
    let true_error = truth
        .map(|t| {
            let targets = CanonicalTargets::new(&t.input, grid)?;
            true_error_at(&targets, model, &t.canonical)
        })
        .transpose()?;
    Ok(Accuracy {
        predicted,
        true_error,
    })
}

/// Maps before (design with the prior) and after (estimate with the
/// posterior) a calibration. `before` is `None` without a prior.
pub struct BeforeAfter {
    /// The design with the prior's covariance; `None` without a prior.
    pub before: Option<Accuracy>,
    /// The estimate with the posterior covariance; `None` when there is none.
    pub after: Option<Accuracy>,
}

/// The accuracy a run buys, the targets placed by the run's design
/// geometry.
pub fn before_after(
    truth: Option<&TrueMachine>,
    run: &CalibrationRun,
    grid: &MapGrid,
) -> Result<BeforeAfter, AccuracyError> {
    let before = run
        .prior
        .as_ref()
        .map(|prior| {
            accuracy(
                &run.design,
                truth,
                &run.initial_params,
                prior.covariance(),
                grid,
            )
        })
        .transpose()?;
    let after = run
        .covariance
        .as_ref()
        .map(|covariance| accuracy(&run.design, truth, &run.params, covariance, grid))
        .transpose()?;
    Ok(BeforeAfter { before, after })
}
