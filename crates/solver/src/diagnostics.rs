//! Spectrum of the reduced `G × G` matrix: condition number and the
//! near-singular directions of the global parameters.

use nalgebra::{DMatrix, SymmetricEigen};

use crate::qr::all_finite;

/// Eigenvalues at most this fraction of the largest are always reported as
/// weak directions.
const WEAK_RELATIVE: f64 = 1e-10;
/// Eigenvalues at most `n ε` times the largest are zero up to rounding: the
/// directions nothing in the problem determines.
const UNIDENTIFIED_RELATIVE: f64 = f64::EPSILON;
/// The implicit QR iteration of the tridiagonal matrix gives up after this
/// many steps per eigenvalue (LAPACK's `dsteqr` allows as many).
const QR_SWEEPS_PER_EIGENVALUE: usize = 30;
/// At least this many of the smallest eigenvalues are reported.
const MIN_WEAK: usize = 3;
/// A weak direction's dominant indices cover at least this fraction of its
/// squared norm…
const DOMINANT_COVERAGE: f64 = 0.9;
/// …with at most this many indices.
const MAX_DOMINANT: usize = 6;

/// Eigen-decomposition summary of the reduced matrix (the Schur complement of
/// the normal matrix onto the global block, i.e. the information of the
/// global parameters).
#[derive(Clone, Debug, PartialEq)]
pub struct SpectrumDiagnostics {
    /// All eigenvalues, ascending. Empty if the matrix is not finite or the
    /// eigen-decomposition failed.
    pub eigenvalues: Vec<f64>,
    /// The weakest directions, weakest first: the `MIN_WEAK` (3) smallest
    /// eigenvalues, and any further ones below `1e-10 ×` the largest.
    pub weakest: Vec<WeakDirection>,
}

/// One eigenvector of the reduced matrix with a small eigenvalue.
#[derive(Clone, Debug, PartialEq)]
pub struct WeakDirection {
    /// Its eigenvalue.
    pub eigenvalue: f64,
    /// Whether the eigenvalue is above rounding (`n ε λ_max`): a direction
    /// with a finite sigma. `false`: nothing in the problem determines it.
    pub identified: bool,
    /// Global indices with the largest `|component|` of the unit eigenvector,
    /// descending, with the component's value: the fewest that cover ≥ 90 % of
    /// its squared norm, at most 6.
    pub dominant: Vec<(usize, f64)>,
}

impl SpectrumDiagnostics {
    /// Decomposes the symmetric `n × n` matrix given row-major (both
    /// triangles filled).
    pub fn of_symmetric(matrix: &[f64], n: usize) -> Self {
        assert_eq!(matrix.len(), n * n, "matrix must be n × n");
        let decomposition = all_finite(matrix)
            .then(|| {
                SymmetricEigen::try_new(
                    DMatrix::from_row_slice(n, n, matrix),
                    f64::EPSILON,
                    QR_SWEEPS_PER_EIGENVALUE * n,
                )
            })
            .flatten();
        let Some(SymmetricEigen {
            eigenvalues: s,
            eigenvectors: u,
        }) = decomposition
        else {
            return Self {
                eigenvalues: Vec::new(),
                weakest: Vec::new(),
            };
        };
        let mut order: Vec<usize> = (0..n).collect();
        let values: Vec<f64> = (0..n).map(|j| s[j]).collect();
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        let eigenvalues: Vec<f64> = order.iter().map(|&j| values[j]).collect();
        let largest = eigenvalues.last().copied().unwrap_or(0.0).max(0.0);
        let zero = zero_level(n, largest);
        let weakest = order
            .iter()
            .enumerate()
            .take_while(|&(rank, &j)| rank < MIN_WEAK || values[j] <= WEAK_RELATIVE * largest)
            .map(|(_, &j)| {
                let v: Vec<f64> = (0..n).map(|i| u[(i, j)]).collect();
                WeakDirection {
                    eigenvalue: values[j],
                    identified: values[j] > zero,
                    dominant: dominant_components(&v),
                }
            })
            .collect();
        Self {
            eigenvalues,
            weakest,
        }
    }

