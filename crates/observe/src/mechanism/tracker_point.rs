//! The tool point measured by a tracker in the tracker's own frame (a laser
//! tracker's reflector, a motion-capture marker), the tracker's placement
//! unknown.
//!
//! The machine is put at a commanded position or read at its actuators'
//! readings ([`Actuation`]) and reaches the tool point `T = T(p, f(p, q))`
//! in its own frame. The tracker `k` measures `P` in its frame, `F_k = F₀_k
//! ∘ C_k` ([`crate::frame`]: `F₀_k` a fixed reference, `C_k = (Exp(ω),
//! τ)` a correction, six unknowns of the global block). With `L⁻¹` the
//! whitening of the point's covariance `W = L Lᵀ` (the tracker's noise,
//! and the actuators' propagated through `dT/dq` where they were read):
//!
//! ```text
//! c = F₀_k C_k (T) − P,     r = L⁻¹ c,     3 rows,
//! dr/dp = L⁻¹ R_F dT/dp|_q,     dr/d(ω, τ) = L⁻¹ [R_F₀ d(Exp(ω) T)/dω | R_F₀],
//! ```
//!
//! `R_F = R_F₀ Exp(ω)` ([`PointBlock`]). The hexapod's own calibration
//! observes its tracker points by the same block.

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3x6};
use parcal_kinematics::mechanism::{Mechanism, MechanismError, Reached};

use super::commanded::{Actuation, Rows};
use crate::{CoordinateWhitening, FrameCorrection, PointBlock};

/// One point a tracker measured (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerPoint {
    /// The index of the tracker that measured it.
    pub tracker: usize,
    /// Where the machine was put.
    pub at: Actuation,
    /// `P`, the measured point (the tracker's frame, mm).
    pub measured: [f64; 3],
    /// The whitening of its three rows: `L⁻¹` of their covariance `W`
    /// (mm²).
    pub weight: CoordinateWhitening,
}

/// A tracker's frame at some value of its correction: `F = F₀ ∘ C`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerFrame {
    /// `F₀`, the fixed reference (the mechanism's frame → the tracker's).
    pub reference: Isometry3<f64>,
    /// `C`, the correction.
    pub correction: FrameCorrection,
}

impl TrackerFrame {
    /// `F = F₀ ∘ C` as an isometry.
    pub fn isometry(&self) -> Isometry3<f64> {
        self.reference * self.correction.isometry()
    }
}

/// A tracker point's whitened rows.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerPointRows {
    /// `r` and `dr/dp` (3 rows).
    pub rows: Rows,
    /// `dr/d(ω, τ)`, the derivative with respect to the tracker's
    /// correction.
    pub d_frame: Matrix3x6<f64>,
    /// The pose the machine reached: a start for the next evaluation's
    /// forward kinematics.
    pub pose: DVector<f64>,
}

impl TrackerPoint {
    /// The whitened rows at true parameters `params`, configured
    /// parameters `configured` and the tracker's frame `frame` (module
    /// doc), the forward kinematics of readings started from `start` if
    /// given ([`Actuation::tool_point`]).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        frame: &TrackerFrame,
        start: Option<&[f64]>,
    ) -> Result<TrackerPointRows, MechanismError> {
        let reached = self.at.tool_point(mechanism, params, configured, start)?;
        Ok(self.rows(reached, frame))
    }

    /// The whitened rows of the point where the machine reached `reached`,
    /// seen through `frame` (module doc).
    pub fn rows(&self, reached: Reached, frame: &TrackerFrame) -> TrackerPointRows {
        let measured = self.measured.into();
        let block = PointBlock {
            measured: &measured,
            tracker_reference: &frame.reference,
            tracker: frame.correction,
        }
        .evaluate(&reached.point);
        let whitening = self.weight.inverse_factor();
        let d_params = whitening * block.d_tip * &reached.d_params;
        let d_params = DMatrix::from_column_slice(3, d_params.ncols(), d_params.as_slice());
        TrackerPointRows {
            rows: Rows {
                residual: DVector::from_column_slice((whitening * block.residual).as_slice()),
                d_params,
            },
            d_frame: whitening * block.d_tracker,
            pose: reached.pose,
        }
    }
}

