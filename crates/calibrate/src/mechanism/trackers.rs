//! The trackers' frames in the global block: each tracker `k` sees the
//! mechanism's frame through `F_k = F₀_k ∘ C_k`
//! ([`TrackerFrame`]), `C_k = (Exp(ω), τ)` six unknowns of the global
//! block (after the mechanism's parameters and the trigger height,
//! [`super::prior::global_priors`]), without a prior; a re-homed
//! tracker's actuator offsets follow every frame, one per actuator; with
//! tracker poses, the body frame's correction `C_B` follows them
//! ([`BodyFrame`], `B = C_B ∘ B₀`, six unknowns without a prior), then
//! each tracker's body rotation `φ_k` and origin shift `ρ_k` where the body
//! was turned or moved before it measured (`C_B,k = (Exp(ω_B + φ_k), τ_B
//! + ρ_k)`, three unknowns each).
//!
//! `F₀_k` is fixed before the fit: the rigid motion that best maps the
//! tool points its points reach at the priors' means, and the platform
//! origins its poses reach there, onto the points it measured and the
//! origins its poses put the platform at through `B₀` (`M B₀⁻¹`; Kabsch),
//! as the hexapod's own calibration starts a session of points alone.
//! `C_k` and `C_B` start at zero; what is reported is `F_k` and `B`.

use nalgebra::{DVector, Isometry3, Matrix3, Vector6};
use parcal_accuracy::kabsch;
use parcal_kinematics::Vec3;
use parcal_kinematics::mechanism::{Mechanism, Reached};
use parcal_observe::FrameCorrection;
use parcal_observe::mechanism::{Actuation, BodyFrame, TrackerFrame, TrackerPoint, TrackerPose};

use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::observation::{ObservationKind, ObservationRef};
use super::prior::FRAME_UNKNOWNS;
use crate::instruments::model::isometry;

/// A tracker's points spread less than this fraction of their largest
/// spread across their line (the second singular value of their centred
/// coordinates over the first) do not locate its rotation about it.
const MIN_SPREAD: f64 = 1e-6;

/// The trackers' reference frames and where their corrections are in the
/// global block.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Trackers {
    /// `F₀_k` of each tracker.
    references: Vec<Isometry3<f64>>,
    /// The global column of the first tracker's first unknown.
    first: usize,
    /// The global column of each tracker's first actuator offset, if it
    /// has offsets.
    offsets: Vec<Option<usize>>,
    /// The number of a tracker's offsets: the mechanism's actuators.
    actuators: usize,
    /// `B₀` and the global column of the body frame's correction, when
    /// there are tracker poses.
    body: Option<(Isometry3<f64>, usize)>,
    /// The global columns of each tracker's body rotation and origin
    /// shift, where its body was turned or moved.
    shifts: Vec<BodyShift>,
}

/// Where a tracker's body shift is in the global block: the first column
/// of its rotation `φ` and of its origin shift `ρ`, where they are
/// unknowns.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct BodyShift {
    pub(crate) rotation: Option<usize>,
    pub(crate) origin: Option<usize>,
}

impl Trackers {
    /// The trackers of `data` (validated), their corrections from global
    /// column `first` on, then their offsets, their references located at
    /// the parameters `params` (module doc, [`locate_frame`]). An error
    /// names the tracker point whose tool point cannot be reached, or the
    /// tracker whose points do not locate its frame.
    pub(crate) fn locate(
        data: &MechanismData,
        params: &[f64],
        first: usize,
    ) -> Result<Self, MechanismCalibrationError> {
        let o = &data.observations;
        let machine = (data.mechanism.as_ref(), data.configured.as_slice());
        let references = (0..o.trackers.len())
            .map(|k| {
                let seen = Seen {
                    points: &o.tracker_points,
                    point_indices: &points_of(&o.tracker_points, k),
                    poses: &o.tracker_poses,
                    pose_indices: &poses_of(&o.tracker_poses, k),
                    body: &o.body_reference,
                };
                let what = format!("tracker {:?}", o.trackers[k].label);
                locate_frame(machine, params, &seen, &what).map(|(frame, _)| frame)
            })
            .collect::<Result<_, _>>()?;
        let actuators = data.mechanism.actuators().len();
        let mut next = first + FRAME_UNKNOWNS * o.trackers.len();
        let offsets = (o.trackers.iter())
            .map(|tracker| {
                tracker.rehomed.then(|| {
                    next += actuators;
                    next - actuators
                })
            })
            .collect();
        let body = (!o.tracker_poses.is_empty()).then(|| {
            next += FRAME_UNKNOWNS;
            (o.body_reference, next - FRAME_UNKNOWNS)
        });
        let mut three = |unknown: bool| {
            unknown.then(|| {
                next += 3;
                next - 3
            })
        };
        let shifts = (o.trackers.iter())
            .map(|tracker| BodyShift {
                rotation: three(tracker.body_turned),
                origin: three(tracker.body_moved),
            })
            .collect();
        Ok(Self {
            references,
            first,
            offsets,
            actuators,
            body,
            shifts,
        })
    }

