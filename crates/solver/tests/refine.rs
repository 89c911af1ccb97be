//! Group refinement (`parcal_solver::refine`): a group whose own problem
//! is far from linear is brought to its minimum for the current global
//! block, and the run reaches the minimum without refinement reaches, in
//! fewer steps.

use crate::common;

use common::{Rng, Spec, perturb, sigmas_apart, touches};
use nalgebra::Vector3;
use parcal_solver::{Solution, SolverOptions, State, Status, solve};

fn run<Pr: parcal_solver::Problem<3, 2, 3>>(
    problem: &Pr,
    start: &State<3, 2>,
    refine_groups: bool,
) -> Solution<3, 2> {
    let options = SolverOptions {
        groups_per_chunk: 3,
        refine_groups,
        ..SolverOptions::default()
    };
    solve(problem, start.clone(), &options, &mut |_| {})
}

/// `√(δᵀHδ)` of each step of a run.
fn step_sigmas(solution: &Solution<3, 2>) -> Vec<String> {
    let sigmas = solution.history.iter().map(|r| r.step_sigmas);
    sigmas.map(|s| format!("{s:.2e}")).collect()
}

#[test]
fn a_group_far_from_linear_is_refined_and_the_run_ends_sooner() {
    // Touches of 12 balls with priors on everything; ball 0's touches are
    // off by a tenth of the radius (20 sigma a coordinate), as a ball
    // settled in a poor minimum: its residuals are large and curve
    // strongly with its unknowns, and plain Gauss-Newton converges
    // linearly, slowly.
    let (mut problem, truth) = touches(Spec {
        seed: 5,
        n_groups: 12,
        points_per_group: 8,
        noise: 1e-3,
        priors: true,
    });
    let mut rng = Rng::new(11);
    let radius = problem.0.radius;
    for m in &mut problem.0.measurements[..8] {
        *m += Vector3::new(rng.normal(), rng.normal(), rng.normal()) * (radius / 10.0);
    }
    let start = perturb(&truth, 2, 1e-3, 1e-2, 1e-2);
    let plain = run(&problem, &start, false);
    let refined = run(&problem, &start, true);
    println!(
        "steps in sigmas, plain {:?}\nrefined {:?}",
        step_sigmas(&plain),
        step_sigmas(&refined)
    );
    assert_eq!(plain.status, Status::Converged);
    assert_eq!(refined.status, Status::Converged);
    assert!(
        refined.history.len() < plain.history.len(),
        "refined {} steps, plain {}",
        refined.history.len(),
        plain.history.len()
    );
    assert_same_minimum(&plain, &refined);
}

#[test]
fn a_well_behaved_problem_converges_as_before() {
    let (problem, truth) = touches(Spec {
        seed: 7,
        ..Spec::default()
    });
    let start = perturb(&truth, 3, 1e-3, 1e-2, 1e-2);
    let plain = run(&problem, &start, false);
    let refined = run(&problem, &start, true);
    assert_eq!(refined.status, Status::Converged);
    assert!(refined.history.len() <= plain.history.len());
    assert_same_minimum(&plain, &refined);
}

/// Both runs ended within the sigma tolerance of the same minimum: every
/// unknown (and every linear function of them) within 1e-3 of its sigma
/// of the limit, so within 2e-3 of each other's.
fn assert_same_minimum(plain: &Solution<3, 2>, refined: &Solution<3, 2>) {
    let apart = sigmas_apart(plain, refined);
    assert!(apart < 2e-3, "{apart:.2e} sigma apart");
}
