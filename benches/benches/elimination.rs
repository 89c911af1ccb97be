//! The solver's own work per contact: elimination of the point and group
//! blocks into the 33 x 33 reduced system, solve and back-substitution, for a
//! problem whose linearisation costs nothing (fixed random blocks), so that
//! only the Schur machinery is timed. Groups of 7 points, P = 2, R = 3.

use std::ops::Range;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use nalgebra::{DVector, Dyn, OMatrix, SMatrix, SVector, U3};
use parcal_solver::{Linearization, Problem, SolverOptions, State, linear_step};

const POINTS: usize = 7;

/// Fixed pseudo-random blocks, 64 distinct ones.
struct Synthetic {
    groups: usize,
    blocks: Vec<Linearization<3, 2, 3>>,
}

impl Synthetic {
    fn new(groups: usize) -> Self {
        let mut seed = 12345u64;
        let mut next = move || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let blocks = (0..64)
            .map(|_| Linearization {
                residual: SVector::from_fn(|_, _| next()),
                d_global: OMatrix::from_fn_generic(U3, Dyn(33), |_, _| next()),
                d_group: SMatrix::from_fn(|_, _| next()) + SMatrix::identity(),
                d_point: SMatrix::from_fn(|_, _| next()),
            })
            .collect();
        Self { groups, blocks }
    }
}

impl Problem<3, 2, 3> for Synthetic {
    type PointCache = ();
    type Workspace = ();
    type Anchor = ();
    type Error = std::convert::Infallible;
    type Jacobian = OMatrix<f64, U3, Dyn>;
    type Global = ();

    fn global_size(&self) -> usize {
        33
    }

    fn prepare_global(&self, _: &DVector<f64>) {}

    fn n_groups(&self) -> usize {
        self.groups
    }

    fn group_points(&self, k: usize) -> Range<usize> {
        k * POINTS..(k + 1) * POINTS
    }

    fn initial_cache(&self, _: usize) {}

    fn linearize(
        &self,
        i: usize,
        _: &(),
        _: &SVector<f64, 3>,
        _: &SVector<f64, 2>,
        _: &mut (),
        out: &mut Linearization<3, 2, 3>,
    ) -> Result<(), Self::Error> {
        let block = &self.blocks[i % self.blocks.len()];
        out.residual = block.residual;
        out.d_global.copy_from(&block.d_global);
        out.d_group = block.d_group;
        out.d_point = block.d_point;
        Ok(())
    }
}

fn elimination(c: &mut Criterion) {
    let groups = 100_000 / POINTS;
    let problem = Synthetic::new(groups);
    let state = State {
        global: DVector::zeros(33),
        groups: vec![SVector::zeros(); groups],
        points: vec![SVector::zeros(); groups * POINTS],
    };
    let chunk = SolverOptions::default().groups_per_chunk;
    let mut group = c.benchmark_group("elimination");
    group.sample_size(20);
    group.throughput(Throughput::Elements((groups * POINTS) as u64));
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    group.bench_function("1-thread, per 10^5 contacts", |b| {
        b.iter(|| {
            pool.install(|| {
                linear_step(&problem, &state, &mut Vec::new(), 0.0, chunk).expect("step")
            })
        })
    });
    group.finish();
}

criterion_group!(benches, elimination);
criterion_main!(benches);
