//! A touched ball as its touches' rows see it: where its unknowns are
//! (its group's columns, or the global block's when a ball distance ties
//! it), and its centre from its touches' tool points at the start.

use std::ops::Range;

use nalgebra::{Const, DVector, Dyn, OMatrix, SMatrix, SVector, Vector3};
use parcal_kinematics::batch_workspace::BatchWorkspace;
use parcal_kinematics::mechanism::{Mechanism, MechanismError, ReachedAlong};
use parcal_observe::mechanism::{Actuation, BallTouch};
use parcal_solver::Linearization;

use crate::sphere_fit::{SphereFit, SphereFitError, best_fit};

use super::error::{MechanismCalibrationError, failed};
use super::observation::{ObservationKind, ObservationRef, touch_ref};
use super::warm_start::WarmStart;

/// Where [`ball_centre`] puts what a ball's touches reached, in the order
/// of its touches.
pub(crate) struct BallFit<'a> {
    /// The warm start of the pose each touch reached.
    pub warm_starts: &'a mut [WarmStart],
    /// The tool point each touch reached.
    pub tips: &'a mut [Vector3<f64>],
}

/// Each ball's [`BallFit`] in `warm_starts` and `tips` (the touches'
/// places, in the order of their points), the balls' points `ball_points`
/// one after the other.
pub(super) fn ball_rooms<'a>(
    ball_points: &[Range<usize>],
    mut warm_starts: &'a mut [WarmStart],
    mut tips: &'a mut [Vector3<f64>],
) -> Vec<BallFit<'a>> {
    let mut rooms = Vec::with_capacity(ball_points.len());
    for points in ball_points {
        let (ball_warm_starts, rest_warm_starts) = warm_starts.split_at_mut(points.len());
        let (ball_tips, rest_tips) = tips.split_at_mut(points.len());
        rooms.push(BallFit {
            warm_starts: ball_warm_starts,
            tips: ball_tips,
        });
        (warm_starts, tips) = (rest_warm_starts, rest_tips);
    }
    rooms
}

/// A touched ball's unknowns' values and where they are
/// ([`MechanismProblem::touched_ball`](super::problem::MechanismProblem::touched_ball)).
pub(crate) struct TouchedBall {
    /// Its centre.
    pub centre: Vector3<f64>,
    /// Its radius.
    pub radius: f64,
    /// Its first column in the global block when it is tied.
    pub tied: Option<usize>,
    /// Whether its radius is an unknown.
    pub uncertain: bool,
}

impl TouchedBall {
    /// The product of a touch's rows' derivatives with respect to the
    /// ball's centre `d_centre` and radius `d_radius` with the global step
    /// `dg`: their share of `d_global · dg` when the ball is tied (its
    /// radius's only when it is an unknown), else none.
    pub(crate) fn tied_step<const R: usize>(
        &self,
        d_centre: &SMatrix<f64, R, 3>,
        d_radius: &SVector<f64, R>,
        dg: &DVector<f64>,
    ) -> SVector<f64, R> {
        let Some(column) = self.tied else {
            return SVector::zeros();
        };
        let mut step = d_centre * dg.fixed_rows::<3>(column);
        if self.uncertain {
            step += d_radius * dg[column + 3];
        }
        step
    }
}

/// A touch's rows' derivatives with respect to its ball's centre
/// `d_centre` and radius `d_radius` written into `out` where the ball's
/// unknowns are ([`TouchedBall`]): the global block's columns when it is
/// tied, else its group's; the radius's only when it is an unknown.
pub(crate) fn put_ball_columns<const C: usize, const P: usize, const R: usize>(
    out: &mut Linearization<C, P, R, OMatrix<f64, Const<R>, Dyn>>,
    ball: &TouchedBall,
    d_centre: &SMatrix<f64, R, 3>,
    d_radius: &SVector<f64, R>,
) {
    match ball.tied {
        Some(column) => {
            out.d_global.columns_mut(column, 3).copy_from(d_centre);
            if ball.uncertain {
                out.d_global.column_mut(column + 3).copy_from(d_radius);
            }
        }
        None => put_group_columns(&mut out.d_group, ball, d_centre, d_radius),
    }
}

