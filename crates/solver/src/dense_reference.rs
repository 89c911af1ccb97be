//! A plain dense solve of the FULL normal equations, for checking the Schur
//! solver on small problems (and for callers' own tests).
//!
//! It builds the whole Jacobian `J` — every point's rows, the global
//! observations' rows, then the point, group and global prior rows (square
//! roots of the information matrices by eigen-decomposition) — as a faer
//! [`Mat`], forms `N = JᵀJ` and `Jᵀr`, and solves `(N + λ D) δ = −Jᵀr` with
//! `D = clamp(diag N, 1e-6, 1e32)` (the same Marquardt scaling as the
//! solver; `λ = 0` is Gauss–Newton). The unknowns are ordered
//! `[g | c_0 … c_{K−1} | p_0 … p_{N−1}]`, fixed groups left out; see
//! [`Columns`]. With a robust loss ([`Problem::loss`]) each point's and
//! each global observation's rows are scaled by `√w(u)` at the state, as
//! the solver weighs them. Memory and time are cubic in the number of
//! unknowns: small problems only.

use faer::linalg::solvers::DenseSolveCore;
use faer::prelude::Solve;
use faer::{Mat, Side};
use nalgebra::{DMatrix, DVector, SVector};

use crate::eliminate::damping_diagonal;
use crate::loss::Loss;
use crate::problem::{
    GlobalJacobian, GlobalObservations, Linearization, Problem, State, point_degrees_of_freedom,
};

/// `√w(u)` of an observation of `dof` degrees of freedom and whitened
/// residual `residual` under `loss`, `u = |residual| / √dof`, from the
/// loss's weight function alone.
fn robust_scale(loss: Loss, residual: &[f64], dof: usize) -> f64 {
    let norm: f64 = residual.iter().map(|e| e * e).sum::<f64>().sqrt();
    loss.weight(norm / (dof as f64).sqrt()).sqrt()
}

/// A row's entries times `s`.
fn scaled(entries: Vec<(usize, f64)>, s: f64) -> Vec<(usize, f64)> {
    entries.into_iter().map(|(c, v)| (c, s * v)).collect()
}

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
    /// The global observations failed.
    #[error("the global observations failed: {message}")]
    GlobalObservations {
        /// The error's message.
        message: String,
    },
    /// The (damped) normal matrix is not positive definite.
    #[error("the normal matrix is not positive definite")]
    NotPositiveDefinite,
    /// The problem's blocks do not match the state.
    #[error("the problem's blocks do not match the state")]
    Structure,
    /// A prior's information matrix could not be decomposed (non-finite).
    #[error("a prior's information matrix is not finite")]
    BadPrior,
}

/// The dense linear system at one state and its solution.
#[derive(Clone, Debug)]
pub struct DenseReference<const C: usize, const P: usize> {
    /// The step `δ`, laid out like the state (zero for a fixed group).
    pub step: State<C, P>,
    /// Where each unknown's column is.
    pub columns: Columns,
    /// The full Jacobian: point rows, global observation rows, then prior
    /// rows.
    pub jacobian: Mat<f64>,
    /// The full residual (one column).
    pub residual: Mat<f64>,
    /// `N = JᵀJ`, undamped.
    pub normal: Mat<f64>,
    /// `N⁻¹` of the undamped normal matrix, if it is positive definite.
    pub inverse: Option<Mat<f64>>,
    /// `|r|²`, data, global observation and prior rows.
    pub cost: f64,
}

/// The order of the unknowns, `[g | c_k … (groups not fixed) | p_0 …]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Columns {
    global_size: usize,
    /// The first column of each group, `None` for a fixed group.
    groups: Vec<Option<usize>>,
    /// The first point column.
    points: usize,
    point_size: usize,
}

impl Columns {
    /// The columns of a problem whose groups (`C` unknowns each) are fixed
    /// as `fixed` says, with `global_size` global and `point_size` point
    /// unknowns.
    fn new(global_size: usize, group_size: usize, point_size: usize, fixed: &[bool]) -> Self {
        let mut next = global_size;
        let groups = fixed
            .iter()
            .map(|&fixed| {
                (!fixed).then(|| {
                    next += group_size;
                    next - group_size
                })
            })
            .collect();
        Self {
            global_size,
            groups,
            points: next,
            point_size,
        }
    }

