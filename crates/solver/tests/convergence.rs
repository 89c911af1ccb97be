//! Gauss–Newton and Levenberg–Marquardt on noisy synthetic problems.

use crate::common;

use common::{
    Spec, couple, direction, distances, flatten, perturb, rel_diff, sigmas_apart, touches,
};
use parcal_solver::{
    IterationRecord, Method, Problem, SIGMA_TOLERANCE, Solution, SolverOptions, State, Status,
    linear_step, solve,
};

fn options(method: Method) -> SolverOptions {
    SolverOptions {
        method,
        groups_per_chunk: 3,
        ..SolverOptions::default()
    }
}

const LM: Method = Method::LevenbergMarquardt {
    initial_lambda: 1e-3,
};

fn run<const P: usize, const R: usize, Pr: Problem<3, P, R>>(
    problem: &Pr,
    start: &State<3, P>,
    method: Method,
) -> (Solution<3, P>, Vec<IterationRecord>) {
    let mut seen = Vec::new();
    let solution = solve(problem, start.clone(), &options(method), &mut |r| {
        seen.push(r.clone())
    });
    (solution, seen)
}

/// The estimate is within `k` sigmas of the truth, per global parameter and
/// per centre coordinate, and its Mahalanobis distance is plausible.
fn check_against_truth<const P: usize>(solution: &Solution<3, P>, truth: &State<3, P>, dof: usize) {
    let cov = solution.covariance.clone().expect("covariance");
    let g = cov.nrows();
    let err = &solution.state.global - &truth.global;
    let z: Vec<f64> = (0..g).map(|j| err[j] / cov[(j, j)].sqrt()).collect();
    let mahalanobis = err.dot(&(cov.try_inverse().unwrap() * &err));
    let sigmas = solution.group_sigmas.as_ref().expect("group sigmas");
    let zc = solution
        .state
        .groups
        .iter()
        .zip(&truth.groups)
        .zip(sigmas)
        // A fixed group (sigma 0) is not an estimate.
        .filter(|(_, s)| s.iter().all(|s| *s > 0.0))
        .flat_map(|((c, t), s)| (0..3).map(move |j| (c[j] - t[j]) / s[j]))
        .fold(0.0, |m: f64, z| m.max(z.abs()));
    let cost = solution.history.last().unwrap().cost;
    println!(
        "global z-scores {:?}\nMahalanobis² {mahalanobis:.2} (χ²({g})), worst centre |z| {zc:.2}, cost {cost:.1} for {dof} degrees of freedom",
        z.iter().map(|z| format!("{z:.2}")).collect::<Vec<_>>()
    );
    assert!(
        z.iter().all(|z| z.abs() < 4.0),
        "global parameter off by > 4σ: {z:?}"
    );
    // χ²(G): mean G, standard deviation √(2G); 30 for G = 8 is 5.5 of them.
    let limit = (g as f64 + 5.5 * (2.0 * g as f64).sqrt()).max(30.0);
    assert!(mahalanobis < limit, "Mahalanobis² {mahalanobis}");
    assert!(zc < 4.5, "centre off by {zc}σ");
    let ratio = cost / dof as f64;
    assert!((0.5..1.6).contains(&ratio), "cost / dof = {ratio}");
}

fn without_points<const P: usize>(s: &State<3, P>) -> State<3, 0> {
    State {
        global: s.global.clone(),
        groups: s.groups.clone(),
        points: Vec::new(),
    }
}

/// The observer saw every record; every record but the last has a step;
/// the last (a converged run's final state) has the step that certified
/// convergence, not applied: below the step tolerance relative to the
/// state, or, undamped, below the sigma tolerance.
fn check_history<const P: usize>(solution: &Solution<3, P>, seen: &[IterationRecord]) {
    assert_eq!(seen, &solution.history[..], "the observer saw every record");
    let last = solution.history.last().unwrap();
    let state = &solution.state;
    let state_norm2 = state.global.norm_squared()
        + state.groups.iter().map(|c| c.norm_squared()).sum::<f64>()
        + state.points.iter().map(|p| p.norm_squared()).sum::<f64>();
    let tolerance = SolverOptions::default().step_tolerance;
    assert!(
        last.step_norm / (state_norm2.sqrt() + 1.0) < tolerance
            || (last.lambda == 0.0 && last.step_sigmas < SIGMA_TOLERANCE),
        "final step {} ({} sigma)",
        last.step_norm,
        last.step_sigmas
    );
    assert!(
        solution.history[..solution.history.len() - 1]
            .iter()
            .all(|r| r.step_norm > 0.0)
    );
}

