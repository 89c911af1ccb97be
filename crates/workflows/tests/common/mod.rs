//! Helpers shared by the integration tests: the calibration case,
//! a dataset with its measurement rows shuffled, and a simulation's true
//! global block with the NEES of an error.

use nalgebra::{DMatrix, DVector, Isometry3, Quaternion, Translation3, UnitQuaternion};
use parcal_accuracy::MapGrid;
use parcal_calibrate::hypothesis::{MAX_REMOVALS, SNOOPING_LEVEL};
use parcal_calibrate::instruments::InstrumentModel;
use parcal_calibrate::layout::ParameterGroup;
use parcal_calibrate::observation::ObservationId;
use parcal_calibrate::snooping::{Snooped, calibrate_with_snooping};
use parcal_calibrate::{CalibrationOptions, CalibrationRun, PriorMode, Simulation};
use parcal_dataset::{Dataset, FrameRecord};
use parcal_kinematics::{Geometry, Vec3, params};
use parcal_workflows::evaluate::{TrueMachine, before_after};

/// Simulation IV with the propagated prior (the case, as in the
/// benches).
pub fn options() -> CalibrationOptions {
    CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    }
}

/// The row of the dataset at row `k` of [`shuffled`]'s, for each `k` of
/// `n` rows.
pub fn permutation(n: usize) -> Vec<usize> {
    (0..n).map(|k| (k * 7919 + 13) % n).collect()
}

/// `dataset` with its measurement rows in a fixed scrambled order, row `k`
/// taken from row `(7919 k + 13) mod n`: every per-row column moves (ball,
/// q, the directions if any, and the truth's contacts if any).
pub fn shuffled(dataset: &Dataset) -> Dataset {
    let n = dataset.measurements.len();
    let permutation = permutation(n);
    let mut seen = vec![false; n];
    for &k in &permutation {
        seen[k] = true;
    }
    assert!(seen.iter().all(|&s| s), "not a permutation of {n} rows");
    fn permute<T: Clone>(column: &[T], permutation: &[usize]) -> Vec<T> {
        permutation.iter().map(|&k| column[k].clone()).collect()
    }
    let mut shuffled = dataset.clone();
    let (from, to) = (&dataset.measurements, &mut shuffled.measurements);
    to.ball = permute(&from.ball, &permutation);
    to.q = permute(&from.q, &permutation);
    to.direction = from.direction.as_deref().map(|d| permute(d, &permutation));
    if let (Some(from), Some(to)) = (&dataset.truth, &mut shuffled.truth) {
        to.contacts = permute(&from.contacts, &permutation);
    }
    shuffled
}

/// How far `result` is from `reference`, relatively: of the 33 parameters
/// `|p - p_ref| / |p_ref|` (Euclidean norms), of their sigmas
/// `max |s - s_ref| / max s_ref`.
pub fn relative_differences(reference: &CalibrationRun, result: &CalibrationRun) -> (f64, f64) {
    let params = (result.params - reference.params).norm() / reference.params.norm();
    let (s, s_ref) = (
        result.sigmas().expect("sigmas"),
        reference.sigmas().expect("sigmas"),
    );
    (params, (s - s_ref).amax() / s_ref.amax())
}

/// A frame of the dataset files as an isometry.
pub fn isometry(record: &FrameRecord) -> Isometry3<f64> {
    let [x, y, z, w] = record.rotation;
    Isometry3::from_parts(
        Translation3::from(Vec3::from(record.translation)),
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)),
    )
}

