//! The observations that locate a held-out tracker's frame (and the body
//! its poses see) ([`TrackerReference`]), and its rows with the unknowns
//! they locate taken out ([`super::projection`]).

use super::super::error::MechanismCalibrationError;
use super::super::observation::{HeldOut, ObservationKind, ObservationRef};
use super::projection::{LocalRows, predict_from_reference, project_out};
use super::rows::PredictedRows;

/// The observations that locate a held-out tracker's frame (and the body
/// its poses see): all of its points and poses, or with reference
/// observations `N` its first `N` points and first `N` poses, the others'
/// rows predicted from theirs.
pub(super) struct TrackerReference<'a> {
    /// The locating points' indices.
    pub(super) points: &'a [usize],
    /// The locating poses' indices.
    pub(super) poses: &'a [usize],
    /// Whether they are the reference observations' (else all).
    pub(super) reference: bool,
}

impl<'a> TrackerReference<'a> {
    /// Of a tracker (`what`) of `points` and `poses`, with `reference`
    /// observations if any; an error when they leave none to predict.
    pub(super) fn of(
        what: &str,
        points: &'a [usize],
        poses: &'a [usize],
        reference: Option<usize>,
    ) -> Result<Self, MechanismCalibrationError> {
        let Some(n) = reference else {
            return Ok(Self {
                points,
                poses,
                reference: false,
            });
        };
        let (p, q) = (n.min(points.len()), n.min(poses.len()));
        if p == points.len() && q == poses.len() {
            return Err(MechanismCalibrationError::InvalidData {
                what: what.to_string(),
                reason: format!(
                    "it has {} held-out points and {} poses: none is left to predict after the first {n} of each, which locate its frame",
                    points.len(),
                    poses.len()
                ),
            });
        }
        Ok(Self {
            points: &points[..p],
            poses: &poses[..q],
            reference: true,
        })
    }

    /// What the locating observations are called in an error: `held-out`
    /// or `reference`.
    pub(super) fn name(&self) -> &'static str {
        if self.reference {
            "reference"
        } else {
            "held-out"
        }
    }

    /// `local`'s rows (the tracker's `points`' 3 each, then its `poses`'
    /// `actuators` each) with the local unknowns projected out, or, with
    /// reference observations, predicted from the locating ones' rows;
    /// `None` when these do not locate the unknowns.
    pub(super) fn predict(
        &self,
        held_out: HeldOut,
        local: &LocalRows,
        (points, poses, actuators): (&[usize], &[usize], usize),
        g: usize,
    ) -> Option<PredictedRows> {
        if !self.reference {
            return project_out(held_out, local, g);
        }
        let pose_rows = 3 * points.len();
        let reference: Vec<usize> = (0..3 * self.points.len())
            .chain(pose_rows..pose_rows + actuators * self.poses.len())
            .collect();
        let of = |kind, indices: &[usize], rows| {
            let sources = indices.iter().flat_map(move |&index| {
                (0..rows).map(move |row| (ObservationRef { kind, index }, row))
            });
            sources.collect::<Vec<_>>()
        };
        let mut sources = of(ObservationKind::TrackerPoint, points, 3);
        sources.extend(of(ObservationKind::TrackerPose, poses, actuators));
        predict_from_reference(held_out, local, &reference, &sources, g)
    }
}
