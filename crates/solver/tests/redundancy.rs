//! Redundancy numbers against the diagonal of the dense hat matrix
//! `J N⁻¹ Jᵀ`, their sum identity, the statistics of the normalised
//! residuals, and their independence of the number of threads.

use crate::common;

use std::time::Instant;

use common::{Spec, couple, distances, in_pool, perturb, touches};
use nalgebra::{DMatrix, SVector};
use parcal_solver::{
    PointRows, Problem, Redundancy, SolverOptions, State, Status, dense_reference, linear_step,
    normalised_residual, redundancy, solve,
};

const TOL: f64 = 1e-9;

/// The covariance of the global block at `state` (`solve` without
/// iterations evaluates it there), and the groups' sigmas of that solve.
fn evaluated<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    groups_per_chunk: usize,
) -> (DMatrix<f64>, Vec<SVector<f64, C>>) {
    let options = SolverOptions {
        max_iterations: 0,
        groups_per_chunk,
        ..SolverOptions::default()
    };
    let solution = solve(problem, state.clone(), &options, &mut |_| {});
    assert_eq!(solution.status, Status::IterationLimit);
    let sigmas = solution.group_sigmas.expect("group sigmas");
    (solution.covariance.expect("covariance"), sigmas)
}

/// The covariance of the global block at `state`.
fn covariance<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    groups_per_chunk: usize,
) -> DMatrix<f64> {
    evaluated(problem, state, groups_per_chunk).0
}

/// What the redundancy pass gives: every point's rows, in order, and the
/// rest.
struct Numbers<const C: usize, const R: usize> {
    points: Vec<PointRows<R>>,
    rest: Redundancy<C>,
}

impl<const C: usize, const R: usize> Numbers<C, R> {
    /// `Σ r_j` over the data and global observation rows, which equals
    /// `m_data + m_obs − n + prior_leverage.total()` (up to rounding).
    fn total(&self) -> f64 {
        let data: f64 = self.points.iter().map(|p| p.redundancy.sum()).sum();
        data + self.rest.global_observations.iter().sum::<f64>()
    }
}

/// [`redundancy`] with every point's rows kept.
fn numbers<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
    covariance: &DMatrix<f64>,
    caches: &mut Vec<Pr::PointCache>,
    groups_per_chunk: usize,
) -> Result<Numbers<C, R>, Status> {
    let mut points = Vec::new();
    let rest = redundancy(problem, state, covariance, caches, groups_per_chunk, |p| {
        points.push(*p)
    })?;
    Ok(Numbers { points, rest })
}

/// The leverage `h_j = a_j N⁻¹ a_jᵀ` of every row of the dense Jacobian.
fn dense_leverage<const C: usize, const P: usize>(
    dense: &dense_reference::DenseReference<C, P>,
) -> Vec<f64> {
    let inv = dense.inverse.as_ref().expect("N⁻¹");
    let j = &dense.jacobian;
    (0..j.nrows())
        .map(|row| {
            let mut h = 0.0;
            for a in (0..j.ncols()).filter(|&a| j[(row, a)] != 0.0) {
                let s: f64 = (0..j.ncols()).map(|b| inv[(a, b)] * j[(row, b)]).sum();
                h += j[(row, a)] * s;
            }
            h
        })
        .collect()
}