/// The true global block of the simulated `dataset` in the layout of
/// `model` (ball centres in the canonical base frame). `T_b`, `T_p`: the true geometry's `base_from_input` and
/// `platform_from_input`; `F_k`, `B_k`: the true frames (design base frame
/// to instrument, body to design platform frame).
///
/// - kinematic: the true geometry's canonical parameters; scales: the
///   true scales; leg offsets: the true ones;
/// - `C_F,k = F₀_k⁻¹ F_k T_b⁻¹`, as `(Log R, t)`;
/// - `C_B,k = T_p B_k B₀⁻¹`: the body frame's correction is session 0's
///   `(ω_B, τ_B) = (Log R(C_B,0), t(C_B,0))`; a later session's turn and
///   shift are `Log R(C_B,k) − ω_B` and `t(C_B,k) − τ_B`, exactly, since
///   `C_B,k = (Exp(ω_B + φ_k), τ_B + ρ_k)`.
pub fn true_block(dataset: &Dataset, model: &InstrumentModel) -> DVector<f64> {
    let truth = dataset.truth.as_ref().expect("a simulated dataset");
    let g = &truth.geometry;
    let geometry =
        Geometry::from_arrays(&g.base_joints, &g.platform_joints, &g.tool, &g.leg_lengths);
    let canonical = geometry.canonicalize().expect("a canonical truth");
    let body = |k: usize| {
        canonical.platform_from_input
            * isometry(&truth.sessions[k].body_frame)
            * model.body_reference.inverse()
    };
    let (omega_b, tau_b) = (body(0).rotation.scaled_axis(), body(0).translation.vector);
    let correction = |c: &Isometry3<f64>| {
        let (w, t) = (c.rotation.scaled_axis(), c.translation.vector);
        vec![w.x, w.y, w.z, t.x, t.y, t.z]
    };
    let mut block = DVector::zeros(model.layout.size());
    for (group, range) in model.layout.groups() {
        let values = match *group {
            ParameterGroup::Kinematic | ParameterGroup::KinematicWithoutTool => {
                params::to_params(&canonical.geometry).as_slice()[..range.len()].to_vec()
            }
            ParameterGroup::ActuatorScales => truth.actuator_scale.expect("true scales").to_vec(),
            ParameterGroup::TrackerFrame { session } => correction(
                &(model.tracker_references[session].inverse()
                    * isometry(&truth.sessions[session].tracker_frame)
                    * canonical.base_from_input.inverse()),
            ),
            ParameterGroup::BodyFrame => correction(&body(0)),
            ParameterGroup::BodyRotation { session } => (body(session).rotation.scaled_axis()
                - omega_b)
                .as_slice()
                .to_vec(),
            ParameterGroup::BodyOrigin { session } => (body(session).translation.vector - tau_b)
                .as_slice()
                .to_vec(),
            ParameterGroup::LegOffsets { session } => truth.sessions[session].leg_offsets.to_vec(),
            ParameterGroup::BallCentre { ball } => {
                let centre = Vec3::from(truth.ball_centres[ball]);
                (canonical.base_from_input * nalgebra::Point3::from(centre))
                    .coords
                    .as_slice()
                    .to_vec()
            }
            ParameterGroup::BallRadius { ball } => vec![truth.ball_radii[ball]],
        };
        block
            .rows_mut(range.start, range.len())
            .copy_from_slice(&values);
    }
    block
}

/// `e^T Σ^-1 e` by the Cholesky factor of `Σ`; `None` when `Σ` is not
/// positive definite.
pub fn nees(e: &DVector<f64>, covariance: &DMatrix<f64>) -> Option<f64> {
    let factor = covariance.clone().cholesky()?;
    Some(factor.l().solve_lower_triangular(e)?.norm_squared())
}

/// The root mean square of `values`.
pub fn rms(values: &[f64]) -> f64 {
    (values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64).sqrt()
}

/// The mean of `values` and its standard error (sample sd / √N).
pub fn mean_and_standard_error(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let mean = values.iter().sum::<f64>() / n;
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (variance / n).sqrt())
}

/// The true registered RMS of `run` on the paper's map (mm), against the
/// truth `dataset` was simulated from.
pub fn true_registered_rms(dataset: &Dataset, run: &CalibrationRun) -> f64 {
    let truth = TrueMachine::of(dataset).unwrap().unwrap();
    let maps = before_after(Some(&truth), run, &MapGrid::paper()).unwrap();
    maps.after
        .and_then(|a| a.true_error)
        .map(|m| m.registered_summary().rms)
        .unwrap()
}

/// The bits of every iteration's cost: equal for runs that took the same
/// steps.
pub fn cost_bits(run: &CalibrationRun) -> Vec<u64> {
    run.history.iter().map(|h| h.cost.to_bits()).collect()
}

/// Data snooping of a calibration (touches, poses, points) at the
/// project's level and removal limit.
pub fn snoop(
    dataset: &Dataset,
    options: &CalibrationOptions,
) -> Snooped<CalibrationRun, ObservationId> {
    calibrate_with_snooping(dataset, options, SNOOPING_LEVEL, MAX_REMOVALS, &mut |_| {}).unwrap()
}

/// The observations snooping removed, in order.
pub fn removed(snooped: &Snooped<CalibrationRun, ObservationId>) -> Vec<ObservationId> {
    snooped.removals.iter().map(|r| r.observation).collect()
}
