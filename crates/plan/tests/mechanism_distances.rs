//! Part distances planned on a delta (`parcal_plan::mechanism`, `--distances`):
//! after planned probe heights, the distances the plan picks against the
//! dense inverse of the same rows, against random distances across the
//! printable disc and against the simulator's diameters. `cargo test -p
//! parcal-plan --test integration mechanism_distances:: -- --nocapture` prints the
//! figures docs/delta-measurements.md quotes.

use crate::common;

use common::dense_prior;
use nalgebra::DMatrix;
use parcal_calibrate::mechanism::MechanismData;
use parcal_dataset::mechanism::Noise;
use parcal_kinematics::delta::{FIRST_LAYER, GAUGE_BLOCK};
use parcal_plan::mechanism::greedy::{dense_covariance, group_trace};
use parcal_plan::mechanism::information::{Linearisation, whitened_rows};
use parcal_plan::mechanism::workspace::{Grid, distance_candidates, grid_candidates};
use parcal_plan::mechanism::{Candidate, Counts, MechanismPlan, PlanRequest, plan_mechanism};
use parcal_simulate::Rng;
use parcal_simulate::delta::{DeltaScenario, simulate_delta};

/// The kit printer's probe (10 µm) and calliper (20 µm).
const NOISE: Noise = Noise {
    probe: Some(0.01),
    distance: Some(0.02),
    actuator: None,
    position: None,
    touch: None,
    tracker: None,
    height: None,
};

/// The index of `diagonal_a`, the first rod.
const RODS: usize = 11;

/// The simulated kit printer of seed 3, as a plan sees it.
fn printer() -> MechanismData {
    let dataset = simulate_delta(&DeltaScenario::typical(), 3).unwrap();
    MechanismData::from_dataset(&dataset).unwrap()
}

/// The plan of `probes` probe heights and `distances` part distances on
/// the grid of 11 per axis, from the prior, minimising the rods' trace
/// (probe candidates only when probes are asked, as `parcal plan` offers
/// them: else the trigger height is no unknown).
fn plan(data: &MechanismData, probes: usize, distances: usize) -> MechanismPlan {
    let mechanism = data.mechanism.as_ref();
    let design: Vec<f64> = data.priors.iter().map(|p| p.mean).collect();
    let mut candidates = distance_candidates(mechanism, grid(11)).unwrap();
    if probes > 0 {
        candidates.extend(grid_candidates(mechanism, &design, grid(11), false).unwrap());
    }
    plan_mechanism(&PlanRequest {
        data,
        noise: NOISE,
        start: None,
        candidates: &candidates,
        group: "diagonal rods",
        counts: Counts {
            measurements: probes,
            distances,
            ..Counts::default()
        },
    })
    .unwrap()
}

/// The print radius the candidates cover (the simulated printer's, its
/// machine.json's).
fn print_radius() -> f64 {
    DeltaScenario::typical().print_radius
}

/// The grid of `per_axis` points per axis over the printable disc.
fn grid(per_axis: usize) -> Grid {
    Grid {
        per_axis,
        print_radius: Some(print_radius()),
        gauge: GAUGE_BLOCK,
    }
}

/// The rods' RMS sigma of a trace of their covariance.
fn rms(trace: f64) -> f64 {
    (trace / 3.0).sqrt()
}