#[test]
fn gauss_newton_converges_to_truth_within_sigmas() {
    let spec = Spec {
        n_groups: 10,
        points_per_group: 12,
        ..Spec::default()
    };
    let (problem, truth) = touches(spec);
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    let (solution, seen) = run(&problem, &start, Method::GaussNewton);
    println!(
        "GN: {:?} after {} records",
        solution.status,
        solution.history.len()
    );
    for r in &solution.history {
        println!("  cost {:.6e} step {:.3e}", r.cost, r.step_norm);
    }
    assert_eq!(solution.status, Status::Converged);
    assert!(solution.history.len() <= 12);
    assert!(
        solution
            .history
            .iter()
            .all(|r| r.lambda == 0.0 && r.accepted)
    );
    check_history(&solution, &seen);
    // The groups' data costs, from the final iterate's elimination pass, add
    // up to the final record's data cost.
    let group_costs = solution.group_costs.as_ref().expect("group costs");
    assert_eq!(group_costs.len(), 10);
    let data_cost = solution.history.last().unwrap().data_cost;
    let total: f64 = group_costs.iter().sum();
    assert!(
        (total - data_cost).abs() <= 1e-12 * data_cost,
        "{total} vs {data_cost}"
    );
    // 120 points × 3 rows, 8 + 30 + 240 unknowns.
    check_against_truth(&solution, &truth, 360 - 278);
    let spectrum = solution.spectrum.as_ref().unwrap();
    assert!(spectrum.condition_number().is_finite());
}

/// The sigma rule alone (no step tolerance) ends a Gauss–Newton run at a
/// step below [`SIGMA_TOLERANCE`] standard deviations, and there every
/// global parameter and centre coordinate is within that many of its
/// sigmas of the minimum (solved to a step tolerance of 1e-14 without the
/// rule): the step left is the bound of what the run leaves undone, the
/// steps after it being smaller still.
/// A Gauss–Newton run of least squares certifies its last step from the
/// reduced system, without back-substituting it: the record's `√(δᵀHδ)`
/// is the back-substitution's at that iterate, to within the rounding of
/// the cost (`√(ε · cost)` in sigmas), and its norm is the step's global
/// part.
#[test]
fn the_reduced_system_certifies_the_last_step_as_the_back_substitution_would() {
    for priors in [false, true] {
        let (problem, truth) = touches(Spec {
            priors,
            seed: 11,
            ..Spec::default()
        });
        let start = perturb(&truth, 2, 0.01, 0.02, 0.1);
        let options = SolverOptions {
            step_tolerance: 0.0,
            ..options(Method::GaussNewton)
        };
        let ended = solve(&problem, start, &options, &mut |_| {});
        assert_eq!(ended.status, Status::Converged);
        let last = ended.history.last().unwrap();
        let full = linear_step(
            &problem,
            &ended.state,
            &mut Vec::new(),
            0.0,
            options.groups_per_chunk,
        )
        .expect("step at the final iterate");
        let sigmas = full.predicted_decrease.max(0.0).sqrt();
        let rounding = (f64::EPSILON * full.cost).sqrt();
        println!(
            "priors {priors}: certified {:.3e} sigma, back-substituted {sigmas:.3e} (rounding {rounding:.1e}); |δg| {:.3e} vs {:.3e}",
            last.step_sigmas,
            last.step_norm,
            full.delta.global.norm()
        );
        assert!(last.step_sigmas < SIGMA_TOLERANCE && sigmas < SIGMA_TOLERANCE);
        assert!(
            (last.step_sigmas - sigmas).abs() <= rounding,
            "{} against {sigmas}",
            last.step_sigmas
        );
        assert_eq!(last.step_norm, full.delta.global.norm());
    }
}

