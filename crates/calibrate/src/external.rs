//! External reliability as a shift of the parameters (Baarda 1968;
//! Förstner and Wrobel, "Photogrammetric Computer Vision", 2016, section
//! 4.6.5): for the [`SHIFTED`] observations of largest
//! bias-to-noise ratio `λ` (the first of
//! [`Reliability::least_reliable`](crate::reliability::Reliability::least_reliable)),
//! the shift of the
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
use crate::observation::ObservationId;

/// How many observations get their shift: those of largest `λ` (no more
/// than the checks keep, [`crate::reliability::LEAST_RELIABLE`]).
pub const SHIFTED: usize = 5;

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

/// The shifts of the observations `chosen` (largest `λ` first, as
/// [`Reliability::least_reliable`](crate::reliability::Reliability::least_reliable)
/// has them) of `problem`, whose
/// points are the contacts of measurements.csv rows `contacts` (in the
/// solver's order) and whose global observation rows are those of `global`
/// in order, for minimal detectable biases `delta0 / √r` row sigmas.
#[allow(clippy::too_many_arguments)]
pub fn external_shifts<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    covariance: &DMatrix<f64>,
    caches: &mut Vec<Pr::PointCache>,
    chosen: &[(ObservationId, f64)],
    contacts: &[u32],
    global: &[ObservationId],
    delta0: f64,
) -> Result<Vec<ExternalShift>, CalibrateError> {
    let missing = |observation: ObservationId| CalibrateError::Calibration {
        reason: format!("the external reliability of {observation}: not among the observations"),
    };
    // The rows of each chosen observation: a contact's its point's, found
    // through the solver's order (a scan for each of a few contacts); a
    // global observation's after the rows of those before it.
    let rows_of = |observation: ObservationId| -> Result<Vec<RowId>, CalibrateError> {
        if let ObservationId::Contact(row) = observation {
            let point = contacts
                .iter()
                .position(|&r| r as usize == row)
                .ok_or_else(|| missing(observation))?;
            return Ok((0..R).map(|row| RowId::Point { point, row }).collect());
        }
        let k = global
            .iter()
            .position(|&o| o == observation)
            .ok_or_else(|| missing(observation))?;
        let first: usize = global[..k].iter().map(|o| o.rows()).sum();
        Ok((0..observation.rows())
            .map(|row| RowId::GlobalObservation(first + row))
            .collect())
    };
    let chosen_rows = chosen
        .iter()
        .map(|&(observation, _)| rows_of(observation))
        .collect::<Result<Vec<_>, _>>()?;
    let rows = chosen_rows.concat();
    let influences =
        row_influence(problem, state, covariance, caches, &rows).map_err(|status| {
            CalibrateError::Calibration {
                reason: format!("the external reliability could not be computed: {status:?}"),
            }
        })?;
    let mut influences = influences.into_iter();
    Ok(chosen
        .iter()
        .zip(&chosen_rows)
        .filter_map(|(&(observation, _), own)| {
            let rows: Vec<_> = influences.by_ref().take(own.len()).enumerate().collect();
            // The row of largest λ, among those another row checks.
            let candidates: Vec<_> = rows
                .into_iter()
                .filter(|(_, i)| normalised_residual(0.0, i.redundancy).is_some())
                .map(|(row, i)| {
                    let lambda = delta0 * (i.global_leverage.max(0.0) / i.redundancy).sqrt();
                    (row, i, lambda)
                })
                .collect();
            let first = first_largest(candidates.iter().map(|c| c.2))?;
            let (row, influence, bias_to_noise) = candidates.into_iter().nth(first)?;
            let mdb = delta0 / influence.redundancy.sqrt();
            Some(ExternalShift {
                observation,
                row,
                redundancy: influence.redundancy,
                minimal_detectable_bias: mdb,
                bias_to_noise,
                global_shift: influence.global_shift * mdb,
            })
        })
        .collect())
}

/// Relative difference below which two rows' `λ` tie: rounding, not the
/// data, tells them apart (a contact's rows share their redundancy, and
/// their `λ` differ in the last digits when the statistic is the same).
const TIE: f64 = 1e-9;

/// The index of the first of `values` within [`TIE`] of their largest, so
/// that a tie goes to the first row whatever the rounding; `None` when
/// there is none.
fn first_largest(values: impl Iterator<Item = f64> + Clone) -> Option<usize> {
    let largest = values.clone().fold(f64::NEG_INFINITY, f64::max);
    values
        .into_iter()
        .position(|v| v >= largest - TIE * largest.abs())
}

#[cfg(test)]
mod tests {
    use super::first_largest;

    #[test]
    fn a_tie_within_rounding_goes_to_the_first_row() {
        let near = 2.0 * (1.0 + 1e-13);
        assert_eq!(first_largest([1.0, near, 2.0].into_iter()), Some(1));
        assert_eq!(first_largest([1.0, 2.0, near].into_iter()), Some(1));
        assert_eq!(first_largest([3.0, 2.0, 2.0].into_iter()), Some(0));
        assert_eq!(first_largest([1.0, 2.0, 2.0 + 1e-6].into_iter()), Some(2));
        assert_eq!(first_largest(std::iter::empty()), None);
    }
}
