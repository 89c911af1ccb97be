//! The Schur solver against a plain dense solve of the FULL normal equations
//! on the paper scenario (simulate seed 1): the first Gauss-Newton update
//! over all unknowns (33 parameters, 27 centres, and the 378 angles of the
//! coordinate observation) and the posterior covariance of the 33, at the
//! initial estimate, for both observations and both priors.

use std::time::Instant;

use parcal_calibrate::run::coordinate_problem_and_state;
use parcal_calibrate::setup::Setup;
use parcal_calibrate::{CalibrationOptions, ParamCovariance, PriorMode, Simulation};
use parcal_dataset::Dataset;
use parcal_kinematics::N_PARAMS;
use parcal_simulate::{Scenario, simulate};
use parcal_solver::{Problem, SolverOptions, State, Status, dense_reference, linear_step, solve};

/// Relative agreement asked of the step and of the covariance.
const TOL: f64 = 1e-9;

fn dataset() -> Dataset {
    simulate(&Scenario::paper(), 1).expect("simulation").dataset
}

/// All unknowns in the dense reference's order `[g | c_0 .. | p_0 ..]`.
fn flatten<const G: usize, const C: usize, const P: usize>(state: &State<G, C, P>) -> Vec<f64> {
    let mut v: Vec<f64> = state.global.iter().copied().collect();
    v.extend(state.groups.iter().flat_map(|c| c.iter().copied()));
    v.extend(state.points.iter().flat_map(|p| p.iter().copied()));
    v
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `|a - b| / |b|`.
fn rel_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len(), "different numbers of unknowns");
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| x - y).collect();
    norm(&d) / norm(b)
}

/// Condition number of the dense normal matrix (ratio of its extreme
/// eigenvalues), for the report.
fn condition<const C: usize, const P: usize>(
    dense: &dense_reference::DenseReference<N_PARAMS, C, P>,
) -> f64 {
    let normal = &dense.normal;
    let n = normal.nrows();
    let matrix = nalgebra::DMatrix::from_fn(n, n, |i, j| normal[(i, j)]);
    let eigenvalues = matrix.symmetric_eigenvalues();
    eigenvalues.max() / eigenvalues.min()
}


/// A double-double accumulator (Dekker/Knuth error-free transformations):
/// sums of products to ~1e-32 relative, for the refined reference below.
#[derive(Clone, Copy, Default)]
struct Dd {
    hi: f64,
    lo: f64,
}

impl Dd {
    fn add(self, x: f64) -> Self {
        let s = self.hi + x;
        let bb = s - self.hi;
        let e = (self.hi - (s - bb)) + (x - bb);
        Self::normalise(s, self.lo + e)
    }

    fn add_product(self, a: f64, b: f64) -> Self {
        let p = a * b;
        let e = a.mul_add(b, -p);
        self.add(p).add(e)
    }

    fn normalise(hi: f64, lo: f64) -> Self {
        let s = hi + lo;
        Self { hi: s, lo: lo - (s - hi) }
    }
}

/// The dense system `N x = b` with `N = JᵀJ` solved to (nearly) full
/// double precision: the dense Cholesky factor of `N` preconditions an
/// iterative refinement whose residuals `b − Jᵀ(J x)` are accumulated in
/// double-double from `J` itself. Each round gains `−log10(cond(N) · eps)`
/// digits, so a handful reach the accuracy of the rounded result whenever
/// `cond(N) · eps < 1`. This is the exact solution of the linear system the
/// dense reference assembles, without the `cond(N) · eps` error of solving
/// the normal equations once in double precision.
struct Refined {
    j: nalgebra::DMatrix<f64>,
    cholesky: nalgebra::Cholesky<f64, nalgebra::Dyn>,
}

impl Refined {
    fn new<const C: usize, const P: usize>(dense: &dense_reference::DenseReference<N_PARAMS, C, P>) -> Self {
        let (m, n) = (dense.jacobian.nrows(), dense.jacobian.ncols());
        let j = nalgebra::DMatrix::from_fn(m, n, |r, c| dense.jacobian[(r, c)]);
        let normal = nalgebra::DMatrix::from_fn(n, n, |a, b| dense.normal[(a, b)]);
        let cholesky = normal.cholesky().expect("dense normal matrix positive definite");
        Self { j, cholesky }
    }

