//! Determinism across thread counts, large groups, and every way a run can
//! end badly: failed or non-finite linearisations, divergence, singular
//! reduced matrices and blocks, invalid input.

use crate::common;

use std::ops::Range;

use common::{
    Fail, G, ObservationFault, Spec, TestError, couple, distances, flatten, in_pool, perturb,
    rel_diff, touches,
};
use nalgebra::{DVector, Dyn, OMatrix, SMatrix, SVector, U2, U3, Vector1};
use parcal_solver::{
    BlockId, Linearization, Method, Problem, Solution, SolverOptions, State, Status,
    dense_reference, linear_step, solve,
};

const LM: Method = Method::LevenbergMarquardt {
    initial_lambda: 1e-3,
};

fn bits<const C: usize, const P: usize>(s: &Solution<C, P>) -> Vec<u64> {
    let mut v: Vec<u64> = flatten(&s.state).iter().map(|x| x.to_bits()).collect();
    for r in &s.history {
        let costs = [r.cost, r.data_cost, r.global_observation_cost, r.prior_cost];
        v.extend(costs.map(f64::to_bits));
        v.extend([r.step_norm, r.lambda].map(f64::to_bits));
    }
    v.extend(
        s.covariance
            .iter()
            .flat_map(|c| c.iter().map(|x| x.to_bits())),
    );
    v.extend(
        s.group_sigmas
            .iter()
            .flatten()
            .flat_map(|c| c.iter().map(|x| x.to_bits())),
    );
    v
}

#[test]
fn bit_identical_for_one_and_two_threads_and_run_to_run() {
    // 300 groups, one per chunk: more than one parallel wave. The second
    // case moves four centres into the global block (distances between
    // them) and holds one group.
    let spec = Spec {
        n_groups: 300,
        points_per_group: 10,
        priors: true,
        seed: 3,
        ..Spec::default()
    };
    let (plain, truth) = touches(spec);
    let plain_start = perturb(&truth, 8, 0.02, 0.03, 0.3);
    let (mut coupled, truth) = touches(spec);
    let truth = couple(&mut coupled.0, &truth, &[1, 3, 4, 200], &[5], 1e-3, 1);
    let mut coupled_start = perturb(&truth, 8, 0.02, 0.03, 0.3);
    coupled_start.groups[5] = truth.groups[5];
    let cases = [
        (Method::GaussNewton, &plain, &plain_start),
        (LM, &plain, &plain_start),
        (Method::GaussNewton, &coupled, &coupled_start),
        (LM, &coupled, &coupled_start),
    ];
    for (method, problem, start) in cases {
        let options = SolverOptions {
            method,
            groups_per_chunk: 1,
            ..SolverOptions::default()
        };
        let run = |threads| {
            in_pool(threads, || {
                solve(problem, start.clone(), &options, &mut |_| {})
            })
        };
        let one = run(1);
        let two = run(2);
        let again = run(2);
        println!(
            "{method:?}, global size {}: {:?} after {} records; {} values compared",
            start.global.len(),
            one.status,
            one.history.len(),
            bits(&one).len()
        );
        assert_eq!(one.status, Status::Converged);
        assert_eq!(bits(&one), bits(&two), "1 vs 2 threads");
        assert_eq!(bits(&two), bits(&again), "run to run");
    }
}

#[test]
fn large_groups_are_folded_in_batches_and_still_match_dense() {
    // 300 rows per group (> the 256-row group buffer), 1 chunk of 600
    // reduced rows; and P = 0 groups of 1200 rows, 4800 reduced rows in one
    // chunk (> the 2048-row GEMM buffer).
    let (problem, truth) = touches(Spec {
        n_groups: 2,
        points_per_group: 300,
        priors: true,
        ..Spec::default()
    });
    let state = perturb(&truth, 1, 0.01, 0.02, 0.1);
    for lambda in [0.0, 0.1] {
        let schur = linear_step(&problem, &state, &mut Vec::new(), lambda, 64).unwrap();
        let dense = dense_reference::solve(&problem, &state, lambda).unwrap();
        let diff = rel_diff(&flatten(&schur.delta), &flatten(&dense.step));
        println!("P = 2, 300 points per group, λ = {lambda}: rel diff {diff:.2e}");
        assert!(diff < 1e-9);
    }
    let (problem, truth) = distances(Spec {
        n_groups: 4,
        points_per_group: 1200,
        ..Spec::default()
    });
    let state = perturb(&truth, 1, 0.01, 0.02, 0.0);
    for lambda in [0.0, 0.1] {
        let schur = linear_step(&problem, &state, &mut Vec::new(), lambda, 64).unwrap();
        let dense = dense_reference::solve(&problem, &state, lambda).unwrap();
        let diff = rel_diff(&flatten(&schur.delta), &flatten(&dense.step));
        println!("P = 0, 1200 points per group, λ = {lambda}: rel diff {diff:.2e}");
        assert!(diff < 1e-9);
    }
}