#[cfg(test)]
mod tests {
    use nalgebra::{Matrix3, Translation3, UnitQuaternion, Vector3, Vector6};

    use super::*;
    use crate::mechanism::test_support::{delta, differences, hexapod_touch};

    fn frame() -> TrackerFrame {
        TrackerFrame {
            reference: Isometry3::from_parts(
                Translation3::new(1500.0, -200.0, 300.0),
                UnitQuaternion::from_euler_angles(0.1, -0.2, 2.5),
            ),
            correction: FrameCorrection {
                rotation: Vector3::new(0.01, -0.02, 0.03),
                translation: Vector3::new(0.4, 0.1, -0.3),
            },
        }
    }

    /// A correlated weight, so that the whitening's off-diagonal terms
    /// are checked too.
    fn weight() -> CoordinateWhitening {
        let w = Matrix3::new(4e-4, 1e-4, 0.0, 1e-4, 9e-4, -2e-4, 0.0, -2e-4, 2.5e-3);
        CoordinateWhitening::from_covariance(&w).unwrap()
    }

    /// `dr/dp` and `dr/d(ω, τ)` against central differences, at `point`.
    fn check(
        mechanism: &dyn Mechanism,
        params: &DVector<f64>,
        configured: &[f64],
        point: &TrackerPoint,
    ) {
        let frame = frame();
        let rows = point
            .evaluate(mechanism, params.as_slice(), configured, &frame, None)
            .unwrap();
        let expected = frame.isometry().transform_point(
            &point
                .at
                .tool_point(mechanism, params.as_slice(), configured, None)
                .unwrap()
                .point
                .into(),
        );
        let c = expected.coords - Vector3::from(point.measured);
        assert!((point.weight.inverse_factor() * c - &rows.rows.residual).amax() < 1e-9);
        let d_params = differences(mechanism, params, 1e-6, |p| {
            point
                .evaluate(mechanism, p, configured, &frame, None)
                .unwrap()
                .rows
                .residual
        });
        let scale = d_params.amax().max(1.0);
        assert!(
            (&rows.rows.d_params - &d_params).amax() < 1e-6 * scale,
            "dr/dp"
        );
        let correction = Vector6::new(0.01, -0.02, 0.03, 0.4, 0.1, -0.3);
        let h = 1e-6;
        for k in 0..6 {
            let at = |step: f64| {
                let mut moved = correction;
                moved[k] += step;
                let frame = TrackerFrame {
                    correction: FrameCorrection::from_params(&moved),
                    ..frame
                };
                point
                    .evaluate(mechanism, params.as_slice(), configured, &frame, None)
                    .unwrap()
                    .rows
                    .residual
            };
            let column = (at(h) - at(-h)) / (2.0 * h);
            let scale = column.amax().max(1.0);
            assert!(
                (rows.d_frame.column(k) - column).amax() < 1e-6 * scale,
                "dr/dC column {k}"
            );
        }
    }

    #[test]
    fn derivatives_match_central_differences() {
        // A delta commanded, and the hexapod read at its legs.
        let (delta, configured, truth) = delta();
        let point = TrackerPoint {
            tracker: 0,
            at: Actuation::Commanded([40.0, -70.0, 120.0]),
            measured: [1400.0, -150.0, 700.0],
            weight: weight(),
        };
        check(&delta, &truth, configured.as_slice(), &point);
        let hexapod = hexapod_touch();
        let point = TrackerPoint {
            at: hexapod.touch.at.clone(),
            ..point
        };
        check(hexapod.hexapod.as_ref(), &hexapod.params, &[], &point);
    }
}
