//! A mechanism calibration judged on held-out data of the same machine
//! (new probe heights, part distances, measured positions, touches of
//! balls): every observation predicted with the calibrated global block
//! `θ̂` ([`super::predicted`]), the calibration's covariance `Σ_θ`
//! propagated, and the verdict of [`crate::prediction`], as the hexapod's
//! validation.
//!
//! With `r` the predicted residuals, `D` their own noise (block-diagonal,
//! `D_i = L_i L_iᵀ`) and `G = dr/dθ`, to first order
//!
//! ```text
//! C = Cov(r) = D + G Σ_θ Gᵀ = L (I + V Vᵀ) Lᵀ,   V = L⁻¹ G Σ_θ^{1/2},
//! ```
//!
//! and `T = rᵀ C⁻¹ r ~ χ²(n)` over the `n` rows, tested against the
//! calibration's own variance factor ([`PredictionTest`]). Each row has its
//! w-test, `w_j = r_j / √C_jj` (standard normal under the model), against
//! the family-wise critical value over the `n` rows (Bonferroni, the
//! calibration's convention, [`critical_value`]); the verdict rejects when
//! either test does.
//!
//! The trigger height is the calibration's estimate when it made one; a
//! calibration without probe heights validated on probe heights takes it
//! from the held-out data's prior (its sigma a common error of every
//! probe). A sample's unknown pose is fitted to its own readings, a
//! ball's unknown centre to its touches, whose rows are the ball's
//! ([`super::predicted`]).
//!
//! What changed, when the data reject: for each unknown `θ_k` alone, the
//! change of the machine `δ_k` that best explains the residuals (the data
//! measured at `θ̂ + δ_k e_k`, so `r ≈ −G e_k δ_k`), by generalised least
//! squares, `δ_k = −⟨a_k, z⟩ / ⟨a_k, a_k⟩` with `z = L⁻¹ r`,
//! `a_k = L⁻¹ G e_k` and `⟨x, y⟩ = xᵀ (I + V Vᵀ)⁻¹ y`, its sigma
//! `⟨a_k, a_k⟩^{-1/2}`, and the statistic left,
//! `T − ⟨a_k, z⟩² / ⟨a_k, a_k⟩` ([`ParameterShift`]).
//!
//! With `W = L⁻¹ G` (its columns the `a_k`) and `V = W Σ_θ^{1/2}`, every
//! product these take is one of `zᵀz`, `Wᵀz` and `WᵀW`: `VᵀV = Σ_θ^{1/2}ᵀ
//! WᵀW Σ_θ^{1/2}`, `Vᵀz` and `Vᵀa_k` likewise. They are summed as the rows
//! are whitened, so that `W` and `V` (`n × g` each) are never kept.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;

use crate::hypothesis::critical_value;
use crate::prediction::{PredictionTest, RowProducts, WhitenedCovariance, square_root};

use super::calibrated::CalibratedMechanism;
use super::data::MechanismData;
use super::error::MechanismCalibrationError;
use super::observation::{HeldOut, ObservationKind, ObservationRef};
use super::predicted::{PredictedRows, predict, tracker_unit};
use super::result::TRIGGER_HEIGHT;

/// The shifts [`MechanismValidation::shifts`] lists.
const SHIFTS: usize = 3;

/// One predicted row.
#[derive(Debug, Clone, PartialEq)]
pub struct ValidatedRow {
    /// Its observation by its place in the held-out data (with reference
    /// observations, the touch, ball distance, tracker point or pose it
    /// predicts), or the ball or tracker whose rows it combines.
    pub observation: HeldOut,
    /// Its row within the observation.
    pub row: usize,
    /// Its unit (`mm`, or the actuators' for a sample's redundant
    /// readings).
    pub unit: String,
    /// The residual `r_j` (prediction less measurement).
    pub residual: f64,
    /// Its predicted standard deviation `√C_jj`.
    pub sigma: f64,
    /// Its w-test statistic `r_j / √C_jj`.
    pub w: f64,
}

/// A change of one unknown that would explain the residuals (module doc).
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterShift {
    /// The unknown (a parameter, or the trigger height).
    pub name: String,
    /// Its unit.
    pub unit: String,
    /// `δ_k`.
    pub shift: f64,
    /// Its standard deviation.
    pub sigma: f64,
    /// The prediction test of the residuals with the shift applied
    /// (`n − 1` degrees of freedom).
    pub test: Option<PredictionTest>,
}

