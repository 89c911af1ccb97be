//! Simulation of an instrument campaign: in each session, platform poses
//! drawn in the workspace, the actuator readings that reach them, and what
//! a laser tracker or a motion-capture system sees of the platform.
//!
//! Session `k` draws from stream `(seed, k)`: first its instrument frame
//! `F_k`, then (for `k >= 1`, when [`SessionModel`] asks) its body origin
//! shift and its leg offsets, then its pose rows, then its point rows. Each
//! row draws a pose until one is acceptable (with a plan: takes the true
//! machine's pose at the planned readings, forward kinematics), then its
//! noise: position (3), orientation (3, poses only), actuators (6).
//!
//! A row at pose `T` of session `k` holds
//!
//! - `q_i = (|R E_i + t - B_i| - l_i - o_{k,i}) / s_i + N(0, s_q^2)` (true
//!   geometry and scales, `s_q` in the actuators' unit);
//! - poses.csv: `M = F_k T B_k`, its translation plus `N(0, s_p^2 I)` and
//!   its rotation `Exp(delta) R_M` with `delta ~ N(0, s_o^2 I)`;
//! - points.csv: `F_k (T E_T) + N(0, s_p^2 I)`.

mod scenario;

use nalgebra::{Matrix6, Translation3, UnitQuaternion};
use parcal_dataset::{
    Actuator, Artefacts, Dataset, FrameRecord, Machine, Measurements, Repeatability, SessionModel,
    SessionRecord, Tracker, Truth,
};
use parcal_kinematics::closure::Legs;
use parcal_kinematics::{ForwardOptions, Geometry, Pose, Vec3, forward_from_home, rotation_zyx};
use rayon::prelude::*;

use crate::campaign::record;
use crate::{Rng, SimulateError, Simulation, Summary};

pub use scenario::{FrameSpread, TrackerKind, TrackerScenario, Workspace};

/// Poses drawn for one row before giving up.
const MAX_DRAWS: usize = 10_000;

/// A pose is kept when its [`singularity_distance`] is at least this
/// fraction of the one at the workspace's centre.
const MIN_SINGULARITY_DISTANCE: f64 = 0.5;

/// Forward kinematics from the home pose must return a kept pose within
/// this (mm, and rad times the platform radius): the readings determine it.
const RECOVERY_TOLERANCE: f64 = 1e-6;

/// One simulated session: its true nuisance and its rows.
struct Session {
    record: SessionRecord,
    poses: Vec<Row>,
    points: Vec<Row>,
}

/// One row of poses.csv or points.csv.
struct Row {
    /// Readings with noise (actuators' unit).
    q: [f64; 6],
    /// Measured position (mm): body origin or tool tip, instrument frame.
    position: [f64; 3],
    /// Measured orientation `[x, y, z, w]` (poses only).
    orientation: [f64; 4],
    /// Leg lengths `L_i` of the true machine (mm).
    legs: [f64; 6],
    /// Angle between the platform's z axis and the base's (rad).
    tilt: f64,
}

/// The true nuisance of one session.
struct Nuisance {
    /// `F_k`: base frame to instrument frame.
    tracker: Pose,
    /// `B_k`: body frame to platform frame.
    body: Pose,
    /// `o_k` (mm).
    leg_offsets: [f64; 6],
}

