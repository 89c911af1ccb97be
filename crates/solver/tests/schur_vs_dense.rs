//! The Schur solver's step and covariance against a plain dense solve of the
//! full normal equations.

mod common;

use common::{G, Spec, distances, flatten, perturb, rel_diff, touches};
use faer::Mat;
use parcal_solver::{Problem, SolverOptions, State, Status, dense_reference, linear_step, solve};

const TOL: f64 = 1e-9;

/// `−2 gᵀδ − δᵀNδ` from the dense system.
fn dense_predicted_decrease<const C: usize, const P: usize>(
    d: &dense_reference::DenseReference<G, C, P>,
) -> f64 {
    let n = d.normal.nrows();
    let delta_state = &d.step;
    let n_groups = delta_state.groups.len();
    let mut delta = Mat::<f64>::zeros(n, 1);
    for j in 0..G {
        delta[(dense_reference::global_index(j), 0)] = delta_state.global[j];
    }
    for (k, c) in delta_state.groups.iter().enumerate() {
        for j in 0..C {
            delta[(dense_reference::group_index::<G, C>(k, j), 0)] = c[j];
        }
    }
    for (i, p) in delta_state.points.iter().enumerate() {
        for j in 0..P {
            delta[(dense_reference::point_index::<G, C, P>(n_groups, i, j), 0)] = p[j];
        }
    }
    let jd = &d.jacobian * &delta;
    let mut pred = 0.0;
    for r in 0..jd.nrows() {
        pred -= 2.0 * d.residual[(r, 0)] * jd[(r, 0)] + jd[(r, 0)] * jd[(r, 0)];
    }
    pred
}

/// Compares one step at `state`; returns the relative step difference.
fn compare_step<const C: usize, const P: usize, const R: usize, Pr: Problem<G, C, P, R>>(
    problem: &Pr,
    state: &State<G, C, P>,
    lambda: f64,
) -> f64 {
    let dense = dense_reference::solve(problem, state, lambda).expect("dense reference");
    let schur = linear_step(problem, state, &mut Vec::new(), lambda, 2).expect("schur step");
    let diff = rel_diff(&flatten(&schur.delta), &flatten(&dense.step));
    let dense_pred = dense_predicted_decrease(&dense);
    let pred_diff = (schur.predicted_decrease - dense_pred).abs() / dense_pred.abs();
    let cost_diff = (schur.cost - dense.cost).abs() / dense.cost;
    println!(
        "λ = {lambda}: |δ| rel diff {diff:.2e}, predicted decrease {:.6e} vs {dense_pred:.6e} (rel {pred_diff:.1e}), cost rel diff {cost_diff:.1e}",
        schur.predicted_decrease
    );
    assert!(diff < TOL, "step differs: {diff:e}");
    assert!(pred_diff < TOL, "predicted decrease differs: {pred_diff:e}");
    assert!(cost_diff < 1e-12, "cost differs: {cost_diff:e}");
    diff
}

#[test]
fn touches_step_matches_dense_without_priors() {
    let (problem, truth) = touches(Spec::default());
    let state = perturb(&truth, 3, 0.01, 0.02, 0.1);
    compare_step(&problem, &state, 0.0);
    compare_step(&problem, &state, 0.3);
    compare_step(&problem, &state, 1e-4);
}

#[test]
fn touches_step_matches_dense_with_all_priors() {
    let (problem, truth) = touches(Spec {
        priors: true,
        seed: 7,
        ..Spec::default()
    });
    assert!(problem.0.global_prior.is_some() && problem.0.point_priors.is_some());
    let state = perturb(&truth, 4, 0.01, 0.02, 0.1);
    compare_step(&problem, &state, 0.0);
    compare_step(&problem, &state, 0.3);
}

#[test]
fn distances_step_matches_dense_with_and_without_priors() {
    for priors in [false, true] {
        let (problem, truth) = distances(Spec {
            priors,
            seed: 11,
            ..Spec::default()
        });
        let state = perturb(&truth, 5, 0.01, 0.02, 0.0);
        compare_step(&problem, &state, 0.0);
        compare_step(&problem, &state, 2.0);
    }
}

