//! Initial instrument and body frames from the design's forward kinematics.
//!
//! With the design geometry, forward kinematics gives each row's platform
//! pose `T_j` (canonical frames) to within the geometry's errors. A
//! measured pose is `M_j = F T_j B`, so for two poses of one session
//!
//! ```text
//! R_Mj R_Miᵀ = R_F (R_Tj R_Tiᵀ) R_Fᵀ   ⇒   a_ij = R_F c_ij,
//! ```
//!
//! `a`, `c` the rotation vectors of the relative rotations: `R_F` is the
//! rotation that best maps the `c_ij` onto the `a_ij` (Kabsch on the pairs
//! and their negatives, which centres both sets), the rotation part of
//! the hand–eye calibration `AX = XB` (Park and Martin, IEEE Trans. Robot.
//! Autom. 10, 1994, 717). Then `R_B` is the chordal mean of `R_Tjᵀ R_Fᵀ
//! R_Mj`, and the translations solve the linear least squares
//! `R_F R_Tj t_B + t_F = t_Mj − R_F t_Tj` (one `t_F` per session, `t_B`
//! shared). A
//! session of points alone: `F` is the best rigid motion of the design's
//! tool tips onto the measured points (Kabsch).

use nalgebra::{DMatrix, DVector, Isometry3, Rotation3};
use parcal_accuracy::kabsch;
use parcal_dataset::Tracker;
use parcal_kinematics::{ForwardOptions, Geometry, Pose, Vec3, forward_from_home};

use crate::CalibrateError;
use crate::instruments::InstrumentTable;
use crate::instruments::model::isometry;

/// Smallest relative rotation (rad) of a pair of poses used for `R_F`.
const MIN_PAIR_ROTATION: f64 = 0.02;

/// The start of an instrument calibration.
#[derive(Debug, Clone)]
pub struct FrameStart {
    /// `F₀_k` of each session.
    pub trackers: Vec<Isometry3<f64>>,
    /// `B₀`.
    pub body: Isometry3<f64>,
    /// The design's platform pose at each row of poses.csv.
    pub pose_poses: Vec<Pose>,
    /// The design's platform pose at each row of points.csv.
    pub point_poses: Vec<Pose>,
}

/// The design's forward kinematics at every row (`scales`: mm per unit,
/// no leg offset), then the frames as the module doc says.
pub fn frame_start(
    tracker: &Tracker,
    design: &Geometry,
    scales: &[f64; 6],
    options: &ForwardOptions,
) -> Result<FrameStart, CalibrateError> {
    let pose_poses = forward_poses(
        InstrumentTable::Poses,
        &tracker.poses.q,
        design,
        scales,
        options,
    )?;
    let point_poses = forward_poses(
        InstrumentTable::Points,
        &tracker.points.q,
        design,
        scales,
        options,
    )?;
    let measured: Vec<Pose> = measured_poses(tracker);
    let sessions = tracker.sessions.len();
    let mut rotations = Vec::with_capacity(sessions);
    for session in 0..sessions {
        let rows: Vec<usize> = (0..tracker.poses.len())
            .filter(|&j| tracker.poses.session[j] as usize == session)
            .collect();
        rotations.push(if rows.is_empty() {
            None
        } else {
            Some(hand_eye_rotation(
                &tracker.sessions[session],
                &rows,
                &measured,
                &pose_poses,
            )?)
        });
    }
    let body_rotation = mean_body_rotation(tracker, &rotations, &measured, &pose_poses);
    let mut trackers = vec![Isometry3::identity(); sessions];
    let mut body_translation = Vec3::zeros();
    if !tracker.poses.is_empty() {
        let (translations, t_b) = translations(tracker, &rotations, &measured, &pose_poses)?;
        body_translation = t_b;
        for (session, t) in translations.into_iter().enumerate() {
            if let (Some(r), Some(t)) = (rotations[session], t) {
                trackers[session] = isometry(r, t);
            }
        }
    }
    for (session, frame) in trackers.iter_mut().enumerate() {
        if rotations[session].is_some() {
            continue;
        }
        let (tips, targets): (Vec<Vec3>, Vec<Vec3>) = (0..tracker.points.len())
            .filter(|&j| tracker.points.session[j] as usize == session)
            .map(|j| {
                (
                    design.tool_tip(&point_poses[j]),
                    Vec3::from(tracker.points.position[j]),
                )
            })
            .unzip();
        let motion = kabsch(&tips, &targets).map_err(|e| CalibrateError::FrameStart {
            session: tracker.sessions[session].clone(),
            reason: format!("the design's tool points do not locate the instrument frame: {e}"),
        })?;
        *frame = isometry(motion.rotation, motion.translation);
    }
    Ok(FrameStart {
        trackers,
        body: isometry(body_rotation, body_translation),
        pose_poses,
        point_poses,
    })
}