/// Simulates the instrument campaign `scenario` with random stream `seed`
/// (module doc): the dataset has machine.json (design geometry and scales,
/// priors, repeatability, session model), poses.csv and/or points.csv,
/// and truth.json (true geometry, scales and each session's nuisance); it
/// has no ball touch.
pub fn simulate_tracker(
    scenario: &TrackerScenario,
    seed: u64,
) -> Result<Simulation, SimulateError> {
    check(scenario)?;
    let reference = singularity_distance(&scenario.truth, &scenario.workspace.centre());
    let sessions: Vec<Result<Session, SimulateError>> = (0..scenario.sessions)
        .into_par_iter()
        .map(|k| simulate_session(scenario, seed, k, reference))
        .collect();
    // The first failing session in order, whatever the threads' timing.
    let sessions: Vec<Session> = sessions.into_iter().collect::<Result<_, _>>()?;

    let rows = || {
        sessions
            .iter()
            .flat_map(|s| s.poses.iter().chain(&s.points))
    };
    let range = |values: &mut dyn Iterator<Item = f64>| {
        values.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        })
    };
    let summary = Summary {
        balls: 0,
        contacts: 0,
        sessions: sessions.len(),
        poses: sessions.iter().map(|s| s.poses.len()).sum(),
        points: sessions.iter().map(|s| s.points.len()).sum(),
        leg_length_range: range(&mut rows().flat_map(|r| r.legs)),
        tilt_range: range(&mut rows().map(|r| r.tilt)),
        worst_check: 0.0,
    };

    let mut tracker = Tracker {
        sessions: sessions.iter().map(|s| s.record.label.clone()).collect(),
        ..Tracker::default()
    };
    for (k, session) in sessions.iter().enumerate() {
        let k = k as u32;
        for row in &session.poses {
            let poses = &mut tracker.poses;
            poses.session.push(k);
            poses.q.push(row.q);
            poses.position.push(row.position);
            poses.orientation.push(row.orientation);
        }
        for row in &session.points {
            let points = &mut tracker.points;
            points.session.push(k);
            points.q.push(row.q);
            points.position.push(row.position);
        }
    }
    let dataset = Dataset {
        machine: machine(scenario),
        artefacts: Artefacts::default(),
        measurements: Measurements::default(),
        tracker,
        truth: Some(Truth {
            geometry: record(&scenario.truth),
            ball_centres: Vec::new(),
            ball_radii: Vec::new(),
            contacts: Vec::new(),
            actuator_scale: Some(scenario.true_scale),
            sessions: sessions.into_iter().map(|s| s.record).collect(),
        }),
    };
    Ok(Simulation { dataset, summary })
}

/// `tracker` as recorded after its marker body was re-mounted `offset`
/// (mm, body frame) away: every measured pose `M` becomes `M Trans(offset)`,
/// its position `p + R_M offset`; the points are kept.
pub fn re_mounted(tracker: &Tracker, offset: Vec3) -> Tracker {
    let mut out = tracker.clone();
    let poses = &mut out.poses;
    for (position, &[x, y, z, w]) in poses.position.iter_mut().zip(&poses.orientation) {
        let rotation = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        *position = (Vec3::from(*position) + rotation * offset).into();
    }
    out
}

/// The counts, ranges and sigmas of a scenario make sense.
fn check(s: &TrackerScenario) -> Result<(), SimulateError> {
    let bad = |message: String| Err(SimulateError::Scenario(message));
    if s.sessions == 0 || s.rows_per_session == 0 {
        return bad(format!(
            "{} sessions of {} rows: at least one of each is needed",
            s.sessions, s.rows_per_session
        ));
    }
    parcal_dataset::bounds::SESSIONS
        .check("sessions", s.sessions)
        .map_err(SimulateError::TooLarge)?;
    crate::check_rows(&[
        ("sessions", s.sessions),
        ("rows per session", s.rows_per_session),
        ("files (poses and points)", s.kind.files()),
    ])?;
    let sigmas = [
        ("actuator", s.actuator_sigma),
        ("position", s.position_sigma),
        ("orientation", s.orientation_sigma),
        (
            "leg offset",
            s.session_model.leg_offset_sigma.unwrap_or(0.0),
        ),
        (
            "body origin",
            s.session_model.body_origin_sigma.unwrap_or(0.0),
        ),
    ];
    if let Some((name, sigma)) = sigmas.iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
        return bad(format!(
            "the {name} sigma must be finite and not negative, got {sigma}"
        ));
    }
    if let Some(i) = (0..6).find(|&i| !(s.true_scale[i].is_finite() && s.true_scale[i] > 0.0)) {
        return bad(format!(
            "the true scale of actuator {} must be positive, got {}",
            i + 1,
            s.true_scale[i]
        ));
    }
    if let Some(plan) = &s.plan {
        if plan.len() != 1 && plan.len() != s.sessions {
            return bad(format!(
                "a plan of {} sessions for {} sessions",
                plan.len(),
                s.sessions
            ));
        }
        for (session, plan) in plan.iter().enumerate() {
            if plan.len() != s.rows_per_session {
                return bad(format!(
                    "{} planned poses in session {} but {} rows per session",
                    plan.len(),
                    session + 1,
                    s.rows_per_session
                ));
            }
            if let Some(k) = plan.iter().position(|q| q.iter().any(|v| !v.is_finite())) {
                return bad(format!(
                    "planned pose {} of session {} has a reading that is not finite",
                    k + 1,
                    session + 1
                ));
            }
        }
    }
    let ordered = |[a, b]: [f64; 2]| a.is_finite() && b.is_finite() && a <= b;
    let w = &s.workspace;
    let ranges = ordered(w.height)
        && ordered(s.stroke)
        && ordered([0.0, w.half_width])
        && (0.0..std::f64::consts::FRAC_PI_2).contains(&s.max_tilt);
    if !ranges {
        return bad(format!(
            "workspace (half width {}, height {:?}), stroke {:?} or tilt {} rad out of range",
            w.half_width, w.height, s.stroke, s.max_tilt
        ));
    }
    Ok(())
}