/// A validation of a mechanism calibration (module doc).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct MechanismValidation {
    /// The mechanism.
    pub mechanism: String,
    /// Every predicted row, in the order of the observations.
    pub rows: Vec<ValidatedRow>,
    /// Point samples at an unknown pose that gave no row (as many
    /// actuators as pose coordinates: nothing to predict).
    pub untested: usize,
    /// The reference observations `N`: each held-out ball's centre located
    /// by its first `N` touches and each tracker's frame (and body) by its
    /// first `N` points and poses, the others predicted; `None`: each
    /// projected out of all its rows.
    pub reference: Option<usize>,
    /// `T = rᵀ C⁻¹ r`.
    pub statistic: f64,
    /// The prediction test of `T`.
    pub test: Option<PredictionTest>,
    /// The w-tests' family-wise level `α`.
    pub alpha: f64,
    /// Their critical value.
    pub critical_value: f64,
    /// The single-unknown changes that best explain the residuals, the
    /// best first.
    pub shifts: Vec<ParameterShift>,
    /// The held-out balls (their indices) whose reference touches fit
    /// their centre and its mirror image about as well, located at the
    /// mirror image, which all their touches fit
    /// ([`located_side`](crate::mirror::located_side)).
    pub mirrored_balls: Vec<usize>,
}

impl MechanismValidation {
    /// Whether the global test passes.
    pub fn global_test_passes(&self) -> bool {
        self.test.is_none_or(|t| !t.rejects())
    }

    /// The rows whose w-test fails.
    pub fn failing_rows(&self) -> impl Iterator<Item = &ValidatedRow> {
        self.rows
            .iter()
            .filter(|row| row.w.abs() > self.critical_value)
    }

    /// Whether the calibration predicts these data: neither the global
    /// test nor a w-test rejects.
    pub fn accepted(&self) -> bool {
        self.global_test_passes() && self.failing_rows().next().is_none()
    }

    /// The row of largest `|w|`.
    pub fn worst(&self) -> Option<&ValidatedRow> {
        self.rows
            .iter()
            .max_by(|a, b| a.w.abs().total_cmp(&b.w.abs()))
    }
}

/// Validates `calibrated` on the held-out `data` (module doc); the
/// w-tests at family-wise level `alpha`; with `reference` observations
/// `N`, each held-out ball's centre located by its first `N` touches and
/// each tracker's frame (and body) by its first `N` points and poses, the
/// others predicted (refused beside sample poses, which their own readings
/// locate). Errors name the observation that cannot be predicted.
pub fn validate_mechanism(
    calibrated: &CalibratedMechanism,
    data: &MechanismData,
    alpha: f64,
    reference: Option<usize>,
) -> Result<MechanismValidation, MechanismCalibrationError> {
    data.validate()?;
    let mechanism = calibrated.mechanism.as_ref();
    if data.mechanism.name() != mechanism.name() {
        return Err(MechanismCalibrationError::InvalidData {
            what: "mechanism".to_string(),
            reason: format!(
                "the calibration is of a {}, the data of a {}",
                mechanism.name(),
                data.mechanism.name()
            ),
        });
    }
    if !(alpha > 0.0 && alpha < 1.0) {
        return Err(MechanismCalibrationError::InvalidData {
            what: "alpha".to_string(),
            reason: format!("{alpha} is not a level in (0, 1)"),
        });
    }
    let (global, covariance, names) = global_block(calibrated, data)?;
    let predicted = predict(
        mechanism,
        &global,
        &data.configured,
        &data.observations,
        reference,
    )?;
    let root = square_root(&covariance);
    let whitened = Whitened::of(&predicted, &root)?;
    let metric = whitened.metric(&root);
    let statistic = metric.inner(whitened.zz, &whitened.vz, &whitened.vz);
    let n = whitened.rows;
    let test = PredictionTest::new(statistic, n, calibrated.global_test);
    let reading_unit = &*mechanism.actuators()[0].unit;
    let mut rows = Vec::with_capacity(n);
    for (rows_of, first) in predicted.iter().zip(&whitened.first_rows) {
        let unit = match &rows_of.observation {
            HeldOut::Observation(observation) if redundant_readings(data, observation) => {
                reading_unit
            }
            HeldOut::Tracker { points, poses, .. } => {
                tracker_unit(mechanism, !points.is_empty(), !poses.is_empty())
            }
            _ => "mm",
        };
        for j in 0..rows_of.residuals.len() {
            let variance = whitened.variances[first + j];
            // A row that predicts one observation by itself is named by it.
            let (observation, row) = match rows_of.row_observations.get(j) {
                Some(&(observation, row)) => (HeldOut::Observation(observation), row),
                None => (rows_of.observation.clone(), j),
            };
            rows.push(ValidatedRow {
                observation,
                row,
                unit: unit.to_string(),
                residual: rows_of.residuals[j],
                sigma: variance.sqrt(),
                w: rows_of.residuals[j] / variance.sqrt(),
            });
        }
    }
    let units: Vec<&str> = mechanism
        .parameters()
        .iter()
        .map(|p| &*p.unit)
        .chain(std::iter::once("mm"))
        .collect();
    let shifts = shifts(&whitened, &metric, statistic, calibrated, &names, &units);
    let samples_with_rows = predicted
        .iter()
        .filter(|p| match &p.observation {
            HeldOut::Observation(observation) => observation.kind == ObservationKind::Sample,
            HeldOut::Ball { .. } | HeldOut::Tracker { .. } | HeldOut::TiedBalls { .. } => false,
        })
        .count();
    let mirrored_balls = predicted
        .iter()
        .flat_map(|p| p.mirrored_balls.iter().copied())
        .collect();
    Ok(MechanismValidation {
        mechanism: mechanism.name().to_string(),
        rows,
        untested: data.observations.samples.len() - samples_with_rows,
        reference,
        statistic,
        test,
        alpha,
        critical_value: critical_value(alpha, n),
        shifts,
        mirrored_balls,
    })
}

