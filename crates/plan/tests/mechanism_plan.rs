//! Mechanism plans (`parcal_plan::mechanism`) checked against what they
//! predict: on a simulated cable robot, planned samples against random
//! ones, and the predicted sigmas against those of a calibration with the
//! planned samples simulated; on a delta, what probe heights leave to the
//! prior. `cargo test -p parcal-plan --test integration mechanism_plan:: -- --nocapture`
//! prints the figures docs/cable-robots.md and docs/delta-measurements.md quote.

use crate::common;

use common::dense_prior;
use nalgebra::DMatrix;
use parcal_calibrate::mechanism::{MechanismData, MechanismOptions, calibrate_mechanism};
use parcal_dataset::mechanism::{MechanismDataset, Noise, SampleRow};
use parcal_kinematics::delta::{GAUGE_BLOCK, probe_rings};
use parcal_plan::mechanism::greedy::{dense_covariance, group_trace};
use parcal_plan::mechanism::information::{Linearisation, whitened_rows};
use parcal_plan::mechanism::workspace::{Grid, grid_candidates};
use parcal_plan::mechanism::{
    Candidate, Counts, MechanismPlan, PlanRequest, Start, plan_mechanism,
};
use parcal_simulate::delta::{DeltaScenario, simulate_delta};
use parcal_simulate::{CableScenario, Rng, simulate_cable_dataset};

/// The Hangprinter-shaped simulation of `seed`, calibrated.
fn calibrated_cable(seed: u64) -> (MechanismDataset, MechanismData, Start) {
    let dataset = simulate_cable_dataset(&CableScenario::hangprinter(), None, seed).unwrap();
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let calibration =
        calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(calibration.converged());
    let record = calibration.record();
    let start = Start::from_record(&record, data.mechanism.as_ref()).unwrap();
    (dataset, data, start)
}

/// The plan of `count` samples at unknown poses after `start`, on a grid
/// of 12 per axis, minimising the anchors' trace.
fn plan_samples(
    dataset: &MechanismDataset,
    data: &MechanismData,
    start: &Start,
    count: usize,
) -> (Vec<Candidate>, MechanismPlan) {
    let mechanism = data.mechanism.as_ref();
    let n = mechanism.parameters().len();
    let candidates = grid_candidates(mechanism, &start.values[..n], Grid::new(12), false).unwrap();
    let plan = plan_mechanism(&PlanRequest {
        data,
        noise: dataset.machine.noise,
        start: Some(start.clone()),
        candidates: &candidates,
        group: "anchors",
        counts: Counts {
            measurements: count,
            ..Counts::default()
        },
    })
    .unwrap();
    (candidates, plan)
}

/// The anchors' sigmas (12), reported or predicted.
fn anchor_sigmas(plan: &MechanismPlan) -> (Vec<f64>, Vec<f64>) {
    plan.parameters
        .iter()
        .filter(|p| p.group == "anchors")
        .map(|p| (p.before, p.after))
        .unzip()
}

#[test]
fn planned_samples_beat_random_ones_and_the_dense_inverse_agrees() {
    let (dataset, data, start) = calibrated_cable(4);
    let count = 10;
    let (candidates, plan) = plan_samples(&dataset, &data, &start, count);
    let mechanism = data.mechanism.as_ref();
    let n = mechanism.parameters().len();
    let at = Linearisation {
        params: &start.values[..n],
        configured: &data.configured,
        trigger_height: 0.0,
        unknowns: n,
    };
    let rows = |c: &Candidate| whitened_rows(mechanism, &at, &dataset.machine.noise, c).unwrap();
    let objective = DMatrix::identity(n, n).rows(0, 12).clone_owned();
    // The Woodbury updates against the dense inverse (C is full rank: the
    // cable robot has no gauge freedom, T = I).
    let planned: Vec<DMatrix<f64>> = plan.picks.iter().map(|(c, _)| rows(c)).collect();
    let dense = dense_covariance(&start.covariance, &planned.iter().collect::<Vec<_>>()).unwrap();
    let trace = group_trace(&dense, &objective);
    assert!(
        (trace - plan.trace_after()).abs() < 1e-9 * trace,
        "{trace} vs {}",
        plan.trace_after()
    );
    // Random sets of as many feasible candidates.
    let feasible: Vec<&Candidate> = candidates
        .iter()
        .filter(|c| {
            mechanism
                .check_feasible(&start.values[..n], &c.positions(0.0)[0])
                .is_ok()
        })
        .collect();
    assert_eq!(feasible.len(), plan.feasible);
    let mut rng = Rng::new(1, 0);
    let random: Vec<f64> = (0..20)
        .map(|_| {
            let chosen: Vec<DMatrix<f64>> = (0..count)
                .map(|_| rows(feasible[rng.below(feasible.len() as u64) as usize]))
                .collect();
            let after = dense_covariance(&start.covariance, &chosen.iter().collect::<Vec<_>>());
            group_trace(&after.unwrap(), &objective)
        })
        .collect();
    let best_random = random.iter().copied().fold(f64::MAX, f64::min);
    let mean_random = random.iter().sum::<f64>() / random.len() as f64;
    let rms = |trace: f64| (trace / 12.0).sqrt();
    eprintln!(
        "anchors' RMS sigma (mm): {:.3} after the calibration's 44 samples; {count} more: planned {:.3}, random mean {:.3}, best of 20 random {:.3} ({} feasible candidates)",
        rms(plan.trace_before),
        rms(plan.trace_after()),
        rms(mean_random),
        rms(best_random),
        plan.feasible
    );
    assert!(plan.trace_after() < best_random);
}

