//! The Schur solver's step and covariance against a plain dense solve of the
//! full normal equations.

use crate::common;

use common::{G, Spec, couple, distances, flatten, perturb, rel_diff, touches};
use parcal_solver::{
    CAUCHY_K, HUBER_K, Loss, Method, Problem, SolverOptions, State, Status, dense_reference,
    linear_step, reduced_step, solve,
};

const TOL: f64 = 1e-9;

/// `−2 gᵀδ − δᵀNδ` from the dense system.
fn dense_predicted_decrease<const C: usize, const P: usize>(
    d: &dense_reference::DenseReference<C, P>,
) -> f64 {
    let delta = d.columns.vector(&d.step);
    let jd = &d.jacobian * &delta;
    let mut pred = 0.0;
    for r in 0..jd.nrows() {
        pred -= 2.0 * d.residual[(r, 0)] * jd[(r, 0)] + jd[(r, 0)] * jd[(r, 0)];
    }
    pred
}

/// Compares one step at `state`; returns the relative step difference.
fn compare_step<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
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
    if lambda == 0.0 && problem.loss().is_squared() {
        // The reduced system alone gives the same global step and the
        // minimum of the linearised cost, `cost − predicted decrease` (of
        // least squares: a robust loss's is that of the reweighted rows).
        let reduced = reduced_step(problem, state, &mut Vec::new(), 2).expect("reduced step");
        assert_eq!(reduced.global, schur.delta.global);
        let minimum = dense.cost - dense_pred;
        // Relative to the cost: what is subtracted to reach the minimum.
        let minimum_diff = (reduced.minimum - minimum).abs() / dense.cost;
        println!(
            "minimum {:.9e} vs {minimum:.9e} (rel {minimum_diff:.1e})",
            reduced.minimum
        );
        assert!(minimum_diff < TOL, "minimum differs: {minimum_diff:e}");
    }
    // The step in standard deviations, √(δᵀHδ) with the undamped H, as
    // the solver records it.
    let method = if lambda == 0.0 {
        Method::GaussNewton
    } else {
        Method::LevenbergMarquardt {
            initial_lambda: lambda,
        }
    };
    let options = SolverOptions {
        method,
        max_iterations: 1,
        groups_per_chunk: 2,
        ..SolverOptions::default()
    };
    let one = solve(problem, state.clone(), &options, &mut |_| {});
    let jd = &dense.jacobian * dense.columns.vector(&dense.step);
    let sigmas = (0..jd.nrows())
        .map(|r| jd[(r, 0)] * jd[(r, 0)])
        .sum::<f64>()
        .sqrt();
    let sigmas_diff = (one.history[0].step_sigmas - sigmas).abs() / sigmas;
    assert!(sigmas_diff < TOL, "step in sigmas differs: {sigmas_diff:e}");
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
fn compare_covariance<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
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
    // Fixed groups: zero on both sides.
    let sigma_diff = sigmas
        .iter()
        .zip(&dense_sigmas)
        .map(|(a, b)| {
            if *b == 0.0 {
                a.abs()
            } else {
                (a - b).abs() / b
            }
        })
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
    assert_eq!(spectrum.eigenvalues.len(), state.global.len());
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

/// Groups 1, 3 and 4 have their centres in the global block (fixed groups),
/// measured against each other by three distances (σ 1e-3); group 5 is held
/// at its value.
const COUPLED: [usize; 3] = [1, 3, 4];
const HELD: [usize; 1] = [5];

#[test]
fn coupled_touches_step_matches_dense() {
    for priors in [false, true] {
        let (mut problem, truth) = touches(Spec {
            priors,
            seed: 13,
            ..Spec::default()
        });
        let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 1);
        assert_eq!(problem.global_size(), G + 9);
        assert_eq!(problem.0.distances.len(), 3);
        let state = perturb(&truth, 4, 0.01, 0.02, 0.1);
        compare_step(&problem, &state, 0.0);
        compare_step(&problem, &state, 0.3);
        compare_step(&problem, &state, 1e-4);
        // A fixed group does not move; the others do.
        let step = linear_step(&problem, &state, &mut Vec::new(), 0.0, 2).unwrap();
        for k in 0..problem.n_groups() {
            let fixed = COUPLED.contains(&k) || HELD.contains(&k);
            assert_eq!(step.delta.groups[k].norm() == 0.0, fixed, "group {k}");
        }
    }
}

#[test]
fn coupled_distances_step_matches_dense() {
    for priors in [false, true] {
        let (mut problem, truth) = distances(Spec {
            priors,
            seed: 17,
            ..Spec::default()
        });
        let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 2);
        let state = perturb(&truth, 5, 0.01, 0.02, 0.0);
        compare_step(&problem, &state, 0.0);
        compare_step(&problem, &state, 2.0);
    }
}

#[test]
fn coupled_covariance_and_group_sigmas_match_dense_inverse() {
    for priors in [false, true] {
        let spec = Spec {
            priors,
            seed: 23,
            ..Spec::default()
        };
        let (mut problem, truth) = touches(spec);
        let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 3);
        compare_covariance(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.05));
        let (mut problem, truth) = distances(spec);
        let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 4);
        compare_covariance(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.0));
    }
}

