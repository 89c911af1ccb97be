//! Choosing poses: greedy selection, then Fedorov exchange, for candidates
//! that carry several rows each and share nuisance unknowns (the frames).
//!
//! The state is the information `M` of the global block
//! ([`super::information`]) and its inverse `Σ` (Cholesky after each
//! change). Adding a candidate with whitened block `J` (`r` rows) gives, by
//! the Woodbury identity,
//!
//! ```text
//! Σ' = Σ − Uᵀ S⁻¹ U,    U = J Σ,   S = I_r + U Jᵀ,
//! ```
//!
//! and the criterion ([`crate::criterion`]) is evaluated on its 33 × 33
//! block `Σ'_pp = Σ_pp − U_pᵀ S⁻¹ U_p` (the nuisances eliminated). Each
//! step evaluates every candidate in parallel and takes the smallest value,
//! the earliest on ties: the same choice for any number of threads. Each
//! candidate belongs to a group (its session) with a quota of poses: a
//! session without poses would cost nothing, so the quotas, not the
//! criterion, say how many poses each session measures. Greedy additions
//! up to the quotas (a candidate at most once, only from groups below
//! their quota); then exchange passes, each chosen pose in turn removed
//! and replaced by the best candidate of its group not chosen (itself
//! included), until a pass improves the criterion by less than a relative
//! 1e-6 or `passes` passes are made.

use nalgebra::DMatrix;
use parcal_kinematics::N_PARAMS;
use rayon::prelude::*;

use crate::DesignError;
use crate::criterion::{Criterion, MapWeights, Square};

/// The covariance `Σ = M⁻¹` of an information matrix.
fn inverse(information: &DMatrix<f64>) -> Result<DMatrix<f64>, DesignError> {
    information
        .clone()
        .cholesky()
        .map(|c| c.inverse())
        .ok_or(DesignError::Singular)
}

/// The 33 × 33 block of `Σ` after adding the block `j` to the design of
/// covariance `sigma`.
pub fn updated_params_covariance(sigma: &DMatrix<f64>, j: &DMatrix<f64>) -> Option<Square> {
    let u = j * sigma;
    let s = DMatrix::<f64>::identity(j.nrows(), j.nrows()) + &u * j.transpose();
    let u_p = u.columns(0, N_PARAMS).into_owned();
    let solved = s.cholesky()?.solve(&u_p);
    let downdate = u_p.transpose() * solved;
    Some(Square::from_fn(|r, c| sigma[(r, c)] - downdate[(r, c)]))
}

/// The 33 × 33 block of `Σ`.
pub fn params_block(sigma: &DMatrix<f64>) -> Square {
    Square::from_fn(|r, c| sigma[(r, c)])
}

/// A chosen design: indices into the candidates (sorted) and the
/// covariance of the 33.
#[derive(Debug, Clone)]
pub struct PoseSelection {
    /// Indices into the candidates, sorted.
    pub chosen: Vec<usize>,
    /// The predicted covariance of the 33 parameters (mm²).
    pub covariance: Square,
}

/// Which group (session) each candidate is in, and how many poses each
/// group gets.
#[derive(Debug, Clone, Copy)]
pub struct Quotas<'a> {
    /// The group of each candidate.
    pub group: &'a [usize],
    /// The number of poses of each group.
    pub quota: &'a [usize],
}

/// The best `quotas` of `blocks` for `criterion` from the prior information
/// `prior` (module doc).
pub fn select_poses(
    blocks: &[DMatrix<f64>],
    quotas: Quotas,
    prior: &DMatrix<f64>,
    map: &MapWeights,
    criterion: Criterion,
    passes: usize,
    progress: &mut dyn FnMut(&str),
) -> Result<PoseSelection, DesignError> {
    let count: usize = quotas.quota.iter().sum();
    let short = (0..quotas.quota.len())
        .find(|&g| quotas.group.iter().filter(|&&c| c == g).count() < quotas.quota[g]);
    if count == 0 || quotas.group.len() != blocks.len() || short.is_some() {
        return Err(DesignError::Options(format!(
            "{count} poses ({:?} per session) from {} feasible candidates: plan at least 1 and at most as many as there are",
            quotas.quota,
            blocks.len()
        )));
    }
    let gram: Vec<DMatrix<f64>> = blocks.par_iter().map(|j| j.tr_mul(j)).collect();
    let mut information = prior.clone();
    let mut chosen: Vec<usize> = Vec::with_capacity(count);
    let mut taken = vec![0; quotas.quota.len()];
    while chosen.len() < count {
        let sigma = inverse(&information)?;
        let open = |k: usize| taken[quotas.group[k]] < quotas.quota[quotas.group[k]];
        let (k, _) = best(blocks, &sigma, map, criterion, &chosen, None, open)?;
        information += &gram[k];
        chosen.push(k);
        taken[quotas.group[k]] += 1;
    }
    let mut value = value_of(&information, map, criterion)?;
    progress(&format!("greedy: criterion {value:.6e}"));
    for pass in 1..=passes {
        let before = value;
        for slot in 0..count {
            let removed = chosen[slot];
            let without = &information - &gram[removed];
            let sigma = inverse(&without)?;
            let group = quotas.group[removed];
            let same = |k: usize| quotas.group[k] == group;
            let (k, v) = best(blocks, &sigma, map, criterion, &chosen, Some(removed), same)?;
            if k != removed && v < value {
                information = without + &gram[k];
                chosen[slot] = k;
                value = value_of(&information, map, criterion)?;
            }
        }
        progress(&format!("exchange pass {pass}: criterion {value:.6e}"));
        if before - value <= 1e-6 * before.abs() {
            break;
        }
    }
    chosen.sort_unstable();
    Ok(PoseSelection {
        chosen,
        covariance: params_block(&inverse(&information)?),
    })
}

