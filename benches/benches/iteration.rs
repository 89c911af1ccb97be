//! One Gauss-Newton iteration (evaluate every block, eliminate, solve,
//! back-substitute) of simulation IV with the propagated prior, at 10^3 to
//! 10^6 contacts, with 1 and 2 threads; beside it, its first pass alone
//! (`reduced-N-thread`: evaluate, eliminate, solve for the global step, no
//! back-substitution), whose difference is the back-substitution's pass.

use std::any::Any;

use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use parcal_benches::{campaign, setup, warm_problem};
use parcal_kinematics::Pose;
use parcal_solver::{SolverOptions, linear_step, reduced_step};

/// One step from the warm starts given (which it updates), its result
/// kept to be dropped untimed.
type Step<'a> = dyn Fn(&mut Vec<Pose>) -> Box<dyn Any + Send> + Sync + 'a;

fn iteration(c: &mut Criterion) {
    let mut group = c.benchmark_group("iteration");
    group.sample_size(10);
    let chunk = SolverOptions::default().groups_per_chunk;
    for contacts in [1_000, 10_000, 100_000, 1_000_000] {
        let dataset = campaign(contacts);
        let (setup, observations) = setup(&dataset);
        let (problem, state) = warm_problem(&dataset, &setup, observations);
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            // The warm starts come back with the step, to be dropped
            // untimed: a run keeps them from iteration to iteration.
            let mut bench = |name: String, step: &Step| {
                group.bench_with_input(BenchmarkId::new(name, contacts), &contacts, |b, _| {
                    b.iter_batched(
                        || setup.poses.clone(),
                        |mut poses| (pool.install(|| step(&mut poses)), poses),
                        BatchSize::PerIteration,
                    )
                });
            };
            bench(format!("{threads}-thread"), &|poses| {
                Box::new(linear_step(&problem, &state, poses, 0.0, chunk).expect("step"))
            });
            bench(format!("reduced-{threads}-thread"), &|poses| {
                Box::new(reduced_step(&problem, &state, poses, chunk).expect("step"))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, iteration);
criterion_main!(benches);
