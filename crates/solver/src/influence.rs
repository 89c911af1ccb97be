//! The influence of a few chosen whitened rows on the global block: the
//! shift an error in one row makes in the global unknowns (external
//! reliability, Baarda 1968; Förstner and Wrobel, "Photogrammetric
//! Computer Vision", 2016, section 4.6.5), recomputed for those rows alone.
//!
//! With the notation of [`crate::redundancy`]: the least-squares step is
//! `Δx = −N⁻¹Aᵀe`, so a change `δ` of row `j`'s whitened residual (an
//! error in its observation, in units of its standard deviation, with the
//! sign it has in the residual) moves the unknowns by `−N⁻¹ a_jᵀ δ`, and
//! the global block (Schur complement) by
//!
//! ```text
//! Δg = −Cov(g) u_j δ = −L z_j δ,     z_j = Lᵀ u_j,   Cov(g) = LLᵀ,
//! ```
//!
//! `u_j` the row's reduced row (its global row after the elimination of
//! its point and group unknowns). For a global observation row `u_j` is its
//! Jacobian row. `|z_j|²` is the row's global leverage.
//!
//! The redundancy pass forms `z_j` of every row but keeps only `|z_j|²`:
//! the `G` values of each of `10^6` rows would not fit. Here the groups of
//! the chosen points are eliminated again, one at a time, with the same
//! sink, which then also keeps their `z_j`: a pass over a few groups.

use nalgebra::{DMatrix, DVector};

use crate::chunked_problem::ChunkedProblem;
use crate::chunks::Chunk;
use crate::eliminate::eliminate_chunk;
use crate::factor_product::times_factor;
use crate::iterate::status_of;
use crate::problem::{Problem, State};
use crate::reduced::covariance_factor;
use crate::redundancy::RedundancySink;
use crate::solution::Status;

/// A whitened row of a problem.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RowId {
    /// Row `row` (`0..R`) of point `point`.
    Point {
        /// The point.
        point: usize,
        /// Its row.
        row: usize,
    },
    /// Row `o` of the global observations.
    GlobalObservation(usize),
}

/// What one whitened row does to the global block ([`row_influence`]).
#[derive(Clone, Debug, PartialEq)]
pub struct RowInfluence {
    /// Its redundancy number `r_j`.
    pub redundancy: f64,
    /// Its global leverage `|z_j|²`.
    pub global_leverage: f64,
    /// `Δg` per unit increase of its whitened residual: `−Cov(g) u_j`.
    pub global_shift: DVector<f64>,
}

