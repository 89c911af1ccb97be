//! A robust loss on a noisy synthetic problem: the iteration converges
//! with either method, down-weights a planted outlier alone, and keeps the
//! global block near the truth where least squares is pulled away.

use crate::common;

use common::{Spec, distances, perturb};
use parcal_solver::{CAUCHY_K, HUBER_K, Loss, Method, SolverOptions, Status, redundancy, solve};

#[test]
fn a_robust_loss_down_weights_a_planted_outlier() {
    let (mut problem, truth) = distances(Spec {
        seed: 31,
        ..Spec::default()
    });
    // Point 13 (group 1) moved 200 sigmas away from its centre.
    let outlier = 13;
    let away = (problem.0.measurements[outlier] - truth.groups[1]).normalize();
    problem.0.measurements[outlier] += 200.0 * problem.0.sigma * away;
    let start = perturb(&truth, 3, 0.002, 0.005, 0.0);
    let options = |method| SolverOptions {
        method,
        max_iterations: 200,
        groups_per_chunk: 2,
        ..SolverOptions::default()
    };
    let error = |global: &nalgebra::DVector<f64>| (global - &truth.global).norm();
    let squared = solve(
        &problem,
        start.clone(),
        &options(Method::GaussNewton),
        &mut |_| {},
    );
    assert_eq!(squared.status, Status::Converged);
    for loss in [Loss::Huber { k: HUBER_K }, Loss::Cauchy { k: CAUCHY_K }] {
        problem.0.loss = loss;
        for method in [
            Method::GaussNewton,
            Method::LevenbergMarquardt {
                initial_lambda: 1e-3,
            },
        ] {
            let solution = solve(&problem, start.clone(), &options(method), &mut |_| {});
            assert_eq!(solution.status, Status::Converged, "{loss}, {method:?}");
            let covariance = solution.covariance.as_ref().unwrap();
            let mut weights = Vec::new();
            let numbers = redundancy(
                &problem,
                &solution.state,
                covariance,
                &mut Vec::new(),
                2,
                |p| weights.push(p.weight),
            )
            .unwrap();
            assert_eq!(weights.len(), solution.state.points.len());
            // A weight for each global observation row.
            let rows = numbers.global_observation_weights.map(|w| w.len());
            assert_eq!(rows, Some(numbers.global_observations.len()), "{loss}");
            println!(
                "{loss}, {method:?}: {} solves, global error {:.2e} (least squares {:.2e}), outlier's weight {:.3e}, smallest other {:.3}",
                solution.history.len(),
                error(&solution.state.global),
                error(&squared.state.global),
                weights[outlier],
                weights
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| *i != outlier)
                    .map(|(_, w)| *w)
                    .fold(1.0, f64::min)
            );
            assert!(weights[outlier] < 0.1, "{loss}");
            // Gaussian noise of 48 points: none beyond 4.5 sigma.
            let smallest = match loss {
                Loss::Huber { k } | Loss::Cauchy { k } => loss.weight(4.5f64.max(k)),
                Loss::Squared => 1.0,
            };
            assert!(
                weights
                    .iter()
                    .enumerate()
                    .all(|(i, &w)| i == outlier || w >= smallest),
                "{loss}"
            );
            // Least squares takes the outlier's full pull (200 sigmas),
            // the robust estimate at most k sigmas of it: a sanity bound.
            assert!(error(&solution.state.global) < 0.5 * error(&squared.state.global));
        }
    }
}
