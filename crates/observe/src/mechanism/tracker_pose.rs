//! A rigid body on the moving platform (a motion-capture body, a 6-dof
//! probe) measured by a tracker in the tracker's own frame, with the
//! actuators' readings: the mechanism's platform frame seen through two
//! unknown frames.
//!
//! The tracker `k` measures the body frame `M` (body → tracker). With the
//! tracker's frame `F_k = F₀_k ∘ C_F` ([`TrackerFrame`]) and the body frame
//! `B = C_B ∘ B₀` (body → platform, [`BodyFrame`]; `C = (Exp(ω), τ)` six
//! unknowns each, [`crate::frame`]), the measurement says where the
//! platform is, and the inverse kinematics what the actuators must read
//! there:
//!
//! ```text
//! T = F_k⁻¹ M B⁻¹,     x = x(T)   (Mechanism::pose_at_platform)
//! e = g(p, x) − q,     r = L⁻¹ (S e − o),     one row per actuator,
//! ```
//!
//! `S = diag(s_i)` the actuators' scales where they are parameters
//! ([`Mechanism::scale_parameters`]; else `S = I`), so that each row is in
//! the actuator's extension (mm) whatever the estimate of its scale, `o`
//! the actuators' zero offsets of a re-homed tracker in that unit (zero
//! otherwise; [`super::TrackerPoint`]'s), `L⁻¹` the whitening of the
//! rows' covariance (the actuators' repeatability and the tracker's,
//! propagated through `dg/dM`). This is
//! the implicit form of `M = F T(q) B` the hexapod's own calibration
//! observes its poses by ([`crate::PoseBlock`]: the same rows in leg
//! length). With `ε = (δt, δω)` a change of `T` (`t → t + δt`, `R →
//! Exp(δω) R`), `G_p` and `G_x` the derivatives of `g`:
//!
//! ```text
//! dr/dp = L⁻¹ (S G_p + diag(e) dS/dp),   dr/dε = L⁻¹ S G_x dx/dε,   dr/do = −L⁻¹,
//! T = C_F⁻¹ A,  A = F₀⁻¹ M B⁻¹:   dt/dτ_F = −R_Cᵀ,   dt/dω_F = d(Exp(ω_F)ᵀ (t_A − τ_F))/dω_F,
//!                                  dω/dω_F = −J_r(ω_F),
//! T = G C_B⁻¹,  G = F⁻¹ M B₀⁻¹:   dt/dτ_B = −R_T,    dt/dω_B = −R_G d(Exp(ω_B)ᵀ τ_B)/dω_B,
//!                                  dω/dω_B = −R_G J_r(ω_B),
//! ```
//!
//! (`J_r` the right Jacobian of SO(3), [`crate::frame::right_jacobian`]).
//! Only a mechanism whose pose fixes an orientation has a platform frame
//! (the hexapod); another's evaluation is an error.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Matrix6};
use parcal_kinematics::mechanism::{Mechanism, MechanismError, check_vector};

use super::commanded::Rows;
use super::tracker_point::TrackerFrame;
use crate::FrameCorrection;
use crate::frame::right_jacobian;

/// One pose a tracker measured (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerPose {
    /// The index of the tracker that measured it.
    pub tracker: usize,
    /// The actuators' readings `q`, one per actuator.
    pub readings: Vec<f64>,
    /// `M`, the body frame measured (body → tracker; mm).
    pub measured: Isometry3<f64>,
    /// `L⁻¹`, the whitening of its rows (actuators × actuators, lower
    /// triangular): the inverse of the Cholesky factor of their covariance,
    /// in the actuators' extensions squared (mm²) when their scales are
    /// the mechanism's parameters, else in the readings' unit squared
    /// (module doc).
    pub weight: DMatrix<f64>,
}

/// The body frame at some value of its correction: `B = C ∘ B₀` (body →
/// platform).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodyFrame {
    /// `B₀`, the fixed reference.
    pub reference: Isometry3<f64>,
    /// `C`, the correction.
    pub correction: FrameCorrection,
}

impl BodyFrame {
    /// `B = C ∘ B₀` as an isometry.
    pub fn isometry(&self) -> Isometry3<f64> {
        self.correction.isometry() * self.reference
    }
}

