//! Per contact: forward kinematics warm-started one iteration away, and the
//! tool tip's analytic Jacobians (the work of one linearisation).

use criterion::{Criterion, criterion_group, criterion_main};
use parcal_kinematics::{
    ForwardOptions, Params, forward, forward_from_home, paper, params, tip_jacobians,
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
    c.bench_function("forward kinematics + tip Jacobian, per contact", |b| {
        let mut k = 0;
        b.iter(|| {
            let (q, start) = &contacts[k % contacts.len()];
            k += 1;
            let solution = forward(&moved, q, start, &fk).unwrap();
            black_box(tip_jacobians(&moved, &solution.legs).unwrap())
        })
    });
}

criterion_group!(benches, kinematics);
criterion_main!(benches);
