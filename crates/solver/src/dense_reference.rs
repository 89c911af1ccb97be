//! A plain dense solve of the FULL normal equations, for checking the Schur
//! solver on small problems (and for callers' own tests).
//!
//! It builds the whole Jacobian `J` — every point's rows, then the point,
//! group and global prior rows (square roots of the information matrices by
//! eigen-decomposition) — as a faer [`Mat`], forms `N = JᵀJ` and `Jᵀr`, and
//! solves `(N + λ D) δ = −Jᵀr` with `D = clamp(diag N, 1e-6, 1e32)` (the same
//! Marquardt scaling as the solver; `λ = 0` is Gauss–Newton). The unknowns are
//! ordered `[g | c_0 … c_{K−1} | p_0 … p_{N−1}]`; see [`global_index`],
//! [`group_index`] and [`point_index`]. Memory and time are cubic in the
//! number of unknowns: small problems only.

use faer::linalg::solvers::DenseSolveCore;
use faer::prelude::Solve;
use faer::{Mat, Side};
use nalgebra::{SMatrix, SVector};

use crate::eliminate::damping_diagonal;
use crate::problem::{GlobalJacobian, Linearization, Problem, State};

/// Why the dense reference could not be computed.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
pub enum DenseError {
    /// A point's linearisation failed.
    #[error("linearisation of point {point} failed: {message}")]
    Linearize {
        /// The point.
        point: usize,
        /// The error's message.
        message: String,
    },
    /// The (damped) normal matrix is not positive definite.
    #[error("the normal matrix is not positive definite")]
    NotPositiveDefinite,
    /// The problem's groups do not match the state.
    #[error("the problem's groups do not match the state")]
    Structure,
    /// A prior's information matrix could not be decomposed (non-finite).
    #[error("a prior's information matrix is not finite")]
    BadPrior,
}

/// The dense linear system at one state and its solution.
#[derive(Clone, Debug)]
pub struct DenseReference<const G: usize, const C: usize, const P: usize> {
    /// The step `δ`, laid out like the state.
    pub step: State<G, C, P>,
    /// The full Jacobian, data rows then prior rows.
    pub jacobian: Mat<f64>,
    /// The full residual (one column).
    pub residual: Mat<f64>,
    /// `N = JᵀJ`, undamped.
    pub normal: Mat<f64>,
    /// `N⁻¹` of the undamped normal matrix, if it is positive definite.
    pub inverse: Option<Mat<f64>>,
    /// `|r|²`, data and prior rows.
    pub cost: f64,
}

/// Column of global parameter `j`.
pub fn global_index(j: usize) -> usize {
    j
}

/// Column of coordinate `j` of group `k`.
pub fn group_index<const G: usize, const C: usize>(k: usize, j: usize) -> usize {
    G + k * C + j
}

/// Column of coordinate `j` of point `i`, in a problem with `n_groups` groups.
pub fn point_index<const G: usize, const C: usize, const P: usize>(
    n_groups: usize,
    i: usize,
    j: usize,
) -> usize {
    G + n_groups * C + i * P + j
}

impl<const G: usize, const C: usize, const P: usize> DenseReference<G, C, P> {
    /// The `G × G` block of `N⁻¹`: the marginal covariance of the global
    /// block.
    pub fn global_covariance(&self) -> Option<SMatrix<f64, G, G>> {
        self.inverse
            .as_ref()
            .map(|inv| SMatrix::from_fn(|i, j| inv[(global_index(i), global_index(j))]))
    }

    /// Marginal sigmas of every group from the diagonal of `N⁻¹`.
    pub fn group_sigmas(&self) -> Option<Vec<SVector<f64, C>>> {
        self.inverse.as_ref().map(|inv| {
            (0..self.step.groups.len())
                .map(|k| {
                    SVector::from_fn(|j, _| {
                        let c = group_index::<G, C>(k, j);
                        inv[(c, c)].sqrt()
                    })
                })
                .collect()
        })
    }
}

/// Rows `U` with `UᵀU = information` (lower triangle read), by
/// eigen-decomposition; negative eigenvalues count as zero.
fn information_rows(information: &Mat<f64>) -> Result<Mat<f64>, DenseError> {
    let n = information.nrows();
    let sym = Mat::<f64>::from_fn(n, n, |i, j| {
        if i >= j {
            information[(i, j)]
        } else {
            information[(j, i)]
        }
    });
    let evd = sym
        .self_adjoint_eigen(Side::Lower)
        .map_err(|_| DenseError::BadPrior)?;
    let (u, s) = (evd.U(), evd.S());
    Ok(Mat::from_fn(n, n, |a, j| s[a].max(0.0).sqrt() * u[(j, a)]))
}

/// Builds and solves the full dense system of `problem` at `state` with
/// Marquardt damping `lambda` (0: Gauss–Newton). Every point is linearised
/// once, with a fresh [`initial_cache`](Problem::initial_cache).
pub fn solve<
    const G: usize,
    const C: usize,
    const P: usize,
    const R: usize,
    Pr: Problem<G, C, P, R>,
