//! Ball touches with measured poses and points of one machine in one
//! calibration ([`parcal_calibrate::mixed`]): the paper scenario's 189
//! touches (1 um) and a laser tracker's poses and points (10 um, 1e-4 rad)
//! in two sessions of 20 rows, legs re-homed between them (0.5 mm),
//! actuators in mm with the known scale 1.
//!
//! - The instrument rows' Jacobian on the touch problem's global block
//!   against central differences of their residuals.
//! - NEES of the global block (33 parameters and the instrument groups)
//!   over seeds, each with a true machine drawn from the prior (0.02 mm):
//!   its mean within 4 standard errors of the block's size.
//! - The true registered error on the paper's map: mixed data against the
//!   touches alone and the tracker alone on the same seeds.
//! - calibration.json: the instrument parameters after the 33, applied
//!   back to the poses and points by `parcal validate`.

use crate::common;

use common::{mean_and_standard_error, nees, rms, true_block};
use nalgebra::DVector;
use parcal_accuracy::MapGrid;
use parcal_calibrate::instruments::{Calibrated, setup, validate_calibration};
use parcal_calibrate::layout::ParameterGroup;
use parcal_calibrate::setup::{Observations, Setup};
use parcal_calibrate::{CalibrateError, CalibrationOptions, ParamCovariance, calibrate};
use parcal_dataset::{Artefacts, Dataset, Measurements, SessionModel, Tracker};
use parcal_kinematics::{Geometry, N_PARAMS, Params, Vec3};
use parcal_simulate::{Readings, Rng, Scenario, TrackerKind, TrackerScenario, simulate_mixed};
use parcal_solver::{GlobalObservations, Problem};
use parcal_workflows::evaluate::{TrueMachine, accuracy};

/// The mean NEES must lie within this many of its standard errors of the
/// block's size (an honest covariance fails with probability about 6e-5).
const STANDARD_ERRORS: f64 = 4.0;
/// Seeds of the comparison with either kind alone.
const SEEDS: std::ops::RangeInclusive<u64> = 1..=40;
/// Seeds (noise and true machine) of the NEES test.
const NEES_SEEDS: std::ops::RangeInclusive<u64> = 1..=100;
/// The design tolerance of every input coordinate in the NEES test (mm):
/// at the paper's 0.1 mm the model's curvature adds to the NEES
/// (`tests/instruments_monte_carlo.rs`).
const TOLERANCE: f64 = 0.02;
/// The random stream of a seed's true machine: apart from the simulator's
/// (balls, sessions, plate, instrument seed).
const TRUTH_STREAM: u64 = 1 << 32;

/// The paper-like tracker of the paper's machine, scales 1 and known.
fn tracker() -> TrackerScenario {
    TrackerScenario {
        kind: TrackerKind::Both,
        true_scale: [1.0; 6],
        scale_sigma: None,
        sessions: 2,
        rows_per_session: 20,
        session_model: SessionModel {
            leg_offset_sigma: Some(0.5),
            body_origin_sigma: None,
            body_rotation_sigma: None,
        },
        ..TrackerScenario::paper_like()
    }
}

fn mixed(seed: u64) -> Dataset {
    simulate_mixed(&Scenario::paper(), &tracker(), seed)
        .expect("simulation")
        .dataset
}

/// The instrument rows' Jacobian (whitened, on every column of the global
/// block) against central differences of their residuals at the initial
/// estimate, column by column; the step is 1e-6 of the column's scale.
#[test]
fn instrument_rows_have_the_derivatives_of_their_residuals() {
    let dataset = mixed(1);
    let options = CalibrationOptions::default();
    let (setup, observations) = Setup::new(&dataset, &options).unwrap();
    let Observations::Coordinates(observations) = observations else {
        panic!("the default observes coordinates")
    };
    let mut problem = setup.problem::<_, 4>(&dataset, &options, observations);
    let initial = setup.initial_state::<4, 2>(&dataset).global;
    problem.attach_instruments(&dataset, &initial).unwrap();
    assert_eq!(
        problem.global_rows(),
        6 * 40 + 3 * 40,
        "no distances: the poses' and points' rows"
    );
    let evaluate = |g: &DVector<f64>| {
        let mut out = GlobalObservations::zeros(0, 0);
        problem.global_observations(g, &mut out).unwrap();
        out
    };
    let at = evaluate(&initial);
    assert_eq!(at.jacobian.ncols(), setup.layout.size());
    let mut worst: f64 = 0.0;
    for c in 0..initial.len() {
        let h = 1e-6 * initial[c].abs().max(1.0);
        let (mut plus, mut minus) = (initial.clone(), initial.clone());
        plus[c] += h;
        minus[c] -= h;
        let numeric = (evaluate(&plus).residual - evaluate(&minus).residual) / (2.0 * h);
        let analytic = at.jacobian.column(c);
        let scale = analytic.norm().max(1.0);
        worst = worst.max((numeric - analytic).norm() / scale);
    }
    // Central differences err by O(h^2 f''') + O(eps |f| / h): about 1e-6
    // relative for whitened rows of order 1e3 at h = 1e-6.
    assert!(worst < 1e-5, "worst relative column error {worst:.2e}");
}