/// machine.json of a scenario. Without ball touches the tool repeatability
/// is unused; machine.json requires one, and the instrument's is written.
fn machine(s: &TrackerScenario) -> Machine {
    Machine {
        geometry: record(&s.design),
        prior_sigma: s.prior_sigma,
        repeatability: Repeatability {
            actuator: s.actuator_sigma,
            tool: s.position_sigma,
            position: Some(s.position_sigma),
            orientation: s.kind.poses().then_some(s.orientation_sigma),
        },
        actuator: Actuator {
            unit: s.unit.clone(),
            scale: s.design_scale,
            scale_sigma: s.scale_sigma,
        },
        session_model: s.session_model,
        stroke: None,
        joint_limits: None,
    }
}

/// Session `k` (0-based) from stream `(seed, k)`.
fn simulate_session(
    scenario: &TrackerScenario,
    seed: u64,
    k: usize,
    reference: f64,
) -> Result<Session, SimulateError> {
    let mut rng = Rng::new(seed, k as u64);
    let nuisance = draw_nuisance(scenario, &mut rng, k);
    let (pose_rows, point_rows) = scenario.rows();
    let mut rows = |count: usize, pose: bool| {
        (0..count)
            .map(|row| {
                simulate_row(scenario, &mut rng, &nuisance, reference, pose, (k, row)).map_err(
                    |reason| SimulateError::Row {
                        session: k + 1,
                        file: if pose { "poses" } else { "points" },
                        row: row + 1,
                        reason,
                    },
                )
            })
            .collect::<Result<Vec<_>, _>>()
    };
    let poses = rows(pose_rows, true)?;
    let points = rows(point_rows, false)?;
    let body_frame = if scenario.kind.poses() {
        frame_record(&nuisance.body)
    } else {
        FrameRecord::IDENTITY
    };
    Ok(Session {
        record: SessionRecord {
            label: (k + 1).to_string(),
            tracker_frame: frame_record(&nuisance.tracker),
            body_frame,
            leg_offsets: nuisance.leg_offsets,
        },
        poses,
        points,
    })
}

/// The instrument frame ([`FrameSpread`]), then for `k >= 1` the body origin
/// shift and the leg offsets that [`SessionModel`] asks for.
fn draw_nuisance(scenario: &TrackerScenario, rng: &mut Rng, k: usize) -> Nuisance {
    let spread = &scenario.tracker_frame;
    let axis = Vec3::from_fn(|_, _| rng.normal(1.0));
    let angle = rng.uniform(0.0, spread.max_angle);
    let rotation = match nalgebra::Unit::try_new(axis, 1e-12) {
        Some(axis) => UnitQuaternion::from_axis_angle(&axis, angle),
        None => UnitQuaternion::identity(),
    };
    let shift = Vec3::from_fn(|_, _| rng.uniform(-spread.spread, spread.spread));
    let tracker = Pose::from_parts(Translation3::from(spread.offset + shift), rotation);

    let SessionModel {
        leg_offset_sigma,
        body_origin_sigma,
        body_rotation_sigma,
    } = scenario.session_model;
    let mut body = scenario.body_frame;
    let mut leg_offsets = [0.0; 6];
    if k > 0 {
        if let Some(sigma) = body_origin_sigma {
            body.translation.vector += Vec3::from_fn(|_, _| rng.normal(sigma));
        }
        if let Some(sigma) = leg_offset_sigma {
            leg_offsets = std::array::from_fn(|_| rng.normal(sigma));
        }
        if let Some(sigma) = body_rotation_sigma {
            // The body turned about the platform frame's origin:
            // B_k = Exp(φ) ∘ B, φ ~ N(0, σ² I).
            let turn = Vec3::from_fn(|_, _| rng.normal(sigma));
            body = Pose::from_parts(
                Translation3::identity(),
                UnitQuaternion::from_scaled_axis(turn),
            ) * body;
        }
    }
    Nuisance {
        tracker,
        body,
        leg_offsets,
    }
}

