//! A cheap version of docs/plan-poses.md's evidence: plan 30 poses of
//! the paper's machine seen by a laser tracker's pose measurement, simulate
//! exactly those with the truth of table 2 over several noise seeds,
//! calibrate, and compare with 30 random poses of the same workspace and
//! tilt.

use parcal_accuracy::{MapGrid, true_error};
use parcal_calibrate::CalibrationOptions;
use parcal_calibrate::calibrate;
use parcal_dataset::{Dataset, SessionModel};
use parcal_kinematics::Geometry;
use parcal_plan::Criterion;
use parcal_plan::tracker::{PosePlan, PosePlanOptions, plan_poses};
use parcal_simulate::{TrackerKind, TrackerScenario, simulate_tracker};

const SEEDS: u64 = 4;
const POSES: usize = 30;

/// The true and the calibration's predicted registered RMS over the
/// paper's map after calibrating `dataset` (um).
fn registered(dataset: &Dataset) -> (f64, f64) {
    let run = calibrate(dataset, &CalibrationOptions::default(), &mut |_| {}).expect("calibration");
    assert!(run.converged(), "the calibration did not converge");
    let g = &dataset.truth.as_ref().unwrap().geometry;
    let truth = Geometry::from_arrays(&g.base_joints, &g.platform_joints, &g.tool, &g.leg_lengths)
        .canonicalize()
        .unwrap()
        .geometry;
    let estimate = run.params;
    let grid = MapGrid::paper();
    let true_rms = true_error(&run.design, &estimate, &truth, &grid)
        .unwrap()
        .registered_summary()
        .rms;
    // Poses alone leave the tool out of the layout: the 33's covariance
    // takes its rows from the prior.
    let covariance = run.covariance.expect("a covariance");
    let predicted = parcal_accuracy::predicted(&run.design, &estimate, &covariance, &grid)
        .unwrap()
        .registered_summary()
        .rms;
    (true_rms * 1e3, predicted * 1e3)
}

/// The random campaign of `poses` poses (one session, the paper's machine,
/// pose measurements), its machine.json with the simulator's stroke, and
/// the plan of as many poses.
fn campaigns(poses: usize) -> (TrackerScenario, TrackerScenario, PosePlan) {
    campaigns_in(poses, 1, SessionModel::default())
}

/// [`campaigns`] over `sessions` sessions sharing the poses evenly, with
/// what changes between them as `session_model` says.
fn campaigns_in(
    poses: usize,
    sessions: usize,
    session_model: SessionModel,
) -> (TrackerScenario, TrackerScenario, PosePlan) {
    let random = TrackerScenario {
        kind: TrackerKind::Poses,
        sessions,
        rows_per_session: poses / sessions,
        session_model,
        ..TrackerScenario::paper_like()
    };
    let mut machine = simulate_tracker(&random, 1).unwrap().dataset.machine;
    machine.stroke = Some(random.stroke);
    let options = PosePlanOptions {
        poses,
        kind: TrackerKind::Poses,
        workspace: random.workspace,
        tilt_degrees: random.max_tilt.to_degrees(),
        criterion: Criterion::Registered,
        passes: 3,
        sessions,
    };
    let plan = plan_poses(&machine, &options, &mut |_| {}).unwrap();
    let by_session = (0..sessions)
        .map(|k| {
            plan.poses
                .iter()
                .zip(&plan.sessions)
                .filter(|(_, s)| **s == k)
                .map(|(c, _)| c.q)
                .collect()
        })
        .collect();
    let planned = TrackerScenario {
        plan: Some(by_session),
        ..random.clone()
    };
    (random, planned, plan)
}