/// Compares the redundancy numbers at `state` with the dense hat matrix
/// (rows: data, global observations, point, group and global priors).
fn compare<const C: usize, const P: usize, const R: usize, Pr: Problem<C, P, R>>(
    problem: &Pr,
    state: &State<C, P>,
) -> Numbers<C, R> {
    let (cov, sigmas) = evaluated(problem, state, 2);
    let ours = numbers(problem, state, &cov, &mut Vec::new(), 2).expect("redundancy");
    // The groups' sigmas of the same pass are the solve's own.
    assert_eq!(ours.rest.group_sigmas, sigmas);
    let dense = dense_reference::solve(problem, state, 0.0).expect("dense reference");
    let h = dense_leverage(&dense);
    let n_points = state.points.len();
    let m_data = R * n_points;
    let m_obs = ours.rest.global_observations.len();
    let mut worst: f64 = 0.0;
    let mut residual_worst: f64 = 0.0;
    // The global leverage: the global part `w_g` of `N⁻¹ a_jᵀ` measured in
    // the global block's covariance, `w_gᵀ Cov(g)⁻¹ w_g`.
    let inv = dense.inverse.as_ref().expect("N⁻¹");
    let g = state.global.len();
    let cov_inverse = DMatrix::from_fn(g, g, |a, b| inv[(a, b)])
        .try_inverse()
        .expect("Cov(g)⁻¹");
    let jacobian = &dense.jacobian;
    let global_leverage = |j: usize| {
        let w = nalgebra::DVector::from_fn(g, |a, _| {
            (0..jacobian.ncols())
                .map(|b| inv[(a, b)] * jacobian[(j, b)])
                .sum::<f64>()
        });
        w.dot(&(&cov_inverse * &w))
    };
    let mut leverage_worst: f64 = 0.0;
    for i in 0..n_points {
        for r in 0..R {
            let j = i * R + r;
            let dense_global = global_leverage(j);
            leverage_worst =
                leverage_worst.max((ours.points[i].global_leverage[r] - dense_global).abs());
            assert!(
                dense_global <= h[j] + 1e-12,
                "global leverage within the row's"
            );
            worst = worst.max((ours.points[i].redundancy[r] - (1.0 - h[j])).abs());
            let e = dense.residual[(j, 0)];
            residual_worst = residual_worst.max((ours.points[i].residual[r] - e).abs());
        }
    }
    for o in 0..m_obs {
        let j = m_data + o;
        worst = worst.max((ours.rest.global_observations[o] - (1.0 - h[j])).abs());
        let e = dense.residual[(j, 0)];
        residual_worst = residual_worst.max((ours.rest.global_observation_residuals[o] - e).abs());
    }
    // Prior rows: P per point prior, C per group prior, G for the global.
    let mut next = m_data + m_obs;
    let mut take = |rows: usize| {
        let sum: f64 = h[next..next + rows].iter().sum();
        next += rows;
        sum
    };
    let point_priors = (0..n_points).filter(|&i| problem.point_prior(i).is_some());
    let dense_points: f64 = point_priors.map(|_| take(P)).sum();
    let group_priors = (0..problem.n_groups()).filter(|&k| problem.group_prior(k).is_some());
    let dense_groups: f64 = group_priors.map(|_| take(C)).sum();
    let g = state.global.len();
    let dense_global = if problem.global_prior().is_some() {
        take(g)
    } else {
        0.0
    };
    assert_eq!(next, h.len(), "every dense row accounted for");
    let prior = ours.rest.prior_leverage;
    let prior_diff = [
        (prior.points, dense_points),
        (prior.groups, dense_groups),
        (prior.global, dense_global),
    ]
    .iter()
    .map(|(a, b)| (a - b).abs())
    .fold(0.0, f64::max);
    let n = dense.normal.nrows();
    let identity = (m_data + m_obs) as f64 - n as f64 + prior.total();
    let range = ours
        .points
        .iter()
        .flat_map(|p| p.redundancy.iter().copied())
        .chain(ours.rest.global_observations.iter().copied())
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), r| {
            (lo.min(r), hi.max(r))
        });
    println!(
        "{m_data} data + {m_obs} observation rows, {n} unknowns: r in {:.3e}..{:.3e}, max |Δr| {worst:.1e}, \
         prior leverage {:.4} + {:.4} + {:.4} (max diff {prior_diff:.1e}), Σ r {:.9} vs {identity:.9}",
        range.0,
        range.1,
        prior.points,
        prior.groups,
        prior.global,
        ours.total()
    );
    assert_eq!(ours.rest.unknowns, n);
    assert!(worst < TOL, "redundancy differs by {worst:e}");
    println!("global leverage: max |Δ| {leverage_worst:.1e}");
    assert!(
        leverage_worst < TOL,
        "global leverage differs by {leverage_worst:e}"
    );
    assert!(prior_diff < TOL, "prior leverage differs by {prior_diff:e}");
    assert!(
        residual_worst < 1e-12,
        "residuals differ by {residual_worst:e}"
    );
    assert!(range.0 > -1e-12 && range.1 < 1.0 + 1e-12, "{range:?}");
    let identity_diff = (ours.total() - identity).abs();
    assert!(
        identity_diff < TOL * (m_data + m_obs) as f64,
        "{identity_diff:e}"
    );
    ours
}