#[test]
fn the_sigma_rule_ends_within_its_tolerance_of_the_minimum() {
    let spec = Spec {
        n_groups: 10,
        points_per_group: 12,
        ..Spec::default()
    };
    let (problem, truth) = touches(spec);
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    let sigma_rule = SolverOptions {
        step_tolerance: 0.0,
        ..options(Method::GaussNewton)
    };
    let ended = solve(&problem, start.clone(), &sigma_rule, &mut |_| {});
    let tight = SolverOptions {
        step_tolerance: 1e-14,
        sigma_tolerance: 0.0,
        ..options(Method::GaussNewton)
    };
    let minimum = solve(&problem, start, &tight, &mut |_| {});
    assert_eq!(ended.status, Status::Converged);
    assert_eq!(minimum.status, Status::Converged);
    let last = ended.history.last().unwrap();
    assert!(last.step_sigmas < SIGMA_TOLERANCE, "{}", last.step_sigmas);
    let cov = minimum.covariance.as_ref().expect("covariance");
    let mut worst: f64 = 0.0;
    for j in 0..cov.nrows() {
        let z = (ended.state.global[j] - minimum.state.global[j]) / cov[(j, j)].sqrt();
        worst = worst.max(z.abs());
    }
    let sigmas = minimum.group_sigmas.as_ref().expect("group sigmas");
    for ((a, b), s) in ended
        .state
        .groups
        .iter()
        .zip(&minimum.state.groups)
        .zip(sigmas)
    {
        for j in 0..3 {
            worst = worst.max(((a[j] - b[j]) / s[j]).abs());
        }
    }
    println!(
        "sigma rule: {} records, last step {:.2e} sigma; tight: {} records; worst |Δ|/σ {worst:.2e}",
        ended.history.len(),
        last.step_sigmas,
        minimum.history.len()
    );
    assert!(ended.history.len() < minimum.history.len());
    assert!(worst < SIGMA_TOLERANCE, "{worst}");
}

#[test]
fn gauss_newton_converges_without_point_unknowns() {
    let spec = Spec {
        n_groups: 10,
        points_per_group: 12,
        seed: 5,
        ..Spec::default()
    };
    let (problem, truth) = distances(spec);
    let start = perturb(&truth, 2, 0.01, 0.02, 0.0);
    let (solution, seen) = run(&problem, &start, Method::GaussNewton);
    println!(
        "GN (P = 0): {:?} after {} records",
        solution.status,
        solution.history.len()
    );
    assert_eq!(solution.status, Status::Converged);
    check_history(&solution, &seen);
    check_against_truth(&solution, &truth, 120 - 38);
}

#[test]
fn levenberg_marquardt_converges_where_gauss_newton_diverges() {
    let spec = Spec {
        n_groups: 10,
        points_per_group: 12,
        ..Spec::default()
    };
    let (problem, truth) = touches(spec);
    let good_start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    let bad_start = perturb(&truth, 1, 0.1, 0.1, 1.0);
    // The minimum to the step tolerance, as Levenberg–Marquardt reaches it
    // (the sigma rule would end Gauss–Newton up to 1e-3 sigma short).
    let to_step_tolerance = SolverOptions {
        sigma_tolerance: 0.0,
        ..options(Method::GaussNewton)
    };
    let reference = solve(&problem, good_start, &to_step_tolerance, &mut |_| {});
    assert_eq!(reference.status, Status::Converged);

    let (gn, gn_seen) = run(&problem, &bad_start, Method::GaussNewton);
    println!(
        "GN from the bad start: {:?} after {} records",
        gn.status,
        gn.history.len()
    );
    assert!(
        matches!(gn.status, Status::Diverged { .. }),
        "{:?}",
        gn.status
    );
    assert!(gn.state.is_finite());
    assert_eq!(gn_seen, gn.history);
    let initial_cost = gn.history[0].cost;
    assert!(gn.history.iter().all(|r| r.cost <= 1e6 * initial_cost));

    let (lm, seen) = run(&problem, &bad_start, LM);
    let rejected = lm.history.iter().filter(|r| !r.accepted).count();
    println!(
        "LM from the bad start: {:?} after {} records ({rejected} rejected), cost {:.4e} → {:.4e}",
        lm.status,
        lm.history.len(),
        lm.history[0].cost,
        lm.history.last().unwrap().cost
    );
    assert_eq!(lm.status, Status::Converged);
    check_history(&lm, &seen);
    // Accepted steps never increase the cost.
    for w in lm.history.windows(2) {
        assert!(w[1].cost <= w[0].cost * (1.0 + 1e-12), "{w:?}");
        if !w[0].accepted {
            assert_eq!(w[1].cost, w[0].cost);
            assert!(w[1].lambda > w[0].lambda);
        }
    }
    assert!(
        lm.history[..lm.history.len() - 1]
            .iter()
            .all(|r| r.lambda > 0.0)
    );
    // Same minimum as Gauss–Newton from a good start (the same touch
    // directions, the angles may differ by the sphere's symmetries).
    let diff = rel_diff(
        &flatten(&without_points(&lm.state)),
        &flatten(&without_points(&reference.state)),
    );
    let angle_diff = lm
        .state
        .points
        .iter()
        .zip(&reference.state.points)
        .map(|(a, b)| (direction(a).0 - direction(b).0).norm())
        .fold(0.0, f64::max);
    println!("LM vs GN minimum: rel diff {diff:.2e}, directions {angle_diff:.2e}");
    assert!(diff < 1e-7 && angle_diff < 1e-7);
    check_against_truth(&lm, &truth, 360 - 278);
}

