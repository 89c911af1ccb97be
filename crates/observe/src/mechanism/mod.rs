//! Observation kinds of any mechanism (a linear delta, a cable robot, the
//! hexapod) through the
//! [`Mechanism`](parcal_kinematics::mechanism::Mechanism) trait: each gives
//! its whitened residual rows and their analytic Jacobians with respect to
//! the true parameters `p` (and its own other unknowns).
//!
//! - [`ProbeHeight`]: a probe triggering on the bed, `(z(x) − h) / σ`
//!   (1 row; unknowns `p`, the trigger height `h`);
//! - [`ManualHeight`]: the nozzle's height above the bed measured by hand,
//!   `(z(x) − h_m) / σ` (1 row; unknowns `p`);
//! - [`PartDistance`]: the distance between two commanded positions as
//!   measured on a printed or reference part (1 row; unknowns `p`);
//! - [`CommandedPoint`]: the effector's position measured at a commanded
//!   position (a tracker point; 3 rows; unknowns `p`);
//! - [`PointSample`]: actuator readings at an unknown pose, with the
//!   actuators' loads when the mechanism models them
//!   (one row per actuator; unknowns `p` and the pose, a point block);
//! - [`MeasuredQuantity`]: a known function of the parameters measured
//!   directly, `(f(p) − v) / σ` (1 row; unknowns `p`);
//! - [`BallTouch`]: the tool point touching a calibrated sphere at an
//!   unknown centre, `(|x − c| − ρ) / σ` (1 row; unknowns `p`, the ball's
//!   centre `c`, a block of its own, and its radius `ρ` when it has a
//!   calibration sigma), at a commanded position or at the actuators'
//!   readings ([`Actuation`]): the one kind a mechanism of any pose (the
//!   hexapod's six coordinates) takes, through its tool point; or by its
//!   three coordinates, `L⁻¹ (c + ρ u(θ) − x)` (paper eq. 10, 3 rows; the
//!   contact's two angles `θ` unknowns of its own,
//!   [`BallTouch::coordinate_rows`]);
//! - [`BallDistance`]: a calibrated distance between two touched balls'
//!   centres, `(|c_a − c_b| − L) / σ` (1 row; unknowns the two centres);
//! - [`TrackerPoint`]: the tool point measured by a tracker in its own
//!   frame, `L⁻¹ (F_k(x) − P)` (3 rows; unknowns `p` and the tracker's
//!   frame `F_k`, six of the global block), at a commanded position or at
//!   the actuators' readings;
//! - [`TrackerPose`]: a body on the platform measured by a tracker in its
//!   own frame, `L⁻¹ (g(p, x(F_k⁻¹ M B⁻¹)) − q)` (one row per actuator;
//!   unknowns `p`, the tracker's frame and the body frame `B`, six each of
//!   the global block), at the actuators' readings, for a mechanism whose
//!   pose fixes an orientation.
//!
//! # Commanded positions
//!
//! A controller moves to a commanded position `x_c` in its own coordinates
//! by computing readings with the parameters it is configured with, `p_c`:
//! `q = g(p_c, x_c)`. The machine, whose true parameters are `p`, is then
//! at `x = f(p, q)`; at fixed readings its derivative is
//! `dx/dp = −G_x⁻¹ G_p`
//! ([`pose_jacobian_at_fixed_readings`](parcal_kinematics::mechanism::pose_jacobian_at_fixed_readings)),
//! and its tool point's
//! ([`Mechanism::tool_point_at_readings`](parcal_kinematics::mechanism::Mechanism::tool_point_at_readings)),
//! which [`reached`] evaluates. `p_c` is known and fixed: only the true
//! `p` is an unknown. Commanded positions need a mechanism whose pose is a
//! position; every kind but the touch takes them.

mod ball_distance;
mod ball_touch;
mod commanded;
mod commanded_point;
mod manual_height;
mod part_distance;
mod point_sample;
mod probe;
mod quantity;
mod touch_coordinates;
mod tracker_point;
mod tracker_pose;

pub use ball_distance::{BallDistance, BallDistanceRow};
pub use ball_touch::{Approach, BallTouch, RadiusRow, TouchRows};
pub use commanded::{
    Actuation, ActuationBatch, ON_STACK, POSE_COORDINATES, Readings, Rows, reached,
};
pub use commanded_point::CommandedPoint;
pub use manual_height::ManualHeight;
pub use part_distance::PartDistance;
pub use point_sample::{PointSample, SampleRows};
pub use probe::ProbeHeight;
pub use quantity::MeasuredQuantity;
pub use tracker_point::{TrackerFrame, TrackerPoint, TrackerPointRows};
pub use tracker_pose::{BodyFrame, TrackerPose, TrackerPoseRows};