#[test]
fn the_predicted_sigmas_are_the_calibration_s_with_the_planned_samples() {
    let (mut dataset, data, start) = calibrated_cable(5);
    let count = 10;
    let (_, plan) = plan_samples(&dataset, &data, &start, count);
    // The planned samples measured on the true machine: the effector at
    // each target, readings with the dataset's noise.
    let truth = dataset.truth.clone().unwrap().parameters;
    let sigma = dataset.machine.noise.actuator.unwrap();
    let mechanism = data.mechanism.as_ref();
    let mut rng = Rng::new(5, 9);
    for (candidate, _) in &plan.picks {
        let exact = mechanism
            .inverse(&truth, &candidate.positions(0.0)[0])
            .unwrap();
        dataset.samples.push(SampleRow {
            readings: exact.iter().map(|q| q + rng.normal(sigma)).collect(),
            position: None,
            loads: None,
        });
    }
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let calibration =
        calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    let (before, predicted) = anchor_sigmas(&plan);
    let reported: Vec<f64> = calibration.parameters[..12]
        .iter()
        .map(|p| p.sigma.unwrap())
        .collect();
    let worst = predicted
        .iter()
        .zip(&reported)
        .map(|(p, r)| (p / r - 1.0).abs())
        .fold(0.0, f64::max);
    for k in 0..12 {
        eprintln!(
            "{:<11} before {:.3}  predicted {:.3}  reported {:.3}",
            calibration.parameters[k].name, before[k], predicted[k], reported[k]
        );
    }
    eprintln!("largest relative difference {worst:.4}");
    // The prediction is the calibration's own covariance, linearised at
    // the earlier estimate instead of the new one: they differ by the
    // change of the Jacobians over the estimate's shift, a few mm on
    // lines of 1.5-2.5 m, of order 1e-3 relative.
    assert!(worst < 0.01, "{worst}");
}

