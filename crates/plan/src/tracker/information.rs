//! What one planned pose tells about the instrument calibration's unknowns,
//! linearised at the design.
//!
//! The candidates are written as a noiseless campaign of `K` sessions
//! (labelled `1`..`K`, every candidate pose in each; a candidate is a pose
//! in a session) seen through the identity instrument frame and the
//! identity body frame (`M = T`, points `T E_T`), and set up exactly as
//! `parcal calibrate` sets up measured poses and points
//! (`parcal_calibrate::instruments::setup`): the same global block (the 33
//! canonical parameters, the actuator scales when machine.json gives their
//! sigmas, each session's instrument frame, the body frame when there are
//! poses, and each later session's leg offsets and body origin and turn as
//! machine.json's `session_model` asks), the same whitened rows `L⁻¹ ∂c/∂g` (the pose block's six rows,
//! the point block's three, `W = L Lᵀ` the propagated actuator and
//! instrument covariance) and the same prior. A candidate's block is its
//! rows of that Jacobian; the information of a design is
//!
//! ```text
//! M = P + Σ_k J_kᵀ J_k,
//! ```
//!
//! `P` the calibration's prior (with the session model's priors) plus
//! `I /` [`WEAK_FRAME_SIGMA`]² on the frames (which have no prior), so
//! that `M` is invertible before the first pose. The criterion acts on the
//! 33 × 33 block of `M⁻¹`: the Schur complement that eliminates the scales,
//! the frames and the sessions' nuisances.

use nalgebra::{DMatrix, UnitQuaternion};
use parcal_calibrate::CalibrationOptions;
use parcal_calibrate::instruments::setup;
use parcal_calibrate::layout::ParameterGroup;
use parcal_dataset::{Artefacts, Dataset, Machine, Measurements, Tracker};
use parcal_kinematics::{Pose, Vec3};
use parcal_simulate::TrackerKind;
use parcal_solver::{GlobalObservations, Problem};

use crate::DesignError;

/// The prior sigma of the frames' corrections (mm and rad): a regulariser
/// that leaves the figures unchanged once a few poses fix the frames.
pub const WEAK_FRAME_SIGMA: f64 = 1e3;

/// The candidates' whitened blocks and the prior, on the global block.
#[derive(Debug, Clone)]
pub struct PoseInformation {
    /// Each candidate's rows (6 per pose, 3 per point, 9 for both) by
    /// columns of the global block; candidate `s P + k` is pose `k` of
    /// `P` in session `s` (0-based).
    pub blocks: Vec<DMatrix<f64>>,
    /// `P` (module doc).
    pub prior: DMatrix<f64>,
    /// The names of the global block's unknowns.
    pub names: Vec<String>,
}

/// The blocks of the platform poses `poses` (design frame) with the
/// design's readings `q` (actuators' unit), observed as `kind` says in
/// each of `sessions` sessions (module doc); `tool` is the design's tool
/// point (platform frame).
pub fn pose_information(
    machine: &Machine,
    tool: &Vec3,
    kind: TrackerKind,
    poses: &[Pose],
    q: &[[f64; 6]],
    sessions: usize,
) -> Result<PoseInformation, DesignError> {
    if sessions == 0 {
        return Err(DesignError::Options(
            "a plan needs at least 1 session".into(),
        ));
    }
    let dataset = campaign(machine, tool, kind, poses, q, sessions);
    let refuse = |e: parcal_calibrate::CalibrateError| {
        DesignError::Options(format!("the candidate poses as a campaign: {e}"))
    };
    let options = CalibrationOptions::default();
    let set = setup(&dataset, &options).map_err(refuse)?;
    let problem = &set.problem;
    let n = problem.global_size();
    let mut rows = GlobalObservations::zeros(0, 0);
    problem
        .global_observations(&set.initial, &mut rows)
        .map_err(refuse)?;
    let jacobian = &rows.jacobian;
    let candidates = sessions * poses.len();
    let pose_rows = if kind.poses() { 6 * candidates } else { 0 };
    let blocks = (0..candidates)
        .map(|k| {
            let mut ranges = Vec::new();
            if kind.poses() {
                ranges.push(6 * k..6 * k + 6);
            }
            if kind.points() {
                ranges.push(pose_rows + 3 * k..pose_rows + 3 * k + 3);
            }
            let r = ranges.iter().map(|r| r.len()).sum();
            let mut block = DMatrix::zeros(r, n);
            let mut at = 0;
            for range in ranges {
                block
                    .rows_mut(at, range.len())
                    .copy_from(&jacobian.rows(range.start, range.len()));
                at += range.len();
            }
            block
        })
        .collect();
    let layout = &problem.model.layout;
    let mut prior = match &problem.prior {
        Some(prior) => prior.information.clone(),
        None => DMatrix::zeros(n, n),
    };
    for (group, range) in layout.groups() {
        if matches!(
            group,
            ParameterGroup::TrackerFrame { .. } | ParameterGroup::BodyFrame
        ) {
            for i in range.clone() {
                prior[(i, i)] += WEAK_FRAME_SIGMA.powi(-2);
            }
        }
    }
    Ok(PoseInformation {
        blocks,
        prior,
        names: layout.names(&[], &problem.model.sessions),
    })
}

