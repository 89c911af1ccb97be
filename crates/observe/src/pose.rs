//! The measured-pose observation: an instrument (motion capture,
//! photogrammetry, a tracker with a 6-dof probe) measures the platform body
//! frame `M` in its own frame; the pose says, through inverse kinematics,
//! what every leg's length must be,
//!
//! ```text
//! T   = C_F⁻¹ F₀⁻¹ M B₀⁻¹ C_B⁻¹           platform pose, canonical frames
//! c_i = |T E_i − B_i| − L_i,   L_i = l_i + o_i + s_i q_i,   i = 1..6,
//! ```
//!
//! with `F = F₀ ∘ C_F` the session's instrument frame and `B = C_B ∘ B₀` the
//! body frame ([`crate::frame`]), `o_i` the session's leg offset and `s_i`
//! the actuator scale. Six rows per pose, in mm of leg length. This is the
//! implicit (inverse-kinematics) form of `M = F T(q) B`: to first order the
//! same information as the six pose coordinates (the two residuals differ
//! by the pose's invertible 6 x 6 Jacobian), without forward kinematics.
//! Its covariance is the actuators' (`s_i² σ_q²` per leg) plus the
//! instrument's, propagated through `∂c/∂M` ([`PoseJacobians::d_measurement`]).

use nalgebra::{Isometry3, Matrix6, RowVector3, Vector6};
use parcal_kinematics::Geometry;
#[cfg(test)]
use parcal_kinematics::Vec3;

use crate::ObserveError;
use crate::frame::{FrameCorrection, skew};
use crate::radius::unit_offset;

/// One measured pose and the frames it is seen through.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseBlock<'a> {
    /// `M`: the body frame in the instrument frame, as measured.
    pub measured: &'a Isometry3<f64>,
    /// `F₀`: the reference of the session's instrument frame (base →
    /// instrument).
    pub tracker_reference: &'a Isometry3<f64>,
    /// `C_F`.
    pub tracker: FrameCorrection,
    /// `B₀`: the reference of the body frame (body → platform).
    pub body_reference: &'a Isometry3<f64>,
    /// `C_B`.
    pub body: FrameCorrection,
}

/// The raw residual of a pose (mm of leg length) and its derivatives.
/// Row `i` depends on `B_i`, `E_i` and `L_i` of its own leg only
/// (`∂c_i/∂L_i = −1`).
#[derive(Debug, Clone, PartialEq)]
pub struct PoseJacobians {
    /// `c_i = |T E_i − B_i| − L_i`.
    pub residual: Vector6<f64>,
    /// `∂c_i/∂B_i = −n_iᵀ`, `n_i` the unit leg vector.
    pub d_base: [RowVector3<f64>; 6],
    /// `∂c_i/∂E_i`.
    pub d_platform: [RowVector3<f64>; 6],
    /// `∂c/∂(ω_F, τ_F)`.
    pub d_tracker: Matrix6<f64>,
    /// `∂c/∂(ω_B, τ_B)`; `τ_B` is also the body origin's shift.
    pub d_body: Matrix6<f64>,
    /// `∂c/∂(δt, δθ)` for a measurement error `M → (Exp(δθ) R_M, t_M + δt)`
    /// (instrument frame; the rotation about the body origin).
    pub d_measurement: Matrix6<f64>,
}