fn gn() -> SolverOptions {
    SolverOptions {
        groups_per_chunk: 2,
        ..SolverOptions::default()
    }
}

#[test]
fn failed_linearisation_at_start_is_problem_failed() {
    let (mut problem, truth) = touches(Spec::default());
    problem.0.fail = Some(Fail { point: 17, call: 0 });
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    for method in [Method::GaussNewton, LM] {
        let s = solve(
            &problem,
            start.clone(),
            &SolverOptions { method, ..gn() },
            &mut |_| {},
        );
        println!("{:?}", s.status);
        match &s.status {
            Status::ProblemFailed {
                iteration: 0,
                point: Some(17),
                message,
            } => assert!(message.contains("injected")),
            other => panic!("{other:?}"),
        }
        assert!(s.history.is_empty());
        assert_eq!(s.state, start);
        assert!(s.covariance.is_none());
    }
}

#[test]
fn failed_linearisation_later_names_point_and_keeps_last_iterate() {
    let (mut problem, truth) = touches(Spec::default());
    // Calls 0 and 1 (build and back-substitution at the start) and 2 (build at
    // iterate 1) succeed; the back-substitution at iterate 1 fails.
    problem.0.fail = Some(Fail { point: 30, call: 3 });
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    let s = solve(&problem, start.clone(), &gn(), &mut |_| {});
    println!("GN: {:?}, {} records", s.status, s.history.len());
    assert!(
        matches!(
            s.status,
            Status::ProblemFailed {
                iteration: 1,
                point: Some(30),
                ..
            }
        ),
        "{:?}",
        s.status
    );
    assert_eq!(s.history.len(), 1);
    assert!(s.state.is_finite());
    assert_ne!(s.state, start);

    // LM: the failure at the trial point counts as a rejection; the retry at
    // the current iterate fails too and ends the run.
    problem.0.fail = Some(Fail { point: 30, call: 2 });
    let s = solve(
        &problem,
        start.clone(),
        &SolverOptions { method: LM, ..gn() },
        &mut |_| {},
    );
    println!("LM: {:?}, {} records", s.status, s.history.len());
    assert!(
        matches!(
            s.status,
            Status::ProblemFailed {
                iteration: 1,
                point: Some(30),
                ..
            }
        ),
        "{:?}",
        s.status
    );
    assert_eq!(s.history.len(), 1);
    assert!(!s.history[0].accepted);
    assert_eq!(s.state, start);
}

#[test]
fn non_finite_linearisation_is_reported() {
    let (mut problem, truth) = distances(Spec::default());
    let start = perturb(&truth, 1, 0.01, 0.02, 0.0);
    problem.0.measurements[9].y = f64::NAN;
    let s = solve(&problem, start, &gn(), &mut |_| {});
    println!("{:?}", s.status);
    assert!(
        matches!(&s.status, Status::ProblemFailed { iteration: 0, point: Some(9), message } if message.contains("non-finite")),
        "{:?}",
        s.status
    );
}

/// Rows `[exp(g) − 1, c_k − t_k]`: Gauss–Newton from a very negative `g`
/// overshoots to where `exp` explodes.
struct Exponential {
    targets: Vec<f64>,
}