    /// The global columns of the body frame's correction, when there are
    /// tracker poses.
    pub(crate) fn body_columns(&self) -> Option<std::ops::Range<usize>> {
        self.body.map(|(_, start)| start..start + FRAME_UNKNOWNS)
    }

    /// The body frame at the global block `global`, when there are tracker
    /// poses.
    pub(crate) fn body(&self, global: &DVector<f64>) -> Option<BodyFrame> {
        let (reference, start) = self.body?;
        let correction =
            Vector6::from_column_slice(&global.as_slice()[start..start + FRAME_UNKNOWNS]);
        Some(BodyFrame {
            reference,
            correction: FrameCorrection::from_params(&correction),
        })
    }

    /// The global columns of tracker `k`'s body rotation and origin shift.
    pub(crate) fn body_shift(&self, k: usize) -> BodyShift {
        self.shifts[k]
    }

    /// The body frame tracker `k`'s poses see at the global block
    /// `global`: the body frame, turned and moved by the tracker's shift
    /// (`C_B,k = (Exp(ω_B + φ), τ_B + ρ)`), when there are tracker poses.
    pub(crate) fn body_of(&self, k: usize, global: &DVector<f64>) -> Option<BodyFrame> {
        let mut body = self.body(global)?;
        let shift = self.shifts[k];
        let at = |start: usize| Vec3::from_column_slice(&global.as_slice()[start..start + 3]);
        if let Some(start) = shift.rotation {
            body.correction.rotation += at(start);
        }
        if let Some(start) = shift.origin {
            body.correction.translation += at(start);
        }
        Some(body)
    }

    /// The global columns of tracker `k`'s actuator offsets, if it has
    /// offsets.
    pub(crate) fn offset_columns(&self, k: usize) -> Option<std::ops::Range<usize>> {
        self.offsets[k].map(|start| start..start + self.actuators)
    }

