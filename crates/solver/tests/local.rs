//! Local steps (`SolverOptions::local_steps`): while the iteration has not
//! settled, each group's unknowns go on from the back-substitution's step
//! by Gauss–Newton steps against its points' rows at the new global block.
//! The touches' anchors are that block itself, so their local rows are
//! exact there.

use crate::common;

use common::{Spec, distances, flatten, in_pool, perturb, sigmas_apart, touches};
use parcal_solver::{Problem, Solution, SolverOptions, State, Status, solve};

fn run<const P: usize, const R: usize, Pr: Problem<3, P, R>>(
    problem: &Pr,
    start: &State<3, P>,
    local_steps: usize,
) -> Solution<3, P> {
    let options = SolverOptions {
        groups_per_chunk: 2,
        local_steps,
        ..SolverOptions::default()
    };
    solve(problem, start.clone(), &options, &mut |_| {})
}

/// Touches of 12 balls with priors, from a start whose angles are far off
/// (a fifth of a radian), where the first step's linear local part
/// overshoots. (From half a radian off, the run without local steps ends
/// in a poorer local minimum than the run with them: no place to test
/// that both reach the same one.)
fn far_start() -> (common::Touches, State<3, 2>) {
    let (problem, truth) = touches(Spec {
        seed: 12,
        n_groups: 12,
        points_per_group: 8,
        priors: true,
        ..Spec::default()
    });
    let start = perturb(&truth, 4, 0.01, 0.05, 0.2);
    (problem, start)
}

/// The costs of a run's iterates.
fn costs<const P: usize>(solution: &Solution<3, P>) -> Vec<String> {
    let costs = solution.history.iter().map(|r| r.cost);
    costs.map(|c| format!("{c:.4e}")).collect()
}

#[test]
fn local_steps_lower_the_cost_of_the_next_iterate() {
    // The global block after the first step is the same with and without
    // local steps; each group's kept local steps lower its cost there (its
    // rows and priors at its anchors, here exact), and the other terms of
    // the cost depend on the global block alone.
    let (problem, start) = far_start();
    let linear = run(&problem, &start, 0);
    let local = run(&problem, &start, 2);
    println!(
        "costs, linear {:?}\nlocal {:?}",
        costs(&linear),
        costs(&local)
    );
    assert_eq!(linear.history[0].cost, local.history[0].cost);
    assert!(
        local.history[1].cost < linear.history[1].cost,
        "local {:e}, linear {:e}",
        local.history[1].cost,
        linear.history[1].cost
    );
}

#[test]
fn local_steps_reach_the_same_minimum_in_fewer_steps() {
    let (problem, start) = far_start();
    let linear = run(&problem, &start, 0);
    let local = run(&problem, &start, 2);
    assert_eq!(linear.status, Status::Converged);
    assert_eq!(local.status, Status::Converged);
    assert!(
        local.history.len() < linear.history.len(),
        "local {} records, linear {}",
        local.history.len(),
        linear.history.len()
    );
    // Each within 1e-3 of its sigma of the minimum (the sigma rule), so
    // within 2e-3 of each other.
    let apart = sigmas_apart(&linear, &local);
    assert!(apart < 2e-3, "{apart:.2e} sigma apart");
}

#[test]
fn local_steps_give_the_same_bits_on_one_and_two_threads() {
    let (problem, start) = far_start();
    let on = |threads| in_pool(threads, || run(&problem, &start, 2));
    let (one, two) = (on(1), on(2));
    let bits = |s: &Solution<3, 2>| -> Vec<u64> {
        let costs = s.history.iter().map(|r| r.cost);
        flatten(&s.state)
            .into_iter()
            .chain(costs)
            .map(f64::to_bits)
            .collect()
    };
    assert_eq!(bits(&one), bits(&two));
    // And they were taken.
    assert_ne!(bits(&one), bits(&run(&problem, &start, 0)));
}

#[test]
fn a_problem_without_local_rows_runs_as_without_local_steps() {
    // The distances' problem has no local rows: its groups take none.
    let (problem, truth) = distances(Spec {
        seed: 3,
        ..Spec::default()
    });
    let start = perturb(&truth, 2, 0.01, 0.05, 0.0);
    let (a, b) = (run(&problem, &start, 0), run(&problem, &start, 2));
    assert_eq!(a.status, Status::Converged);
    assert_eq!(flatten(&a.state), flatten(&b.state));
    assert_eq!(a.history, b.history);
}
