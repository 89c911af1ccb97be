//! `parcal plan` at the paper's budget: 189 touches of the 27 balls within
//! +-30 degrees chosen from a pool of about 20,000 candidates (the
//! command's defaults: the registered criterion, one run of at most three
//! exchange passes). docs/plan.md records the pool size and the time.

use criterion::{Criterion, criterion_group, criterion_main};
use parcal_plan::{PlanOptions, plan};
use parcal_simulate::{Scenario, simulate};
use std::hint::black_box;

fn planning(c: &mut Criterion) {
    let dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    let options = PlanOptions::new(189, 30.0);
    let mut group = c.benchmark_group("plan");
    group.sample_size(10);
    group.bench_function("189 touches from a pool of 20,000 at +-30 degrees", |b| {
        b.iter(|| {
            let planned =
                plan(&dataset.machine, &dataset.artefacts, &options, &mut |_| {}).unwrap();
            assert!(planned.pool_size >= 20_000);
            black_box(planned.predicted)
        })
    });
    group.finish();
}

criterion_group!(benches, planning);
criterion_main!(benches);