    /// Tracker `k`'s actuator offsets at the global block `global`, if it
    /// has offsets.
    pub(crate) fn offsets<'a>(&self, k: usize, global: &'a DVector<f64>) -> Option<&'a [f64]> {
        self.offset_columns(k)
            .map(|columns| &global.as_slice()[columns])
    }

    /// The trackers' corrections in `values` (a global block at the
    /// mechanism's parameters `params`) made to follow the mechanism's
    /// frame to where the parameters `moved` put it (its canonical frame,
    /// [`super::frame`]): the same machine in another frame, its tool
    /// points moved by a rigid motion `A` (the best fit of those the
    /// trackers' points reach at `params` onto those at `moved`), each
    /// tracker then sees it through `F ∘ A⁻¹`: `C` becomes `C ∘ A⁻¹`.
    /// Nothing moves when `moved` is `params`.
    pub(crate) fn follow(
        &self,
        data: &MechanismData,
        params: &[f64],
        moved: &[f64],
        values: &mut DVector<f64>,
    ) -> Result<(), MechanismCalibrationError> {
        if self.references.is_empty() || params == moved {
            return Ok(());
        }
        if self.body.is_some() {
            return Err(MechanismCalibrationError::InvalidData {
                what: "the tracker poses".to_string(),
                reason: format!(
                    "the {} has gauge freedoms, and a body frame that follows its canonical frame is not modelled",
                    data.mechanism.name()
                ),
            });
        }
        let inverse = frame_motion(data, params, moved)?.inverse();
        for k in 0..self.references.len() {
            let followed = self.frame(k, values).correction.isometry() * inverse;
            let columns = self.columns(k);
            values
                .rows_mut(columns.start, 3)
                .copy_from(&followed.rotation.scaled_axis());
            values
                .rows_mut(columns.start + 3, 3)
                .copy_from(&followed.translation.vector);
        }
        Ok(())
    }

    /// The global columns of tracker `k`'s correction.
    pub(crate) fn columns(&self, k: usize) -> std::ops::Range<usize> {
        let start = self.first + FRAME_UNKNOWNS * k;
        start..start + FRAME_UNKNOWNS
    }

    /// Tracker `k`'s frame at the global block `global`.
    pub(crate) fn frame(&self, k: usize, global: &DVector<f64>) -> TrackerFrame {
        let correction = Vector6::from_column_slice(&global.as_slice()[self.columns(k)]);
        TrackerFrame {
            reference: self.references[k],
            correction: FrameCorrection::from_params(&correction),
        }
    }
}

/// The rigid motion `A` that carries the machine of `data` at the
/// parameters `params` to where the parameters `moved` put it (its
/// canonical frame): the best fit of the tool points its tracker points
/// reach at `params` onto those at `moved` (Kabsch); the identity when
/// `moved` is `params`. An error names a point not reached, or says that
/// the points do not locate the frame (fewer than three, or on a line).
pub(crate) fn frame_motion(
    data: &MechanismData,
    params: &[f64],
    moved: &[f64],
) -> Result<Isometry3<f64>, MechanismCalibrationError> {
    if params == moved {
        return Ok(Isometry3::identity());
    }
    let points = &data.observations.tracker_points;
    let all: Vec<usize> = (0..points.len()).collect();
    let machine = (data.mechanism.as_ref(), data.configured.as_slice());
    let tips = |params: &[f64]| -> Result<Vec<Vec3>, MechanismCalibrationError> {
        let reached = reach(machine, params, points, &all)?;
        Ok(reached.iter().map(|r| r.point).collect())
    };
    let motion = kabsch(&tips(params)?, &tips(moved)?).map_err(|e| {
        MechanismCalibrationError::InvalidData {
            what: "the trackers' points".to_string(),
            reason: format!("they do not locate the canonical frame: {e}"),
        }
    })?;
    Ok(isometry(motion.rotation, motion.translation))
}

/// The indices of tracker `tracker`'s points among `points`, increasing.
pub(crate) fn points_of(points: &[TrackerPoint], tracker: usize) -> Vec<usize> {
    (points.iter().enumerate())
        .filter(|(_, point)| point.tracker == tracker)
        .map(|(j, _)| j)
        .collect()
}

/// A mechanism and the parameters its controller runs with.
pub(crate) type Machine<'a> = (&'a dyn Mechanism, &'a [f64]);

/// Where the machine `(mechanism, configured)` of true parameters `params`
/// is at the tracker points `indices` of `points`
/// ([`Actuation::tool_points`]); an error names the point whose tool point
/// cannot be reached.
pub(crate) fn reach(
    (mechanism, configured): Machine<'_>,
    params: &[f64],
    points: &[TrackerPoint],
    indices: &[usize],
) -> Result<Vec<Reached>, MechanismCalibrationError> {
    let actuations: Vec<&Actuation> = indices.iter().map(|&j| &points[j].at).collect();
    Actuation::tool_points_from_scratch(mechanism, params, configured, &actuations)
        .into_iter()
        .zip(indices)
        .map(|(reached, &j)| {
            reached.map_err(|e| MechanismCalibrationError::Observation {
                observation: ObservationRef {
                    kind: ObservationKind::TrackerPoint,
                    index: j,
                },
                reason: format!("its tool point: {e}"),
            })
        })
        .collect()
}

