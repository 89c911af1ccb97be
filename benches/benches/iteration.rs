//! One Gauss-Newton iteration (evaluate every block, eliminate, solve,
//! back-substitute) of simulation IV with the propagated prior, at 10^3 to
//! 10^6 contacts, with 1 and 2 threads; beside it, its first pass alone
//! (`reduced-N-thread`: evaluate, eliminate, solve for the global step, no
//! back-substitution), whose difference is the back-substitution's pass.

use criterion::{BatchSize, BenchmarkId, Criterion, criterion_group, criterion_main};
use parcal_benches::{campaign, setup, warm_problem};
use parcal_solver::{SolverOptions, linear_step, reduced_step};

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
            group.bench_with_input(
                BenchmarkId::new(format!("{threads}-thread"), contacts),
                &contacts,
                |b, _| {
                    // The warm starts come back with the step, to be
                    // dropped untimed: a run keeps them from iteration to
                    // iteration.
                    b.iter_batched(
                        || setup.poses.clone(),
                        |mut poses| {
                            let step = pool.install(|| {
                                linear_step(&problem, &state, &mut poses, 0.0, chunk).expect("step")
                            });
                            (step, poses)
                        },
                        BatchSize::PerIteration,
                    )
                },
            );
            group.bench_with_input(
                BenchmarkId::new(format!("reduced-{threads}-thread"), contacts),
                &contacts,
                |b, _| {
                    b.iter_batched(
                        || setup.poses.clone(),
                        |mut poses| {
                            let step = pool.install(|| {
                                reduced_step(&problem, &state, &mut poses, chunk).expect("step")
                            });
                            (step, poses)
                        },
                        BatchSize::PerIteration,
                    )
                },
            );
        }
    }
    group.finish();
}

criterion_group!(benches, iteration);
criterion_main!(benches);