/// The influence on the global block of each of `rows` of `problem` at
/// `state`, given the covariance `Cov(g)` of the global block there (as
/// [`redundancy`](crate::redundancy) takes it): the groups of the points
/// named are eliminated again, one by one; `caches` as
/// [`linear_step`](crate::linear_step) takes them. The same numbers as the
/// full redundancy pass for those rows. Fails as
/// [`redundancy`](crate::redundancy), or with [`Status::InvalidProblem`]
/// for a row that is not in the problem.
pub fn row_influence<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    covariance: &DMatrix<f64>,
    caches: &mut Vec<Pr::PointCache>,
    rows: &[RowId],
) -> Result<Vec<RowInfluence>, Status> {
    let invalid = |message: String| Status::InvalidProblem { message };
    // One chunk of every group (the context checks the groups' points): the
    // chosen groups are eliminated one at a time below, and a chunk per
    // group would cost 32 bytes a group.
    let ctx =
        ChunkedProblem::new(problem, state, caches, problem.n_groups().max(1)).map_err(invalid)?;
    let g = ctx.dims.g;
    let (_, factor) = covariance_factor(covariance, g)?;
    let observations = if rows
        .iter()
        .any(|row| matches!(row, RowId::GlobalObservation(_)))
    {
        Some(
            ctx.global_observations(&state.global)
                .map_err(|f| status_of(f, 0))?
                .0,
        )
    } else {
        None
    };
    // Each chosen point's group, eliminated once however many of its rows
    // are asked for.
    let mut groups: Vec<(usize, usize)> = Vec::new();
    for row in rows {
        match *row {
            RowId::Point { point, row } => {
                if row >= R || point >= state.points.len() {
                    return Err(invalid(format!(
                        "row {row} of point {point}: the problem has {} points of {R} rows",
                        state.points.len()
                    )));
                }
                groups.push((group_of(problem, point), point));
            }
            RowId::GlobalObservation(o) => {
                let m = observations.as_ref().map_or(0, |o| o.residual.len());
                if o >= m {
                    return Err(invalid(format!(
                        "global observation row {o}: the problem has {m}"
                    )));
                }
            }
        }
    }
    groups.sort_unstable();
    groups.dedup_by_key(|(k, _)| *k);
    let global = problem.prepare_global(&state.global);
    // Per chosen group: its points, their rows (r_j, |z_j|²) and the z_j
    // of their rows.
    let mut eliminated = Vec::with_capacity(groups.len());
    let ChunkedProblem {
        pool, caches, dims, ..
    } = ctx;
    for &(k, _) in &groups {
        let points = problem.group_points(k);
        let chunk = Chunk {
            groups: k..k + 1,
            points: points.clone(),
        };
        let n = points.len();
        let (point_rows, z) = pool
            .with(|ws| {
                let (bufs, _, rows) = ws.split();
                rows.clear();
                let mut sink = RedundancySink::<C, P, R>::new(&factor, g, rows, n, n, true);
                eliminate_chunk::<C, P, R, _, _>(
                    problem,
                    &chunk,
                    state,
                    &global,
                    &mut caches[points.clone()],
                    0.0,
                    dims,
                    bufs,
                    None,
                    &mut sink,
                )?;
                Ok((sink.out, sink.global_z.expect("asked for")))
            })
            .map_err(|f| status_of(f, 0))?;
        eliminated.push((points, point_rows, z));
    }
    let mut z = vec![0.0; g];
    Ok(rows
        .iter()
        .map(|row| match *row {
            RowId::Point { point, row } => {
                let (points, point_rows, zs) = eliminated
                    .iter()
                    .find(|(points, ..)| points.contains(&point))
                    .expect("the point's group was eliminated");
                let i = point - points.start;
                let at = (i * R + row) * g;
                RowInfluence {
                    redundancy: point_rows[i].redundancy[row],
                    global_leverage: point_rows[i].global_leverage[row],
                    global_shift: shift(&factor, &zs[at..at + g]),
                }
            }
            RowId::GlobalObservation(o) => {
                let jacobian = &observations.as_ref().expect("asked for").jacobian;
                let u: Vec<f64> = jacobian.row(o).iter().copied().collect();
                times_factor(&factor, &u, &mut z);
                let leverage: f64 = z.iter().map(|v| v * v).sum();
                RowInfluence {
                    redundancy: 1.0 - leverage,
                    global_leverage: leverage,
                    global_shift: shift(&factor, &z),
                }
            }
        })
        .collect())
}

/// The group of point `point` of `problem`, whose groups' points are
/// contiguous and in order (as the context checked): the first group
/// whose points end after it, by bisection.
fn group_of<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    point: usize,
) -> usize {
    let (mut low, mut high) = (0, problem.n_groups());
    while low < high {
        let middle = low + (high - low) / 2;
        if problem.group_points(middle).end <= point {
            low = middle + 1;
        } else {
            high = middle;
        }
    }
    low
}

/// `−L z` for the lower-triangular `L` (`G × G`, row-major): the global
/// shift `−Cov(g) u` of a row with `z = Lᵀu`.
fn shift(factor: &[f64], z: &[f64]) -> DVector<f64> {
    let g = z.len();
    DVector::from_fn(g, |i, _| {
        -(0..=i).map(|k| factor[i * g + k] * z[k]).sum::<f64>()
    })
}