    /// `b − Jᵀ(J x) − Jᵀ y` in double-double, rounded (`y`: an extra
    /// row-space term, the residual for the step).
    fn residual(&self, b: &[f64], x: &[f64], y: Option<&[f64]>) -> Vec<f64> {
        let (m, n) = self.j.shape();
        let jx: Vec<Dd> = (0..m)
            .map(|r| {
                let mut acc = Dd::default();
                if let Some(y) = y {
                    acc = acc.add(y[r]);
                }
                for c in 0..n {
                    acc = acc.add_product(self.j[(r, c)], x[c]);
                }
                acc
            })
            .collect();
        (0..n)
            .map(|c| {
                let mut acc = Dd::default().add(b[c]);
                for r in 0..m {
                    acc = acc.add_product(-self.j[(r, c)], jx[r].hi);
                    acc = acc.add_product(-self.j[(r, c)], jx[r].lo);
                }
                acc.hi + acc.lo
            })
            .collect()
    }

    /// Solves `JᵀJ x = b − Jᵀ y` by refinement from `x0`.
    fn solve(&self, b: &[f64], y: Option<&[f64]>, x0: &[f64], rounds: usize) -> Vec<f64> {
        let mut x = x0.to_vec();
        for _ in 0..rounds {
            let rho = nalgebra::DVector::from_vec(self.residual(b, &x, y));
            let correction = self.cholesky.solve(&rho);
            for (xi, ci) in x.iter_mut().zip(correction.iter()) {
                *xi += ci;
            }
        }
        x
    }

    /// The Gauss-Newton step `δ = −N⁻¹ Jᵀ r`, refined from `start`.
    fn step(&self, residual: &[f64], start: &[f64]) -> Vec<f64> {
        let zero = vec![0.0; self.j.ncols()];
        let minus_r: Vec<f64> = residual.iter().map(|v| -v).collect();
        self.solve(&zero, Some(&minus_r), start, 6)
    }

    /// The first `N_PARAMS` columns of `N⁻¹` (the covariance of the global
    /// block is their first `N_PARAMS` rows), refined from `start`.
    fn global_covariance(&self, start: &ParamCovariance) -> ParamCovariance {
        let n = self.j.ncols();
        let mut out = ParamCovariance::zeros();
        for k in 0..N_PARAMS {
            let mut e = vec![0.0; n];
            e[k] = 1.0;
            let mut x0 = self.cholesky.solve(&nalgebra::DVector::from_vec(e.clone()));
            for a in 0..N_PARAMS {
                x0[a] = start[(a, k)];
            }
            let x = self.solve(&e, None, x0.as_slice(), 6);
            for a in 0..N_PARAMS {
                out[(a, k)] = x[a];
            }
        }
        out
    }
}