#[test]
fn step_is_independent_of_chunking_up_to_rounding() {
    let (problem, truth) = touches(Spec::default());
    let state = perturb(&truth, 3, 0.01, 0.02, 0.1);
    let a = linear_step(&problem, &state, &mut Vec::new(), 0.0, 1).unwrap();
    let b = linear_step(&problem, &state, &mut Vec::new(), 0.0, 1000).unwrap();
    assert!(rel_diff(&flatten(&a.delta), &flatten(&b.delta)) < 1e-12);
}

#[test]
fn step_hands_back_the_caches_of_its_passes() {
    // The test problem's cache counts a point's linearisations: a step makes
    // two passes (elimination, back-substitution), and a second step goes
    // on from the caches the first handed back.
    let (problem, truth) = touches(Spec::default());
    let state = perturb(&truth, 3, 0.01, 0.02, 0.1);
    let mut caches = Vec::new();
    let first = linear_step(&problem, &state, &mut caches, 0.0, 2).unwrap();
    assert_eq!(caches.len(), state.points.len());
    assert!(caches.iter().all(|&calls| calls == 2), "{caches:?}");
    let second = linear_step(&problem, &state, &mut caches, 0.0, 2).unwrap();
    assert!(caches.iter().all(|&calls| calls == 4), "{caches:?}");
    assert_eq!(flatten(&first.delta), flatten(&second.delta));
}

/// `solve` with no iteration evaluates the covariance at the given state.
fn compare_covariance<const C: usize, const P: usize, const R: usize, Pr: Problem<G, C, P, R>>(
    problem: &Pr,
    state: &State<G, C, P>,
) {
    let options = SolverOptions {
        max_iterations: 0,
        groups_per_chunk: 2,
        ..SolverOptions::default()
    };
    let solution = solve(problem, state.clone(), &options, &mut |_| {});
    assert_eq!(solution.status, Status::IterationLimit);
    assert_eq!(&solution.state, state);
    assert_eq!(solution.history.len(), 1);
    let dense = dense_reference::solve(problem, state, 0.0).unwrap();
    let cov = solution.covariance.expect("covariance");
    let dense_cov = dense.global_covariance().expect("dense covariance");
    let cov_diff = rel_diff(cov.as_slice(), dense_cov.as_slice());
    let sigmas: Vec<f64> = solution
        .group_sigmas
        .expect("sigmas")
        .iter()
        .flat_map(|s| s.iter().copied())
        .collect();
    let dense_sigmas: Vec<f64> = dense
        .group_sigmas()
        .unwrap()
        .iter()
        .flat_map(|s| s.iter().copied())
        .collect();
    let sigma_diff = sigmas
        .iter()
        .zip(&dense_sigmas)
        .map(|(a, b)| (a - b).abs() / b)
        .fold(0.0, f64::max);
    let spectrum = solution.spectrum.expect("spectrum");
    println!(
        "Cov(g) rel diff {cov_diff:.2e}, group sigma max rel diff {sigma_diff:.2e}, sigma range {:.3e}..{:.3e}, cond {:.3e}",
        dense_sigmas.iter().copied().fold(f64::INFINITY, f64::min),
        dense_sigmas.iter().copied().fold(0.0, f64::max),
        spectrum.condition_number()
    );
    assert!(cov_diff < TOL, "covariance differs: {cov_diff:e}");
    assert!(sigma_diff < TOL, "group sigmas differ: {sigma_diff:e}");
    assert_eq!(spectrum.eigenvalues.len(), G);
}

#[test]
fn covariance_and_group_sigmas_match_dense_inverse() {
    for priors in [false, true] {
        let spec = Spec {
            priors,
            seed: 21,
            ..Spec::default()
        };
        let (problem, truth) = touches(spec);
        compare_covariance(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.05));
        let (problem, truth) = distances(spec);
        compare_covariance(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.0));
    }
}
