//! The hexapod through the common interface against its own path: one
//! calibration of the same ball touches (the radius observation, eq. 9,
//! each ball's radius an unknown with its prior or exact with its sigma in
//! the weights; or the coordinate observation, eq. 10, each ball's radius
//! an unknown; the propagated weights; no prior on the parameters; every
//! check of a converged run) by
//! `calibrate` and by `calibrate_mechanism` of `MechanismData::from_hexapod_touches`,
//! at 10^3 and 10^4 contacts, each with its set-up (the design's forward
//! kinematics, the balls' centre fits, the weights). The two reach the same estimate
//! (`cargo test -p parcal-calibrate --test integration hexapod_common::`); the ratio of
//! their times is what the dedicated path saves (docs/mechanisms.md).
//!
//! ```sh
//! cargo bench -p parcal-benches --bench interface
//! ```

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use parcal_benches::campaign;
use parcal_calibrate::mechanism::{MechanismData, MechanismOptions, calibrate_mechanism};
use parcal_calibrate::{CalibrationOptions, RadiusModel, Simulation, calibrate};

fn interface(c: &mut Criterion) {
    let mut group = c.benchmark_group("hexapod");
    group.sample_size(10);
    for (model, simulation, radius) in [
        ("ball", Simulation::I, RadiusModel::PerBall),
        ("contact", Simulation::I, RadiusModel::PerContact),
        ("coordinates", Simulation::II, RadiusModel::PerBall),
    ] {
        let options = CalibrationOptions {
            radius,
            ..CalibrationOptions::simulation(simulation)
        };
        let common_options = MechanismOptions::default().with_observation(options.observation);
        for contacts in [1_000, 10_000] {
            let mut dataset = campaign(contacts);
            dataset.truth = None;
            let own = BenchmarkId::new(format!("own-{model}"), contacts);
            group.bench_with_input(own, &dataset, |b, d| {
                b.iter(|| {
                    let run = calibrate(d, &options, &mut |_| {}).expect("calibration");
                    assert!(run.converged(), "{:?}", run.status);
                    run
                })
            });
            let common = BenchmarkId::new(format!("interface-{model}"), contacts);
            group.bench_with_input(common, &dataset, |b, d| {
                b.iter(|| {
                    let data =
                        MechanismData::from_hexapod_touches(d, &options).expect("hexapod touches");
                    let run = calibrate_mechanism(&data, &common_options, &mut |_| {})
                        .expect("calibration");
                    assert!(run.converged(), "{:?}", run.status);
                    run
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, interface);
criterion_main!(benches);