/// The noiseless campaign of `poses` in each of `sessions` sessions
/// (session-major), identity instrument and body frames, machine.json's
/// stroke and joint limits dropped (the pool checked them).
fn campaign(
    machine: &Machine,
    tool: &Vec3,
    kind: TrackerKind,
    poses: &[Pose],
    q: &[[f64; 6]],
    sessions: usize,
) -> Dataset {
    let mut tracker = Tracker {
        sessions: session_labels(sessions),
        ..Tracker::default()
    };
    let rows = (0..sessions as u32).flat_map(|s| poses.iter().zip(q).map(move |(p, q)| (s, p, q)));
    for (session, pose, q) in rows {
        if kind.poses() {
            let t = &mut tracker.poses;
            t.session.push(session);
            t.q.push(*q);
            t.position.push(pose.translation.vector.into());
            t.orientation.push(quaternion(&pose.rotation));
        }
        if kind.points() {
            let t = &mut tracker.points;
            t.session.push(session);
            t.q.push(*q);
            t.position
                .push(pose.transform_point(&(*tool).into()).coords.into());
        }
    }
    Dataset {
        machine: Machine {
            stroke: None,
            joint_limits: None,
            ..machine.clone()
        },
        artefacts: Artefacts::default(),
        measurements: Measurements::default(),
        tracker,
        truth: None,
    }
}

/// The labels of `sessions` planned sessions: `1`, `2`, ... (the
/// simulator's; `1` is the dataset's default session).
pub fn session_labels(sessions: usize) -> Vec<String> {
    (1..=sessions).map(|s| s.to_string()).collect()
}

/// `[x, y, z, w]` of a rotation (poses.csv's order).
fn quaternion(rotation: &UnitQuaternion<f64>) -> [f64; 4] {
    let q = rotation.quaternion();
    [q.i, q.j, q.k, q.w]
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::DVector;
    use parcal_simulate::{TrackerScenario, simulate_tracker};

    use crate::tracker::pool::pose_pool;

    /// The paper's machine tracked (scales unknown) and five poses of its
    /// pool at different positions and orientations (the frames' start
    /// needs turns between poses).
    fn case(kind: TrackerKind) -> (Machine, Vec<Pose>, Vec<[f64; 6]>) {
        let scenario = TrackerScenario {
            kind,
            sessions: 1,
            rows_per_session: 5,
            ..TrackerScenario::paper_like()
        };
        let machine = simulate_tracker(&scenario, 1).unwrap().dataset.machine;
        let pool = pose_pool(
            &scenario.design,
            &scenario.workspace,
            scenario.max_tilt,
            &machine.actuator.scale,
            None,
            None,
        )
        .unwrap();
        let picked: Vec<_> = (0..5).map(|k| &pool[k * pool.len() / 6 + 3 * k]).collect();
        (
            machine,
            picked.iter().map(|c| c.pose).collect(),
            picked.iter().map(|c| c.q).collect(),
        )
    }

    #[test]
    fn the_blocks_are_central_differences_of_the_whitened_residuals() {
        // Two sessions with re-homed legs and a re-mounted body: the
        // later session's nuisances are columns too.
        let cases = [
            (TrackerKind::Poses, 1),
            (TrackerKind::Points, 1),
            (TrackerKind::Both, 1),
            (TrackerKind::Both, 2),
        ];
        for (kind, sessions) in cases {
            let (mut machine, poses, q) = case(kind);
            if sessions > 1 {
                machine.session_model = parcal_dataset::SessionModel {
                    leg_offset_sigma: Some(0.5),
                    body_origin_sigma: Some(0.2),
                    body_rotation_sigma: Some(1e-3),
                };
            }
            let tool = Vec3::from(machine.geometry.tool);
            let information =
                pose_information(&machine, &tool, kind, &poses, &q, sessions).unwrap();
            let dataset = campaign(&machine, &tool, kind, &poses, &q, sessions);
            let set = setup(&dataset, &CalibrationOptions::default()).unwrap();
            let n = set.problem.global_size();
            let residual = |g: &DVector<f64>| {
                let mut out = GlobalObservations::zeros(0, 0);
                set.problem.global_observations(g, &mut out).unwrap();
                out.residual
            };
            // Noiseless data at the design: every residual vanishes.
            assert!(residual(&set.initial).amax() < 1e-6);
            let rows_per_pose = information.blocks[0].nrows();
            let candidates = information.blocks.len();
            assert_eq!(candidates, sessions * poses.len());
            let pose_rows = if kind.poses() { 6 * candidates } else { 0 };
            if sessions > 1 {
                assert!(
                    information
                        .names
                        .iter()
                        .any(|name| name.starts_with("o_1 2"))
                );
            }
            for i in 0..n {
                let h = 1e-6 * set.initial[i].abs().max(1.0);
                let mut plus = set.initial.clone();
                plus[i] += h;
                let mut minus = set.initial.clone();
                minus[i] -= h;
                let column = (residual(&plus) - residual(&minus)) / (2.0 * h);
                for (k, block) in information.blocks.iter().enumerate() {
                    let mut rows = Vec::new();
                    if kind.poses() {
                        rows.extend(6 * k..6 * k + 6);
                    }
                    if kind.points() {
                        rows.extend(pose_rows + 3 * k..pose_rows + 3 * k + 3);
                    }
                    assert_eq!(rows.len(), rows_per_pose);
                    for (r, &row) in rows.iter().enumerate() {
                        let (analytic, numeric) = (block[(r, i)], column[row]);
                        let scale = block.column(i).amax().max(1.0);
                        assert!(
                            (analytic - numeric).abs() < 1e-5 * scale,
                            "{kind:?} pose {k} row {r} column {} ({}): {analytic} vs {numeric}",
                            i,
                            information.names[i]
                        );
                    }
                }
            }
            // The frames have their weak prior, the 33 the calibration's.
            assert!(information.prior.clone().cholesky().is_some());
        }
    }
}
