//! The effects' projections of the checks' pass (`parcal_solver::effects`)
//! against the dense normal matrix: `cᵀPc`, `cᵀPê` and the global shift
//! `−(N⁻¹Jᵀc)_g`, with priors on every level, fixed groups and global
//! observations; and their independence of the chunking.

use crate::common;

use common::{Shifts, Spec, couple, perturb, touches};
use nalgebra::{DMatrix, DVector, SVector};
use parcal_solver::effects::EffectProjection;
use parcal_solver::{
    Linearization, Problem, SolverOptions, State, Status, dense_reference, redundancy, solve,
};

/// The covariance of the global block at `state`.
fn covariance<Pr: Problem<3, 2, 3>>(problem: &Pr, state: &State<3, 2>) -> DMatrix<f64> {
    let options = SolverOptions {
        max_iterations: 0,
        ..SolverOptions::default()
    };
    let solution = solve(problem, state.clone(), &options, &mut |_| {});
    assert_eq!(solution.status, Status::IterationLimit);
    solution.covariance.expect("covariance")
}

/// The projections of the checks' pass in chunks of `groups_per_chunk`.
fn projections(
    problem: &common::Touches,
    state: &State<3, 2>,
    groups_per_chunk: usize,
) -> Vec<EffectProjection> {
    let cov = covariance(problem, state);
    redundancy(
        problem,
        state,
        &cov,
        &mut Vec::new(),
        groups_per_chunk,
        |_| {},
    )
    .expect("redundancy")
    .effects
}

/// `cᵀPc`, `cᵀPê` and `−(N⁻¹Jᵀc)_g` of every effect from the dense
/// Jacobian: `Jᵀc` and `|c|²`, `cᵀê` summed over the data and
/// observation rows, each prior block adding `−Λ ∂m/∂t`, `∂mᵀΛ∂m` and
/// `−∂mᵀΛ(x − m)` (whatever its square root); and the cost `|ê|²`.
fn dense_projections(
    problem: &common::Touches,
    state: &State<3, 2>,
) -> (Vec<(f64, f64, DVector<f64>)>, f64) {
    let dense = dense_reference::solve(problem, state, 0.0).expect("dense reference");
    let (j, e) = (&dense.jacobian, &dense.residual);
    let inv = dense.inverse.as_ref().expect("N⁻¹");
    let n = j.ncols();
    let shifts = problem.0.shifts.as_ref().expect("effects");
    let g = state.global.len();
    let global = problem.prepare_global(&state.global);
    // The data rows' columns of each effect, then the observations'.
    let mut columns = [Vec::new(), Vec::new()];
    let mut lin = Linearization::zeros(g);
    let groups = (0..state.groups.len()).flat_map(|k| problem.group_points(k).map(move |_| k));
    for ((i, p), k) in state.points.iter().enumerate().zip(groups) {
        let group = &state.groups[k];
        problem
            .linearize(i, &global, group, p, &mut 0, &mut lin)
            .expect("linearize");
        let mut out = [SVector::<f64, 3>::zeros(); 2];
        problem.point_effects(i, &lin, p, &mut out);
        for (column, c) in columns.iter_mut().zip(&out) {
            column.extend(c.iter());
        }
    }
    columns[0].extend(std::iter::repeat_n(0.0, shifts.observations.len()));
    columns[1].extend(shifts.observations.iter());
    let gradient = DVector::from_fn(n, |a, _| {
        (0..j.nrows()).map(|r| j[(r, a)] * e[(r, 0)]).sum()
    });
    let solve = |v: &DVector<f64>| {
        DVector::from_fn(n, |a, _| (0..n).map(|b| inv[(a, b)] * v[b]).sum::<f64>())
    };
    let n_inv_gradient = solve(&gradient);
    let projections = columns
        .iter()
        .enumerate()
        .map(|(effect, column)| {
            let mut v = DVector::from_fn(n, |a, _| {
                column.iter().enumerate().map(|(r, c)| c * j[(r, a)]).sum()
            });
            let mut norm2: f64 = column.iter().map(|c| c * c).sum();
            let mut ce: f64 = column.iter().enumerate().map(|(r, c)| c * e[(r, 0)]).sum();
            if effect == 1 {
                let mut prior = |information: &DMatrix<f64>,
                                 dm: &DVector<f64>,
                                 x: &DVector<f64>,
                                 m: &DVector<f64>,
                                 cols: &[Option<usize>]| {
                    let l_dm = information * dm;
                    norm2 += dm.dot(&l_dm);
                    ce -= l_dm.dot(&(x - m));
                    for (a, col) in cols.iter().enumerate() {
                        if let Some(col) = col {
                            v[*col] -= l_dm[a];
                        }
                    }
                };
                for k in 0..state.groups.len() {
                    let Some(pr) = problem.group_prior(k) else {
                        continue;
                    };
                    let to = |v: &SVector<f64, 3>| DVector::from_column_slice(v.as_slice());
                    let cols: Vec<_> = (0..3).map(|a| dense.columns.group(k, a)).collect();
                    let information = DMatrix::from_column_slice(3, 3, pr.information.as_slice());
                    prior(
                        &information,
                        &to(&shifts.groups[k]),
                        &to(&state.groups[k]),
                        &to(&pr.mean),
                        &cols,
                    );
                }
                if let Some(pr) = problem.global_prior() {
                    let cols: Vec<_> = (0..g).map(|a| Some(dense.columns.global(a))).collect();
                    prior(
                        &pr.information,
                        &shifts.global,
                        &state.global,
                        &pr.mean,
                        &cols,
                    );
                }
            }
            let n_inv_v = solve(&v);
            let shift = DVector::from_fn(g, |a, _| -n_inv_v[dense.columns.global(a)]);
            (norm2 - v.dot(&n_inv_v), ce - v.dot(&n_inv_gradient), shift)
        })
        .collect();
    (projections, dense.cost)
}