>(
    problem: &Pr,
    state: &State<G, C, P>,
    lambda: f64,
) -> Result<DenseReference<G, C, P>, DenseError> {
    let n_groups = problem.n_groups();
    let n_points = state.points.len();
    if state.groups.len() != n_groups {
        return Err(DenseError::Structure);
    }
    let n = G + n_groups * C + n_points * P;
    // Rows: data, then priors (point, group, global).
    let mut rows: Vec<(Vec<(usize, f64)>, f64)> = Vec::new();
    let mut point_group = vec![usize::MAX; n_points];
    for k in 0..n_groups {
        for i in problem.group_points(k) {
            if i >= n_points {
                return Err(DenseError::Structure);
            }
            point_group[i] = k;
        }
    }
    if point_group.contains(&usize::MAX) {
        return Err(DenseError::Structure);
    }
    let mut lin = Linearization::zeros();
    let global = problem.prepare_global(&state.global);
    for (i, &k) in point_group.iter().enumerate() {
        let mut cache = problem.initial_cache(i);
        let (c, p) = (&state.groups[k], &state.points[i]);
        problem
            .linearize(i, &global, c, p, &mut cache, &mut lin)
            .map_err(|e| DenseError::Linearize {
                point: i,
                message: e.to_string(),
            })?;
        let mut global_row = vec![0.0; G];
        for row in 0..R {
            lin.d_global.row(row, &mut global_row);
            let mut entries = Vec::new();
            entries.extend((0..G).map(|j| (global_index(j), global_row[j])));
            entries.extend((0..C).map(|j| (group_index::<G, C>(k, j), lin.d_group[(row, j)])));
            entries.extend((0..P).map(|j| {
                (
                    point_index::<G, C, P>(n_groups, i, j),
                    lin.d_point[(row, j)],
                )
            }));
            rows.push((entries, lin.residual[row]));
        }
    }
    let mut prior_rows =
        |columns: Vec<usize>, info: Mat<f64>, error: Vec<f64>| -> Result<(), DenseError> {
            let u = information_rows(&info)?;
            for a in 0..columns.len() {
                let entries = columns
                    .iter()
                    .enumerate()
                    .map(|(j, &c)| (c, u[(a, j)]))
                    .collect();
                let r = (0..columns.len()).map(|j| u[(a, j)] * error[j]).sum();
                rows.push((entries, r));
            }
            Ok(())
        };
    for i in 0..n_points {
        if let Some(prior) = problem.point_prior(i) {
            prior_rows(
                (0..P)
                    .map(|j| point_index::<G, C, P>(n_groups, i, j))
                    .collect(),
                Mat::from_fn(P, P, |a, b| prior.information[(a, b)]),
                (0..P).map(|j| state.points[i][j] - prior.mean[j]).collect(),
            )?;
        }
    }
    for k in 0..n_groups {
        if let Some(prior) = problem.group_prior(k) {
            prior_rows(
                (0..C).map(|j| group_index::<G, C>(k, j)).collect(),
                Mat::from_fn(C, C, |a, b| prior.information[(a, b)]),
                (0..C).map(|j| state.groups[k][j] - prior.mean[j]).collect(),
            )?;
        }
    }
    if let Some(prior) = problem.global_prior() {
        prior_rows(
            (0..G).map(global_index).collect(),
            Mat::from_fn(G, G, |a, b| prior.information[(a, b)]),
            (0..G).map(|j| state.global[j] - prior.mean[j]).collect(),
        )?;
    }
    let m = rows.len();
    let mut jacobian = Mat::<f64>::zeros(m, n);
    let mut residual = Mat::<f64>::zeros(m, 1);
    for (r, (entries, value)) in rows.iter().enumerate() {
        for &(c, v) in entries {
            jacobian[(r, c)] += v;
        }
        residual[(r, 0)] = *value;
    }
    let normal = jacobian.transpose() * &jacobian;
    let gradient = jacobian.transpose() * &residual;
    let cost = (0..m).map(|r| residual[(r, 0)] * residual[(r, 0)]).sum();
    let mut damped = normal.clone();
    if lambda > 0.0 {
        for j in 0..n {
            damped[(j, j)] += lambda * damping_diagonal(normal[(j, j)]);
        }
    }
    let llt = damped
        .llt(Side::Lower)
        .map_err(|_| DenseError::NotPositiveDefinite)?;
    let mut delta = Mat::<f64>::from_fn(n, 1, |j, _| -gradient[(j, 0)]);
    llt.solve_in_place(delta.as_mut());
    let inverse = normal.llt(Side::Lower).ok().map(|l| l.inverse());
    let step = State {
        global: SVector::from_fn(|j, _| delta[(global_index(j), 0)]),
        groups: (0..n_groups)
            .map(|k| SVector::from_fn(|j, _| delta[(group_index::<G, C>(k, j), 0)]))
            .collect(),
        points: (0..n_points)
            .map(|i| SVector::from_fn(|j, _| delta[(point_index::<G, C, P>(n_groups, i, j), 0)]))
            .collect(),
    };
    Ok(DenseReference {
        step,
        jacobian,
        residual,
        normal,
        inverse,
        cost,
    })
}
