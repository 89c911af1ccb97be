//! The rows of a held-out tracker with poses ([`predict_posed_tracker`]):
//! the body frame its poses see is its unknown too (mounted anew), beside
//! its frame (placed anew) and a re-homed tracker's offsets: `K` points
//! and `J` poses of `A` actuators give `3K + AJ − 12` rows, located by
//! Gauss-Newton on the whitened rows before the projection
//! ([`tracker_unit`] for their unit).

use nalgebra::{DMatrix, DVector, Isometry3};
use parcal_kinematics::mechanism::{Mechanism, MechanismError};
use parcal_observe::FrameCorrection;
use parcal_observe::mechanism::{BodyFrame, Rows, TrackerFrame};

#[cfg(doc)]
use parcal_observe::mechanism::TrackerPoint;

use super::super::data::Observations;
use super::super::error::MechanismCalibrationError;
use super::super::observation::{HeldOut, ObservationKind, ObservationRef};
use super::super::trackers::{Seen, locate_frame};
use super::projection::LocalRows;
use super::rows::PredictedRows;
use super::tracker_reference::TrackerReference;

/// The unit of rows in noise standard deviations: a held-out tracker's
/// whose points (mm) and poses (the readings' unit) are projected together
/// ([`tracker_unit`]).
pub(crate) const NOISE_SIGMAS: &str = "noise sigmas";

/// The unit of a held-out tracker's projected rows: its points' (mm)
/// without poses, its poses' (the readings') without points, and with both
/// mm when the readings are, else [`NOISE_SIGMAS`] (the rows whitened: a
/// projection mixes them).
pub(crate) fn tracker_unit(mechanism: &dyn Mechanism, points: bool, poses: bool) -> &str {
    let readings = &*mechanism.actuators()[0].unit;
    match (points, poses) {
        (_, false) => "mm",
        (false, true) => readings,
        (true, true) if readings == "mm" => "mm",
        (true, true) => NOISE_SIGMAS,
    }
}

/// The most Gauss-Newton steps that locate a held-out tracker's frame and
/// the body frame its poses see.
const NUISANCE_ITERATIONS: usize = 50;

/// A held-out tracker's frame and body located when the step changes its
/// whitened rows by less than this (`|J δ|²`, in noise units squared).
const NUISANCE_TOLERANCE: f64 = 1e-12;

/// The rows of tracker `tracker` with its points `points` and poses
/// `poses` (module doc): its frame `F`, the body
/// frame `B` its poses see and a re-homed tracker's offsets are its own
/// unknowns (the tracker placed anew, the body mounted anew), located by
/// its points and poses together: from the frame [`locate_frame`] gives
/// through the data's body reference, Gauss-Newton on their whitened rows
/// ([`TrackerPose`](parcal_observe::mechanism::TrackerPose),
/// [`TrackerPoint`]) to the least-squares frames. There the rows are
/// un-whitened (`r = L r_w`, `D = L Lᵀ` for each observation's `L⁻¹`;
/// kept whitened when they are of two units, [`tracker_unit`]), and the
/// unknowns projected out. With reference observations (`locating`), the
/// frames are located by those alone and the other rows predicted from
/// theirs ([`TrackerReference::predict`]).
pub(super) fn predict_posed_tracker(
    mechanism: &dyn Mechanism,
    params: &[f64],
    configured: &[f64],
    observations: &Observations,
    ((tracker, points, poses), locating): ((usize, &[usize], &[usize]), &TrackerReference),
    g: usize,
) -> Result<PredictedRows, MechanismCalibrationError> {
    let held_out = HeldOut::Tracker {
        tracker,
        points: points.to_vec(),
        poses: poses.to_vec(),
    };
    let what = held_out.to_string();
    let seen = Seen {
        points: &observations.tracker_points,
        point_indices: locating.points,
        poses: &observations.tracker_poses,
        pose_indices: locating.poses,
        body: &observations.body_reference,
    };
    let (reference, _) = locate_frame((mechanism, configured), params, &seen, &what)?;
    let rows = |points, poses| NuisanceRows {
        mechanism,
        params,
        configured,
        observations,
        reference,
        points,
        poses,
        offsets: observations.trackers[tracker].rehomed,
    };
    let not_located = |reason: &str| MechanismCalibrationError::InvalidData {
        what: what.clone(),
        reason: format!(
            "the {} points and poses do not locate its frame and body{reason}",
            locating.name()
        ),
    };
    let fitted = rows(locating.points, locating.poses);
    let mut nuisance = DVector::zeros(fitted.unknowns());
    let mut stacked = fitted.at(&nuisance)?;
    let mut converged = false;
    for _ in 0..NUISANCE_ITERATIONS {
        let normal = stacked.d_local.tr_mul(&stacked.d_local);
        let gradient = stacked.d_local.tr_mul(&stacked.residuals);
        let step = -normal
            .cholesky()
            .ok_or_else(|| not_located(""))?
            .solve(&gradient);
        let change = (&stacked.d_local * &step).norm_squared();
        nuisance += step;
        stacked = fitted.at(&nuisance)?;
        if change < NUISANCE_TOLERANCE {
            converged = true;
            break;
        }
    }
    if !converged {
        return Err(not_located(&format!(
            " within {NUISANCE_ITERATIONS} Gauss-Newton steps"
        )));
    }
    if locating.reference {
        stacked = rows(points, poses).at(&nuisance)?;
    }
    // Rows of two units stay whitened (`L = I`).
    let unit = tracker_unit(mechanism, !points.is_empty(), true);
    let factor = match unit {
        NOISE_SIGMAS => DMatrix::identity(stacked.factor.nrows(), stacked.factor.ncols()),
        _ => stacked.factor.clone(),
    };
    let factor = &factor;
    let local = LocalRows {
        residuals: factor * &stacked.residuals,
        d_local: &(factor * &stacked.d_local),
        d_params: &(factor * &stacked.d_params),
        noise: factor * factor.transpose(),
    };
    let actuators = mechanism.actuators().len();
    locating
        .predict(held_out, &local, (points, poses, actuators), g)
        .ok_or_else(|| not_located(""))
}

