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
//!
//! When the machine was re-homed before the tracker measured, its
//! actuators read with zero offsets `o` of their own (unknowns of the
//! global block), in their extension (mm) when their scales `s_i` are the
//! mechanism's parameters ([`Mechanism::scale_parameters`], `S =
//! diag(s_i)`), else in the readings' unit (`S = I`): the machine is at
//! the readings `q + S⁻¹o` (`q` those given, or those the controller
//! computes for the commanded position), and
//!
//! ```text
//! dr/do = L⁻¹ R_F dT/dq S⁻¹,     dr/ds_i += −(o_i / s_i²) L⁻¹ R_F dT/dq_i,     dT/dq = dT/dx G_x⁻¹
//! ```
//!
//! ([`tool_point_reading_jacobian`]: a mechanism with as many actuators
//! as pose coordinates).

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3x6};
use parcal_kinematics::mechanism::{
    Mechanism, MechanismError, Reached, check_vector, tool_point_reading_jacobian,
};

use super::commanded::{Actuation, Readings, Rows};
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
    /// `dr/do`, the derivative with respect to the actuators' offsets
    /// (3 x actuators), when the point was evaluated with offsets.
    pub d_offsets: Option<DMatrix<f64>>,
    /// The warm start of the pose the machine reached: a start for the
    /// next evaluation's forward kinematics.
    pub warm_start: DVector<f64>,
}

impl TrackerPoint {
    /// The whitened rows at true parameters `params`, configured
    /// parameters `configured` and the tracker's frame `frame` (module
    /// doc), the forward kinematics of readings started from the warm
    /// start `start` if given ([`Actuation::tool_point`]); with the
    /// actuators' zero `offsets`, at the readings `q + S⁻¹o` and with
    /// `dr/do` (module doc).
    pub fn evaluate(
        &self,
        mechanism: &dyn Mechanism,
        params: &[f64],
        configured: &[f64],
        frame: &TrackerFrame,
        offsets: Option<&[f64]>,
        start: Option<&[f64]>,
    ) -> Result<TrackerPointRows, MechanismError> {
        let Some(offsets) = offsets else {
            let reached = self.at.tool_point(mechanism, params, configured, start)?;
            return Ok(self.rows(reached, frame));
        };
        check_vector(mechanism, "offsets", offsets, mechanism.actuators().len())?;
        let (readings, commanded) = match &self.at {
            Actuation::Readings(q) => (DVector::from_column_slice(q), None),
            Actuation::Commanded(x) => (
                mechanism.inverse(configured, x)?,
                Some(mechanism.warm_start(x)?),
            ),
        };
        // `s_i`, where the scales are parameters.
        let scales = mechanism.scales(params);
        let shifted: Readings = (readings.iter().zip(offsets).enumerate())
            .map(|(i, (q, o))| q + o / scales.map_or(1.0, |s| s[i]))
            .collect();
        let reached = Actuation::Readings(shifted).tool_point(
            mechanism,
            params,
            configured,
            start.or(commanded.as_ref().map(DVector::as_slice)),
        )?;
        let pose = mechanism.pose_of_warm_start(reached.warm_start.as_slice())?;
        let d_tip = tool_point_reading_jacobian(mechanism, params, pose.as_slice())?;
        let mut rows = self.rows(reached, frame);
        // `L⁻¹ R_F dT/dq`, then over the scales.
        let d_readings = self.weight.inverse_factor() * frame_rotation(frame) * d_tip;
        let mut d_offsets =
            DMatrix::from_column_slice(3, d_readings.ncols(), d_readings.as_slice());
        if let (Some(columns), Some(scales)) = (mechanism.scale_parameters(), scales) {
            for (i, (k, &s)) in columns.zip(scales).enumerate() {
                let mut d_scale = rows.rows.d_params.column_mut(k);
                d_scale.axpy(-offsets[i] / (s * s), &d_offsets.column(i), 1.0);
                d_offsets.column_mut(i).unscale_mut(s);
            }
        }
        rows.d_offsets = Some(d_offsets);
        Ok(rows)
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
        let d_params = whitening * block.d_tip * reached.d_params.to_dense();
        let d_params = DMatrix::from_column_slice(3, d_params.ncols(), d_params.as_slice());
        TrackerPointRows {
            rows: Rows {
                residual: DVector::from_column_slice((whitening * block.residual).as_slice()),
                d_params,
            },
            d_frame: whitening * block.d_tracker,
            d_offsets: None,
            warm_start: reached.warm_start,
        }
    }
}

/// `R_F = R_F₀ Exp(ω)`, the rotation of `frame`.
fn frame_rotation(frame: &TrackerFrame) -> nalgebra::Matrix3<f64> {
    frame.reference.rotation.to_rotation_matrix().into_inner() * frame.correction.rotation_matrix()
}

#[cfg(test)]
mod tests {
    use nalgebra::{DMatrix, Matrix3, Vector3, Vector6};