/// The platform pose of `geometry` at every row's readings `q` (`scales`:
/// mm per unit, no leg offset), by forward kinematics from home.
pub fn forward_poses(
    table: InstrumentTable,
    q: &[[f64; 6]],
    geometry: &Geometry,
    scales: &[f64; 6],
    options: &ForwardOptions,
) -> Result<Vec<Pose>, CalibrateError> {
    q.iter()
        .enumerate()
        .map(|(row, q)| {
            let extensions = std::array::from_fn(|i| scales[i] * q[i]);
            forward_from_home(geometry, &extensions, options)
                .map(|s| s.pose)
                .map_err(|e| CalibrateError::InstrumentRow {
                    table,
                    row,
                    reason: format!("forward kinematics from home failed: {e}"),
                })
        })
        .collect()
}

/// The measured poses of poses.csv as isometries.
pub fn measured_poses(tracker: &Tracker) -> Vec<Pose> {
    let poses = &tracker.poses;
    (0..poses.len())
        .map(|j| {
            let [x, y, z, w] = poses.orientation[j];
            let rotation =
                nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
            Pose::from_parts(Vec3::from(poses.position[j]).into(), rotation)
        })
        .collect()
}

/// `R_F` of one session from its pairs of poses (module doc).
fn hand_eye_rotation(
    label: &str,
    rows: &[usize],
    measured: &[Pose],
    design: &[Pose],
) -> Result<Rotation3<f64>, CalibrateError> {
    let (mut c, mut a) = (Vec::new(), Vec::new());
    for (n, &i) in rows.iter().enumerate() {
        for &j in &rows[n + 1..] {
            let relative = |p: &[Pose]| (p[j].rotation * p[i].rotation.inverse()).scaled_axis();
            let (cij, aij) = (relative(design), relative(measured));
            if cij.norm() < MIN_PAIR_ROTATION {
                continue;
            }
            c.extend([cij, -cij]);
            a.extend([aij, -aij]);
        }
    }
    let motion = kabsch(&c, &a).map_err(|e| CalibrateError::FrameStart {
        session: label.to_owned(),
        reason: format!(
            "the poses do not turn the platform enough (by {MIN_PAIR_ROTATION} rad between \
             two poses) to orient the instrument frame: {e}"
        ),
    })?;
    Ok(motion.rotation)
}

/// The chordal mean of `R_Tjᵀ R_Fᵀ R_Mj` over every pose (identity
/// without poses).
fn mean_body_rotation(
    tracker: &Tracker,
    rotations: &[Option<Rotation3<f64>>],
    measured: &[Pose],
    design: &[Pose],
) -> Rotation3<f64> {
    let (mut axes, mut images) = (Vec::new(), Vec::new());
    for j in 0..tracker.poses.len() {
        let Some(r_f) = rotations[tracker.poses.session[j] as usize] else {
            continue;
        };
        let r_b = design[j].rotation.to_rotation_matrix().inverse()
            * r_f.inverse()
            * measured[j].rotation.to_rotation_matrix();
        for axis in [Vec3::x(), Vec3::y(), Vec3::z()] {
            axes.extend([axis, -axis]);
            images.extend([r_b * axis, -(r_b * axis)]);
        }
    }
    kabsch(&axes, &images).map_or(Rotation3::identity(), |m| m.rotation)
}

/// The sessions' `t_F` (for those with poses) and the shared `t_B`, by
/// linear least squares (module doc).
#[allow(clippy::type_complexity)]
fn translations(
    tracker: &Tracker,
    rotations: &[Option<Rotation3<f64>>],
    measured: &[Pose],
    design: &[Pose],
) -> Result<(Vec<Option<Vec3>>, Vec3), CalibrateError> {
    let sessions = rotations.len();
    let n = tracker.poses.len();
    let mut a = DMatrix::zeros(3 * n, 3 + 3 * sessions);
    let mut b = DVector::zeros(3 * n);
    for j in 0..n {
        let session = tracker.poses.session[j] as usize;
        let r_f = rotations[session].expect("a session with poses has its rotation");
        let r_ft = r_f * design[j].rotation.to_rotation_matrix();
        a.view_mut((3 * j, 0), (3, 3)).copy_from(r_ft.matrix());
        a.view_mut((3 * j, 3 + 3 * session), (3, 3))
            .fill_with_identity();
        let rhs = measured[j].translation.vector - r_f * design[j].translation.vector;
        b.rows_mut(3 * j, 3).copy_from(&rhs);
    }
    // Sessions without poses have zero columns: solve on the others.
    let used: Vec<usize> = (0..3 + 3 * sessions)
        .filter(|&c| a.column(c).norm() > 0.0)
        .collect();
    let reduced = a.select_columns(&used);
    let solution =
        reduced
            .svd(true, true)
            .solve(&b, 1e-12)
            .map_err(|e| CalibrateError::FrameStart {
                session: tracker.sessions[0].clone(),
                reason: format!("the frames' translations cannot be solved for: {e}"),
            })?;
    let mut x = DVector::zeros(3 + 3 * sessions);
    for (k, &c) in used.iter().enumerate() {
        x[c] = solution[k];
    }
    let t_b = x.fixed_rows::<3>(0).into_owned();
    let t_f = (0..sessions)
        .map(|s| rotations[s].map(|_| x.fixed_rows::<3>(3 + 3 * s).into_owned()))
        .collect();
    Ok((t_f, t_b))
}