/// A held-out tracker's whitened rows as functions of its nuisance: its
/// frame's correction, the body's, and its offsets if re-homed.
struct NuisanceRows<'a> {
    mechanism: &'a dyn Mechanism,
    params: &'a [f64],
    configured: &'a [f64],
    observations: &'a Observations,
    /// `F₀`, the located frame the correction is of.
    reference: Isometry3<f64>,
    points: &'a [usize],
    poses: &'a [usize],
    offsets: bool,
}

/// The stacked whitened rows ([`NuisanceRows::at`]).
struct Stacked {
    /// `r_w`.
    residuals: DVector<f64>,
    /// `dr_w/du`.
    d_local: DMatrix<f64>,
    /// `dr_w/dp`.
    d_params: DMatrix<f64>,
    /// `L`, block-diagonal: what un-whitens each observation's rows.
    factor: DMatrix<f64>,
}

impl NuisanceRows<'_> {
    /// The nuisance's size: 12, and the actuators' offsets.
    fn unknowns(&self) -> usize {
        12 + if self.offsets {
            self.mechanism.actuators().len()
        } else {
            0
        }
    }

    /// Every point's and pose's whitened rows at the nuisance `u`.
    fn at(&self, u: &DVector<f64>) -> Result<Stacked, MechanismCalibrationError> {
        let correction = |start: usize| {
            FrameCorrection::from_params(&nalgebra::Vector6::from_column_slice(
                &u.as_slice()[start..start + 6],
            ))
        };
        let frame = TrackerFrame {
            reference: self.reference,
            correction: correction(0),
        };
        let body = BodyFrame {
            reference: self.observations.body_reference,
            correction: correction(6),
        };
        let offsets = self.offsets.then(|| &u.as_slice()[12..]);
        let actuators = self.mechanism.actuators().len();
        let m = 3 * self.points.len() + actuators * self.poses.len();
        let (n, w) = (self.params.len(), u.len());
        let mut stacked = Stacked {
            residuals: DVector::zeros(m),
            d_local: DMatrix::zeros(m, w),
            d_params: DMatrix::zeros(m, n),
            factor: DMatrix::zeros(m, m),
        };
        let failed = |kind, index, e: MechanismError| MechanismCalibrationError::Observation {
            observation: ObservationRef { kind, index },
            reason: e.to_string(),
        };
        let mut row = 0;
        for &j in self.points {
            let point = &self.observations.tracker_points[j];
            let evaluated = point
                .evaluate(
                    self.mechanism,
                    self.params,
                    self.configured,
                    &frame,
                    offsets,
                    None,
                )
                .map_err(|e| failed(ObservationKind::TrackerPoint, j, e))?;
            let unwhiten = point.weight.covariance().cholesky().map(|c| c.l());
            let unwhiten = unwhiten.ok_or_else(|| {
                failed(ObservationKind::TrackerPoint, j, MechanismError::Singular)
            })?;
            let d_frame = DMatrix::from_column_slice(3, 6, evaluated.d_frame.as_slice());
            let d_offsets = evaluated.d_offsets.as_ref();
            stacked.put(row, &evaluated.rows, &[(0, &d_frame)], d_offsets);
            stacked
                .factor
                .view_mut((row, row), (3, 3))
                .copy_from(&unwhiten);
            row += 3;
        }
        for &j in self.poses {
            let pose = &self.observations.tracker_poses[j];
            let evaluated = pose
                .evaluate(self.mechanism, self.params, &frame, &body, offsets)
                .map_err(|e| failed(ObservationKind::TrackerPose, j, e))?;
            let unwhiten = pose
                .row_whitening(self.mechanism, self.params)
                .solve_lower_triangular(&DMatrix::identity(actuators, actuators))
                .ok_or_else(|| failed(ObservationKind::TrackerPose, j, MechanismError::Singular))?;
            let locals = [(0, &evaluated.d_frame), (6, &evaluated.d_body)];
            stacked.put(row, &evaluated.rows, &locals, evaluated.d_offsets.as_ref());
            stacked
                .factor
                .view_mut((row, row), (actuators, actuators))
                .copy_from(&unwhiten);
            row += actuators;
        }
        Ok(stacked)
    }
}

