//! Heights measured by hand planned on a delta (`parcal_plan::mechanism`,
//! `--heights`): after a calibration from probe heights alone, which
//! leaves the trigger height at its prior, the heights the plan picks are
//! measured on the true printer and calibrated with the probes. The
//! trigger height's sigma is then the plan's prediction, and its estimate
//! is within that sigma of the truth. `cargo test -p parcal-plan --test
//! integration mechanism_heights:: -- --nocapture` prints the figures
//! docs/delta-measurements.md quotes.

use parcal_calibrate::mechanism::{MechanismData, MechanismOptions, calibrate_mechanism};
use parcal_dataset::mechanism::{MechanismDataset, Noise};
use parcal_observe::mechanism::ManualHeight;
use parcal_plan::mechanism::workspace::{Grid, height_candidates};
use parcal_plan::mechanism::{
    Candidate, Counts, MechanismPlan, PlanRequest, Start, TRIGGER_GROUP, plan_mechanism,
};
use parcal_simulate::Rng;
use parcal_simulate::delta::{DeltaScenario, simulate_delta};

/// The heights' standard deviation: a gauge block under the nozzle, the
/// nozzle lowered onto it in steps of 20 µm.
const HEIGHT_SIGMA: f64 = 0.02;

/// The heights planned after each calibration.
const HEIGHTS: usize = 3;

/// The printers simulated.
const PRINTERS: u64 = 30;

/// The kit printer of `seed`, probed on 3 rings of 8, calibrated: its
/// dataset, its data and the start a plan takes from the calibration.
fn calibrated(seed: u64) -> (MechanismDataset, MechanismData, Start) {
    let dataset = simulate_delta(&DeltaScenario::typical(), seed).unwrap();
    let data = MechanismData::from_dataset(&dataset).unwrap();
    let run = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
    assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
    let start = Start::from_record(&run.record(), data.mechanism.as_ref()).unwrap();
    (dataset, data, start)
}

/// The plan of [`HEIGHTS`] heights minimising the trigger height's
/// variance after `start`, on the grid of 11 per axis.
fn plan(dataset: &MechanismDataset, data: &MechanismData, start: &Start) -> MechanismPlan {
    let grid = Grid {
        print_radius: dataset.machine.print_radius,
        ..Grid::new(11)
    };
    let candidates = height_candidates(data.mechanism.as_ref(), grid).unwrap();
    plan_mechanism(&PlanRequest {
        data,
        noise: Noise {
            height: Some(HEIGHT_SIGMA),
            ..dataset.machine.noise
        },
        start: Some(start.clone()),
        candidates: &candidates,
        group: TRIGGER_GROUP,
        counts: Counts {
            heights: HEIGHTS,
            ..Counts::default()
        },
    })
    .unwrap()
}

/// `dataset` with the heights of `plan` measured on its true printer,
/// drawing their noise from stream `seed`: the nozzle's true height at each
/// commanded position (a [`ManualHeight`]'s residual against a height of
/// zero, unit sigma), plus noise.
fn measured(
    dataset: &MechanismDataset,
    data: &MechanismData,
    plan: &MechanismPlan,
    seed: u64,
) -> MechanismDataset {
    let truth = dataset.truth.as_ref().unwrap();
    let mut rng = Rng::new(seed, 2000);
    let mut with_heights = dataset.clone();
    with_heights.machine.noise.height = Some(HEIGHT_SIGMA);
    with_heights.heights = (plan.picks.iter())
        .map(|(candidate, _)| {
            let Candidate::Height(commanded) = *candidate else {
                unreachable!("a plan of heights alone")
            };
            let true_height = ManualHeight {
                commanded,
                height: 0.0,
                sigma: 1.0,
            }
            .evaluate(data.mechanism.as_ref(), &truth.parameters, &data.configured)
            .unwrap()
            .residual[0];
            let [x, y, z] = commanded;
            [x, y, z, true_height + rng.normal(HEIGHT_SIGMA)]
        })
        .collect();
    with_heights
}

#[test]
fn planned_heights_find_the_trigger_height_as_predicted() {
    let (mut squares, mut worst_relative) = (Vec::new(), 0.0f64);
    for seed in 0..PRINTERS {
        let (dataset, data, start) = calibrated(seed);
        let plan = plan(&dataset, &data, &start);
        assert_eq!(plan.picks.len(), HEIGHTS);
        let trigger = plan.parameters.last().unwrap();
        assert_eq!(trigger.group, TRIGGER_GROUP);
        // Probe heights alone leave the trigger height at its prior.
        let prior = data.trigger_height.sigma.unwrap();
        assert!(
            trigger.before > 0.9 * prior,
            "{} of {prior}",
            trigger.before
        );

        let with_heights = measured(&dataset, &data, &plan, seed);
        let data = MechanismData::from_dataset(&with_heights).unwrap();
        let run = calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {}).unwrap();
        assert!(run.converged(), "seed {seed}: {:?}", run.reasons);
        let covariance = run.covariance.as_ref().unwrap();
        let n = covariance.nrows() - 1;
        let sigma = covariance[(n, n)].sqrt();
        let relative = (sigma / trigger.after - 1.0).abs();
        worst_relative = worst_relative.max(relative);
        let estimate = run.values()[n];
        let truth = with_heights.truth.as_ref().unwrap().trigger_height.unwrap();
        squares.push(((estimate - truth) / sigma).powi(2));
        if seed == 0 {
            for (candidate, _) in &plan.picks {
                eprintln!("planned height at {:?}", candidate.positions(0.0)[0]);
            }
            eprintln!(
                "trigger height's sigma {:.4} mm after the probes, {:.4} predicted with {HEIGHTS} heights of {HEIGHT_SIGMA} mm, {sigma:.4} calibrated",
                trigger.before, trigger.after
            );
        }
    }
    let mean = squares.iter().sum::<f64>() / squares.len() as f64;
    let spread = (squares.iter().map(|s| (s - mean).powi(2)).sum::<f64>()
        / (squares.len() - 1) as f64)
        .sqrt();
    let standard_error = spread / (squares.len() as f64).sqrt();
    eprintln!(
        "over {PRINTERS} printers: calibrated sigma within {worst_relative:.2e} of the plan's; mean ((estimate - truth) / sigma)^2 {mean:.3} +- {standard_error:.3}"
    );
    // The plan linearises at the probes' estimate, the calibration at its
    // own, within a sigma of it: the rows move by about sigma / rod length,
    // 1e-4 relative.
    assert!(worst_relative < 1e-3, "{worst_relative:e}");
    // A chi-square of one degree of freedom has mean 1.
    assert!(
        (mean - 1.0).abs() < 4.0 * standard_error,
        "{mean:.3} +- {standard_error:.3}"
    );
}
