//! Greedy A-optimal selection by rank-`r` Woodbury updates.
//!
//! With `C` the covariance of the unknowns and a candidate's whitened rows
//! `M` ([`super::information`]), the covariance after its measurement is
//!
//! ```text
//! C' = C − C Mᵀ (I + M C Mᵀ)⁻¹ M C = C − G Gᵀ,   G = C Mᵀ L⁻ᵀ,  L Lᵀ = I + M C Mᵀ,
//! ```
//!
//! valid for a singular `C` too (a covariance in a canonical frame). The
//! criterion is the trace of the covariance of a group of values `R u`
//! (rows of the canonical frame's derivative), `tr(R C Rᵀ)`, which the
//! measurement lowers by `‖R G‖²_F`: each pick costs `O(g² r)` per
//! candidate, and only the chosen one updates `C`. A candidate may be
//! picked again (a repeated measurement adds its information again).

use nalgebra::DMatrix;

/// One pick.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pick {
    /// The candidate's index.
    pub candidate: usize,
    /// `tr(R C Rᵀ)` after this and the earlier picks.
    pub trace_after: f64,
}

/// `tr(R C Rᵀ)`.
pub fn group_trace(covariance: &DMatrix<f64>, objective: &DMatrix<f64>) -> f64 {
    (objective * covariance * objective.transpose()).trace()
}

/// `G = C Mᵀ L⁻ᵀ` (module doc); `None` if `I + M C Mᵀ` is not positive
/// definite (a covariance that is not).
fn factor(covariance: &DMatrix<f64>, m: &DMatrix<f64>) -> Option<DMatrix<f64>> {
    let cm = covariance * m.transpose();
    let middle = DMatrix::identity(m.nrows(), m.nrows()) + m * &cm;
    let l = middle.cholesky()?.l();
    let solved = l.solve_lower_triangular(&cm.transpose())?;
    Some(solved.transpose())
}

/// Picks `count` of the candidates whose rows are `rows` (`None`: not
/// feasible), each the one that most lowers `tr(R C Rᵀ)` (the first of
/// equals), starting from `covariance`; returns the picks and the
/// covariance after them. `None` if no candidate is feasible.
pub fn select(
    covariance: &DMatrix<f64>,
    rows: &[Option<DMatrix<f64>>],
    objective: &DMatrix<f64>,
    count: usize,
) -> Option<(Vec<Pick>, DMatrix<f64>)> {
    let mut covariance = covariance.clone();
    let mut picks = Vec::with_capacity(count);
    for _ in 0..count {
        let mut best: Option<(usize, f64, DMatrix<f64>)> = None;
        for (k, m) in rows.iter().enumerate() {
            let Some(g) = m.as_ref().and_then(|m| factor(&covariance, m)) else {
                continue;
            };
            let gain = (objective * &g).norm_squared();
            if best.as_ref().is_none_or(|b| gain > b.1) {
                best = Some((k, gain, g));
            }
        }
        let (candidate, _, g) = best?;
        covariance -= &g * g.transpose();
        picks.push(Pick {
            candidate,
            trace_after: group_trace(&covariance, objective),
        });
    }
    Some((picks, covariance))
}

/// The covariance after measurements of rows `rows`, by the dense inverse
/// `(C⁻¹ + Σ MᵀM)⁻¹` (for checking [`select`]); `None` if `C` or the
/// result is singular.
pub fn dense_covariance(covariance: &DMatrix<f64>, rows: &[&DMatrix<f64>]) -> Option<DMatrix<f64>> {
    let mut information = covariance.clone().try_inverse()?;
    for m in rows {
        information += m.transpose() * *m;
    }
    information.try_inverse()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small problem: the Woodbury picks equal the dense inverse, the
    /// traces fall, and the first pick beats every other candidate alone.
    #[test]
    fn woodbury_picks_follow_the_dense_inverse() {
        let g = 5;
        let covariance = DMatrix::from_fn(g, g, |i, j| {
            if i == j {
                2.0 + i as f64
            } else {
                0.3 / (1.0 + (i + j) as f64)
            }
        });
        let rows: Vec<Option<DMatrix<f64>>> = (0..8)
            .map(|k| {
                (k != 3).then(|| {
                    DMatrix::from_fn(2, g, |i, j| {
                        ((k * 7 + i * 3 + j * 5) % 11) as f64 / 5.0 - 1.0
                    })
                })
            })
            .collect();
        let objective = DMatrix::from_fn(2, g, |i, j| if j == i + 1 { 1.0 } else { 0.0 });
        let (picks, after) = select(&covariance, &rows, &objective, 4).unwrap();
        assert!(picks.iter().all(|p| p.candidate != 3));
        assert!(
            picks
                .windows(2)
                .all(|w| w[1].trace_after < w[0].trace_after)
        );
        let chosen: Vec<&DMatrix<f64>> = picks
            .iter()
            .map(|p| rows[p.candidate].as_ref().unwrap())
            .collect();
        let dense = dense_covariance(&covariance, &chosen).unwrap();
        assert!((&dense - &after).amax() < 1e-12 * dense.amax());
        let trace = group_trace(&dense, &objective);
        assert!((trace - picks[3].trace_after).abs() < 1e-12 * trace);
        for m in rows.iter().flatten() {
            let alone = dense_covariance(&covariance, &[m]).unwrap();
            assert!(group_trace(&alone, &objective) >= picks[0].trace_after * (1.0 - 1e-12));
        }
        assert!(select(&covariance, &[None, None], &objective, 1).is_none());
    }
}