/// Over `seeds` noise seeds, the RMS of: the planned poses' true
/// registered RMS, the random poses', and the planned calibrations'
/// predicted (um).
fn compare(random: &TrackerScenario, planned: &TrackerScenario, seeds: u64) -> [f64; 3] {
    let mut sums = [0.0; 3];
    for seed in 1..=seeds {
        let (p, p_pred) = registered(&simulate_tracker(planned, seed).unwrap().dataset);
        let (r, _) = registered(&simulate_tracker(random, seed).unwrap().dataset);
        eprintln!("seed {seed}: planned {p:.3} um (predicted {p_pred:.3}), random {r:.3} um");
        for (sum, v) in sums.iter_mut().zip([p, r, p_pred]) {
            *sum += v * v / seeds as f64;
        }
    }
    sums.map(f64::sqrt)
}

#[test]
fn planned_poses_beat_random_ones_and_their_prediction_holds() {
    let (random, planned, plan) = campaigns(POSES);
    assert_eq!(plan.poses.len(), POSES);
    assert!(plan.predicted.registered_rms_um < plan.prior.registered_rms_um);
    let [planned_true, random_true, planned_predicted] = compare(&random, &planned, SEEDS);
    eprintln!(
        "plan predicts {:.3} um; calibrations predict {planned_predicted:.3} um; true {planned_true:.3} um planned, {random_true:.3} um random",
        plan.predicted.registered_rms_um
    );
    assert!(
        planned_true < random_true,
        "{planned_true} vs {random_true}"
    );
    // The plan's prediction is the calibrations' own (the same rows and
    // prior, linearised at the design instead of the estimate, weighed at
    // the design, the frames' weak prior): within 15 %.
    let ratio = plan.predicted.registered_rms_um / planned_predicted;
    assert!(
        (ratio - 1.0).abs() < 0.15,
        "plan {ratio} x the calibrations'"
    );
    // The true mean square over the seeds is a mean of 4 quadratic forms
    // `eᵀ A e`, `e ~ N(0, Σ)`, whose expectation is the predicted square:
    // with at least 3 effective degrees of freedom per seed it lies within
    // a factor 4 of it (chi-square, 12 dof: P < 0.5 %), the RMS within 2.
    let ratio = planned_true / plan.predicted.registered_rms_um;
    assert!((0.5..2.0).contains(&ratio), "true {ratio} x predicted");
}

/// docs/plan-poses.md's table (`cargo test -p parcal-plan --test
/// plan_tracker_poses -- --ignored --nocapture`): budgets 15, 30 and 60,
/// 8 seeds.
#[test]
#[ignore = "the documented run: a few minutes"]
fn evidence_table() {
    for poses in [15, 30, 60] {
        let (random, planned, plan) = campaigns(poses);
        let [planned_true, random_true, planned_predicted] = compare(&random, &planned, 8);
        println!(
            "| {poses} | {:.2} | {planned_predicted:.2} | {planned_true:.2} | {random_true:.2} |",
            plan.predicted.registered_rms_um
        );
    }
}

/// Two sessions with re-homed legs (0.5 mm) and a re-mounted marker body
/// (0.2 mm, 1 mrad): the plan of 30 poses, 15 per session, against 15
/// random poses per session; docs/plan-poses.md's two-session table
/// (`cargo test -p parcal-plan --test integration plan_tracker_poses::two_sessions --
/// --ignored --nocapture`).
#[test]
#[ignore = "the documented run: a few minutes"]
fn two_sessions_evidence() {
    let model = SessionModel {
        leg_offset_sigma: Some(0.5),
        body_origin_sigma: Some(0.2),
        body_rotation_sigma: Some(1e-3),
    };
    for poses in [30, 60] {
        let (random, planned, plan) = campaigns_in(poses, 2, model);
        assert!((0..2).all(|k| plan.sessions.iter().filter(|&&s| s == k).count() == poses / 2));
        let [planned_true, random_true, planned_predicted] = compare(&random, &planned, 6);
        println!(
            "| {poses} (2 x {}) | {:.2} | {planned_predicted:.2} | {planned_true:.2} | {random_true:.2} |",
            poses / 2,
            plan.predicted.registered_rms_um
        );
    }
}