impl PoseBlock<'_> {
    /// The block at the canonical `geometry` (joints) and the current leg
    /// lengths `lengths` (`L_i`). Refuses a leg of zero length.
    pub fn evaluate(
        &self,
        geometry: &Geometry,
        lengths: &[f64; 6],
    ) -> Result<PoseJacobians, ObserveError> {
        let (e_f, e_b) = (self.tracker.rotation_matrix(), self.body.rotation_matrix());
        let r_f0 = self
            .tracker_reference
            .rotation
            .to_rotation_matrix()
            .into_inner();
        let r_m = self.measured.rotation.to_rotation_matrix().into_inner();
        let r_b0 = self
            .body_reference
            .rotation
            .to_rotation_matrix()
            .into_inner();
        // z = F₀⁻¹ M B₀⁻¹ y: its rotation, and ∂x/∂y = E_Fᵀ R'.
        let pre = self.tracker_reference.inverse() * self.measured * self.body_reference.inverse();
        let dx_dy = e_f.transpose() * pre.rotation.to_rotation_matrix().into_inner();
        let dx_dw = e_f.transpose() * r_f0.transpose();
        let mut out = PoseJacobians {
            residual: Vector6::zeros(),
            d_base: [RowVector3::zeros(); 6],
            d_platform: [RowVector3::zeros(); 6],
            d_tracker: Matrix6::zeros(),
            d_body: Matrix6::zeros(),
            d_measurement: Matrix6::zeros(),
        };
        for (i, &leg) in lengths.iter().enumerate() {
            let e = geometry.platform[i];
            let y = e_b.transpose() * (e - self.body.translation);
            let z = pre.transform_point(&y.into()).coords;
            let x = e_f.transpose() * (z - self.tracker.translation);
            let (n, length) = unit_offset(&x, &geometry.base[i], "leg (pose observation)")?;
            let n = n.transpose();
            out.residual[i] = length - leg;
            out.d_base[i] = -n;
            out.d_platform[i] = n * dx_dy * e_b.transpose();
            let d_omega_f = n * self.tracker.d_rotate_back(&(z - self.tracker.translation));
            let d_tau_f = -n * e_f.transpose();
            let d_beta = n * dx_dy * self.body.d_rotate_back(&(e - self.body.translation));
            let d_rho = -n * dx_dy * e_b.transpose();
            let v = r_b0.transpose() * (y - self.body_reference.translation.vector);
            let d_dt = n * dx_dw;
            let d_dtheta = -n * dx_dw * skew(&(r_m * v));
            for (block, (first, second)) in [
                (&mut out.d_tracker, (d_omega_f, d_tau_f)),
                (&mut out.d_body, (d_beta, d_rho)),
                (&mut out.d_measurement, (d_dt, d_dtheta)),
            ] {
                block.fixed_view_mut::<1, 3>(i, 0).copy_from(&first);
                block.fixed_view_mut::<1, 3>(i, 3).copy_from(&second);
            }
        }
        Ok(out)
    }
}

/// The covariance of a pose's six rows (mm²): the actuators'
/// `diag(s_i² σ_q²)` plus the instrument's `D diag(σ_t² I₃, σ_θ² I₃) Dᵀ`,
/// `D` = [`PoseJacobians::d_measurement`].
pub fn pose_covariance(
    d_measurement: &Matrix6<f64>,
    actuator_sigma_mm: &[f64; 6],
    position_sigma: f64,
    orientation_sigma: f64,
) -> Matrix6<f64> {
    let mut instrument = Vector6::repeat(position_sigma * position_sigma);
    instrument
        .fixed_rows_mut::<3>(3)
        .fill(orientation_sigma * orientation_sigma);
    let mut covariance =
        d_measurement * Matrix6::from_diagonal(&instrument) * d_measurement.transpose();
    for (i, s) in actuator_sigma_mm.iter().enumerate() {
        covariance[(i, i)] += s * s;
    }
    covariance
}

#[cfg(test)]
mod tests {
    use nalgebra::{Translation3, UnitQuaternion, Vector3};
    use parcal_kinematics::{Pose, leg_lengths, paper, rotation_zyx};

    use super::*;
    use crate::test_support::{assert_close, central_difference};

    struct Case {
        geometry: Geometry,
        measured: Isometry3<f64>,
        f0: Isometry3<f64>,
        b0: Isometry3<f64>,
        tracker: FrameCorrection,
        body: FrameCorrection,
        lengths: [f64; 6],
    }

    fn iso(t: [f64; 3], yaw: f64, pitch: f64, roll: f64) -> Isometry3<f64> {
        Isometry3::from_parts(
            Translation3::from(Vector3::from(t)),
            rotation_zyx(yaw, pitch, roll),
        )
    }

