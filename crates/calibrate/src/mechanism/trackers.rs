//! The trackers' frames in the global block: each tracker `k` sees the
//! mechanism's frame through `F_k = F₀_k ∘ C_k`
//! ([`TrackerFrame`]), `C_k = (Exp(ω), τ)` six unknowns of the global
//! block (after the mechanism's parameters and the trigger height,
//! [`super::prior::global_priors`]), without a prior.
//!
//! `F₀_k` is fixed before the fit: the rigid motion that best maps the
//! tool points its points reach at the priors' means onto the points it
//! measured (Kabsch), as the hexapod's own calibration starts a session of
//! points alone. `C_k` starts at zero; what is reported is `F_k`.

use nalgebra::{DVector, Isometry3, Matrix3, Rotation3, Translation3, UnitQuaternion, Vector6};
use parcal_accuracy::kabsch;
use parcal_kinematics::Vec3;
use parcal_observe::FrameCorrection;
use parcal_observe::mechanism::{Actuation, TrackerFrame};

use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::observation::{ObservationKind, ObservationRef};
use super::prior::FRAME_UNKNOWNS;

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
}

impl Trackers {
    /// The trackers of `data` (validated), their corrections from global
    /// column `first` on, their references located at the parameters
    /// `params` (module doc). An error names the tracker point whose tool
    /// point cannot be reached, or the tracker whose points lie on a line.
    pub(crate) fn locate(
        data: &MechanismData,
        params: &[f64],
        first: usize,
    ) -> Result<Self, MechanismCalibrationError> {
        let o = &data.observations;
        let mechanism = data.mechanism.as_ref();
        let configured = data.configured.as_slice();
        let references = (0..o.trackers.len())
            .map(|k| {
                let (indices, targets): (Vec<usize>, Vec<Vec3>) = (o.tracker_points.iter())
                    .enumerate()
                    .filter(|(_, point)| point.tracker == k)
                    .map(|(j, point)| (j, Vec3::from(point.measured)))
                    .unzip();
                let actuations: Vec<&Actuation> =
                    indices.iter().map(|&j| &o.tracker_points[j].at).collect();
                let starts = vec![None; actuations.len()];
                let reached =
                    Actuation::tool_points(mechanism, params, configured, &actuations, &starts);
                let tips = reached
                    .into_iter()
                    .zip(&indices)
                    .map(|(reached, &j)| {
                        reached.map(|r| r.point).map_err(|e| {
                            let observation = ObservationRef {
                                kind: ObservationKind::TrackerPoint,
                                index: j,
                            };
                            MechanismCalibrationError::Observation {
                                observation,
                                reason: format!("its tool point at the priors' means: {e}"),
                            }
                        })
                    })
                    .collect::<Result<Vec<Vec3>, _>>()?;
                let not_located = |reason: String| MechanismCalibrationError::InvalidData {
                    what: format!("tracker {:?}", o.trackers[k]),
                    reason: format!("its points do not locate its frame: {reason}"),
                };
                if spread(&targets) < MIN_SPREAD {
                    return Err(not_located("they lie on a line".to_string()));
                }
                let motion = kabsch(&tips, &targets).map_err(|e| not_located(e.to_string()))?;
                Ok(isometry(motion.rotation, motion.translation))
            })
            .collect::<Result<_, _>>()?;
        Ok(Self { references, first })
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
        let o = &data.observations;
        let mechanism = data.mechanism.as_ref();
        let configured = data.configured.as_slice();
        let actuations: Vec<&Actuation> = o.tracker_points.iter().map(|p| &p.at).collect();
        let starts = vec![None; actuations.len()];
        let tips = |params: &[f64]| {
            Actuation::tool_points(mechanism, params, configured, &actuations, &starts)
                .into_iter()
                .enumerate()
                .map(|(j, reached)| {
                    reached.map(|r| r.point).map_err(|e| {
                        let observation = ObservationRef {
                            kind: ObservationKind::TrackerPoint,
                            index: j,
                        };
                        MechanismCalibrationError::Observation {
                            observation,
                            reason: format!("its tool point in the canonical frame: {e}"),
                        }
                    })
                })
                .collect::<Result<Vec<Vec3>, _>>()
        };
        let motion = kabsch(&tips(params)?, &tips(moved)?).map_err(|e| {
            MechanismCalibrationError::InvalidData {
                what: "the trackers' points".to_string(),
                reason: format!("they do not locate the canonical frame: {e}"),
            }
        })?;
        let inverse = isometry(motion.rotation, motion.translation).inverse();
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

/// `R x + t` as an isometry.
fn isometry(rotation: Rotation3<f64>, translation: Vec3) -> Isometry3<f64> {
    Isometry3::from_parts(
        Translation3::from(translation),
        UnitQuaternion::from_rotation_matrix(&rotation),
    )
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