#[test]
fn redundancy_matches_dense_hat_matrix() {
    for priors in [false, true] {
        let spec = Spec {
            priors,
            seed: 31,
            ..Spec::default()
        };
        let (problem, truth) = touches(spec);
        compare(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.05));
        let (problem, truth) = distances(spec);
        compare(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.0));
    }
}

/// Groups 1, 3 and 4 have their centres in the global block (fixed),
/// measured by three distances (the global observations); group 5 is held.
#[test]
fn redundancy_with_fixed_groups_and_global_observations_matches_dense() {
    for priors in [false, true] {
        let spec = Spec {
            priors,
            seed: 37,
            ..Spec::default()
        };
        let (mut problem, truth) = touches(spec);
        let truth = couple(&mut problem.0, &truth, &[1, 3, 4], &[5], 1e-3, 3);
        let ours = compare(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.05));
        assert_eq!(ours.rest.global_observations.len(), 3);
        let (mut problem, truth) = distances(spec);
        let truth = couple(&mut problem.0, &truth, &[1, 3, 4], &[5], 1e-3, 4);
        compare(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.0));
    }
}

/// At the solution, each normalised residual has unit variance (to first
/// order): their mean square over `N` points is 1 within a few `√(2/N)`,
/// and the cost `Σ e²` is a χ² with `Σ r` degrees of freedom. A touch's
/// three rows have one `|w|`.
#[test]
fn normalised_residuals_have_unit_variance_at_the_solution() {
    let spec = Spec {
        seed: 43,
        n_groups: 50,
        points_per_group: 10,
        ..Spec::default()
    };
    // Converged to rounding, so that each point's residuals are
    // orthogonal to its own columns.
    let options = SolverOptions {
        groups_per_chunk: 4,
        step_tolerance: 1e-14,
        sigma_tolerance: 0.0,
        ..SolverOptions::default()
    };
    let (problem, truth) = touches(spec);
    let solution = solve(
        &problem,
        perturb(&truth, 2, 0.005, 0.01, 0.05),
        &options,
        &mut |_| {},
    );
    assert_eq!(solution.status, Status::Converged);
    let cov = solution.covariance.as_ref().unwrap();
    let ours = numbers(&problem, &solution.state, cov, &mut Vec::new(), 4).unwrap();
    // A touch has one eliminated row: at the solution its three residuals
    // lie along the panel's normal, and its three |w| are one.
    let mut spread: f64 = 0.0;
    let mut w2 = Vec::new();
    for p in &ours.points {
        let w = [0, 1, 2].map(|j| {
            normalised_residual(p.residual[j], p.redundancy[j])
                .expect("redundant")
                .abs()
        });
        let (min, max) = (
            w.iter().copied().fold(f64::INFINITY, f64::min),
            w[0].max(w[1]).max(w[2]),
        );
        spread = spread.max(max - min);
        w2.push(w[0] * w[0]);
    }
    println!("largest spread of |w| within a touch: {spread:.1e}");
    assert!(spread < 1e-6, "{spread:e}");
    check_unit_variance("touches", &w2, solution.history.last().unwrap().cost, &ours);

    let (problem, truth) = distances(spec);
    let solution = solve(
        &problem,
        perturb(&truth, 2, 0.005, 0.01, 0.0),
        &options,
        &mut |_| {},
    );
    assert_eq!(solution.status, Status::Converged);
    let cov = solution.covariance.as_ref().unwrap();
    let ours = numbers(&problem, &solution.state, cov, &mut Vec::new(), 4).unwrap();
    let w2: Vec<f64> = ours
        .points
        .iter()
        .map(|p| {
            normalised_residual(p.residual[0], p.redundancy[0])
                .unwrap()
                .powi(2)
        })
        .collect();
    check_unit_variance(
        "distances",
        &w2,
        solution.history.last().unwrap().cost,
        &ours,
    );
}

/// `w²` of independent standard normals has mean 1 and variance 2; the
/// cost is a χ² with mean `dof` and variance `2 dof`. Five standard
/// deviations either way.
fn check_unit_variance<const C: usize, const R: usize>(
    name: &str,
    w2: &[f64],
    cost: f64,
    ours: &Numbers<C, R>,
) {
    let n = w2.len() as f64;
    let mean = w2.iter().sum::<f64>() / n;
    let dof = ours.total();
    println!(
        "{name}: mean w² {mean:.3} over {n} points (±{:.3}), cost {cost:.1} for {dof:.1} degrees of freedom (±{:.1})",
        (2.0 / n).sqrt(),
        (2.0 * dof).sqrt()
    );
    assert!(
        (mean - 1.0).abs() < 5.0 * (2.0 / n).sqrt(),
        "mean w² {mean}"
    );
    assert!(
        (cost - dof).abs() < 5.0 * (2.0 * dof).sqrt(),
        "{cost} vs {dof}"
    );
}