/// One row `(session, row)`: an acceptable pose (the session's `row`-th
/// planned one with a plan), then the measurement and the readings with
/// their noise.
fn simulate_row(
    scenario: &TrackerScenario,
    rng: &mut Rng,
    nuisance: &Nuisance,
    reference: f64,
    pose_row: bool,
    (session, row): (usize, usize),
) -> Result<Row, String> {
    let (pose, legs) = match &scenario.plan {
        Some(plan) => {
            let q = &plan[session.min(plan.len() - 1)][row];
            planned_pose(scenario, q, &nuisance.leg_offsets)?
        }
        None => draw_pose(scenario, rng, &nuisance.leg_offsets, reference)?,
    };
    let sigma = scenario.position_sigma;
    let position_noise = Vec3::from_fn(|_, _| rng.normal(sigma));
    let (position, orientation) = if pose_row {
        let measured = nuisance.tracker * pose * nuisance.body;
        let delta = Vec3::from_fn(|_, _| rng.normal(scenario.orientation_sigma));
        let rotation = UnitQuaternion::from_scaled_axis(delta) * measured.rotation;
        (
            measured.translation.vector + position_noise,
            quaternion(&rotation),
        )
    } else {
        let tip = nuisance.tracker * pose * nalgebra::Point3::from(scenario.truth.tool);
        (tip.coords + position_noise, [0.0, 0.0, 0.0, 1.0])
    };
    let q = std::array::from_fn(|i| {
        let extension = legs[i] - scenario.truth.legs[i] - nuisance.leg_offsets[i];
        extension / scenario.true_scale[i] + rng.normal(scenario.actuator_sigma)
    });
    let z_axis = pose.rotation * Vec3::z();
    Ok(Row {
        q,
        position: position.into(),
        orientation,
        legs,
        tilt: z_axis.z.clamp(-1.0, 1.0).acos(),
    })
}

/// A platform pose drawn uniformly in the workspace and the tilt box, kept
/// when every leg's extension `L_i - l_i - o_i` is within the stroke, its
/// [`singularity_distance`] is at least [`MIN_SINGULARITY_DISTANCE`] times
/// `reference`, and
/// forward kinematics from the home pose finds it back from the lengths;
/// with its leg lengths `L_i`.
fn draw_pose(
    scenario: &TrackerScenario,
    rng: &mut Rng,
    offsets: &[f64; 6],
    reference: f64,
) -> Result<(Pose, [f64; 6]), String> {
    let truth = &scenario.truth;
    let (w, tilt) = (&scenario.workspace, scenario.max_tilt);
    let [low, high] = scenario.stroke;
    for _ in 0..MAX_DRAWS {
        let t = Vec3::new(
            rng.uniform(-w.half_width, w.half_width),
            rng.uniform(-w.half_width, w.half_width),
            rng.uniform(w.height[0], w.height[1]),
        );
        let [yaw, pitch, roll] = [(); 3].map(|()| rng.uniform(-tilt, tilt));
        let pose = Pose::from_parts(Translation3::from(t), rotation_zyx(yaw, pitch, roll));
        let legs = Legs::at(truth, &pose);
        let extension: [f64; 6] =
            std::array::from_fn(|i| legs.length[i] - truth.legs[i] - offsets[i]);
        if extension.iter().any(|e| !(low..=high).contains(e))
            || singularity_distance_of(&legs, platform_radius(truth))
                < MIN_SINGULARITY_DISTANCE * reference
            || !recovered(truth, offsets, &extension, &pose)
        {
            continue;
        }
        return Ok((pose, legs.length));
    }
    Err(format!(
        "no pose in {MAX_DRAWS} draws has every leg within the stroke {low}..{high} mm and \
         stays away from singular configurations"
    ))
}