/// The criterion of the design of information `information`.
fn value_of(
    information: &DMatrix<f64>,
    map: &MapWeights,
    criterion: Criterion,
) -> Result<f64, DesignError> {
    criterion
        .of(&params_block(&inverse(information)?), map)
        .ok_or(DesignError::Singular)
}

/// The candidate whose addition to the design of covariance `sigma` gives
/// the smallest criterion, and that value: among those `eligible` and not
/// in `chosen`, and `allowed` even if it is.
fn best(
    blocks: &[DMatrix<f64>],
    sigma: &DMatrix<f64>,
    map: &MapWeights,
    criterion: Criterion,
    chosen: &[usize],
    allowed: Option<usize>,
    eligible: impl Fn(usize) -> bool + Sync,
) -> Result<(usize, f64), DesignError> {
    let values: Vec<Option<f64>> = blocks
        .par_iter()
        .enumerate()
        .map(|(k, j)| {
            if !eligible(k) || (chosen.contains(&k) && allowed != Some(k)) {
                return None;
            }
            criterion.of(&updated_params_covariance(sigma, j)?, map)
        })
        .collect();
    values
        .iter()
        .enumerate()
        .filter_map(|(k, v)| v.filter(|v| v.is_finite()).map(|v| (k, v)))
        .fold(None, |best: Option<(usize, f64)>, (k, v)| match best {
            Some((_, b)) if b <= v => best,
            _ => Some((k, v)),
        })
        .ok_or(DesignError::Singular)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pseudo(rows: usize, cols: usize, seed: usize) -> DMatrix<f64> {
        DMatrix::from_fn(rows, cols, |r, c| {
            ((seed * 131 + r * 17 + c * 7) as f64 * 0.61).sin()
        })
    }

    #[test]
    fn the_woodbury_update_is_the_inverse_of_the_updated_information() {
        let n = N_PARAMS + 12;
        let a = pseudo(n, n, 1);
        let information = a.tr_mul(&a) + DMatrix::identity(n, n);
        let j = pseudo(6, n, 2);
        let sigma = inverse(&information).unwrap();
        let updated = updated_params_covariance(&sigma, &j).unwrap();
        let direct = params_block(&inverse(&(information + j.tr_mul(&j))).unwrap());
        let error = (updated - direct).amax();
        assert!(error < 1e-10 * direct.amax(), "{error:e}");
    }

    #[test]
    fn exchange_never_loses_to_greedy_and_threads_do_not_matter() {
        let n = N_PARAMS + 6;
        let blocks: Vec<DMatrix<f64>> = (0..60).map(|k| pseudo(6, n, k + 3)).collect();
        let prior = DMatrix::identity(n, n) * 0.5;
        let map = MapWeights::new(
            (0..5)
                .map(|k| {
                    crate::criterion::MapJacobian::from_fn(|r, c| {
                        ((k * 3 + r + 5 * c) as f64).cos()
                    })
                })
                .collect(),
        );
        let one_group = vec![0; blocks.len()];
        let run = |passes: usize| {
            let quotas = Quotas {
                group: &one_group,
                quota: &[8],
            };
            select_poses(
                &blocks,
                quotas,
                &prior,
                &map,
                Criterion::Registered,
                passes,
                &mut |_| {},
            )
            .unwrap()
        };
        let value = |s: &PoseSelection| Criterion::Registered.of(&s.covariance, &map).unwrap();
        let (greedy, exchanged) = (run(0), run(5));
        assert!(value(&exchanged) <= value(&greedy) * (1.0 + 1e-12));
        let single = rayon::ThreadPoolBuilder::new()
            .num_threads(1)
            .build()
            .unwrap()
            .install(|| run(5));
        assert_eq!(single.chosen, exchanged.chosen);
        assert_eq!(exchanged.chosen.len(), 8);
        // Two groups of 30 with quotas 3 and 5 get exactly those.
        let halves: Vec<usize> = (0..blocks.len()).map(|k| k / 30).collect();
        let quotas = Quotas {
            group: &halves,
            quota: &[3, 5],
        };
        let split = select_poses(
            &blocks,
            quotas,
            &prior,
            &map,
            Criterion::Registered,
            5,
            &mut |_| {},
        )
        .unwrap();
        let first = split.chosen.iter().filter(|&&k| k < 30).count();
        assert_eq!((first, split.chosen.len() - first), (3, 5));
    }
}