impl Problem<1, 0, 2> for Exponential {
    type PointCache = ();
    type Workspace = ();
    type Anchor = ();
    type Error = TestError;
    type Jacobian = OMatrix<f64, U2, Dyn>;
    type Global = f64;
    fn global_size(&self) -> usize {
        1
    }
    fn prepare_global(&self, global: &DVector<f64>) -> f64 {
        global[0]
    }
    fn n_groups(&self) -> usize {
        self.targets.len()
    }
    fn group_points(&self, k: usize) -> Range<usize> {
        k..k + 1
    }
    fn initial_cache(&self, _i: usize) {}
    fn linearize(
        &self,
        i: usize,
        global: &f64,
        group: &Vector1<f64>,
        _point: &SVector<f64, 0>,
        _cache: &mut (),
        out: &mut Linearization<1, 0, 2>,
    ) -> Result<(), TestError> {
        let e = global.exp();
        out.residual = SVector::<f64, 2>::new(e - 1.0, group[0] - self.targets[i]);
        out.d_global.copy_from_slice(&[e, 0.0]);
        out.d_group = SMatrix::<f64, 2, 1>::new(0.0, 1.0);
        Ok(())
    }
}

#[test]
fn exploding_problem_diverges_with_finite_state_and_history() {
    let problem = Exponential {
        targets: vec![1.0, 2.0, 3.0],
    };
    let start = State {
        global: DVector::from_element(1, -3.0),
        groups: vec![Vector1::new(0.0); 3],
        points: vec![SVector::zeros(); 3],
    };
    let s = solve(
        &problem,
        start.clone(),
        &SolverOptions::default(),
        &mut |_| {},
    );
    println!("GN: {:?}, history {:?}", s.status, s.history);
    assert!(
        matches!(s.status, Status::Diverged { iteration: 1, .. }),
        "{:?}",
        s.status
    );
    assert_eq!(s.history.len(), 1);
    assert!(s.state.is_finite());
    assert_eq!(s.state, start);
    // From further out the step overflows exp: reported, not a panic.
    let far = State {
        global: DVector::from_element(1, -30.0),
        ..start.clone()
    };
    let s = solve(&problem, far, &SolverOptions::default(), &mut |_| {});
    println!("GN from -30: {:?}", s.status);
    assert!(
        matches!(s.status, Status::Diverged { .. }),
        "{:?}",
        s.status
    );
    assert!(s.state.is_finite());
    // LM does not diverge.
    let s = solve(
        &problem,
        start,
        &SolverOptions {
            method: LM,
            max_iterations: 200,
            ..SolverOptions::default()
        },
        &mut |_| {},
    );
    println!(
        "LM: {:?} after {} records, g = {}",
        s.status,
        s.history.len(),
        s.state.global[0]
    );
    assert_eq!(s.status, Status::Converged);
    assert!(s.state.global[0].abs() < 1e-6);
}

#[test]
fn a_gauss_newton_step_that_raises_the_cost_too_much_diverges() {
    // From g = −1.5 the full step overshoots to g ≈ 2 (the cost rises about
    // 7 times), and Gauss–Newton comes back from there.
    let problem = Exponential {
        targets: vec![1.0, 2.0, 3.0],
    };
    let start = State {
        global: DVector::from_element(1, -1.5),
        groups: vec![Vector1::new(0.0); 3],
        points: vec![SVector::zeros(); 3],
    };
    let s = solve(&problem, start.clone(), &gn(), &mut |_| {});
    assert_eq!(s.status, Status::Converged);
    let rise = s.history[1].cost / s.history[0].cost;
    println!(
        "GN: {} records, the first step raised the cost {rise:.1} times",
        s.history.len()
    );
    assert!(rise > 5.0 && rise < 10.0, "{rise}");
    let options = SolverOptions {
        step_divergence_ratio: 5.0,
        ..gn()
    };
    let s = solve(&problem, start.clone(), &options, &mut |_| {});
    println!("{:?}", s.status);
    assert!(
        matches!(&s.status, Status::Diverged { iteration: 1, reason } if reason.contains("raised the cost")),
        "{:?}",
        s.status
    );
    assert_eq!(s.state, start);
    assert_eq!(s.history.len(), 1);
    assert!(!s.history[0].accepted);
}

