//! Prints the time per iteration of a problem of the target's shape
//! (G = 33, C = 3, P = 2, R = 3) with a cheap linearisation; asserts nothing
//! about time. `PARCAL_SOLVER_TIMING_POINTS` sets the number of points
//! (default 50 000; the target is < 0.5 s per iteration at 10⁶ on 2 threads).

use std::ops::Range;
use std::time::Instant;

use nalgebra::{SMatrix, SVector, Vector2, Vector3};
use parcal_solver::{
    GaussianPrior, Linearization, Method, Problem, SolverOptions, State, Status, solve,
};

const G: usize = 33;
const PER_GROUP: usize = 100;
const RADIUS: f64 = 0.2;

/// Quadratic distortion `D(y) = y + Σ_j g_j b_j(y)`: 10 monomials (1, x, y,
/// z, x², y², z², xy, yz, zx) per axis and `|y|² y`.
fn basis(y: &Vector3<f64>) -> SMatrix<f64, 3, G> {
    let m = [
        1.0,
        y.x,
        y.y,
        y.z,
        y.x * y.x,
        y.y * y.y,
        y.z * y.z,
        y.x * y.y,
        y.y * y.z,
        y.z * y.x,
    ];
    let mut b = SMatrix::<f64, 3, G>::zeros();
    for a in 0..3 {
        for (j, v) in m.iter().enumerate() {
            b[(a, 10 * a + j)] = *v;
        }
    }
    let n2 = y.norm_squared();
    for a in 0..3 {
        b[(a, 30 + a)] = n2 * y[a];
    }
    b
}

/// `∂D/∂y` for the same basis.
fn basis_dy(y: &Vector3<f64>, g: &SVector<f64, G>) -> SMatrix<f64, 3, 3> {
    let mut d = SMatrix::<f64, 3, 3>::identity();
    for a in 0..3 {
        let c = &g.as_slice()[10 * a..10 * a + 10];
        d[(a, 0)] += c[1] + 2.0 * c[4] * y.x + c[7] * y.y + c[9] * y.z;
        d[(a, 1)] += c[2] + 2.0 * c[5] * y.y + c[7] * y.x + c[8] * y.z;
        d[(a, 2)] += c[3] + 2.0 * c[6] * y.z + c[8] * y.y + c[9] * y.x;
        let n2 = y.norm_squared();
        for b in 0..3 {
            d[(a, b)] += g[30 + a] * (2.0 * y[a] * y[b] + if a == b { n2 } else { 0.0 });
        }
    }
    d
}

struct Big {
    measurements: Vec<Vector3<f64>>,
    prior: GaussianPrior<G>,
}

impl Problem<G, 3, 2, 3> for Big {
    type PointCache = ();
    type Error = std::convert::Infallible;
    fn n_groups(&self) -> usize {
        self.measurements.len() / PER_GROUP
    }
    fn group_points(&self, k: usize) -> Range<usize> {
        k * PER_GROUP..(k + 1) * PER_GROUP
    }
    fn initial_cache(&self, _i: usize) {}
    fn linearize(
        &self,
        i: usize,
        g: &SVector<f64, G>,
        c: &SVector<f64, 3>,
        p: &SVector<f64, 2>,
        _cache: &mut (),
    ) -> Result<Linearization<G, 3, 2, 3>, Self::Error> {
        let (st, ct) = p[0].sin_cos();
        let (sp, cp) = p[1].sin_cos();
        let u = Vector3::new(ct * cp, st * cp, sp);
        let du = SMatrix::<f64, 3, 2>::new(-st * cp, -ct * sp, ct * cp, -st * sp, 0.0, cp);
        let y = c + RADIUS * u;
        let b = basis(&y);
        let dy = basis_dy(&y, g);
        let s = 1e3;
        Ok(Linearization {
            residual: s * (self.measurements[i] - y - b * g),
            d_global: -s * b,
            d_group: -s * dy,
            d_point: -s * RADIUS * dy * du,
        })
    }
    fn global_prior(&self) -> Option<&GaussianPrior<G>> {
        Some(&self.prior)
    }
}

#[test]
fn time_per_iteration() {
    let n_points: usize = std::env::var("PARCAL_SOLVER_TIMING_POINTS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(50_000);
    let n_groups = n_points / PER_GROUP;
    let mut seed = 12345u64;
    let mut rand = move || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((seed >> 11) as f64) / ((1u64 << 53) as f64) - 0.5
    };
    let g_true = SVector::<f64, G>::from_fn(|_, _| 0.01 * rand());
    let centres: Vec<SVector<f64, 3>> = (0..n_groups)
        .map(|_| Vector3::new(2.0 * rand(), 2.0 * rand(), 2.0 * rand()))
        .collect();
    let mut points = Vec::with_capacity(n_groups * PER_GROUP);
    let mut measurements = Vec::with_capacity(n_groups * PER_GROUP);
    for c in &centres {
        for j in 0..PER_GROUP {
            let p = Vector2::new(
                2.0 * std::f64::consts::PI * j as f64 / PER_GROUP as f64,
                1.8 * rand(),
            );
            let y = c + RADIUS
                * Vector3::new(p[0].cos() * p[1].cos(), p[0].sin() * p[1].cos(), p[1].sin());
            measurements.push(y + basis(&y) * g_true + Vector3::new(rand(), rand(), rand()) * 2e-3);
            points.push(p);
        }
    }
    let problem = Big {
        measurements,
        prior: GaussianPrior::new(g_true, SMatrix::identity() * 1e4),
    };
    let start = State {
        global: SVector::zeros(),
        groups: centres
            .iter()
            .map(|c| c + Vector3::new(0.01, -0.01, 0.005))
            .collect(),
        points: points
            .iter()
            .map(|p| p + Vector2::new(0.05, -0.05))
            .collect(),
    };
    for (threads, method) in [
        (1, Method::GaussNewton),
        (2, Method::GaussNewton),
        (
            2,
            Method::LevenbergMarquardt {
                initial_lambda: 1e-3,
            },
        ),
    ] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let options = SolverOptions {
            method,
            max_iterations: 4,
            ..SolverOptions::default()
        };
        let mut last = Instant::now();
        let mut laps = Vec::new();
        let t0 = Instant::now();
        let solution = pool.install(|| {
            solve(&problem, start.clone(), &options, &mut |r| {
                laps.push((r.cost, last.elapsed().as_secs_f64()));
                last = Instant::now();
            })
        });
        let total = t0.elapsed().as_secs_f64();
        println!(
            "{n_points} points, {threads} thread(s), {method:?}: {:?}, {total:.3} s total for {} records",
            solution.status,
            solution.history.len()
        );
        for (cost, secs) in &laps {
            println!("  cost {cost:.6e}  {secs:.3} s since previous record");
        }
        assert!(matches!(
            solution.status,
            Status::IterationLimit | Status::Converged
        ));
        assert!(solution.covariance.is_some());
    }
}