/// [`put_ball_columns`] of a ball in its group: `d_centre` and, when its
/// radius is an unknown, `d_radius` into the group's columns `d_group`.
pub(crate) fn put_group_columns<const C: usize, const R: usize>(
    d_group: &mut SMatrix<f64, R, C>,
    ball: &TouchedBall,
    d_centre: &SMatrix<f64, R, 3>,
    d_radius: &SVector<f64, R>,
) {
    d_group.fixed_columns_mut::<3>(0).copy_from(d_centre);
    if ball.uncertain {
        d_group.column_mut(3).copy_from(d_radius);
    }
}

/// The error of touch `t` on ball `ball`.
pub(crate) fn touch_failed(
    t: usize,
    ball: usize,
    error: impl std::fmt::Display,
) -> MechanismCalibrationError {
    failed(
        ObservationRef {
            kind: ObservationKind::Touch,
            index: t,
        },
        format!("on ball {ball}: {error}"),
    )
}

/// The centre of ball `b` of calibrated radius `radius` from its
/// `touches` (indices into `all`): the best fit ([`fitted_centre`]) of
/// the tool points the touches reach with parameters `params` and the
/// controller's `configured`, put with their warm starts into `fit`
/// ([`reach_touches`]).
#[allow(
    clippy::too_many_arguments,
    reason = "a ball, its touches and where they are put"
)]
pub(crate) fn ball_centre(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    all: &[BallTouch],
    touches: &[usize],
    b: usize,
    radius: f64,
    reached: &mut Vec<Result<ReachedAlong, MechanismError>>,
    fit: BallFit<'_>,
) -> Result<Vector3<f64>, MechanismCalibrationError> {
    let tips = reach_touches(mechanism, params, configured, all, touches, reached, fit)?;
    Ok(fitted_centre(tips, radius, b)?.centre)
}

/// The tool points the `touches` (indices into `all`) reach with
/// parameters `params` and the controller's `configured`, and their warm
/// starts, put into `fit` in the order of `touches`; returns the tool
/// points. `reached` is room for the touches' outcomes, kept from ball to
/// ball so that their rooms are allocated once.
pub(crate) fn reach_touches<'a>(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    all: &[BallTouch],
    touches: &[usize],
    reached: &mut Vec<Result<ReachedAlong, MechanismError>>,
    fit: BallFit<'a>,
) -> Result<&'a [Vector3<f64>], MechanismCalibrationError> {
    // Together: a mechanism may reach several at once (the hexapod's
    // lanes), each from its start pose. Of each only its tool point and
    // warm start are wanted, not `dT/dp |_q`: the touches along a zero
    // step, which a mechanism's batches give without forming `dT/dp |_q`.
    let actuations: Vec<&Actuation> = touches.iter().map(|&t| &all[t].at).collect();
    let (starts, zero_step) = (vec![None; touches.len()], vec![0.0; params.len()]);
    Actuation::tool_points_along(
        mechanism,
        params,
        configured,
        &(&actuations[..], &starts[..]),
        &zero_step,
        &mut BatchWorkspace::default(),
        reached,
    );
    let rooms = fit.tips.iter_mut().zip(fit.warm_starts.iter_mut());
    for ((along, &t), (tip, warm_start)) in reached.iter().zip(touches).zip(rooms) {
        let along = along.as_ref().map_err(|e| failed(touch_ref(t), e))?;
        *tip = along.reached.point;
        *warm_start = WarmStart::of(along.reached.warm_start.as_slice());
    }
    Ok(fit.tips)
}

/// The best fit of the sphere of radius `radius` through ball `b`'s tool
/// points `tips` ([`sphere_through`]).
pub(crate) fn fitted_centre(
    tips: &[Vector3<f64>],
    radius: f64,
    b: usize,
) -> Result<SphereFit, MechanismCalibrationError> {
    sphere_through(tips, radius).map_err(|e| MechanismCalibrationError::InvalidData {
        what: format!("ball {b}"),
        reason: format!("its touches do not locate its centre: {e}"),
    })
}

/// The best fit of the sphere of radius `radius` through the tool points
/// `tips` ([`best_fit`]; the last iterate of a fit that did not converge).
pub(crate) fn sphere_through(
    tips: &[Vector3<f64>],
    radius: f64,
) -> Result<SphereFit, SphereFitError> {
    match best_fit(tips, radius) {
        Ok(fit) | Err(SphereFitError::NotConverged { last: fit }) => Ok(fit),
        Err(e) => Err(e),
    }
}