#[test]
fn unobserved_global_parameter_is_singular_with_its_weak_direction() {
    let (mut problem, truth) = touches(Spec::default());
    problem.0.unseen = Some(7);
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    let s = solve(&problem, start.clone(), &gn(), &mut |_| {});
    let Status::Singular {
        iteration,
        diagnostics,
    } = &s.status
    else {
        panic!("{:?}", s.status);
    };
    let weakest = &diagnostics.weakest[0];
    println!(
        "Singular at {iteration}: weakest eigenvalue {:.3e} dominated by {:?}; eigenvalues {:.3e}..{:.3e}",
        weakest.eigenvalue,
        weakest.dominant,
        diagnostics.eigenvalues[0],
        diagnostics.eigenvalues[G - 1]
    );
    assert_eq!(*iteration, 0);
    assert_eq!(weakest.dominant.len(), 1);
    assert_eq!(weakest.dominant[0].0, 7);
    assert!(weakest.eigenvalue.abs() <= 1e-12 * diagnostics.eigenvalues[G - 1]);
    assert!(diagnostics.eigenvalues[1] > 1e-6 * diagnostics.eigenvalues[G - 1]);
    assert_eq!(s.state, start);
    assert_eq!(s.history.len(), 1);
    assert_eq!(s.spectrum.as_ref(), Some(&**diagnostics));

    // LM damps the direction and converges; the final undamped matrix is
    // still singular: no covariance, and the spectrum says why.
    let s = solve(
        &problem,
        start,
        &SolverOptions { method: LM, ..gn() },
        &mut |_| {},
    );
    assert_eq!(s.status, Status::Converged);
    assert!(s.covariance.is_none() && s.group_sigmas.is_none());
    let spectrum = s.spectrum.unwrap();
    assert_eq!(spectrum.weakest[0].dominant[0].0, 7);
    assert!(spectrum.condition_number().is_infinite() || spectrum.condition_number() > 1e15);
}

#[test]
fn underdetermined_blocks_are_singular_blocks() {
    // Group 2 gets only two touches: two rows for three centre coordinates.
    let (mut problem, truth) = touches(Spec::default());
    problem.0.starts[3] = problem.0.starts[2] + 2;
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    let s = solve(&problem, start.clone(), &gn(), &mut |_| {});
    println!("{:?}", s.status);
    assert_eq!(
        s.status,
        Status::SingularBlock {
            iteration: 0,
            block: BlockId::Group(2)
        }
    );
    // A point whose second coordinate no row sees.
    let problem = Degenerate { blind: 4 };
    let start = State {
        global: DVector::from_element(1, 0.5),
        groups: vec![Vector1::new(0.0); 3],
        points: vec![SVector::zeros(); 9],
    };
    let s = solve(&problem, start.clone(), &gn(), &mut |_| {});
    println!("{:?}", s.status);
    assert_eq!(
        s.status,
        Status::SingularBlock {
            iteration: 0,
            block: BlockId::Point(4)
        }
    );
    // Without the blind point the same problem is fine.
    let s = solve(&problem_without_blind_point(), start, &gn(), &mut |_| {});
    assert_eq!(s.status, Status::Converged);
}

/// Three groups of three points; rows `[p0 − a, p1 − b, s g + c + p0 − t]`,
/// except that point `blind`'s second row is `p0 − b`.
struct Degenerate {
    blind: usize,
}

fn problem_without_blind_point() -> Degenerate {
    Degenerate { blind: usize::MAX }
}

impl Problem<1, 2, 3> for Degenerate {
    type PointCache = ();
    type Workspace = ();
    type Anchor = ();
    type Error = TestError;
    type Jacobian = OMatrix<f64, U3, Dyn>;
    type Global = f64;
    fn global_size(&self) -> usize {
        1
    }
    fn prepare_global(&self, global: &DVector<f64>) -> f64 {
        global[0]
    }
    fn n_groups(&self) -> usize {
        3
    }
    fn group_points(&self, k: usize) -> Range<usize> {
        3 * k..3 * k + 3
    }
    fn initial_cache(&self, _i: usize) {}
    fn linearize(
        &self,
        i: usize,
        global: &f64,
        group: &Vector1<f64>,
        point: &SVector<f64, 2>,
        _cache: &mut (),
        out: &mut Linearization<1, 2, 3>,
    ) -> Result<(), TestError> {
        let t = i as f64;
        let blind = i == self.blind;
        let second = if blind { point[0] } else { point[1] };
        out.residual = SVector::<f64, 3>::new(
            point[0] - 0.1 * t,
            second - 0.2,
            (1.0 + 0.1 * t) * global + group[0] + point[0] - t,
        );
        out.d_global.copy_from_slice(&[0.0, 0.0, 1.0 + 0.1 * t]);
        out.d_group = SMatrix::<f64, 3, 1>::new(0.0, 0.0, 1.0);
        out.d_point = SMatrix::<f64, 3, 2>::new(
            1.0,
            0.0,
            if blind { 1.0 } else { 0.0 },
            if blind { 0.0 } else { 1.0 },
            1.0,
            0.0,
        );
        Ok(())
    }
}

