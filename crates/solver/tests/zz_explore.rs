mod common;
use common::*;
use parcal_solver::*;

#[test]
fn explore() {
    for (dg, dc, dp) in [(0.01, 0.02, 0.1), (0.05, 0.05, 0.5), (0.1, 0.1, 1.0), (0.2, 0.1, 1.5), (0.05, 0.15, 2.0), (0.3, 0.2, 0.5)] {
        for seed in 1..4 {
            let (problem, truth) = touches(Spec { seed, n_groups: 10, points_per_group: 12, ..Spec::default() });
            let start = perturb(&truth, seed, dg, dc, dp);
            for method in [Method::GaussNewton, Method::LevenbergMarquardt { initial_lambda: 1e-3 }] {
                let o = SolverOptions { method, ..SolverOptions::default() };
                let s = solve(&problem, start.clone(), &o, &mut |_| {});
                let err = (s.state.global - truth.global).norm();
                println!("{dg} {dc} {dp} seed {seed} {:?}: {:?} iters {} cost {:.3e} |g-g*| {:.2e}", method, s.status, s.history.len(), s.history.last().map(|h| h.cost).unwrap_or(f64::NAN), err);
            }
        }
    }
}