/// The mixed campaign of seed `seed` with design tolerances [`TOLERANCE`]
/// and a true machine drawn from them: each input coordinate of the
/// design plus `N(0, TOLERANCE²)`.
fn mixed_with_truth_from_prior(seed: u64) -> Dataset {
    let mut rng = Rng::new(seed, TRUTH_STREAM);
    let design = Scenario::paper().design;
    let mut moved = |v: &Vec3| v + Vec3::from_fn(|_, _| rng.normal(TOLERANCE));
    let (base, platform, tool) = (
        design.base.map(|b| moved(&b)),
        design.platform.map(|e| moved(&e)),
        moved(&design.tool),
    );
    let legs = design.legs.map(|l| l + rng.normal(TOLERANCE));
    let truth = Geometry {
        base,
        platform,
        tool,
        legs,
    };
    let touches = Scenario {
        truth: truth.clone(),
        prior_sigma: TOLERANCE,
        ..Scenario::paper()
    };
    let tracker = TrackerScenario { truth, ..tracker() };
    simulate_mixed(&touches, &tracker, seed)
        .expect("simulation")
        .dataset
}

/// The global block's NEES over seeds, each with its own true machine
/// drawn from the prior: the run's covariance describes its error.
#[test]
fn mean_nees_of_the_mixed_global_block_is_its_size() {
    let options = CalibrationOptions::default();
    let mut values = Vec::new();
    let mut size = 0;
    for seed in NEES_SEEDS {
        let dataset = mixed_with_truth_from_prior(seed);
        let run = calibrate(&dataset, &options, &mut |_| {}).expect("calibration");
        assert!(run.converged(), "seed {seed}: {:?}", run.status);
        let instruments = run.instruments.expect("poses and points were calibrated");
        let covariance = run.global_covariance.as_ref().expect("a covariance");
        let error = &run.global - true_block(&dataset, &instruments.model);
        size = error.len();
        values.push(nees(&error, covariance).expect("positive definite"));
    }
    let (mean, standard_error) = mean_and_standard_error(&values);
    println!(
        "mixed: {} seeds, mean NEES {mean:.2} for {size} parameters, standard error \
         {standard_error:.2}",
        values.len()
    );
    assert!(
        (mean - size as f64).abs() <= STANDARD_ERRORS * standard_error,
        "mean NEES {mean:.2} is more than {STANDARD_ERRORS} standard errors ({standard_error:.2}) \
         from {size}"
    );
}

/// The true registered RMS on the paper's map (mm) of `params`.
fn registered(dataset: &Dataset, params: &Params, covariance: &ParamCovariance) -> f64 {
    let truth = TrueMachine::of(dataset)
        .expect("truth")
        .expect("canonical truth");
    let design = parcal_calibrate::setup::design_geometry(dataset);
    let maps = accuracy(&design, Some(&truth), params, covariance, &MapGrid::paper()).unwrap();
    maps.true_error.expect("truth").registered_summary().rms
}