    /// A pose of the design machine seen through frames far from identity,
    /// corrections away from zero, lengths 0.1 mm off the pose's.
    fn case() -> Case {
        let geometry = paper::design().canonicalize().unwrap().geometry;
        let pose: Pose = iso([-30.0, 20.0, 260.0], 0.1, -0.05, 0.08);
        let f0 = iso([100.0, -2000.0, 700.0], 2.0, 0.1, -0.05);
        let b0 = iso([5.0, -3.0, 40.0], -0.5, 0.02, 0.03);
        let tracker = FrameCorrection {
            rotation: Vec3::new(0.01, -0.02, 0.015),
            translation: Vec3::new(0.5, -0.3, 0.2),
        };
        let body = FrameCorrection {
            rotation: Vec3::new(-0.01, 0.005, 0.02),
            translation: Vec3::new(-0.2, 0.4, 0.1),
        };
        let measured = f0 * tracker.isometry() * pose * (body.isometry() * b0);
        let lengths = leg_lengths(&geometry, &pose).map(|l| l + 0.1);
        Case {
            geometry,
            measured,
            f0,
            b0,
            tracker,
            body,
            lengths,
        }
    }

    impl Case {
        fn block(&self) -> PoseBlock<'_> {
            PoseBlock {
                measured: &self.measured,
                tracker_reference: &self.f0,
                tracker: self.tracker,
                body_reference: &self.b0,
                body: self.body,
            }
        }

        fn residual(&self) -> Vector6<f64> {
            self.block()
                .evaluate(&self.geometry, &self.lengths)
                .unwrap()
                .residual
        }
    }

    #[test]
    fn residual_is_the_length_error() {
        let c = case();
        let r = c.residual();
        assert!((r - Vector6::repeat(-0.1)).amax() < 1e-9, "{r}");
    }

    #[test]
    fn derivatives_match_central_differences() {
        let c = case();
        let j = c.block().evaluate(&c.geometry, &c.lengths).unwrap();
        let six = |p: &Vector6<f64>, f: &dyn Fn(&mut Case, FrameCorrection)| {
            let mut moved = case();
            f(&mut moved, FrameCorrection::from_params(p));
            moved.residual()
        };
        let params = |f: FrameCorrection| {
            Vector6::new(
                f.rotation.x,
                f.rotation.y,
                f.rotation.z,
                f.translation.x,
                f.translation.y,
                f.translation.z,
            )
        };
        let d_tracker =
            central_difference(&params(c.tracker), 1e-6, |p| six(p, &|m, f| m.tracker = f));
        assert_close(&j.d_tracker, &d_tracker, 1e-6, "dc/dC_F");
        let d_body = central_difference(&params(c.body), 1e-6, |p| six(p, &|m, f| m.body = f));
        assert_close(&j.d_body, &d_body, 1e-6, "dc/dC_B");
        for i in 0..6 {
            let d_base = central_difference(&c.geometry.base[i], 1e-5, |b| {
                let mut moved = case();
                moved.geometry.base[i] = *b;
                moved.residual()
            });
            let d_platform = central_difference(&c.geometry.platform[i], 1e-5, |e| {
                let mut moved = case();
                moved.geometry.platform[i] = *e;
                moved.residual()
            });
            for k in 0..6 {
                let expected = |d: &nalgebra::Matrix6x3<f64>| d.row(k).into_owned();
                let (base, platform) = if k == i {
                    (j.d_base[i], j.d_platform[i])
                } else {
                    (RowVector3::zeros(), RowVector3::zeros())
                };
                assert_close(&base, &expected(&d_base), 1e-6, "dc/dB");
                assert_close(&platform, &expected(&d_platform), 1e-6, "dc/dE");
            }
        }
        let d_measurement = central_difference(&Vector6::zeros(), 1e-6, |d| {
            let mut moved = case();
            let rotation = UnitQuaternion::from_scaled_axis(Vector3::new(d[3], d[4], d[5]));
            moved.measured = Isometry3::from_parts(
                Translation3::from(
                    moved.measured.translation.vector + Vector3::new(d[0], d[1], d[2]),
                ),
                rotation * moved.measured.rotation,
            );
            moved.residual()
        });
        assert_close(&j.d_measurement, &d_measurement, 1e-6, "dc/dM");
    }

    #[test]
    fn covariance_adds_the_actuators_and_the_instrument() {
        let c = case();
        let j = c.block().evaluate(&c.geometry, &c.lengths).unwrap();
        let w = pose_covariance(&j.d_measurement, &[0.01; 6], 0.2, 0.0);
        let expected =
            j.d_measurement.columns(0, 3) * j.d_measurement.columns(0, 3).transpose() * 0.04
                + Matrix6::identity() * 1e-4;
        assert!((w - expected).amax() < 1e-12);
        assert!(w.cholesky().is_some());
    }
}