#[test]
fn levenberg_marquardt_and_gauss_newton_agree_with_priors() {
    let (problem, truth) = touches(Spec {
        priors: true,
        seed: 9,
        ..Spec::default()
    });
    let start = perturb(&truth, 3, 0.01, 0.02, 0.1);
    let (gn, _) = run(&problem, &start, Method::GaussNewton);
    let (lm, _) = run(&problem, &start, LM);
    assert_eq!(gn.status, Status::Converged);
    assert_eq!(lm.status, Status::Converged);
    assert!(gn.history.last().unwrap().prior_cost > 0.0);
    // Gauss-Newton ends by the sigma rule, within `sigma_tolerance` of
    // each unknown's sigma of the minimum (to first order); LM by the step
    // tolerance, at the minimum to far less.
    let tolerance = options(Method::GaussNewton).sigma_tolerance;
    let sigmas_apart = sigmas_apart(&gn, &lm);
    println!(
        "with priors: GN {} records, LM {} records, {sigmas_apart:.2e} sigma apart",
        gn.history.len(),
        lm.history.len()
    );
    assert!(sigmas_apart < tolerance, "{sigmas_apart:e} sigma apart");
    let cov_diff = rel_diff(
        gn.covariance.unwrap().as_slice(),
        lm.covariance.unwrap().as_slice(),
    );
    assert!(cov_diff < 1e-6);
}

#[test]
fn both_methods_converge_with_centres_in_the_global_block() {
    // Groups 1, 3 and 4 have their centres in the global block, measured
    // against each other by three distances; group 5 is held at the truth.
    let spec = Spec {
        n_groups: 10,
        points_per_group: 12,
        seed: 4,
        ..Spec::default()
    };
    let (mut problem, truth) = touches(spec);
    let truth = couple(&mut problem.0, &truth, &[1, 3, 4], &[5], 1e-3, 1);
    let mut start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    start.groups[5] = truth.groups[5];
    for method in [Method::GaussNewton, LM] {
        let (solution, seen) = run(&problem, &start, method);
        println!(
            "{method:?}: {:?} after {} records, global observation cost {:.3e}",
            solution.status,
            solution.history.len(),
            solution.history.last().unwrap().global_observation_cost
        );
        assert_eq!(solution.status, Status::Converged);
        check_history(&solution, &seen);
        let last = solution.history.last().unwrap();
        assert!(last.global_observation_cost > 0.0);
        assert_eq!(
            last.cost,
            last.data_cost + last.global_observation_cost + last.prior_cost
        );
        // The fixed groups keep their values and report zero sigmas.
        let sigmas = solution.group_sigmas.as_ref().unwrap();
        for k in [1, 3, 4, 5] {
            assert_eq!(solution.state.groups[k], start.groups[k]);
            assert_eq!(sigmas[k].norm(), 0.0);
        }
        // 360 rows and 3 distances; 8 + 9 global unknowns, 6 × 3 centres,
        // 240 angles.
        check_against_truth(&solution, &truth, 363 - 275);
    }
}

/// A zero time budget: the run ends at the initial state with
/// `TimeLimit` (not a divergence), evaluated there as at the iteration
/// limit (one record, covariance and group sigmas); an ample budget
/// changes nothing.
#[test]
fn a_time_limit_ends_the_run_at_its_iterate() {
    let spec = Spec {
        n_groups: 10,
        points_per_group: 12,
        ..Spec::default()
    };
    let (problem, truth) = touches(spec);
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    for method in [Method::GaussNewton, LM] {
        let budget = |time_limit| SolverOptions {
            time_limit,
            ..options(method)
        };
        let zero = solve(
            &problem,
            start.clone(),
            &budget(Some(std::time::Duration::ZERO)),
            &mut |_| {},
        );
        assert_eq!(zero.status, Status::TimeLimit);
        assert_eq!(zero.history.len(), 1);
        assert_eq!(zero.state, start);
        assert!(zero.covariance.is_some() && zero.group_sigmas.is_some());
        let ample = solve(
            &problem,
            start.clone(),
            &budget(Some(std::time::Duration::from_secs(3600))),
            &mut |_| {},
        );
        let (free, _) = run(&problem, &start, method);
        assert_eq!(ample.status, Status::Converged);
        assert_eq!(ample.state, free.state);
    }
}