/// Mixed data against each kind alone, on the same seeds: the true
/// registered RMS over the seeds is lower than either's.
#[test]
fn mixed_data_beat_either_kind_alone() {
    let options = CalibrationOptions::default();
    let (mut both, mut touches, mut instruments) = (Vec::new(), Vec::new(), Vec::new());
    for seed in SEEDS {
        let dataset = mixed(seed);
        let run = calibrate(&dataset, &options, &mut |_| {}).expect("mixed");
        both.push(registered(
            &dataset,
            &run.params,
            &run.covariance.expect("mixed covariance"),
        ));
        let touch_only = Dataset {
            tracker: Tracker::default(),
            truth: None,
            ..dataset.clone()
        };
        let run = calibrate(&touch_only, &options, &mut |_| {}).expect("touches");
        touches.push(registered(
            &dataset,
            &run.params,
            &run.covariance.expect("touch covariance"),
        ));
        let tracker_only = Dataset {
            artefacts: Artefacts::default(),
            measurements: Measurements::default(),
            truth: None,
            ..dataset.clone()
        };
        let run = calibrate(&tracker_only, &options, &mut |_| {}).expect("tracker");
        instruments.push(registered(
            &dataset,
            &run.params,
            &run.covariance.expect("tracker covariance"),
        ));
    }
    let (both, touches, instruments) = (rms(&both), rms(&touches), rms(&instruments));
    println!(
        "true registered RMS over {} seeds: touches {:.3} um, tracker {:.3} um, mixed {:.3} um",
        SEEDS.count(),
        1e3 * touches,
        1e3 * instruments,
        1e3 * both
    );
    assert!(
        both < touches && both < instruments,
        "mixed {both:.3e} mm is not below touches {touches:.3e} mm and tracker {instruments:.3e} mm"
    );
}

/// Touches with instrument data and unknown actuator scales (the paper
/// tracker's, true scales about 1e-3 off, prior 2e-3): one scale group,
/// seen by the touches and the instrument rows, the NEES of the scales
/// within chi-square(6)'s 0.999 quantile; the instrument stage's set-up
/// refuses touches.
#[test]
fn actuator_scales_are_calibrated_with_touches_and_instruments() {
    let tracker = TrackerScenario {
        scale_sigma: Some([2e-3; 6]),
        true_scale: TrackerScenario::paper_like().true_scale,
        ..tracker()
    };
    let touches = Scenario::paper().reading(Readings::of(&tracker));
    let dataset = simulate_mixed(&touches, &tracker, 1)
        .expect("simulation")
        .dataset;
    let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {}).expect("mixed");
    assert!(run.converged(), "{:?}", run.status);
    let scales = run
        .layout
        .range(ParameterGroup::ActuatorScales)
        .expect("the scales are unknowns");
    let covariance = run.global_covariance.as_ref().expect("a covariance");
    let error = DVector::from_fn(6, |i, _| {
        run.global[scales.start + i] - tracker.true_scale[i]
    });
    let block = covariance
        .view((scales.start, scales.start), (6, 6))
        .into_owned();
    let scales_nees = nees(&error, &block).expect("positive definite");
    println!(
        "scales: errors {:?}, NEES {scales_nees:.2}",
        error.as_slice()
    );
    // chi-square(6) exceeds 22.46 with probability 1e-3.
    assert!(scales_nees < 22.46, "NEES of the scales {scales_nees:.2}");
    let error = setup(&mixed(1), &CalibrationOptions::default())
        .err()
        .expect("refused");
    assert!(matches!(error, CalibrateError::HasTouches), "{error}");
}

/// calibration.json of mixed data: the 33, then the instrument parameters
/// with their covariance, the calibrated machine and the sessions; applied
/// back to the same poses and points (`parcal validate`), it predicts their
/// residual RMS within 20 % (in sample, the sessions' nuisance as
/// calibrated).
#[test]
fn the_record_carries_the_instrument_parameters_and_validates() {
    let dataset = mixed(2);
    let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {}).expect("mixed");
    let record = run.record(String::new());
    let names = &record.parameters.names;
    // 33, two frames, the body frame, the second session's offsets.
    assert_eq!(names.len(), N_PARAMS + 6 + 6 + 6 + 6);
    assert_eq!(names[N_PARAMS], "frame 1.wx");
    assert_eq!(names[names.len() - 1], "o_6 2");
    assert_eq!(record.covariance.len(), names.len());
    assert_eq!(record.sessions.len(), 2);
    assert!(record.machine.is_some());
    assert_eq!(record.ball_centres.len(), 27);
    let calibrated = Calibrated::from_record(&record).expect("an instrument record");
    let validation = validate_calibration(&dataset, &calibrated, None).expect("validation");
    let (observed, predicted) = (validation.rms(), validation.predicted_rms());
    println!("in sample: residual RMS {observed:.4} mm, predicted {predicted:.4} mm");
    assert!(
        (predicted / observed - 1.0).abs() < 0.2,
        "predicted {predicted:.4} mm against {observed:.4} mm"
    );
}