#[test]
fn invalid_input_is_reported_without_evaluation() {
    let (mut problem, truth) = touches(Spec::default());
    problem.0.fail = Some(Fail { point: 0, call: 0 });
    let mut wrong = truth.clone();
    wrong.groups.pop();
    let s = solve(&problem, wrong, &gn(), &mut |_| {});
    assert!(
        matches!(s.status, Status::InvalidProblem { .. }),
        "{:?}",
        s.status
    );
    let mut wrong = truth.clone();
    wrong.points.push(SVector::zeros());
    let s = solve(&problem, wrong, &gn(), &mut |_| {});
    assert!(
        matches!(s.status, Status::InvalidProblem { .. }),
        "{:?}",
        s.status
    );
    let mut wrong = truth.clone();
    wrong.global[0] = f64::NAN;
    let s = solve(&problem, wrong, &gn(), &mut |_| {});
    assert!(
        matches!(s.status, Status::InvalidProblem { .. }),
        "{:?}",
        s.status
    );
    let s = solve(
        &problem,
        truth.clone(),
        &SolverOptions {
            groups_per_chunk: 0,
            ..gn()
        },
        &mut |_| {},
    );
    assert!(
        matches!(s.status, Status::InvalidProblem { .. }),
        "{:?}",
        s.status
    );
    let s = solve(
        &problem,
        truth,
        &SolverOptions {
            method: Method::LevenbergMarquardt {
                initial_lambda: 0.0,
            },
            ..gn()
        },
        &mut |_| {},
    );
    assert!(
        matches!(s.status, Status::InvalidProblem { .. }),
        "{:?}",
        s.status
    );
}

/// The paper-like coupling of [`common::couple`]: three centres in the
/// global block, measured by distances, and one held group.
fn coupled() -> (common::Touches, State<3, 2>) {
    let (mut problem, truth) = touches(Spec::default());
    let truth = couple(&mut problem.0, &truth, &[1, 3, 4], &[5], 1e-3, 1);
    (problem, truth)
}

#[test]
fn failed_global_observations_are_problem_failures() {
    let (mut problem, truth) = coupled();
    let start = perturb(&truth, 1, 0.01, 0.02, 0.1);
    problem.0.observation_fault = Some(ObservationFault::Error);
    let s = solve(&problem, start.clone(), &gn(), &mut |_| {});
    assert!(
        matches!(&s.status, Status::ProblemFailed { iteration: 0, point: None, message } if message.contains("injected")),
        "{:?}",
        s.status
    );
    problem.0.observation_fault = Some(ObservationFault::WrongShape);
    let s = solve(&problem, start.clone(), &gn(), &mut |_| {});
    assert!(
        matches!(&s.status, Status::ProblemFailed { iteration: 0, point: None, message } if message.contains("x 18")),
        "{:?}",
        s.status
    );
    problem.0.observation_fault = None;
    problem.0.distances[1].measured = f64::NAN;
    let s = solve(&problem, start, &gn(), &mut |_| {});
    assert!(
        matches!(&s.status, Status::ProblemFailed { iteration: 0, point: None, message } if message.contains("non-finite")),
        "{:?}",
        s.status
    );
}

#[test]
fn a_global_block_or_prior_of_the_wrong_size_is_invalid() {
    let (mut problem, truth) = coupled();
    let mut short = truth.clone();
    short.global = short.global.rows(0, G).into_owned();
    let s = solve(&problem, short, &gn(), &mut |_| {});
    assert!(
        matches!(&s.status, Status::InvalidProblem { message } if message.contains("17 global unknowns")),
        "{:?}",
        s.status
    );
    problem.0.global_prior = Some(parcal_solver::GaussianPrior::new(
        DVector::zeros(G),
        nalgebra::DMatrix::identity(G, G),
    ));
    let s = solve(&problem, truth, &gn(), &mut |_| {});
    assert!(
        matches!(&s.status, Status::InvalidProblem { message } if message.contains("global prior")),
        "{:?}",
        s.status
    );
}