/// What one tracker measured: its points `point_indices` of `points` and
/// its poses `pose_indices` of `poses`, the latter through the body frame's
/// reference `body`.
pub(crate) struct Seen<'a> {
    pub(crate) points: &'a [TrackerPoint],
    pub(crate) point_indices: &'a [usize],
    pub(crate) poses: &'a [TrackerPose],
    pub(crate) pose_indices: &'a [usize],
    pub(crate) body: &'a Isometry3<f64>,
}

/// The frame `F` (the mechanism's frame → a tracker's) that best maps the
/// tool points the tracker's points reach on `machine` at `params`, and
/// the platform origins its poses reach there, onto the points measured
/// and the origins of `M B₀⁻¹` (Kabsch), with where the machine is at each
/// point. An error names the point or pose whose place cannot be reached,
/// or says why they do not locate `what`'s frame (fewer than three, or on
/// a line).
pub(crate) fn locate_frame(
    machine: Machine<'_>,
    params: &[f64],
    seen: &Seen<'_>,
    what: &str,
) -> Result<(Isometry3<f64>, Vec<Reached>), MechanismCalibrationError> {
    let body_inverse = seen.body.inverse();
    let measured: Vec<Vec3> = (seen.point_indices.iter())
        .map(|&j| seen.points[j].measured.into())
        .chain(
            (seen.pose_indices.iter())
                .map(|&j| (seen.poses[j].measured * body_inverse).translation.vector),
        )
        .collect();
    let not_located = |reason: String| MechanismCalibrationError::InvalidData {
        what: what.to_string(),
        reason: format!("its points do not locate its frame: {reason}"),
    };
    if measured.len() >= 3 && spread(&measured) < MIN_SPREAD {
        return Err(not_located("they lie on a line".to_string()));
    }
    let reached = reach(machine, params, seen.points, seen.point_indices)?;
    let origins = platform_origins(machine.0, params, seen.poses, seen.pose_indices)?;
    let model: Vec<Vec3> = reached.iter().map(|r| r.point).chain(origins).collect();
    let motion = kabsch(&model, &measured).map_err(|e| not_located(e.to_string()))?;
    Ok((isometry(motion.rotation, motion.translation), reached))
}

/// The indices of tracker `tracker`'s poses among `poses`, increasing.
pub(crate) fn poses_of(poses: &[TrackerPose], tracker: usize) -> Vec<usize> {
    (poses.iter().enumerate())
        .filter(|(_, pose)| pose.tracker == tracker)
        .map(|(j, _)| j)
        .collect()
}

/// The origin of the platform frame at each of the tracker poses `indices`
/// of `poses`, by the forward kinematics of its readings at `params`; an
/// error names the pose whose platform cannot be reached.
fn platform_origins(
    mechanism: &dyn Mechanism,
    params: &[f64],
    poses: &[TrackerPose],
    indices: &[usize],
) -> Result<Vec<Vec3>, MechanismCalibrationError> {
    (indices.iter())
        .map(|&j| {
            let readings = &poses[j].readings;
            mechanism
                .start_pose(params, readings)
                .and_then(|start| mechanism.forward(params, readings, start.as_slice()))
                .and_then(|x| mechanism.platform_frame(x.as_slice()))
                .map(|frame| frame.translation.vector)
                .map_err(|e| MechanismCalibrationError::Observation {
                    observation: ObservationRef {
                        kind: ObservationKind::TrackerPose,
                        index: j,
                    },
                    reason: format!("its platform: {e}"),
                })
        })
        .collect()
}

/// The second singular value of the centred `points` over the first (0
/// for fewer than two distinct points).
fn spread(points: &[Vec3]) -> f64 {
    let centroid = points.iter().sum::<Vec3>() / points.len() as f64;
    let scatter: Matrix3<f64> = points
        .iter()
        .map(|p| (p - centroid) * (p - centroid).transpose())
        .sum();
    let mut values = scatter.symmetric_eigenvalues();
    values.as_mut_slice().sort_by(|a, b| b.total_cmp(a));
    if values[0] > 0.0 {
        (values[1].max(0.0) / values[0]).sqrt()
    } else {
        0.0
    }
}