/// Whether `observation`'s rows are a point sample's redundant readings
/// (its pose unknown).
fn redundant_readings(data: &MechanismData, observation: &ObservationRef) -> bool {
    observation.kind == ObservationKind::Sample
        && data.observations.samples[observation.index]
            .known_pose
            .is_none()
}

/// A global block's values, covariance and unknowns' names.
type GlobalBlock = (DVector<f64>, DMatrix<f64>, Vec<String>);

/// The global block the predictions take, its covariance and its
/// unknowns' names: the calibration's, with the held-out data's trigger
/// height prior appended when the data have probe heights and the
/// calibration no trigger height.
fn global_block(
    calibrated: &CalibratedMechanism,
    data: &MechanismData,
) -> Result<GlobalBlock, MechanismCalibrationError> {
    let mut names: Vec<String> = calibrated
        .mechanism
        .parameters()
        .iter()
        .map(|p| p.name.clone())
        .collect();
    names.push(TRIGGER_HEIGHT.to_string());
    let (values, covariance) = (&calibrated.values, &calibrated.covariance);
    if !data.has_trigger_height() || calibrated.trigger_height().is_some() {
        names.truncate(values.len());
        return Ok((values.clone(), covariance.clone(), names));
    }
    let prior = data.trigger_height;
    let sigma = prior.sigma.ok_or_else(|| MechanismCalibrationError::InvalidData {
        what: "trigger height".to_string(),
        reason: "the calibration did not estimate one, and the data's prior has no sigma: give the data's trigger height a prior sigma".to_string(),
    })?;
    let g = values.len() + 1;
    let global = values.clone().resize_vertically(g, prior.mean);
    let mut extended = DMatrix::zeros(g, g);
    extended
        .view_mut((0, 0), (g - 1, g - 1))
        .copy_from(covariance);
    extended[(g - 1, g - 1)] = sigma * sigma;
    Ok((global, extended, names))
}

/// The predicted rows whitened by their own noise, as the products the
/// tests take (module doc).
struct Whitened {
    /// The rows `n`.
    rows: usize,
    /// `zᵀz`, `z = L⁻¹ r`.
    zz: f64,
    /// `WᵀW`, `W = L⁻¹ G`.
    ww: DMatrix<f64>,
    /// `Wᵀz`.
    wz: DVector<f64>,
    /// `VᵀW = Σ_θ^{1/2}ᵀ WᵀW`: its column `k` is `Vᵀa_k`.
    vw: DMatrix<f64>,
    /// `Vᵀz = Σ_θ^{1/2}ᵀ Wᵀz`.
    vz: DVector<f64>,
    /// `C_jj` of every row.
    variances: Vec<f64>,
    /// Each observation's first row.
    first_rows: Vec<usize>,
}

impl Whitened {
    /// The rows `predicted` whitened, `root` the square root `Σ_θ^{1/2}` of
    /// the global block's covariance. An error names an observation whose
    /// noise covariance is not positive definite (it always is for valid
    /// data: a sigma's square, or a measured position's plus a positive
    /// semi-definite term).
    fn of(
        predicted: &[PredictedRows],
        root: &DMatrix<f64>,
    ) -> Result<Self, MechanismCalibrationError> {
        let g = root.nrows();
        // Pieces of observations on the threads, each summed on its own,
        // then the pieces' sums added in their order: the same bits on any
        // number of threads, the first error in the observations' order.
        let pieces: Vec<_> = (predicted.par_chunks(WHITENED_PIECE))
            .map(|piece| whiten_piece(piece, root))
            .collect();
        let (mut zz, mut ww, mut wz) = (0.0, DMatrix::zeros(g, g), DVector::zeros(g));
        let mut variances = Vec::new();
        let mut first_rows = Vec::with_capacity(predicted.len());
        for piece in pieces {
            let piece = piece?;
            zz += piece.zz;
            ww += piece.ww;
            wz += piece.wz;
            let offset = variances.len();
            first_rows.extend(piece.first_rows.iter().map(|first| offset + first));
            variances.extend(piece.variances);
        }
        Ok(Self {
            rows: variances.len(),
            zz,
            vz: root.tr_mul(&wz),
            vw: root.tr_mul(&ww),
            ww,
            wz,
            variances,
            first_rows,
        })
    }

