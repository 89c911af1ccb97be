//! One instrument calibration end to end (set-up, Gauss-Newton to
//! convergence, covariance, reliability): the real hexapod of
//! fixtures/jugglebot (108 motion-capture poses), a simulated Jugglebot-like
//! campaign of 1,002 poses in 3 sessions (334 each, legs re-homed), and the
//! paper's 189 ball touches with a laser tracker's 150 poses and 150 points
//! in 3 sessions in one calibration.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use parcal_calibrate::{CalibrationOptions, calibrate};
use parcal_dataset::Dataset;
use parcal_simulate::{Scenario, TrackerScenario, simulate_mixed, simulate_tracker};

fn jugglebot() -> Dataset {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../fixtures/jugglebot");
    Dataset::read(&dir).expect("fixtures/jugglebot")
}

fn simulated() -> Dataset {
    let scenario = TrackerScenario {
        sessions: 3,
        rows_per_session: 334,
        ..TrackerScenario::jugglebot_like()
    };
    let mut dataset = simulate_tracker(&scenario, 1).expect("simulation").dataset;
    dataset.truth = None;
    dataset
}

fn mixed() -> Dataset {
    let tracker = TrackerScenario {
        true_scale: [1.0; 6],
        scale_sigma: None,
        ..TrackerScenario::paper_like()
    };
    let mut dataset = simulate_mixed(&Scenario::paper(), &tracker, 1)
        .expect("simulation")
        .dataset;
    dataset.truth = None;
    dataset
}

fn instruments(c: &mut Criterion) {
    let mut group = c.benchmark_group("instruments");
    group.sample_size(10);
    let options = CalibrationOptions::default();
    for (name, dataset) in [
        ("jugglebot-108", jugglebot()),
        ("simulated-1002", simulated()),
    ] {
        group.bench_with_input(BenchmarkId::new("calibrate", name), &dataset, |b, d| {
            b.iter(|| {
                let run = calibrate(d, &options, &mut |_| {}).expect("calibration");
                assert!(run.converged(), "{name}: {:?}", run.status);
                run
            })
        });
    }
    let dataset = mixed();
    group.bench_with_input(
        BenchmarkId::new("calibrate", "mixed-189-touches-300-rows"),
        &dataset,
        |b, d| {
            b.iter(|| {
                let run = calibrate(d, &options, &mut |_| {}).expect("calibration");
                assert!(run.converged(), "mixed: {:?}", run.status);
                run
            })
        },
    );
    group.finish();
}

criterion_group!(benches, instruments);
criterion_main!(benches);
