//! The global shift of chosen rows (`row_influence`) against the dense
//! `−N⁻¹ a_jᵀ`, the full redundancy pass, and a re-solve with an error
//! added to the observation.

use crate::common;

use common::{Spec, couple, perturb, touches};
use nalgebra::{DMatrix, DVector};
use parcal_solver::{
    RowId, SolverOptions, Status, dense_reference, redundancy, row_influence, solve,
};

/// Touches with three centres tied by distances (global observations),
/// with priors on every level when noisy; exact data and distances without
/// noise.
fn tied(noise: f64) -> (common::Touches, parcal_solver::State<3, 2>) {
    let spec = Spec {
        priors: noise > 0.0,
        seed: 53,
        noise,
        ..Spec::default()
    };
    let (mut problem, truth) = touches(spec);
    let tied = [1, 3, 4];
    let truth = couple(&mut problem.0, &truth, &tied, &[5], 1e-3, 5);
    if noise == 0.0 {
        for d in &mut problem.0.distances {
            let (a, b) = (
                truth.groups[tied[d.between.0]],
                truth.groups[tied[d.between.1]],
            );
            d.measured = (a - b).norm();
        }
    }
    (problem, truth)
}

fn rows() -> Vec<RowId> {
    vec![
        RowId::Point { point: 3, row: 0 },
        RowId::Point { point: 3, row: 2 },
        RowId::Point { point: 17, row: 1 },
        // A point of a group tied to the global block (group 1).
        RowId::Point { point: 9, row: 1 },
        RowId::GlobalObservation(2),
    ]
}

#[test]
fn the_shift_is_the_global_part_of_minus_n_inverse_a_j() {
    let (problem, truth) = tied(1e-3);
    let state = perturb(&truth, 6, 0.005, 0.01, 0.05);
    let options = SolverOptions {
        max_iterations: 0,
        groups_per_chunk: 2,
        ..SolverOptions::default()
    };
    let cov = solve(&problem, state.clone(), &options, &mut |_| {})
        .covariance
        .expect("covariance");
    let influence = row_influence(&problem, &state, &cov, &mut Vec::new(), &rows()).unwrap();
    let mut points = Vec::new();
    let full = redundancy(&problem, &state, &cov, &mut Vec::new(), 2, |p| {
        points.push(*p)
    })
    .unwrap();
    let dense = dense_reference::solve(&problem, &state, 0.0).expect("dense reference");
    let inv = dense.inverse.as_ref().expect("N⁻¹");
    let g = state.global.len();
    let m_data = 3 * state.points.len();
    let mut worst: f64 = 0.0;
    for (row, ours) in rows().iter().zip(&influence) {
        let (j, r, h) = match *row {
            RowId::Point { point, row } => (
                point * 3 + row,
                points[point].redundancy[row],
                points[point].global_leverage[row],
            ),
            RowId::GlobalObservation(o) => {
                let r = full.global_observations[o];
                (m_data + o, r, 1.0 - r)
            }
        };
        let a = &dense.jacobian;
        let expected = DVector::from_fn(g, |k, _| {
            -(0..a.ncols()).map(|b| inv[(k, b)] * a[(j, b)]).sum::<f64>()
        });
        let scale = expected.amax();
        let diff = (&ours.global_shift - &expected).amax() / scale;
        println!(
            "{row:?}: |Δg| {:.3e}, rel. diff {diff:.1e}, r {r:.4}",
            expected.norm()
        );
        worst = worst.max(diff);
        assert!((ours.redundancy - r).abs() < 1e-12, "{row:?}: r");
        assert!((ours.global_leverage - h).abs() < 1e-12, "{row:?}: |z|²");
        // |z|² = Δgᵀ Cov(g)⁻¹ Δg.
        let cov_inverse = DMatrix::from_fn(g, g, |a, b| inv[(a, b)])
            .try_inverse()
            .unwrap();
        let measured = ours.global_shift.dot(&(&cov_inverse * &ours.global_shift));
        assert!(
            (measured - h).abs() < 1e-8 * h.max(1e-3),
            "{measured} vs {h}"
        );
    }
    assert!(worst < 1e-8, "the shift differs by {worst:e}");
    let error = row_influence(
        &problem,
        &state,
        &cov,
        &mut Vec::new(),
        &[RowId::Point { point: 0, row: 3 }],
    )
    .unwrap_err();
    assert!(matches!(error, Status::InvalidProblem { .. }), "{error:?}");
}

/// Adding `±δ σ` to one reading and solving again moves the global block
/// by `±δ` times the shift (the measured value enters the touch's
/// residual with `+`, the distance's with `−`). The central difference
/// cancels the curvature's quadratic term: with exact data (residuals zero
/// at the solution) what remains is `O(δ²)`, under `1e-4` of the global
/// sigmas; with noisy data the solution's derivative also has the term
/// `Σ e_i ∇²e_i` that Gauss-Newton's `N` leaves out, of the order of the
/// residuals times the curvature, under `1e-2` sigmas here.
#[test]
fn an_error_added_to_a_reading_moves_the_solution_by_the_shift() {
    for (noise, tolerance) in [(0.0, 1e-4), (1e-3, 1e-2)] {
        let (problem, truth) = tied(noise);
        let options = SolverOptions {
            step_tolerance: 1e-14,
            sigma_tolerance: 0.0,
            groups_per_chunk: 2,
            ..SolverOptions::default()
        };
        // The held group at its true value: exact data fit exactly.
        let mut start = perturb(&truth, 2, 0.005, 0.01, 0.05);
        start.groups[5] = truth.groups[5];
        let solved = solve(&problem, start, &options, &mut |_| {});
        assert_eq!(solved.status, Status::Converged);
        let cov = solved.covariance.as_ref().unwrap();
        let influence =
            row_influence(&problem, &solved.state, cov, &mut Vec::new(), &rows()).unwrap();
        let moved = |row: RowId, delta: f64| {
            let mut data = problem.0.clone();
            let sign = match row {
                RowId::Point { point, row } => {
                    data.measurements[point][row] += delta * data.sigma;
                    1.0
                }
                RowId::GlobalObservation(o) => {
                    let d = &mut data.distances[o];
                    d.measured += delta * d.sigma;
                    -1.0
                }
            };
            let again = solve(
                &common::Touches(data),
                solved.state.clone(),
                &options,
                &mut |_| {},
            );
            assert_eq!(again.status, Status::Converged);
            (&again.state.global - &solved.state.global) * sign
        };
        // Differences in the global block's own sigmas (per sigma of error).
        let cov_inverse = cov.clone().try_inverse().unwrap();
        let sigmas = |v: &DVector<f64>| v.dot(&(&cov_inverse * v)).sqrt();
        let delta = 1.0;
        for (row, ours) in rows().iter().zip(&influence) {
            let central = (moved(*row, delta) - moved(*row, -delta)) / (2.0 * delta);
            let shift = &ours.global_shift;
            let diff = sigmas(&(&central - shift));
            println!(
                "noise {noise}: {row:?}: shift {:.4} sigmas, the re-solve's differs by {diff:.1e}",
                sigmas(shift)
            );
            assert!(diff < tolerance, "{row:?}: {diff:e}");
        }
    }
}