    use super::*;
    use crate::mechanism::test_support::{
        delta, differences, hexapod_touch, tracker_frame as frame,
    };

    /// A correlated weight, so that the whitening's off-diagonal terms
    /// are checked too.
    fn weight() -> CoordinateWhitening {
        let w = Matrix3::new(4e-4, 1e-4, 0.0, 1e-4, 9e-4, -2e-4, 0.0, -2e-4, 2.5e-3);
        CoordinateWhitening::from_covariance(&w).unwrap()
    }

    /// `dr/dp`, `dr/d(ω, τ)` and, with `offsets`, `dr/do` against central
    /// differences, at `point`.
    fn check(
        mechanism: &dyn Mechanism,
        params: &DVector<f64>,
        configured: &[f64],
        point: &TrackerPoint,
        offsets: Option<&[f64]>,
    ) {
        let frame = frame();
        let residual = |p: &[f64], frame: &TrackerFrame, offsets: Option<&[f64]>| {
            point
                .evaluate(mechanism, p, configured, frame, offsets, None)
                .unwrap()
                .rows
                .residual
        };
        let rows = point
            .evaluate(
                mechanism,
                params.as_slice(),
                configured,
                &frame,
                offsets,
                None,
            )
            .unwrap();
        if offsets.is_none() {
            let reached = point
                .at
                .tool_point(mechanism, params.as_slice(), configured, None);
            let seen = frame
                .isometry()
                .transform_point(&reached.unwrap().point.into());
            let c = seen.coords - Vector3::from(point.measured);
            assert!((point.weight.inverse_factor() * c - &rows.rows.residual).amax() < 1e-9);
        }
        let d_params = differences(mechanism, params, 1e-6, |p| residual(p, &frame, offsets));
        let close = |analytic: &DMatrix<f64>, numeric: &DMatrix<f64>, what: &str| {
            let scale = numeric.amax().max(1.0);
            assert!((analytic - numeric).amax() < 1e-6 * scale, "{what}");
        };
        close(&rows.rows.d_params, &d_params, "dr/dp");
        let h = 1e-6;
        let correction = Vector6::new(0.01, -0.02, 0.03, 0.4, 0.1, -0.3);
        let d_frame = DMatrix::from_fn(3, 6, |r, k| {
            let at = |step: f64| {
                let mut moved = correction;
                moved[k] += step;
                let frame = TrackerFrame {
                    correction: FrameCorrection::from_params(&moved),
                    ..frame
                };
                residual(params.as_slice(), &frame, offsets)[r]
            };
            (at(h) - at(-h)) / (2.0 * h)
        });
        close(
            &DMatrix::from_column_slice(3, 6, rows.d_frame.as_slice()),
            &d_frame,
            "dr/dC",
        );
        if let Some(offsets) = offsets {
            let d_offsets = DMatrix::from_fn(3, offsets.len(), |r, k| {
                let at = |step: f64| {
                    let mut moved = offsets.to_vec();
                    moved[k] += step;
                    residual(params.as_slice(), &frame, Some(&moved))[r]
                };
                (at(h) - at(-h)) / (2.0 * h)
            });
            close(rows.d_offsets.as_ref().unwrap(), &d_offsets, "dr/do");
        }
    }

    #[test]
    fn derivatives_match_central_differences() {
        // A delta commanded, and the hexapod read at its legs; each without
        // and with its actuators' zero offsets.
        let (delta, configured, truth) = delta();
        let point = TrackerPoint {
            tracker: 0,
            at: Actuation::Commanded([40.0, -70.0, 120.0]),
            measured: [1400.0, -150.0, 700.0],
            weight: weight(),
        };
        check(&delta, &truth, configured.as_slice(), &point, None);
        check(
            &delta,
            &truth,
            configured.as_slice(),
            &point,
            Some(&[0.3, -0.2, 0.1]),
        );
        let hexapod = hexapod_touch();
        let point = TrackerPoint {
            at: hexapod.touch.at.clone(),
            ..point
        };
        let (mechanism, params) = (hexapod.hexapod.as_ref(), &hexapod.params);
        check(mechanism, params, &[], &point, None);
        let offsets = [0.4, -0.3, 0.2, -0.1, 0.5, -0.6];
        check(mechanism, params, &[], &point, Some(&offsets));
        // Read in revolutions of unknown scales: the offsets in mm.
        let scaled = parcal_kinematics::hexapod::Hexapod::typical().with_unknown_scales(
            "rev",
            [0.5, 0.8, 1.0, 1.25, 2.0, 4.0],
            [0.01; 6],
        );
        let params = parcal_kinematics::mechanism::design(&scaled);
        let pose = [-30.0, 20.0, 240.0, 0.08, -0.05, 0.1];
        let readings = scaled.inverse(params.as_slice(), &pose).unwrap();
        let point = TrackerPoint {
            at: Actuation::Readings(readings.iter().copied().collect()),
            ..point
        };
        check(&scaled, &params, &[], &point, Some(&offsets));
    }
}