#[cfg(test)]
pub(crate) mod test_support {
    //! A perturbed delta, central differences over its parameters and
    //! the check of an analytic Jacobian against them.
    use nalgebra::{DMatrix, DVector, Dim, Dyn, Matrix, Storage, Vector3};
    use parcal_kinematics::delta::{DeltaParams, LinearDelta};
    use parcal_kinematics::mechanism::{Mechanism, design};
    use parcal_kinematics::mechanisms::by_name;

    use super::{Actuation, BallTouch};

    /// A typical delta, its configured (design) parameters and a true
    /// machine a few tenths away.
    pub fn delta() -> (LinearDelta, DVector<f64>, DVector<f64>) {
        let delta = LinearDelta::typical();
        let configured = design(&delta);
        let mut truth = DeltaParams::from_slice(configured.as_slice());
        truth.endstop = [0.3, -0.2, 0.1];
        truth.radius += 0.4;
        truth.tower_radius = [0.1, -0.2, 0.05];
        truth.angle = [0.2, -0.3, 0.1];
        truth.diagonal = [270.3, 269.8, 270.1];
        truth.tilt = [0.1, -0.15];
        (delta, configured, truth.to_vector())
    }

    /// The hexapod at its design, a touch of 2 um sigma at the legs'
    /// readings of a tilted pose, the tool point it reaches and a ball
    /// centre √29 mm from it.
    pub struct HexapodTouch {
        pub hexapod: Box<dyn Mechanism>,
        pub params: DVector<f64>,
        pub touch: BallTouch,
        pub tip: Vector3<f64>,
        pub centre: Vector3<f64>,
    }

    /// [`HexapodTouch`].
    pub fn hexapod_touch() -> HexapodTouch {
        let hexapod = by_name("hexapod").unwrap();
        let params = design(hexapod.as_ref());
        let pose = [-30.0, 20.0, 240.0, 0.08, -0.05, 0.1];
        let q = hexapod.inverse(params.as_slice(), &pose).unwrap();
        let touch = BallTouch::new(0, Actuation::Readings(q.iter().copied().collect()), 0.002);
        let tip = hexapod.tool_point(params.as_slice(), &pose).unwrap().point;
        let centre = tip + Vector3::new(2.0, -3.0, 4.0);
        HexapodTouch {
            hexapod,
            params,
            touch,
            tip,
            centre,
        }
    }

    /// A tracker's frame turned and shifted from the mechanism's, with a
    /// correction of a few hundredths.
    pub fn tracker_frame() -> super::TrackerFrame {
        super::TrackerFrame {
            reference: nalgebra::Isometry3::from_parts(
                nalgebra::Translation3::new(1500.0, -200.0, 300.0),
                nalgebra::UnitQuaternion::from_euler_angles(0.1, -0.2, 2.5),
            ),
            correction: crate::FrameCorrection {
                rotation: Vector3::new(0.01, -0.02, 0.03),
                translation: Vector3::new(0.4, 0.1, -0.3),
            },
        }
    }

    /// Central differences of `f` over the parameters, step `h`.
    pub fn differences(
        mechanism: &dyn Mechanism,
        params: &DVector<f64>,
        h: f64,
        f: impl Fn(&[f64]) -> DVector<f64>,
    ) -> DMatrix<f64> {
        let n = mechanism.parameters().len();
        let rows = f(params.as_slice()).len();
        let mut jacobian = DMatrix::zeros(rows, n);
        for k in 0..n {
            let (mut plus, mut minus) = (params.clone(), params.clone());
            plus[k] += h;
            minus[k] -= h;
            let column = (f(plus.as_slice()) - f(minus.as_slice())) / (2.0 * h);
            jacobian.set_column(k, &column);
        }
        jacobian
    }

    /// Asserts that `analytic` is `numeric` (central differences of steps
    /// of 1e-4 on rows of O(100) per unit: truncation ~1e-8 relative,
    /// rounding ~1e-16 · 1e4 / 1e-4) within 1e-6 of its largest entry.
    pub fn assert_matches<R: Dim, S: Storage<f64, R, Dyn>>(
        analytic: &Matrix<f64, R, Dyn, S>,
        numeric: &DMatrix<f64>,
    ) {
        assert_eq!(analytic.shape(), numeric.shape());
        let error = (analytic.iter().zip(numeric.iter()))
            .map(|(a, n)| (a - n).abs())
            .fold(0.0, f64::max);
        assert!(error < 1e-6 * numeric.amax(), "{error:e}");
    }
}