    /// Column of global unknown `j`.
    pub fn global(&self, j: usize) -> usize {
        j
    }

    /// Column of coordinate `j` of group `k`; `None` if the group is fixed.
    pub fn group(&self, k: usize, j: usize) -> Option<usize> {
        self.groups[k].map(|first| first + j)
    }

    /// Column of coordinate `j` of point `i`.
    pub fn point(&self, i: usize, j: usize) -> usize {
        self.points + i * self.point_size + j
    }

    /// A state-shaped vector (e.g. a step) in this column order, fixed
    /// groups left out.
    pub fn vector<const C: usize, const P: usize>(&self, x: &State<C, P>) -> Mat<f64> {
        let n = self.points + x.points.len() * self.point_size;
        let mut v = Mat::<f64>::zeros(n, 1);
        for j in 0..self.global_size {
            v[(self.global(j), 0)] = x.global[j];
        }
        for (k, c) in x.groups.iter().enumerate() {
            for j in 0..C {
                if let Some(col) = self.group(k, j) {
                    v[(col, 0)] = c[j];
                }
            }
        }
        for (i, p) in x.points.iter().enumerate() {
            for j in 0..P {
                v[(self.point(i, j), 0)] = p[j];
            }
        }
        v
    }
}

impl<const C: usize, const P: usize> DenseReference<C, P> {
    /// The `G × G` block of `N⁻¹`: the marginal covariance of the global
    /// block.
    pub fn global_covariance(&self) -> Option<DMatrix<f64>> {
        let g = self.step.global.len();
        let c = &self.columns;
        self.inverse
            .as_ref()
            .map(|inv| DMatrix::from_fn(g, g, |i, j| inv[(c.global(i), c.global(j))]))
    }