fn bits<const C: usize, const R: usize>(r: &Numbers<C, R>) -> Vec<u64> {
    let mut v: Vec<u64> = r
        .points
        .iter()
        .flat_map(|p| [p.redundancy, p.residual, p.global_leverage])
        .flat_map(|x| x.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
        .collect();
    v.extend(r.rest.global_observations.iter().map(|x| x.to_bits()));
    let p = r.rest.prior_leverage;
    v.extend([p.points, p.groups, p.global].map(f64::to_bits));
    v.extend(
        r.rest
            .group_sigmas
            .iter()
            .flat_map(|s| s.iter().map(|x| x.to_bits())),
    );
    v
}

#[test]
fn bit_identical_for_one_and_two_threads() {
    // 300 groups, one per chunk: more than one parallel wave; four
    // centres in the global block, one group held, all priors.
    let spec = Spec {
        n_groups: 300,
        points_per_group: 10,
        priors: true,
        seed: 47,
        ..Spec::default()
    };
    let (mut problem, truth) = touches(spec);
    let truth = couple(&mut problem.0, &truth, &[1, 3, 4, 200], &[5], 1e-3, 1);
    let state = perturb(&truth, 8, 0.005, 0.01, 0.05);
    let cov = covariance(&problem, &state, 1);
    let run = |threads| {
        in_pool(threads, || {
            numbers(&problem, &state, &cov, &mut Vec::new(), 1).unwrap()
        })
    };
    let (one, two) = (run(1), run(2));
    println!("{} values compared", bits(&one).len());
    assert_eq!(bits(&one), bits(&two));
}

#[test]
fn a_covariance_of_the_wrong_shape_or_not_definite_is_refused() {
    let (problem, truth) = distances(Spec::default());
    let g = truth.global.len();
    for cov in [DMatrix::identity(g + 1, g + 1), DMatrix::zeros(g, g)] {
        let result = redundancy(&problem, &truth, &cov, &mut Vec::new(), 2, |_| {});
        assert!(
            matches!(result, Err(Status::InvalidProblem { .. })),
            "{result:?}"
        );
    }
}

/// Timing, not a check: the redundancy pass against one Gauss–Newton step
/// (elimination and back-substitution) and against the final evaluation
/// of a solve (elimination, covariance, group sigmas' pass) at 10^5
/// points, `G` = 35. Run with
/// `cargo test --release -p parcal-solver --test integration redundancy:: -- --ignored
/// --nocapture`.
#[test]
#[ignore]
fn timing_at_1e5_points() {
    let (mut problem, truth) = touches(Spec {
        n_groups: 12_500,
        points_per_group: 8,
        seed: 53,
        ..Spec::default()
    });
    let truth = couple(
        &mut problem.0,
        &truth,
        &(0..9).collect::<Vec<_>>(),
        &[],
        1e-3,
        5,
    );
    let state = perturb(&truth, 3, 0.001, 0.002, 0.01);
    let mut caches = Vec::new();
    linear_step(&problem, &state, &mut caches, 0.0, 64).unwrap();
    let cov = covariance(&problem, &state, 64);
    let best = |f: &mut dyn FnMut()| {
        (0..3)
            .map(|_| {
                let t = Instant::now();
                f();
                t.elapsed().as_secs_f64()
            })
            .fold(f64::INFINITY, f64::min)
    };
    let step = best(&mut || {
        linear_step(&problem, &state, &mut caches, 0.0, 64).unwrap();
    });
    let final_evaluation = best(&mut || {
        covariance(&problem, &state, 64);
    });
    let pass = best(&mut || {
        redundancy(&problem, &state, &cov, &mut caches, 64, |_| {}).unwrap();
    });
    println!(
        "G = {}, {} points, {} threads: one step {step:.3} s, covariance and group sigmas {final_evaluation:.3} s, \
         redundancy {pass:.3} s (ratio to the step {:.2})",
        state.global.len(),
        state.points.len(),
        rayon::current_num_threads(),
        pass / step
    );
}