#[test]
fn probe_heights_leave_the_xy_scale_to_the_prior() {
    let dataset = simulate_delta(&DeltaScenario::typical(), 3).unwrap();
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let mechanism = data.mechanism.as_ref();
    let n = mechanism.parameters().len();
    let design: Vec<f64> = data.priors.iter().map(|p| p.mean).collect();
    // The grid over the simulated printer's own printable disc.
    let grid = Grid {
        per_axis: 11,
        print_radius: dataset.machine.print_radius,
        gauge: GAUGE_BLOCK,
    };
    let candidates = grid_candidates(mechanism, &design[..n], grid, false).unwrap();
    let plan = plan_mechanism(&PlanRequest {
        data: &data,
        noise: Noise {
            probe: Some(0.01),
            ..Noise::default()
        },
        start: None,
        candidates: &candidates,
        group: "diagonal rods",
        counts: Counts {
            measurements: 25,
            ..Counts::default()
        },
    })
    .unwrap();
    let picked: Vec<String> = plan
        .picks
        .iter()
        .map(|(c, _)| {
            let [x, y, _] = c.positions(0.0)[0];
            format!("({x:.0}, {y:.0})")
        })
        .collect();
    eprintln!(
        "{} feasible probe points; picked: {}",
        plan.feasible,
        picked.join(" ")
    );
    for p in &plan.parameters {
        eprintln!(
            "{:<14} prior {:>7}  before {:.4}  after {:.4}",
            p.name,
            p.prior_sigma.map_or("-".into(), |s| format!("{s:.3}")),
            p.before,
            p.after
        );
    }
    for statement in &plan.statements {
        eprintln!("{statement}");
    }
    // The plan says what probe heights leave to the prior: combinations
    // of the rods with the bed tilt, named by their parameters.
    let rods = plan
        .statements
        .iter()
        .filter(|s| s.contains("do not determine") && s.contains("diagonal_"))
        .count();
    assert!(rods >= 1, "{:?}", plan.statements);
    // The rods stay far from what a part distance gives (docs/delta-measurements.md):
    // above half their prior sigma.
    for p in plan
        .parameters
        .iter()
        .filter(|p| p.group == "diagonal rods")
    {
        assert!(
            p.after > 0.5 * p.prior_sigma.unwrap(),
            "{}: {}",
            p.name,
            p.after
        );
    }
    // The rods' trace against the firmware's usual layout, 25 probes on
    // three rings out to 100 mm (the calibration's, docs/delta-measurements.md), each
    // probed once: the dense inverse of the same prior and rows.
    let at = Linearisation {
        params: &design,
        configured: &data.configured,
        trigger_height: data.trigger_height.mean,
        unknowns: n + 1,
    };
    let noise = Noise {
        probe: Some(0.01),
        ..Noise::default()
    };
    let rings: Vec<DMatrix<f64>> = probe_rings(100.0, 3, 8)
        .into_iter()
        .map(|xy| whitened_rows(mechanism, &at, &noise, &Candidate::Probe(xy)).unwrap())
        .collect();
    let prior = dense_prior(&data);
    let after = dense_covariance(&prior, &rings.iter().collect::<Vec<_>>()).unwrap();
    // The rods are their own canonical values (no gauge freedom moves
    // them): their rows of the canonical frame's derivative are unit rows.
    let rods = DMatrix::identity(n + 1, n + 1).rows(11, 3).clone_owned();
    let ring_trace = group_trace(&after, &rods);
    eprintln!(
        "rods' RMS sigma (mm): prior {:.3}, 25 planned probes {:.3}, 25 probes on 3 rings {:.3}",
        (plan.trace_before / 3.0).sqrt(),
        (plan.trace_after() / 3.0).sqrt(),
        (ring_trace / 3.0).sqrt()
    );
    assert!(plan.trace_after() < ring_trace);
    // Every pick is a probe within the print radius; the trace falls.
    assert!(plan.picks.iter().all(|(c, _)| {
        let [x, y, _] = c.positions(0.0)[0];
        matches!(c, Candidate::Probe(_)) && x.hypot(y) <= 110.0
    }));
    assert!(plan.trace_after() < plan.trace_before);
    // No noise for probes: refused, naming it.
    let error = plan_mechanism(&PlanRequest {
        data: &data,
        noise: Noise::default(),
        start: None,
        candidates: &candidates,
        group: "diagonal rods",
        counts: Counts {
            measurements: 5,
            ..Counts::default()
        },
    })
    .unwrap_err()
    .to_string();
    assert!(error.contains("noise.probe"), "{error}");
}

#[test]
fn bad_requests_are_named() {
    let dataset = simulate_delta(&DeltaScenario::typical(), 3).unwrap();
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let request = |group, count, candidates: &[Candidate]| {
        plan_mechanism(&PlanRequest {
            data: &data,
            noise: dataset.machine.noise,
            start: None,
            candidates,
            group,
            counts: Counts {
                measurements: count,
                ..Counts::default()
            },
        })
        .unwrap_err()
        .to_string()
    };
    let one = [Candidate::Probe([0.0, 0.0])];
    let error = request("legs", 1, &one);
    assert!(error.contains("no parameter group \"legs\""), "{error}");
    let error = request("endstops", 0, &one);
    assert!(error.contains("measurements"), "{error}");
    let error = request("endstops", 1, &[]);
    assert!(error.contains("0 candidates"), "{error}");
    let error = request("endstops", 1, &[Candidate::Probe([900.0, 0.0])]);
    assert!(
        error.contains("none of the 1 candidate measurements is feasible"),
        "{error}"
    );
    // A calibration of another mechanism, or without a covariance, is no
    // start.
    let calibration =
        calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    let mut record = calibration.record();
    let cable = parcal_kinematics::cable::CableRobot::typical();
    let error = Start::from_record(&record, &cable).unwrap_err().to_string();
    assert!(
        error.contains("the dataset's mechanism is a cable robot"),
        "{error}"
    );
    record.covariance = None;
    let error = Start::from_record(&record, data.mechanism.as_ref())
        .unwrap_err()
        .to_string();
    assert!(error.contains("no covariance"), "{error}");
}