/// Compares the checks' pass with the dense reference; returns its
/// projections.
fn compare(problem: &common::Touches, state: &State<3, 2>) -> Vec<EffectProjection> {
    let ours = projections(problem, state, 2);
    let (dense, cost) = dense_projections(problem, state);
    assert_eq!(ours.len(), dense.len());
    for (k, (ours, (c_pc, c_pe, shift))) in ours.iter().zip(&dense).enumerate() {
        println!(
            "effect {k}: cᵀPc {:.9e} vs {c_pc:.9e}, cᵀPê {:.9e} vs {c_pe:.9e}, |γ|² {:.3e}",
            ours.c_pc, ours.c_pe, ours.reduced_norm2
        );
        // Both are differences of sums of size |γ|² and |γ| |ê|.
        let norm = ours.reduced_norm2;
        assert!(
            (ours.c_pc - c_pc).abs() <= 1e-9 * norm,
            "cᵀPc of effect {k}"
        );
        let tolerance = 1e-9 * (norm * cost).sqrt();
        assert!((ours.c_pe - c_pe).abs() <= tolerance, "cᵀPê of effect {k}");
        let scale = shift.amax();
        assert!(
            (&ours.global_shift - shift).amax() <= 1e-8 * scale,
            "shift of effect {k}"
        );
    }
    ours
}

#[test]
fn effects_match_the_dense_reference() {
    for priors in [false, true] {
        let spec = Spec {
            priors,
            seed: 53,
            ..Spec::default()
        };
        let (mut problem, truth) = touches(spec);
        problem.0.shifts = Some(Shifts::new(&problem.0, 1));
        compare(&problem, &perturb(&truth, 6, 0.005, 0.01, 0.05));
    }
}

/// Groups 1, 3 and 4 have their centres in the global block (fixed, their
/// priors' rows touching no unknown), measured by three distances; group
/// 5 is held.
#[test]
fn effects_with_fixed_groups_and_global_observations_match_the_dense_reference() {
    let spec = Spec {
        priors: true,
        seed: 59,
        ..Spec::default()
    };
    let (mut problem, truth) = touches(spec);
    let truth = couple(&mut problem.0, &truth, &[1, 3, 4], &[5], 1e-3, 3);
    problem.0.shifts = Some(Shifts::new(&problem.0, 2));
    let state = perturb(&truth, 6, 0.005, 0.01, 0.05);
    let ours = compare(&problem, &state);
    // The chunking changes nothing but the order of sums.
    for groups_per_chunk in [1, 4] {
        let other = projections(&problem, &state, groups_per_chunk);
        for (a, b) in ours.iter().zip(&other) {
            assert!((a.c_pc - b.c_pc).abs() < 1e-12 * a.reduced_norm2);
        }
    }
    // No effects: none projected.
    problem.0.shifts = None;
    assert!(projections(&problem, &state, 2).is_empty());
}

/// The radius column is `d_group u(θ)`: the residual's change when the
/// radius changes, by central differences.
#[test]
fn the_radius_effect_is_the_residuals_derivative() {
    let (mut problem, truth) = touches(Spec::default());
    problem.0.shifts = Some(Shifts::new(&problem.0, 3));
    let state = perturb(&truth, 6, 0.005, 0.01, 0.05);
    let global = problem.prepare_global(&state.global);
    let residual = |problem: &common::Touches, i: usize| {
        let mut lin = Linearization::zeros(state.global.len());
        problem
            .linearize(
                i,
                &global,
                &state.groups[0],
                &state.points[i],
                &mut 0,
                &mut lin,
            )
            .unwrap();
        lin
    };
    let h = 1e-6;
    for i in problem.group_points(0) {
        let lin = residual(&problem, i);
        let mut out = [SVector::zeros(); 2];
        problem.point_effects(i, &lin, &state.points[i], &mut out);
        let mut moved = |t: f64| {
            problem.0.radius += t;
            let r = residual(&problem, i).residual;
            problem.0.radius -= t;
            r
        };
        let numeric = (moved(h) - moved(-h)) / (2.0 * h);
        assert!(
            (out[0] - numeric).amax() < 1e-6 * numeric.amax(),
            "{} vs {numeric}",
            out[0]
        );
    }
}