impl Stacked {
    /// Puts one observation's `rows` from `row` on: its residuals, `dr/dp`,
    /// each local derivative at its first nuisance column, its offsets'
    /// after the two frames.
    fn put(
        &mut self,
        row: usize,
        rows: &Rows,
        locals: &[(usize, &DMatrix<f64>)],
        d_offsets: Option<&DMatrix<f64>>,
    ) {
        let m = rows.residual.len();
        self.residuals.rows_mut(row, m).copy_from(&rows.residual);
        self.d_params
            .view_mut((row, 0), (m, rows.d_params.ncols()))
            .copy_from(&rows.d_params);
        for &(column, d) in locals {
            self.d_local
                .view_mut((row, column), (m, d.ncols()))
                .copy_from(d);
        }
        if let Some(d) = d_offsets {
            self.d_local
                .view_mut((row, 12), (m, d.ncols()))
                .copy_from(d);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mechanism::observation::ObservationKind;
    use crate::mechanism::predicted::predict::predict;
    use crate::mechanism::predicted::simulated::{far_frame, placement};
    use nalgebra::{Isometry3, Vector3};
    use parcal_kinematics::hexapod::Hexapod;
    use parcal_kinematics::mechanism::{design, prior_sigma};
    use parcal_observe::mechanism::{Actuation, TrackerPoint, TrackerPose};
    use parcal_simulate::Rng;

    /// A hexapod measured by a tracker at `frame`, a body mounted at `body`
    /// on its platform: `k` poses of the machine of parameters `truth`,
    /// each reading off by `error()` times 0.01 mm, and two tool points,
    /// each coordinate off by `error()` times 1 um (their stated noise);
    /// the body's reference a few hundredths off.
    fn posed(
        hexapod: &Hexapod,
        truth: &DVector<f64>,
        (frame, body): (&Isometry3<f64>, &Isometry3<f64>),
        k: usize,
        mut error: impl FnMut() -> f64,
    ) -> Observations {
        let sigma = 0.01;
        let at = crate::mechanism::problem::tests::hexapod_pose;
        let tracker_poses = (0..k)
            .map(|j| {
                let x = at(j);
                let q = hexapod.inverse(truth.as_slice(), &x).unwrap();
                let platform = hexapod.platform_frame(&x).unwrap();
                TrackerPose {
                    tracker: 0,
                    readings: q.iter().map(|q| q + sigma * error()).collect(),
                    measured: frame * platform * body,
                    weight: DMatrix::identity(6, 6) / sigma,
                }
            })
            .collect();
        let tracker_points = (k..k + 2)
            .map(|j| {
                let x = at(j);
                let tip = hexapod.tool_point(truth.as_slice(), &x).unwrap().point;
                let q = hexapod.inverse(truth.as_slice(), &x).unwrap();
                let off = Vector3::new(error(), error(), error()) * 1e-3;
                TrackerPoint {
                    tracker: 0,
                    at: Actuation::Readings(q.iter().copied().collect()),
                    measured: (frame.transform_point(&tip.into()).coords + off).into(),
                    weight: parcal_observe::CoordinateWhitening::isotropic(1e-3).unwrap(),
                }
            })
            .collect();
        Observations {
            trackers: vec![crate::mechanism::data::Tracker::new("T")],
            tracker_points,
            tracker_poses,
            body_reference: body
                * Isometry3::new(
                    Vector3::new(0.3, -0.2, 0.4),
                    Vector3::new(0.02, -0.01, 0.03),
                ),
            ..Default::default()
        }
    }

    /// A hexapod tracker's rows of `k` poses and 2 points (`posed`),
    /// predicted with `reference` observations: exact, zero at the truth
    /// and `G` against central differences over the parameters (returned
    /// for the caller's checks); noisy (seed `seed`), `T = r'ᵀ D⁻¹ r'`
    /// over 100 placements has the mean of its `χ²` within 4 standard
    /// errors.
    fn check_posed_rows(reference: Option<usize>, k: usize, seed: u64) -> PredictedRows {
        let hexapod = Hexapod::typical();
        let mut truth = design(&hexapod);
        for (k, value) in truth.iter_mut().enumerate() {
            *value += 0.05 * ((k as f64) * 1.7).sin();
        }
        let configured = design(&hexapod);
        let frame = far_frame();
        let body = Isometry3::new(Vector3::new(5.0, 8.0, 30.0), Vector3::new(0.03, 0.02, 2.6));
        let rows = |params: &DVector<f64>, observations: &Observations| {
            let mut predicted = predict(
                &hexapod,
                params,
                configured.as_slice(),
                observations,
                reference,
            )
            .unwrap();
            assert_eq!(predicted.len(), 1);
            predicted.remove(0)
        };
        let exact = posed(&hexapod, &truth, (&frame, &body), k, || 0.0);
        let at = rows(&truth, &exact);
        assert!(at.residuals.amax() < 1e-8, "{}", at.residuals);
        let steps = prior_sigma(&hexapod) * 1e-3;
        for j in 0..truth.len() {
            let (mut plus, mut minus) = (truth.clone(), truth.clone());
            plus[j] += steps[j];
            minus[j] -= steps[j];
            let column =
                (rows(&plus, &exact).residuals - rows(&minus, &exact).residuals) / (2.0 * steps[j]);
            // Central differences of a smooth function of step 1e-4 mm, the
            // located frames converged to 1e-6 of the noise.
            let error = (&column - at.d_global.column(j)).amax();
            assert!(error < 1e-5 * at.d_global.amax(), "column {j}: {error:e}");
        }
        let mut noise = Rng::new(seed, 0);
        let (mut total, mut n) = (0.0, 0);
        for draw in 0..100 {
            let frame = placement(draw);
            let observations = posed(&hexapod, &truth, (&frame, &body), k, || noise.normal(1.0));
            let at = rows(&truth, &observations);
            let d = at.noise.clone().cholesky().unwrap();
            total += at.residuals.dot(&d.solve(&at.residuals));
            n += at.residuals.len();
        }
        let mean = total / n as f64;
        let standard_error = (2.0 / n as f64).sqrt();
        println!("T/n {mean:.4} over {n} rows, standard error {standard_error:.4}");
        assert!((mean - 1.0).abs() < 4.0 * standard_error, "{mean}");
        at
    }

    /// A held-out tracker's poses locate its frame and the body anew:
    /// `6k + 3·2 − 12` rows of 6 poses ([`check_posed_rows`]).
    #[test]
    fn a_tracker_s_poses_locate_its_frame_and_body() {
        let at = check_posed_rows(None, 6, 41);
        assert_eq!(at.residuals.len(), 6 * 6 + 3 * 2 - 12);
        assert_eq!(
            at.observation.to_string(),
            "tracker 0 (tracker points 0-1, tracker poses 0-5)"
        );
    }

    /// A tracker's frame and the body located by its first 3 poses and
    /// first 3 points (both of its 2): its other 5 poses' rows, each named
    /// by its pose and reading ([`check_posed_rows`]).
    #[test]
    fn a_tracker_s_reference_poses_locate_its_frame_and_body() {
        let at = check_posed_rows(Some(3), 8, 47);
        assert_eq!(at.residuals.len(), 6 * 5);
        let pose = ObservationRef {
            kind: ObservationKind::TrackerPose,
            index: 3,
        };
        assert_eq!(
            (at.row_observations[0], at.row_observations[5]),
            ((pose, 0), (pose, 5))
        );
    }
}
