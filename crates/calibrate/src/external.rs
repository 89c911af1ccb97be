//! External reliability as a shift of the parameters (Baarda 1968;
//! Förstner and Wrobel, "Photogrammetric Computer Vision", 2016, section
//! 4.6.5): for the [`LEAST_RELIABLE`] observations of largest
//! bias-to-noise ratio `λ` ([`crate::reliability`]), the shift of the
//! global block that an undetected error of one minimal detectable bias in
//! the observation's row of largest `λ` makes,
//!
//! ```text
//! ∇g = −Cov(g) u_j ∇₀,     ∇₀ = δ₀ / √r_j,     λ_j = δ₀ √(|z_j|² / r_j),
//! ```
//!
//! the error `∇₀` (row sigmas) increasing the row's whitened residual
//! ([`parcal_solver::row_influence`], which eliminates only those
//! observations' balls again). Its effect on the registered accuracy map
//! is the report's (`parcal_report::diagnostics`).

use nalgebra::{DMatrix, DVector};
use parcal_solver::{Problem, RowId, State, normalised_residual, row_influence};

use crate::CalibrateError;
use crate::reliability::{ObservationCheck, ObservationId};

/// How many observations get their shift: those of largest `λ`.
pub const LEAST_RELIABLE: usize = 5;

/// What an undetected error of one minimal detectable bias in one
/// observation does to the global block.
#[derive(Debug, Clone, PartialEq)]
pub struct ExternalShift {
    /// The observation.
    pub observation: ObservationId,
    /// Its row of largest `λ` (a pose's leg, a point's coordinate, a
    /// contact's whitened coordinate row).
    pub row: usize,
    /// That row's redundancy number `r_j`.
    pub redundancy: f64,
    /// Its minimal detectable bias `∇₀ = δ₀ / √r_j`, in row sigmas.
    pub minimal_detectable_bias: f64,
    /// Its bias-to-noise ratio `λ_j`.
    pub bias_to_noise: f64,
    /// `∇g`, the shift of the global block (its units: mm, rad).
    pub global_shift: DVector<f64>,
}

/// The shifts of the [`LEAST_RELIABLE`] observations of `checks` (the
/// contacts, one per point of `problem` in its order, then the global
/// observations), largest `λ` first (ties in the order of `checks`), for
/// minimal detectable biases `delta0 / √r` row sigmas.
pub fn external_shifts<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    covariance: &DMatrix<f64>,
    caches: &mut Vec<Pr::PointCache>,
    checks: &[ObservationCheck],
    delta0: f64,
) -> Result<Vec<ExternalShift>, CalibrateError> {
    let lambda = |k: usize| checks[k].bias_to_noise.unwrap_or(0.0);
    let mut chosen: Vec<usize> = (0..checks.len())
        .filter(|&k| checks[k].bias_to_noise.is_some())
        .collect();
    chosen.sort_by(|&a, &b| lambda(b).total_cmp(&lambda(a)).then(a.cmp(&b)));
    chosen.truncate(LEAST_RELIABLE);
    let points = state.points.len();
    let rows_of = |k: usize| -> Vec<RowId> {
        if k < points {
            (0..R).map(|row| RowId::Point { point: k, row }).collect()
        } else {
            // After the rows of the global observations before it.
            let first: usize = checks[points..k].iter().map(|c| c.observation.rows()).sum();
            (0..checks[k].observation.rows())
                .map(|row| RowId::GlobalObservation(first + row))
                .collect()
        }
    };
    let rows: Vec<RowId> = chosen.iter().flat_map(|&k| rows_of(k)).collect();
    let influences =
        row_influence(problem, state, covariance, caches, &rows).map_err(|status| {
            CalibrateError::Calibration {
                reason: format!("the external reliability could not be computed: {status:?}"),
            }
        })?;
    let mut influences = influences.into_iter();
    Ok(chosen
        .iter()
        .filter_map(|&k| {
            let rows: Vec<_> = influences
                .by_ref()
                .take(rows_of(k).len())
                .enumerate()
                .collect();
            // The row of largest λ, among those another row checks.
            let row = rows
                .into_iter()
                .filter(|(_, i)| normalised_residual(0.0, i.redundancy).is_some())
                .map(|(row, i)| {
                    let lambda = delta0 * (i.global_leverage.max(0.0) / i.redundancy).sqrt();
                    (row, i, lambda)
                })
                .max_by(|a, b| a.2.total_cmp(&b.2).then(b.0.cmp(&a.0)))?;
            let (row, influence, bias_to_noise) = row;
            let mdb = delta0 / influence.redundancy.sqrt();
            Some(ExternalShift {
                observation: checks[k].observation,
                row,
                redundancy: influence.redundancy,
                minimal_detectable_bias: mdb,
                bias_to_noise,
                global_shift: influence.global_shift * mdb,
            })
        })
        .collect())
}