#[test]
fn planned_part_distances_fix_the_rods_better_than_random_ones() {
    let data = printer();
    let mechanism = data.mechanism.as_ref();
    let n = mechanism.parameters().len();
    let (probes, distances) = (25, 3);
    let plan = plan(&data, probes, distances);
    assert_eq!(plan.picks.len(), probes + distances);
    assert!(
        plan.picks[..probes]
            .iter()
            .all(|(c, _)| matches!(c, Candidate::Probe(_)))
    );
    assert!(
        plan.picks[probes..]
            .iter()
            .all(|(c, _)| matches!(c, Candidate::Distance(_)))
    );
    let after_probes = plan.picks[probes - 1].1;
    let mut before = after_probes;
    for (candidate, trace) in &plan.picks[probes..] {
        let Candidate::Distance([a, b]) = candidate else {
            unreachable!()
        };
        eprintln!(
            "distance ({:.1}, {:.1}) to ({:.1}, {:.1}): rods' RMS sigma {:.4} -> {:.4} mm",
            a[0],
            a[1],
            b[0],
            b[1],
            rms(before),
            rms(*trace)
        );
        before = *trace;
    }

    // The same rows by the dense inverse of the prior's information plus
    // theirs. The rods are their own canonical values (no gauge freedom
    // moves them): their rows of the canonical frame's derivative are unit
    // rows.
    let design: Vec<f64> = data.priors.iter().map(|p| p.mean).collect();
    let at = Linearisation {
        params: &design,
        configured: &data.configured,
        trigger_height: data.trigger_height.mean,
        unknowns: n + 1,
    };
    let rows = |c: &Candidate| whitened_rows(mechanism, &at, &NOISE, c).unwrap();
    let prior = dense_prior(&data);
    let rods = DMatrix::identity(n + 1, n + 1).rows(RODS, 3).clone_owned();
    let probe_rows: Vec<DMatrix<f64>> = plan.picks[..probes].iter().map(|(c, _)| rows(c)).collect();
    let trace_with = |extra: &[DMatrix<f64>]| {
        let all: Vec<&DMatrix<f64>> = probe_rows.iter().chain(extra).collect();
        group_trace(&dense_covariance(&prior, &all).unwrap(), &rods)
    };
    let planned: Vec<DMatrix<f64>> = plan.picks[probes..].iter().map(|(c, _)| rows(c)).collect();
    let dense = trace_with(&planned);
    assert!(
        (dense - plan.trace_after()).abs() < 1e-9 * dense,
        "{dense} vs {}",
        plan.trace_after()
    );

    // Random distances: both ends uniform over the printable disc the
    // candidates cover, on the first layer, where the controller reaches
    // them.
    let radius = print_radius();
    let mut rng = Rng::new(1, 0);
    let mut end = || loop {
        let (r, angle) = (
            radius * rng.unit().sqrt(),
            rng.uniform(0.0, std::f64::consts::TAU),
        );
        let end = [r * angle.cos(), r * angle.sin(), FIRST_LAYER];
        if mechanism.check_feasible(&data.configured, &end).is_ok() {
            return end;
        }
    };
    let random: Vec<f64> = (0..20)
        .map(|_| {
            let chosen: Vec<DMatrix<f64>> = (0..distances)
                .map(|_| rows(&Candidate::Distance([end(), end()])))
                .collect();
            rms(trace_with(&chosen))
        })
        .collect();
    let mean = random.iter().sum::<f64>() / random.len() as f64;
    let spread = random.iter().map(|s| (s - mean).powi(2)).sum::<f64>() / 19.0;
    let standard_error = (spread / 20.0).sqrt();
    // The simulator's: diameters at 0.8 of the print radius, spread over
    // the half turn.
    let diameters: Vec<DMatrix<f64>> = (0..distances)
        .map(|k| {
            let angle = std::f64::consts::PI * (k as f64 + 0.5) / distances as f64;
            let (sin, cos) = angle.sin_cos();
            let r = 0.8 * radius;
            rows(&Candidate::Distance([
                [r * cos, r * sin, FIRST_LAYER],
                [-r * cos, -r * sin, FIRST_LAYER],
            ]))
        })
        .collect();
    let simulator = rms(trace_with(&diameters));
    eprintln!(
        "rods' RMS sigma (mm): prior {:.4}; {probes} planned probes {:.4}; and {distances} planned distances {:.4}; and {distances} random distances {mean:.4} +- {standard_error:.4} (mean of 20 draws, its standard error); and the simulator's {distances} diameters {simulator:.4}",
        rms(plan.trace_before),
        rms(after_probes),
        rms(plan.trace_after()),
    );
    for p in plan
        .parameters
        .iter()
        .filter(|p| p.group == "diagonal rods")
    {
        eprintln!(
            "{:<11} prior {:.3}  after {:.4}",
            p.name,
            p.prior_sigma.unwrap(),
            p.after
        );
    }
    // The planned distances beat the random ones' mean by more than 4 of
    // its standard errors.
    assert!(
        rms(plan.trace_after()) < mean - 4.0 * standard_error,
        "planned {} against random {mean} +- {standard_error}",
        rms(plan.trace_after())
    );
    assert!(plan.trace_after() < after_probes);
}

#[test]
fn a_plan_of_part_distances_alone() {
    let data = printer();
    let plan = plan(&data, 0, 2);
    assert_eq!(plan.picks.len(), 2);
    for (candidate, _) in &plan.picks {
        let Candidate::Distance(ends) = candidate else {
            panic!("{candidate:?}")
        };
        assert!(
            ends.iter()
                .all(|[x, y, z]| x.hypot(*y) <= print_radius() && *z == FIRST_LAYER)
        );
    }
    assert!(plan.picks[1].1 < plan.picks[0].1 && plan.picks[0].1 < plan.trace_before);
    // No trigger height among the unknowns: a distance does not see it.
    assert!(plan.parameters.iter().all(|p| p.name != "trigger_height"));
    // A distance without the calliper's noise is refused, naming it.
    let mechanism = data.mechanism.as_ref();
    let candidates = distance_candidates(mechanism, grid(5)).unwrap();
    let error = plan_mechanism(&PlanRequest {
        data: &data,
        noise: Noise::default(),
        start: None,
        candidates: &candidates,
        group: "diagonal rods",
        counts: Counts {
            distances: 1,
            ..Counts::default()
        },
    })
    .unwrap_err()
    .to_string();
    assert!(error.contains("noise.distance"), "{error}");
}