    /// `λ_max / λ_min`; infinite if a direction is not identified
    /// ([`Self::unidentified`]), NaN if there are no eigenvalues.
    pub fn condition_number(&self) -> f64 {
        match (self.eigenvalues.first(), self.eigenvalues.last()) {
            (Some(_), Some(_)) if self.unidentified() > 0 => f64::INFINITY,
            (Some(&lo), Some(&hi)) => hi / lo,
            _ => f64::NAN,
        }
    }

    /// The number of directions nothing in the problem determines: the
    /// eigenvalues at most `n ε λ_max` (rounding of a zero eigenvalue).
    pub fn unidentified(&self) -> usize {
        let n = self.eigenvalues.len();
        let largest = self.eigenvalues.last().copied().unwrap_or(0.0).max(0.0);
        let zero = zero_level(n, largest);
        self.eigenvalues.iter().take_while(|&&v| v <= zero).count()
    }
}

/// The level at or below which an eigenvalue of an `n × n` matrix with
/// largest eigenvalue `largest` is zero up to rounding.
fn zero_level(n: usize, largest: f64) -> f64 {
    n as f64 * UNIDENTIFIED_RELATIVE * largest
}

/// The fewest largest-magnitude components covering `DOMINANT_COVERAGE` of
/// the squared norm, at most `MAX_DOMINANT`.
fn dominant_components(v: &[f64]) -> Vec<(usize, f64)> {
    let total: f64 = v.iter().map(|x| x * x).sum();
    let mut idx: Vec<usize> = (0..v.len()).collect();
    idx.sort_by(|&a, &b| v[b].abs().total_cmp(&v[a].abs()).then(a.cmp(&b)));
    let mut out = Vec::new();
    let mut covered = 0.0;
    for i in idx {
        if out.len() == MAX_DOMINANT || covered >= DOMINANT_COVERAGE * total {
            break;
        }
        covered += v[i] * v[i];
        out.push((i, v[i]));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn diagonal_matrix_spectrum_and_weak_direction() {
        let n = 4;
        let mut m = vec![0.0; n * n];
        let diag = [5.0, 0.0, 2.0, 7.0];
        for (i, d) in diag.iter().enumerate() {
            m[i * n + i] = *d;
        }
        let s = SpectrumDiagnostics::of_symmetric(&m, n);
        for (got, want) in s.eigenvalues.iter().zip([0.0, 2.0, 5.0, 7.0]) {
            assert!((got - want).abs() < 1e-12, "{:?}", s.eigenvalues);
        }
        assert_eq!(s.weakest.len(), 3);
        assert_eq!(s.weakest[0].dominant.len(), 1);
        assert_eq!(s.weakest[0].dominant[0].0, 1);
        assert_eq!(s.weakest[1].dominant[0].0, 2);
        assert!(s.condition_number().is_infinite());
        assert_eq!(s.unidentified(), 1);
        assert!(!s.weakest[0].identified && s.weakest[1].identified);
    }

    #[test]
    fn rounding_of_a_zero_eigenvalue_is_unidentified() {
        // A rank-one matrix v vᵀ: two zero eigenvalues, computed as ±rounding.
        let v = [1.0, 2.0, 3.0];
        let m: Vec<f64> = (0..9).map(|k| v[k / 3] * v[k % 3] * 1e6).collect();
        let s = SpectrumDiagnostics::of_symmetric(&m, 3);
        assert_eq!(s.unidentified(), 2, "{:?}", s.eigenvalues);
        assert!(s.condition_number().is_infinite());
    }

    #[test]
    fn dominant_covers_ninety_percent() {
        let v = [0.1, -0.7, 0.1, 0.7, 0.0];
        let d = dominant_components(&v);
        assert_eq!(d.iter().map(|x| x.0).collect::<Vec<_>>(), vec![1, 3]);
    }
}
