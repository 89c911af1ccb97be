//! Per contact: the kinematics of one linearisation (forward kinematics
//! warm-started one iteration away, then one combination of the tip
//! Jacobian's rows, as the elimination uses it; one contact at a time and
//! `LANES` at once, `forward_batch::forward_jacobian_batch`), of one
//! back-substitution (`J_f dp` at the converged pose, one contact at a time
//! and `LANES` at once, `forward_batch::forward_along_batch`) and, for
//! comparison, the full 3 x 33 tip Jacobian; and the forward kinematics
//! alone, one contact at a time and `LANES` at once
//! (`forward_batch::forward_batch`). `LANES` (eight) at once run in the SIMD
//! lanes of AVX-512 on a machine with AVX-512F, four at a time in those of
//! AVX2 on a machine with AVX2 alone. As in a calibration's passes, one set
//! of derivatives is reused from contact to contact (forward kinematics in
//! place; its LU tries the previous contact's row order first).

use criterion::{Criterion, criterion_group, criterion_main};
use parcal_kinematics::forward::forward_in_place;
use parcal_kinematics::forward_batch::{
    LANES, PivotOrder, forward_along_batch, forward_batch, forward_jacobian_batch,
};
use parcal_kinematics::{
    ForwardOptions, ForwardSolution, N_PARAMS, Params, Pose, SolutionAlong, SolutionJacobian,
    TipDerivatives, Vec3, forward, forward_from_home, paper, params,
};
use std::hint::black_box;

fn kinematics(c: &mut Criterion) {
    let dataset = parcal_benches::campaign(700);
    let design = paper::design().canonicalize().unwrap().geometry;
    let moved = params::from_params(&(params::to_params(&design) + Params::repeat(1e-3)));
    let fk = ForwardOptions::default();
    let contacts: Vec<_> = dataset
        .measurements
        .q
        .iter()
        .map(|q| (*q, forward_from_home(&design, q, &fk).unwrap().pose))
        .collect();
    let h = Vec3::new(0.3, -0.8, 0.5);
    let dp = Params::repeat(1e-3);
    let mut k = 0;
    let mut next = || {
        k += 1;
        &contacts[k % contacts.len()]
    };
    c.bench_function(
        "forward kinematics + one row combination of J_f, per contact",
        |b| {
            let mut derivatives = TipDerivatives::default();
            b.iter(|| {
                let (q, start) = next();
                derivatives.forward(&moved, q, start, &fk).unwrap();
                let mut row = [0.0; N_PARAMS];
                derivatives.params_row(&h, &mut row);
                black_box(row)
            })
        },
    );
    c.bench_function(
        &format!("the same, {LANES} contacts in lanes (factored J_f), per {LANES} contacts"),
        |b| {
            let mut trial = PivotOrder::default();
            let mut out: [SolutionJacobian; LANES] = Default::default();
            b.iter(|| {
                let batch: [&([f64; 6], Pose); LANES] = std::array::from_fn(|_| next());
                let (q, starts) = (batch.map(|(q, _)| q), batch.map(|(_, start)| *start));
                forward_jacobian_batch(&moved, &q, &starts, &fk, &mut trial, &mut out, |s| s)
                    .unwrap();
                let mut rows = [[0.0; N_PARAMS]; LANES];
                for (solution, row) in out.iter().zip(&mut rows) {
                    solution.jacobian.params_row(&h, row);
                }
                black_box(rows)
            })
        },
    );
    c.bench_function("forward kinematics, per contact", |b| {
        let mut solution = ForwardSolution::default();
        b.iter(|| {
            let (q, start) = next();
            solution.pose = *start;
            forward_in_place(&moved, q, &fk, &mut solution).unwrap();
            black_box(solution.iterations)
        })
    });
    c.bench_function(
        &format!("forward kinematics of {LANES} contacts in lanes, per {LANES} contacts"),
        |b| {
            let mut solutions: [ForwardSolution; LANES] = Default::default();
            b.iter(|| {
                let batch: [&([f64; 6], Pose); LANES] = std::array::from_fn(|_| next());
                let q = batch.map(|(q, _)| q);
                for (solution, (_, start)) in solutions.iter_mut().zip(batch) {
                    solution.pose = *start;
                }
                forward_batch(&moved, &q, &fk, &mut solutions, |s| s).unwrap();
                black_box(solutions[0].iterations)
            })
        },
    );
    c.bench_function("J_f dp at a known pose, per contact", |b| {
        let mut derivatives = TipDerivatives::default();
        b.iter(|| {
            let (q, pose) = next();
            // Converged: no Newton step, the legs and one LU at `pose`.
            derivatives.forward(&design, q, pose, &fk).unwrap();
            black_box(derivatives.along(&dp))
        })
    });
    c.bench_function(
        &format!("J_f dp at the known poses of {LANES} contacts in lanes, per {LANES} contacts"),
        |b| {
            let mut trial = PivotOrder::default();
            let mut out = [SolutionAlong::default(); LANES];
            b.iter(|| {
                let batch: [&([f64; 6], Pose); LANES] = std::array::from_fn(|_| next());
                let (q, poses) = (batch.map(|(q, _)| q), batch.map(|(_, pose)| *pose));
                forward_along_batch(&design, &q, &poses, &dp, &fk, &mut trial, &mut out).unwrap();
                black_box(out[0].tip)
            })
        },
    );
    c.bench_function("forward kinematics + full J_f, per contact", |b| {
        b.iter(|| {
            let (q, start) = next();
            let solution = forward(&moved, q, start, &fk).unwrap();
            black_box(TipDerivatives::new(&moved, &solution).jacobians())
        })
    });
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