/// A tracker pose's whitened rows.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerPoseRows {
    /// `r` and `dr/dp` (one row per actuator).
    pub rows: Rows,
    /// `dr/d(ω, τ)` of the tracker's correction `C_F`.
    pub d_frame: DMatrix<f64>,
    /// `dr/d(ω, τ)` of the body's correction `C_B`.
    pub d_body: DMatrix<f64>,
    /// `dr/do` (`−L⁻¹`), when the pose was evaluated with offsets.
    pub d_offsets: Option<DMatrix<f64>>,
}

impl TrackerPose {
    /// The whitening `L⁻¹` of a covariance (actuators × actuators), or
    /// `None` when it is not positive definite.
    pub fn whitening(covariance: &DMatrix<f64>) -> Option<DMatrix<f64>> {
        let factor = covariance.clone().cholesky()?.l();
        factor.solve_lower_triangular(&DMatrix::identity(covariance.nrows(), covariance.nrows()))
    }

    /// `L⁻¹ S`, the whitening of its rows in the readings at parameters
    /// `params` (module doc).
    pub fn row_whitening(&self, mechanism: &dyn Mechanism, params: &[f64]) -> DMatrix<f64> {
        let mut w = self.weight.clone();
        if let Some(scales) = mechanism.scales(params) {
            for (mut column, s) in w.column_iter_mut().zip(scales) {
                column *= *s;
            }
        }
        w
    }

    /// The platform frame `T = F⁻¹ M B⁻¹` the measurement says, at the
    /// tracker's frame `frame` and the body frame `body`.
    pub fn platform(&self, frame: &TrackerFrame, body: &BodyFrame) -> Isometry3<f64> {
        frame.isometry().inverse() * self.measured * body.isometry().inverse()
    }

    /// The whitened rows at parameters `params`, the tracker's frame
    /// `frame` and the body frame `body` (module doc); with the actuators'
    /// zero `offsets`, and `dr/do`.
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        frame: &TrackerFrame,
        body: &BodyFrame,
        offsets: Option<&[f64]>,
    ) -> Result<TrackerPoseRows, MechanismError> {
        let actuators = mechanism.actuators().len();
        check_vector(mechanism, "readings", &self.readings, actuators)?;
        if let Some(offsets) = offsets {
            check_vector(mechanism, "offsets", offsets, actuators)?;
        }
        if self.weight.shape() != (actuators, actuators) {
            return Err(MechanismError::Dimension {
                mechanism: mechanism.name().to_string(),
                what: "rows of a pose's weight",
                expected: actuators,
                found: self.weight.nrows(),
            });
        }
        let platform = self.platform(frame, body);
        let at = mechanism.pose_at_platform(&platform)?;
        let predicted = mechanism.inverse(params, at.pose.as_slice())?;
        let jacobians = mechanism.reading_jacobians(params, at.pose.as_slice())?;
        let e = predicted - DVector::from_column_slice(&self.readings);
        let w = &self.row_whitening(mechanism, params);
        let mut residual = w * &e;
        if let Some(offsets) = offsets {
            residual -= &self.weight * DVector::from_column_slice(offsets);
        }
        let d_change = w * &jacobians.d_pose * &at.d_frame;
        let mut d_params = w * &jacobians.d_params;
        if let Some(scales) = mechanism.scale_parameters() {
            // dS/dp: the column of each scale gains `L⁻¹[·, i] e_i`.
            for (i, k) in scales.enumerate() {
                d_params
                    .column_mut(k)
                    .axpy(e[i], &self.weight.column(i), 1.0);
            }
        }
        Ok(TrackerPoseRows {
            rows: Rows { residual, d_params },
            d_frame: &d_change * to_dmatrix(&tracker_change(self, frame, body)),
            d_body: &d_change * to_dmatrix(&body_change(self, frame, body)),
            d_offsets: offsets.map(|_| -&self.weight),
        })
    }
}

/// `dε/d(ω_F, τ_F)`: how the platform frame moves with the tracker's
/// correction (module doc).
fn tracker_change(pose: &TrackerPose, frame: &TrackerFrame, body: &BodyFrame) -> Matrix6<f64> {
    let c = &frame.correction;
    let a = frame.reference.inverse() * pose.measured * body.isometry().inverse();
    let mut d = Matrix6::zeros();
    let to_a = a.translation.vector - c.translation;
    d.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&c.d_rotate_back(&to_a));
    d.fixed_view_mut::<3, 3>(0, 3)
        .copy_from(&-c.rotation_matrix().transpose());
    d.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&-right_jacobian(&c.rotation));
    d
}

