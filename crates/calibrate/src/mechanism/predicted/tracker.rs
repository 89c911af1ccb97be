//! The rows of a held-out tracker ([`predict_tracker`]): its frame is its
//! own unknown (placed anew), fitted to its `K` points, which give `3K − 6`
//! rows together (less its actuators' offsets when re-homed, its unknowns
//! too), one observation named by the tracker ([`HeldOut::Tracker`]):
//! `c = F̂(x_k) − P_k` ([`TrackerPoint`]), noise its covariance `W_k`. With
//! poses, the body frame they see is its unknown too
//! ([`super::posed_tracker`]).

use nalgebra::{DMatrix, DVector, Isometry3};
use parcal_kinematics::mechanism::{Mechanism, tool_point_reading_jacobian};
use parcal_observe::mechanism::TrackerPoint;
use parcal_observe::{FrameCorrection, PointBlock};

use super::super::data::Observations;
use super::super::error::MechanismCalibrationError;
use super::super::observation::{HeldOut, ObservationKind, ObservationRef};
use super::super::trackers::{Seen, locate_frame, points_of, poses_of, reach};
use super::posed_tracker::predict_posed_tracker;
use super::projection::LocalRows;
use super::rows::PredictedRows;
use super::tracker_reference::TrackerReference;

/// The rows of tracker `tracker`'s points (module doc): its frame `F`
/// located by them alone (the best rigid motion of the tool points they
/// reach onto the points measured, Kabsch), each point's `c = F(T) − P`,
/// `dc/dp = R_F dT/dp|_q`, `dc/dC = [R_F d(Exp(ω) T)/dω | R_F]` on the
/// frame's correction `C` at zero, noise its covariance `W = L Lᵀ`, and
/// the frame's six unknowns projected out; for a re-homed tracker its
/// actuators' offsets too, `dc/do = R_F dT/dq`. With `reference`
/// observations `N`, `F` is located by its first `N` points and the other
/// points' rows are predicted from theirs ([`predict_from_reference`](super::projection::predict_from_reference)).
pub(super) fn predict_tracker(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    observations: &Observations,
    (tracker, reference): (usize, Option<usize>),
    g: usize,
) -> Result<PredictedRows, MechanismCalibrationError> {
    let all = &observations.tracker_points;
    let indices = points_of(all, tracker);
    let poses = poses_of(&observations.tracker_poses, tracker);
    let held_out = HeldOut::Tracker {
        tracker,
        points: indices.clone(),
        poses: poses.clone(),
    };
    let what = held_out.to_string();
    let locating = TrackerReference::of(&what, &indices, &poses, reference)?;
    if !poses.is_empty() {
        let seen = (tracker, &indices[..], &poses[..]);
        return predict_posed_tracker(
            mechanism,
            params,
            configured,
            observations,
            (seen, &locating),
            g,
        );
    }
    let seen = Seen {
        points: all,
        point_indices: locating.points,
        poses: &[],
        pose_indices: &[],
        body: &Isometry3::identity(),
    };
    let machine = (mechanism, configured);
    let (frame, mut reached) = locate_frame(machine, params, &seen, &what)?;
    // The locating points are the first: the others reached after them.
    let others = &indices[locating.points.len()..];
    reached.extend(reach(machine, params, all, others)?);
    let points: Vec<&TrackerPoint> = indices.iter().map(|&j| &all[j]).collect();
    // A re-homed tracker's offsets are its own unknowns too.
    let rehomed = observations.trackers[tracker].rehomed;
    let u = 6 + if rehomed {
        mechanism.actuators().len()
    } else {
        0
    };
    let (n, m) = (params.len(), 3 * points.len());
    let (mut residuals, mut d_local) = (DVector::zeros(m), DMatrix::zeros(m, u));
    let (mut d_params, mut noise) = (DMatrix::zeros(m, n), DMatrix::zeros(m, m));
    for (k, (point, reached)) in points.iter().zip(&reached).enumerate() {
        let measured = point.measured.into();
        let block = PointBlock {
            measured: &measured,
            tracker_reference: &frame,
            tracker: FrameCorrection::IDENTITY,
        }
        .evaluate(&reached.point);
        let rows = 3 * k;
        residuals.rows_mut(rows, 3).copy_from(&block.residual);
        d_local
            .view_mut((rows, 0), (3, 6))
            .copy_from(&block.d_tracker);
        if rehomed {
            let d_tip = mechanism
                .pose_of_warm_start(reached.warm_start.as_slice())
                .and_then(|pose| tool_point_reading_jacobian(mechanism, params, pose.as_slice()))
                .map_err(|e| MechanismCalibrationError::Observation {
                    observation: ObservationRef {
                        kind: ObservationKind::TrackerPoint,
                        index: indices[k],
                    },
                    reason: e.to_string(),
                })?;
            d_local
                .view_mut((rows, 6), (3, u - 6))
                .copy_from(&(block.d_tip * d_tip));
        }
        d_params
            .view_mut((rows, 0), (3, n))
            .copy_from(&(block.d_tip * reached.d_params.to_dense()));
        noise
            .view_mut((rows, rows), (3, 3))
            .copy_from(&point.weight.covariance());
    }
    let local = LocalRows {
        residuals,
        d_local: &d_local,
        d_params: &d_params,
        noise,
    };
    let located = if rehomed {
        "its frame and offsets"
    } else {
        "its frame"
    };
    locating
        .predict(held_out, &local, (&indices, &[], 0), g)
        .ok_or_else(|| MechanismCalibrationError::InvalidData {
            what,
            reason: format!("the {} points do not locate {located}", locating.name()),
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::predicted::predict::predict;
    use crate::mechanism::predicted::simulated::{
        assert_derivatives_match_differences, assert_rows_have_their_stated_noise, ball_rows,
        delta, far_frame, placement, tracked,
    };
    use parcal_simulate::Rng;

    /// A held-out tracker's exact points: `3k − 6` rows, zero at the
    /// truth, `G = N_⊥ᵀ G_p` against central differences over the
    /// parameters.
    #[test]
    fn tracker_derivatives_match_central_differences() {
        let machine = delta();
        let frame = far_frame();
        let observations = tracked(&machine, &frame, 7, || 0.0);
        let at = ball_rows(&machine, &machine.2, &observations, None);
        assert_eq!(at.residuals.len(), 3 * 7 - 6);
        assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
        assert_eq!(
            at.observation,
            HeldOut::Tracker {
                tracker: 0,
                points: (0..7).collect(),
                poses: Vec::new(),
            }
        );
        assert_derivatives_match_differences(&machine, &observations, None, &at);
        // Re-homed, a delta's offsets are its own unknowns too: their
        // common part lifts the effector as the frame's z translation
        // does, so that its points cannot locate both, and it is refused.
        let mut rehomed = observations;
        rehomed.trackers[0] = crate::mechanism::data::Tracker::rehomed("T", Some(0.1));
        let (delta, configured, truth) = &machine;
        let error = predict(delta, truth, configured.as_slice(), &rehomed, None).unwrap_err();
        assert!(
            error
                .to_string()
                .starts_with("tracker 0 (tracker points 0-6): the held-out points do not locate its frame and offsets"),
            "{error}"
        );
    }

    /// A held-out tracker's rows of noisy points: `T = r'ᵀ D⁻¹ r'` over
    /// 200 placements of 8 points (3600 rows), the noise correlated as
    /// each point's weight states, has the mean of its `χ²` within 4
    /// standard errors.
    #[test]
    fn a_tracker_s_rows_have_their_stated_noise() {
        let machine = delta();
        let mut noise = Rng::new(37, 0);
        let sets = (0..200).map(|draw| {
            let frame = placement(draw);
            tracked(&machine, &frame, 8, || noise.normal(1.0))
        });
        assert_rows_have_their_stated_noise("a tracker's rows", &machine, None, sets);
    }

    /// A tracker's frame located by its first 4 points: its other points'
    /// rows, each named by its point and coordinate, zero at the truth
    /// when exact, `G` against central differences; of noisy points, `T =
    /// r'ᵀ D⁻¹ r'` over 200 placements of 8 points (2400 rows) has the
    /// mean of its `χ²` within 4 standard errors.
    #[test]
    fn a_tracker_located_by_reference_points_predicts_the_others() {
        let machine = delta();
        let frame = far_frame();
        let observations = tracked(&machine, &frame, 7, || 0.0);
        let at = ball_rows(&machine, &machine.2, &observations, Some(4));
        assert_eq!(at.residuals.len(), 3 * 3);
        assert!(at.residuals.amax() < 1e-9, "{}", at.residuals);
        let point = |index| ObservationRef {
            kind: ObservationKind::TrackerPoint,
            index,
        };
        assert_eq!(at.row_observations[0], (point(4), 0));
        assert_eq!(at.row_observations[8], (point(6), 2));
        assert_derivatives_match_differences(&machine, &observations, Some(4), &at);
        let mut noise = Rng::new(43, 0);
        let sets = (0..200).map(|draw| {
            let frame = placement(draw);
            tracked(&machine, &frame, 8, || noise.normal(1.0))
        });
        assert_rows_have_their_stated_noise("a tracker's rows from 4", &machine, Some(4), sets);
    }
}