/// Compares the Schur solver with the dense reference at `state`: the
/// Gauss-Newton step (from `linear_step`, and from `solve` with one
/// iteration, differencing the states), the covariance of the global block
/// and the group sigmas (from `solve` with zero iterations).
fn compare<const C: usize, const P: usize, const R: usize, Pr: Problem<N_PARAMS, C, P, R>>(
    label: &str,
    problem: &Pr,
    state: &State<N_PARAMS, C, P>,
) {
    let start = Instant::now();
    let dense = dense_reference::solve(problem, state, 0.0).expect("dense reference");
    let dense_step = flatten(&dense.step);
    let n = dense_step.len();
    assert_eq!(n, state.n_unknowns());

    // The step as the solver's linear algebra computes it.
    let schur = linear_step(
        problem,
        state,
        0.0,
        SolverOptions::default().groups_per_chunk,
    )
    .expect("Schur step");
    let step_diff = rel_diff(&flatten(&schur.delta), &dense_step);
    let global_diff = {
        let a: Vec<f64> = schur.delta.global.iter().copied().collect();
        let b: Vec<f64> = dense.step.global.iter().copied().collect();
        rel_diff(&a, &b)
    };
    let cost_diff = (schur.cost - dense.cost).abs() / dense.cost;

    // The first update of a real run: one Gauss-Newton iteration, state
    // after minus state before.
    let one = solve(
        problem,
        state.clone(),
        &SolverOptions {
            max_iterations: 1,
            ..SolverOptions::default()
        },
        &mut |_| {},
    );
    assert_eq!(one.status, Status::IterationLimit, "{label}: one iteration");
    let taken: Vec<f64> = flatten(&one.state)
        .iter()
        .zip(flatten(state))
        .map(|(after, before)| after - before)
        .collect();
    let taken_diff = rel_diff(&taken, &dense_step);
    let history_norm = one.history[0].step_norm;
    let norm_diff = (history_norm - norm(&dense_step)).abs() / norm(&dense_step);

    // Covariance at the same state: zero iterations evaluate it there.
    let zero = solve(
        problem,
        state.clone(),
        &SolverOptions {
            max_iterations: 0,
            ..SolverOptions::default()
        },
        &mut |_| {},
    );
    assert_eq!(
        zero.state, *state,
        "{label}: zero iterations moved the state"
    );
    let schur_cov = zero.covariance.expect("Schur covariance");
    let dense_cov = dense.global_covariance().expect("dense covariance");
    let cov_diff = (schur_cov - dense_cov).norm() / dense_cov.norm();
    let sigma_diff = {
        let a: Vec<f64> = schur_cov.diagonal().iter().map(|v| v.sqrt()).collect();
        let b: Vec<f64> = dense_cov.diagonal().iter().map(|v| v.sqrt()).collect();
        a.iter()
            .zip(&b)
            .map(|(x, y)| ((x - y) / y).abs())
            .fold(0.0, f64::max)
    };
    let group_diff = {
        let a: Vec<f64> = zero
            .group_sigmas
            .expect("Schur group sigmas")
            .iter()
            .flat_map(|s| s.iter().copied())
            .collect();
        let b: Vec<f64> = dense
            .group_sigmas()
            .expect("dense group sigmas")
            .iter()
            .flat_map(|s| s.iter().copied())
            .collect();
        rel_diff(&a, &b)
    };

    let refined = Refined::new(&dense);
    let residual: Vec<f64> = (0..dense.residual.nrows()).map(|r| dense.residual[(r, 0)]).collect();
    let exact_step = refined.step(&residual, &dense_step);
    let exact_cov = refined.global_covariance(&dense_cov);
    println!(
        "  refined: step rel error dense {:.2e}, Schur {:.2e}; covariance rel error dense {:.2e}, Schur {:.2e}",
        rel_diff(&dense_step, &exact_step),
        rel_diff(&flatten(&schur.delta), &exact_step),
        (dense_cov - exact_cov).norm() / exact_cov.norm(),
        (schur_cov - exact_cov).norm() / exact_cov.norm(),
    );
    println!(
        "{label}: {n} unknowns, {} rows, cond(N) {:.2e}, |δ| {:.4e}\n\
         \x20 step rel diff: linear_step {step_diff:.2e} (global block {global_diff:.2e}), \
         solve(1 iteration) {taken_diff:.2e}, history |δ| {norm_diff:.2e}; cost rel diff {cost_diff:.2e}\n\
         \x20 covariance of the 33 rel diff {cov_diff:.2e}, worst sigma rel diff {sigma_diff:.2e}, \
         group sigmas rel diff {group_diff:.2e}  ({:.2} s)",
        dense.jacobian.nrows(),
        condition(&dense),
        norm(&dense_step),
        start.elapsed().as_secs_f64(),
    );
    assert!(
        step_diff < TOL,
        "{label}: Schur step differs from the dense one by {step_diff:e}"
    );
    assert!(
        taken_diff < TOL,
        "{label}: the first update of solve differs from the dense step by {taken_diff:e}"
    );
    assert!(
        norm_diff < TOL,
        "{label}: the recorded |δ| differs from the dense one by {norm_diff:e}"
    );
    assert!(cost_diff < 1e-12, "{label}: cost differs by {cost_diff:e}");
    assert!(
        cov_diff < TOL,
        "{label}: covariance of the 33 differs by {cov_diff:e}"
    );
    assert!(
        sigma_diff < TOL,
        "{label}: a parameter sigma differs by {sigma_diff:e}"
    );
    assert!(
        group_diff < TOL,
        "{label}: centre sigmas differ by {group_diff:e}"
    );
}

fn options(sim: Simulation, prior: PriorMode) -> CalibrationOptions {
    CalibrationOptions {
        prior,
        ..CalibrationOptions::simulation(sim)
    }
}

#[test]
fn coordinate_observation_matches_the_dense_solve() {
    let dataset = dataset();
    for prior in [PriorMode::Propagated, PriorMode::Paper] {
        let (problem, state) =
            coordinate_problem_and_state(&dataset, &options(Simulation::IV, prior)).unwrap();
        assert_eq!(state.n_unknowns(), 33 + 81 + 378);
        compare(&format!("coordinates, {prior} prior"), &problem, &state);
    }
}

/// There is no `radius_problem_and_state`; the public [`Setup`] builds the
/// same problem and initial state as `calibrate` does.
#[test]
fn radius_observation_matches_the_dense_solve() {
    let dataset = dataset();
    for prior in [PriorMode::Propagated, PriorMode::Paper] {
        let options = options(Simulation::III, prior);
        let setup = Setup::new(&dataset, &options).unwrap();
        let problem = setup.radius_problem(&dataset, &options).unwrap();
        let state = State::<N_PARAMS, 3, 0> {
            global: setup.initial_params,
            groups: setup.initial_centres.clone(),
            points: vec![nalgebra::SVector::zeros(); setup.order.len()],
        };
        assert_eq!(state.n_unknowns(), 33 + 81);
        compare(&format!("radius, {prior} prior"), &problem, &state);
    }
}