/// `dε/d(ω_B, τ_B)`: how the platform frame moves with the body's
/// correction (module doc).
fn body_change(pose: &TrackerPose, frame: &TrackerFrame, body: &BodyFrame) -> Matrix6<f64> {
    let c = &body.correction;
    let g = frame.isometry().inverse() * pose.measured * body.reference.inverse();
    let r_g: Matrix3<f64> = g.rotation.to_rotation_matrix().into_inner();
    let r_t = r_g * c.rotation_matrix().transpose();
    let mut d = Matrix6::zeros();
    d.fixed_view_mut::<3, 3>(0, 0)
        .copy_from(&(-r_g * c.d_rotate_back(&c.translation)));
    d.fixed_view_mut::<3, 3>(0, 3).copy_from(&-r_t);
    d.fixed_view_mut::<3, 3>(3, 0)
        .copy_from(&(-r_g * right_jacobian(&c.rotation)));
    d
}

/// A 6 × 6 matrix as a dynamic one.
fn to_dmatrix(m: &Matrix6<f64>) -> DMatrix<f64> {
    DMatrix::from_column_slice(6, 6, m.as_slice())
}

#[cfg(test)]
mod tests {
    use nalgebra::{Translation3, UnitQuaternion, Vector3, Vector6};
    use parcal_kinematics::hexapod::Hexapod;
    use parcal_kinematics::mechanism::design;

    use super::*;
    use crate::mechanism::test_support::{delta, differences, tracker_frame as frame};

    fn body() -> BodyFrame {
        BodyFrame {
            reference: Isometry3::from_parts(
                Translation3::new(5.0, -3.0, 40.0),
                UnitQuaternion::from_euler_angles(0.05, 0.02, -0.4),
            ),
            correction: FrameCorrection {
                rotation: Vector3::new(-0.02, 0.01, 0.04),
                translation: Vector3::new(0.3, -0.5, 0.2),
            },
        }
    }

    fn hexapod(scaled: bool) -> Hexapod {
        let hexapod = Hexapod::typical();
        if scaled {
            hexapod.with_unknown_scales("rev", [0.5, 0.8, 1.0, 1.25, 2.0, 4.0], [0.01; 6])
        } else {
            hexapod
        }
    }

    /// A pose measured at the readings `q` (a few hundredths off those of
    /// the platform it says) through `frame()` and `body()`, with a
    /// correlated weight.
    fn pose(hexapod: &Hexapod, params: &DVector<f64>) -> TrackerPose {
        let x = [-30.0, 20.0, 240.0, 0.08, -0.05, 0.1];
        let q = hexapod.inverse(params.as_slice(), &x).unwrap();
        let platform = hexapod.platform_frame(&x).unwrap();
        let measured = frame().isometry() * platform * body().isometry();
        let covariance = DMatrix::from_fn(6, 6, |i, j| {
            if i == j {
                4e-4 * (1.0 + i as f64)
            } else {
                1e-5
            }
        });
        TrackerPose {
            tracker: 0,
            readings: q
                .iter()
                .enumerate()
                .map(|(i, q)| q + 0.01 * i as f64)
                .collect(),
            measured,
            weight: TrackerPose::whitening(&covariance).unwrap(),
        }
    }

    /// `dr/d(ω, τ)` of a correction `field` of the frames against central
    /// differences.
    fn frame_differences(
        at: &dyn Fn(&FrameCorrection) -> DVector<f64>,
        correction: &FrameCorrection,
    ) -> DMatrix<f64> {
        let params = Vector6::new(
            correction.rotation.x,
            correction.rotation.y,
            correction.rotation.z,
            correction.translation.x,
            correction.translation.y,
            correction.translation.z,
        );
        let h = 1e-6;
        let columns: Vec<DVector<f64>> = (0..6)
            .map(|k| {
                let step = Vector6::ith(k, h);
                let plus = FrameCorrection::from_params(&(params + step));
                let minus = FrameCorrection::from_params(&(params - step));
                (at(&plus) - at(&minus)) / (2.0 * h)
            })
            .collect();
        DMatrix::from_columns(&columns)
    }