/// The true machine's pose at the planned readings `q`: forward
/// kinematics from the home pose with the leg lengths `l_i + o_i + s_i
/// q_i` (true `l`, `s`), with those lengths.
fn planned_pose(
    scenario: &TrackerScenario,
    q: &[f64; 6],
    offsets: &[f64; 6],
) -> Result<(Pose, [f64; 6]), String> {
    let truth = &scenario.truth;
    let shifted = Geometry {
        legs: std::array::from_fn(|i| truth.legs[i] + offsets[i]),
        ..truth.clone()
    };
    let extension: [f64; 6] = std::array::from_fn(|i| scenario.true_scale[i] * q[i]);
    let solution = forward_from_home(&shifted, &extension, &ForwardOptions::default())
        .map_err(|e| format!("the true machine does not reach the planned readings {q:?}: {e}"))?;
    Ok((
        solution.pose,
        std::array::from_fn(|i| shifted.legs[i] + extension[i]),
    ))
}

/// Whether forward kinematics from the home pose, with the leg lengths
/// `l_i + o_i + extension_i`, returns `pose`.
fn recovered(truth: &Geometry, offsets: &[f64; 6], extension: &[f64; 6], pose: &Pose) -> bool {
    let shifted = Geometry {
        legs: std::array::from_fn(|i| truth.legs[i] + offsets[i]),
        ..truth.clone()
    };
    forward_from_home(&shifted, extension, &ForwardOptions::default()).is_ok_and(|solution| {
        let error = solution.pose.inverse() * pose;
        error.translation.vector.norm() < RECOVERY_TOLERANCE
            && error.rotation.angle() * platform_radius(truth) < RECOVERY_TOLERANCE
    })
}

/// The smallest singular value of the closure Jacobian `A` (rows `[n_i^T,
/// (a_i x n_i)^T / rho]`, [`parcal_kinematics::closure`], with `rho` the
/// platform joints' RMS radius) of `geometry` at `pose`: the 2-norm distance
/// from `A` to the nearest singular matrix (Eckart-Young), dimensionless.
fn singularity_distance(geometry: &Geometry, pose: &Pose) -> f64 {
    singularity_distance_of(&Legs::at(geometry, pose), platform_radius(geometry))
}

/// [`singularity_distance`] of evaluated legs.
fn singularity_distance_of(legs: &Legs, radius: f64) -> f64 {
    let rows = legs.closure_rows();
    let jacobian = Matrix6::from_fn(|i, j| {
        if j < 3 {
            rows[i][j]
        } else {
            rows[i][j] / radius
        }
    });
    jacobian.singular_values().min()
}

/// RMS distance of the platform joints from their centroid (mm).
fn platform_radius(geometry: &Geometry) -> f64 {
    let centroid = geometry.platform.iter().sum::<Vec3>() / 6.0;
    let sum: f64 = geometry
        .platform
        .iter()
        .map(|e| (e - centroid).norm_squared())
        .sum();
    (sum / 6.0).sqrt()
}

/// A rotation as `[x, y, z, w]`, with `w >= 0`.
fn quaternion(rotation: &UnitQuaternion<f64>) -> [f64; 4] {
    let c = rotation.coords;
    let sign = if c.w < 0.0 { -1.0 } else { 1.0 };
    [sign * c.x, sign * c.y, sign * c.z, sign * c.w]
}

/// A rigid transformation as the dataset files hold it.
pub(crate) fn frame_record(frame: &Pose) -> FrameRecord {
    FrameRecord {
        translation: frame.translation.vector.into(),
        rotation: quaternion(&frame.rotation),
    }
}