/// Central differences of the residuals (data, global observation and
/// prior rows) against the Jacobian the dense reference assembles from the
/// problem's: every column, including the moved centres' and the
/// distances' rows.
fn check_jacobian<const P: usize, const R: usize, Pr: Problem<3, P, R>>(
    problem: &Pr,
    state: &State<3, P>,
) {
    let at = |x: &State<3, P>| dense_reference::solve(problem, x, 0.0).expect("dense");
    let dense = at(state);
    let columns = &dense.columns;
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    let mut check = |column: usize, shift: &dyn Fn(&mut State<3, P>, f64)| {
        let (mut plus, mut minus) = (state.clone(), state.clone());
        shift(&mut plus, h);
        shift(&mut minus, -h);
        let (rp, rm) = (at(&plus).residual, at(&minus).residual);
        for r in 0..dense.jacobian.nrows() {
            let fd = (rp[(r, 0)] - rm[(r, 0)]) / (2.0 * h);
            let analytic = dense.jacobian[(r, column)];
            let error = (fd - analytic).abs() / analytic.abs().max(1.0);
            worst = worst.max(error);
            assert!(error < 1e-5, "row {r}, column {column}: {fd} vs {analytic}");
        }
    };
    for j in 0..state.global.len() {
        check(columns.global(j), &|x, d| x.global[j] += d);
    }
    for k in 0..state.groups.len() {
        for j in 0..3 {
            if let Some(column) = columns.group(k, j) {
                check(column, &|x, d| x.groups[k][j] += d);
            }
        }
    }
    for i in 0..state.points.len() {
        for j in 0..P {
            check(columns.point(i, j), &|x, d| x.points[i][j] += d);
        }
    }
    println!(
        "{} columns, worst relative difference {worst:.1e}",
        dense.jacobian.ncols()
    );
}

#[test]
fn coupled_jacobians_match_finite_differences() {
    let spec = Spec {
        priors: true,
        seed: 29,
        n_groups: 6,
        points_per_group: 4,
        ..Spec::default()
    };
    let (mut problem, truth) = touches(spec);
    let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 5);
    check_jacobian(&problem, &perturb(&truth, 7, 0.01, 0.02, 0.1));
    let (mut problem, truth) = distances(spec);
    let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 6);
    check_jacobian(&problem, &perturb(&truth, 7, 0.01, 0.02, 0.0));
}

/// With a robust loss, the Schur step, predicted decrease, cost and
/// covariance against the dense reference, which weighs its rows from the
/// loss's weight function alone. The perturbed states put most residuals
/// well beyond `k` (the weights are in play: the weighted cost is far
/// below least squares'), the distances are grouped into observations of
/// two rows and one, and the priors are not weighted.
#[test]
fn robust_steps_and_covariance_match_dense() {
    for loss in [Loss::Huber { k: HUBER_K }, Loss::Cauchy { k: CAUCHY_K }] {
        let spec = Spec {
            priors: true,
            seed: 29,
            ..Spec::default()
        };
        let (mut problem, truth) = touches(spec);
        let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 5);
        problem.0.observation_rows = Some(vec![2, 1]);
        let state = perturb(&truth, 4, 0.01, 0.02, 0.1);
        let squared = linear_step(&problem, &state, &mut Vec::new(), 0.0, 2).unwrap();
        problem.0.loss = loss;
        let weighted = linear_step(&problem, &state, &mut Vec::new(), 0.0, 2).unwrap();
        println!(
            "{loss}: cost {:.3e}, least squares {:.3e}",
            weighted.cost, squared.cost
        );
        assert!(weighted.cost < 0.5 * squared.cost);
        compare_step(&problem, &state, 0.0);
        compare_step(&problem, &state, 0.3);
        compare_covariance(&problem, &state);
        let (mut problem, truth) = distances(spec);
        let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 6);
        problem.0.loss = loss;
        let state = perturb(&truth, 5, 0.01, 0.02, 0.0);
        compare_step(&problem, &state, 0.0);
        compare_step(&problem, &state, 2.0);
        compare_covariance(&problem, &state);
    }
}

/// Global observation sizes that do not add up to its rows fail the pass
/// with a message, not a panic.
#[test]
fn robust_observation_sizes_must_fit_the_rows() {
    let (mut problem, truth) = touches(Spec::default());
    let truth = couple(&mut problem.0, &truth, &COUPLED, &HELD, 1e-3, 5);
    problem.0.loss = Loss::Huber { k: HUBER_K };
    problem.0.observation_rows = Some(vec![2, 2]);
    let failed = linear_step(&problem, &truth, &mut Vec::new(), 0.0, 2).unwrap_err();
    let Status::ProblemFailed { message, .. } = failed else {
        panic!("{failed:?}");
    };
    assert!(message.contains("4 rows in all"), "{message}");
}
