//! One calibration end to end (set-up, Gauss-Newton to convergence,
//! covariance, every check of a converged run: redundancy, external
//! reliability, systematic tests and their sensitivity) at 10^3 to 10^6
//! contacts, with the default options and with simulation IV; beside it the
//! plain solve of simulation IV (set-up, iterations, covariance, the
//! centres' sigmas), so that the checks' cost is the difference. The whole
//! `parcal calibrate` process at 10^6, reading and writing included, is
//! measured on the command line (docs/performance.md).
//!
//! ```sh
//! cargo bench -p parcal-benches --bench calibration
//! cargo bench -p parcal-benches --bench calibration -- /1000000   # 10^6 alone
//! ```

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use parcal_benches::{campaign, options, setup};
use parcal_calibrate::{CalibrationOptions, calibrate};
use parcal_solver::{IterationRecord, SolverOptions, Status, solve_with_caches};

fn calibration(c: &mut Criterion) {
    let mut group = c.benchmark_group("calibration");
    group.sample_size(10);
    for contacts in [1_000, 10_000, 100_000, 1_000_000] {
        let mut dataset = campaign(contacts);
        dataset.truth = None;
        for (name, options) in [
            ("default", CalibrationOptions::default()),
            ("IV", options()),
        ] {
            group.bench_with_input(
                BenchmarkId::new(format!("calibrate-{name}"), contacts),
                &dataset,
                |b, d| {
                    b.iter(|| {
                        let run = calibrate(d, &options, &mut |_| {}).expect("calibration");
                        assert!(run.converged(), "{:?}", run.status);
                        run
                    })
                },
            );
        }
        group.bench_with_input(BenchmarkId::new("solve-IV", contacts), &dataset, |b, d| {
            b.iter(|| {
                let (mut setup, observations) = setup(d);
                let mut poses = std::mem::take(&mut setup.poses);
                let problem = setup.problem::<_, 3>(d, &options(), observations);
                let solver = SolverOptions {
                    step_tolerance: options().step_tolerance,
                    sigma_tolerance: options().sigma_tolerance,
                    ..SolverOptions::default()
                };
                let solution = solve_with_caches(
                    &problem,
                    setup.initial_state(d),
                    &mut poses,
                    &solver,
                    &mut |_: &IterationRecord| {},
                );
                assert_eq!(solution.status, Status::Converged);
                solution
            })
        });
    }
    group.finish();
}

criterion_group!(benches, calibration);
criterion_main!(benches);