    /// Marginal sigmas of every group from the diagonal of `N⁻¹` (zero for
    /// a fixed group).
    pub fn group_sigmas(&self) -> Option<Vec<SVector<f64, C>>> {
        self.inverse.as_ref().map(|inv| {
            (0..self.step.groups.len())
                .map(|k| {
                    SVector::from_fn(|j, _| {
                        self.columns.group(k, j).map_or(0.0, |c| inv[(c, c)].sqrt())
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

/// One row of `J` (its non-zero entries by column) and its residual.
type Row = (Vec<(usize, f64)>, f64);

/// Builds and solves the full dense system of `problem` at `state` with
/// Marquardt damping `lambda` (0: Gauss–Newton). Every point is linearised
/// once, with a fresh [`initial_cache`](Problem::initial_cache). A fixed
/// group's block is not an unknown: its columns are left out, and its
/// prior, if any, adds a constant row (cost only).
pub fn solve<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    lambda: f64,
) -> Result<DenseReference<C, P>, DenseError> {
    let g = problem.global_size();
    let n_groups = problem.n_groups();
    let n_points = state.points.len();
    if state.groups.len() != n_groups || state.global.len() != g {
        return Err(DenseError::Structure);
    }
    let fixed: Vec<bool> = (0..n_groups).map(|k| problem.group_is_fixed(k)).collect();
    let columns = Columns::new(g, C, P, &fixed);
    let n = columns.point(n_points, 0);
    // Rows: data, global observations, then priors (point, group, global).
    let mut rows: Vec<Row> = Vec::new();
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
    let loss = problem.loss();
    let mut lin = Linearization::zeros(g);
    let global = problem.prepare_global(&state.global);
    let mut global_row = vec![0.0; g];
    for (i, &k) in point_group.iter().enumerate() {
        let mut cache = problem.initial_cache(i);
        let (c, p) = (&state.groups[k], &state.points[i]);
        problem
            .linearize(i, &global, c, p, &mut cache, &mut lin)
            .map_err(|e| DenseError::Linearize {
                point: i,
                message: e.to_string(),
            })?;
        let s = robust_scale(
            loss,
            lin.residual.as_slice(),
            point_degrees_of_freedom(R, P),
        );
        for row in 0..R {
            lin.d_global.row(row, &mut global_row);
            let mut entries = Vec::new();
            entries.extend((0..g).map(|j| (columns.global(j), global_row[j])));
            entries.extend(
                (0..C).filter_map(|j| columns.group(k, j).map(|c| (c, lin.d_group[(row, j)]))),
            );
            entries.extend((0..P).map(|j| (columns.point(i, j), lin.d_point[(row, j)])));
            rows.push((scaled(entries, s), s * lin.residual[row]));
        }
    }
    let mut observations = GlobalObservations::zeros(0, g);
    problem
        .global_observations(&state.global, &mut observations)
        .map_err(|e| DenseError::GlobalObservations {
            message: e.to_string(),
        })?;
    if observations.jacobian.ncols() != g
        || observations.jacobian.nrows() != observations.residual.len()
    {
        return Err(DenseError::Structure);
    }
    let m_observations = observations.residual.len();
    let sizes = match problem.global_observation_rows() {
        Some(sizes) if !loss.is_squared() => sizes,
        _ => vec![1; m_observations],
    };
    if sizes.iter().sum::<usize>() != m_observations {
        return Err(DenseError::Structure);
    }
    let mut first = 0;
    for n in sizes {
        let rows_of = first..first + n;
        let s = robust_scale(loss, &observations.residual.as_slice()[rows_of.clone()], n);
        for r in rows_of {
            let entries = (0..g)
                .map(|j| (columns.global(j), observations.jacobian[(r, j)]))
                .collect();
            rows.push((scaled(entries, s), s * observations.residual[r]));
        }
        first += n;
    }
    let mut prior_rows =
        |columns: Vec<Option<usize>>, info: Mat<f64>, error: Vec<f64>| -> Result<(), DenseError> {
            let u = information_rows(&info)?;
            for a in 0..columns.len() {
                let entries = columns
                    .iter()
                    .enumerate()
                    .filter_map(|(j, &c)| c.map(|c| (c, u[(a, j)])))
                    .collect();
                let r = (0..columns.len()).map(|j| u[(a, j)] * error[j]).sum();
                rows.push((entries, r));
            }
            Ok(())
        };
    for i in 0..n_points {
        if let Some(prior) = problem.point_prior(i) {
            prior_rows(
                (0..P).map(|j| Some(columns.point(i, j))).collect(),
                Mat::from_fn(P, P, |a, b| prior.information[(a, b)]),
                (0..P).map(|j| state.points[i][j] - prior.mean[j]).collect(),
            )?;
        }
    }
    for k in 0..n_groups {
        if let Some(prior) = problem.group_prior(k) {
            prior_rows(
                (0..C).map(|j| columns.group(k, j)).collect(),
                Mat::from_fn(C, C, |a, b| prior.information[(a, b)]),
                (0..C).map(|j| state.groups[k][j] - prior.mean[j]).collect(),
            )?;
        }
    }
    if let Some(prior) = problem.global_prior() {
        if prior.mean.len() != g || prior.information.shape() != (g, g) {
            return Err(DenseError::Structure);
        }
        prior_rows(
            (0..g).map(|j| Some(columns.global(j))).collect(),
            Mat::from_fn(g, g, |a, b| prior.information[(a, b)]),
            (0..g).map(|j| state.global[j] - prior.mean[j]).collect(),
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
        global: DVector::from_fn(g, |j, _| delta[(columns.global(j), 0)]),
        groups: (0..n_groups)
            .map(|k| SVector::from_fn(|j, _| columns.group(k, j).map_or(0.0, |c| delta[(c, 0)])))
            .collect(),
        points: (0..n_points)
            .map(|i| SVector::from_fn(|j, _| delta[(columns.point(i, j), 0)]))
            .collect(),
    };
    Ok(DenseReference {
        step,
        columns,
        jacobian,
        residual,
        normal,
        inverse,
        cost,
    })
}