    /// The covariance `I + V Vᵀ` of the whitened rows, by `VᵀV = VᵀW
    /// Σ_θ^{1/2}`.
    fn metric(&self, root: &DMatrix<f64>) -> WhitenedCovariance {
        WhitenedCovariance::from_gram(&(&self.vw * root))
    }
}

/// The observations [`Whitened::of`] whitens at a time on a thread.
const WHITENED_PIECE: usize = 1024;

/// A piece of observations whitened: its sums and each row's `C_jj`.
struct WhitenedPiece {
    /// `zᵀz` over its rows.
    zz: f64,
    /// `WᵀW` over its rows.
    ww: DMatrix<f64>,
    /// `Wᵀz` over its rows.
    wz: DVector<f64>,
    /// `C_jj` of each of its rows.
    variances: Vec<f64>,
    /// Each observation's first row among them.
    first_rows: Vec<usize>,
}

/// The observations `piece` whitened ([`Whitened::of`]).
fn whiten_piece(
    piece: &[PredictedRows],
    root: &DMatrix<f64>,
) -> Result<WhitenedPiece, MechanismCalibrationError> {
    let mut products = RowProducts::new(root.nrows());
    let mut variances = Vec::new();
    let mut first_rows = Vec::with_capacity(piece.len());
    for rows in piece {
        let m = rows.residuals.len();
        let reason = "its predicted noise covariance is not positive definite".to_string();
        let not_definite = || match &rows.observation {
            HeldOut::Observation(observation) => MechanismCalibrationError::Observation {
                observation: *observation,
                reason: reason.clone(),
            },
            ball => MechanismCalibrationError::InvalidData {
                what: ball.to_string(),
                reason: reason.clone(),
            },
        };
        let l = rows.noise.clone().cholesky().ok_or_else(not_definite)?.l();
        let solve = |b: &DMatrix<f64>| l.solve_lower_triangular(b).ok_or_else(not_definite);
        let residuals = DMatrix::from_column_slice(m, 1, rows.residuals.as_slice());
        products.add(&solve(&rows.d_global)?, &solve(&residuals)?.column(0));
        let common = &rows.d_global * root;
        first_rows.push(variances.len());
        for j in 0..m {
            variances.push(rows.noise[(j, j)] + common.row(j).norm_squared());
        }
    }
    let (zz, ww, wz) = products.sums();
    Ok(WhitenedPiece {
        zz,
        ww,
        wz,
        variances,
        first_rows,
    })
}

/// The [`SHIFTS`] single-unknown shifts that leave the least statistic
/// (module doc).
fn shifts(
    whitened: &Whitened,
    metric: &WhitenedCovariance,
    statistic: f64,
    calibrated: &CalibratedMechanism,
    names: &[String],
    units: &[&str],
) -> Vec<ParameterShift> {
    let n = whitened.rows;
    let mut shifts: Vec<(f64, ParameterShift)> = Vec::new();
    for k in 0..whitened.vw.ncols() {
        let va_k = whitened.vw.column(k).into_owned();
        let squared = whitened.ww[(k, k)];
        let aa = metric.inner(squared, &va_k, &va_k);
        let az = metric.inner(whitened.wz[k], &va_k, &whitened.vz);
        // A column the data do not see (or see only through the
        // calibration's uncertainty, relative to rounding) explains
        // nothing.
        let seen = aa > 1e-12 * squared.max(f64::MIN_POSITIVE);
        if !seen {
            continue;
        }
        let left = (statistic - az * az / aa).max(0.0);
        shifts.push((
            left,
            ParameterShift {
                name: names[k].clone(),
                unit: units[k].to_string(),
                shift: -az / aa,
                sigma: aa.sqrt().recip(),
                test: n
                    .checked_sub(1)
                    .and_then(|m| PredictionTest::new(left, m, calibrated.global_test)),
            },
        ));
    }
    shifts.sort_by(|a, b| a.0.total_cmp(&b.0));
    shifts.into_iter().take(SHIFTS).map(|(_, s)| s).collect()
}