    fn check(scaled: bool, offsets: Option<&[f64]>) {
        let hexapod = hexapod(scaled);
        let params = design(&hexapod);
        let pose = pose(&hexapod, &params);
        let (frame, body) = (frame(), body());
        let rows = pose
            .evaluate(&hexapod, params.as_slice(), &frame, &body, offsets)
            .unwrap();
        let residual = |p: &[f64], frame: &TrackerFrame, body: &BodyFrame, o: Option<&[f64]>| {
            pose.evaluate(&hexapod, p, frame, body, o)
                .unwrap()
                .rows
                .residual
        };
        // The rows are whitened by up to 1 / 0.02, and the leg lengths are
        // ~1e3 mm: rounding ~50 * 1e-13 / 1e-6, truncation ~h^2.
        let tolerance = 1e-5;
        let d_params = differences(&hexapod, &params, 1e-6, |p| {
            residual(p, &frame, &body, offsets)
        });
        assert!(
            (&d_params - &rows.rows.d_params).amax() < tolerance * d_params.amax().max(1.0),
            "dr/dp"
        );
        let p = params.as_slice();
        let d_frame = frame_differences(
            &|c| {
                residual(
                    p,
                    &TrackerFrame {
                        correction: *c,
                        ..frame
                    },
                    &body,
                    offsets,
                )
            },
            &frame.correction,
        );
        assert!(
            (&d_frame - &rows.d_frame).amax() < tolerance * d_frame.amax(),
            "dr/dC_F:\n{d_frame}\n{}",
            rows.d_frame
        );
        let d_body = frame_differences(
            &|c| {
                residual(
                    p,
                    &frame,
                    &BodyFrame {
                        correction: *c,
                        ..body
                    },
                    offsets,
                )
            },
            &body.correction,
        );
        assert!(
            (&d_body - &rows.d_body).amax() < tolerance * d_body.amax(),
            "dr/dC_B:\n{d_body}\n{}",
            rows.d_body
        );
        if let Some(offsets) = offsets {
            let h = 1e-6;
            let columns: Vec<DVector<f64>> = (0..offsets.len())
                .map(|k| {
                    let (mut plus, mut minus) = (offsets.to_vec(), offsets.to_vec());
                    plus[k] += h;
                    minus[k] -= h;
                    (residual(p, &frame, &body, Some(&plus))
                        - residual(p, &frame, &body, Some(&minus)))
                        / (2.0 * h)
                })
                .collect();
            let d_offsets = DMatrix::from_columns(&columns);
            let analytic = rows.d_offsets.as_ref().unwrap();
            assert!((&d_offsets - analytic).amax() < 1e-6, "dr/do");
        } else {
            assert!(rows.d_offsets.is_none());
        }
    }

    #[test]
    fn rows_match_central_differences() {
        check(false, None);
        check(false, Some(&[0.1, -0.2, 0.05, 0.3, 0.0, -0.1]));
        check(true, None);
        check(true, Some(&[0.1, -0.2, 0.05, 0.3, 0.0, -0.1]));
    }

    /// At the platform the readings reach, through the frames the
    /// measurement was made in, a pose's residual is the readings' error.
    #[test]
    fn the_residual_is_the_readings_error() {
        let hexapod = hexapod(false);
        let params = design(&hexapod);
        let pose = pose(&hexapod, &params);
        let rows = pose
            .evaluate(&hexapod, params.as_slice(), &frame(), &body(), None)
            .unwrap();
        let expected = &pose.weight * DVector::from_fn(6, |i, _| -0.01 * i as f64);
        assert!((rows.rows.residual - expected).amax() < 1e-9);
    }

    #[test]
    fn a_mechanism_without_a_platform_frame_is_refused() {
        let (delta, configured, _) = delta();
        let pose = TrackerPose {
            tracker: 0,
            readings: vec![100.0; 3],
            measured: Isometry3::identity(),
            weight: DMatrix::identity(3, 3),
        };
        let error = pose
            .evaluate(&delta, configured.as_slice(), &frame(), &body(), None)
            .unwrap_err();
        assert!(matches!(error, MechanismError::NoModel { .. }), "{error}");
    }
}
