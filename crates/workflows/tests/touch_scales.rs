//! Ball touches read in the actuators' own unit with unknown scales
//! (machine.json's `actuator.scale_sigma`): leg `i` is `l_i + s_i q_i`
//! long and the layout holds `s` after the 33
//! ([`parcal_calibrate::layout::ParameterGroup::ActuatorScales`]). The
//! campaign is the paper's touches read in motor revolutions at Jugglebot's
//! scales (`parcal simulate --readings rev`: design about 71 mm/rev, true
//! scales 1 % off, prior sigma 2 %).
//!
//! - Each contact's whitened residual block against central differences on
//!   every column of the global block, and the back-substitution's step
//!   `J dg` against the Jacobian applied to `dg`.
//! - NEES of the global block (33 and 6 scales) over noise seeds of one
//!   truth: its mean within 4 standard errors of 39.
//! - calibration.json: the scales after the 33, the calibrated actuator
//!   block, and `parcal validate`'s prediction of new touches.

use crate::common;

use common::{mean_and_standard_error, nees};
use nalgebra::{DVector, SVector};
use parcal_calibrate::layout::ParameterGroup;
use parcal_calibrate::problem::{CalibrationProblem, ContactJacobian, ContactObservations};
use parcal_calibrate::setup::{Observations, Setup};
use parcal_calibrate::validate_touches;
use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation, calibrate};
use parcal_dataset::Dataset;
use parcal_kinematics::N_PARAMS;
use parcal_simulate::{Readings, Scenario, TrackerScenario, simulate};
use parcal_solver::{GlobalJacobian, Linearization, Problem};
use parcal_workflows::evaluate::TrueMachine;

/// The mean NEES must lie within this many of its standard errors of the
/// block's size (an honest covariance fails with probability about 6e-5).
const STANDARD_ERRORS: f64 = 4.0;
/// Noise seeds of the NEES test.
const SEEDS: std::ops::RangeInclusive<u64> = 1..=40;

/// The paper's touches read in Jugglebot's motor revolutions.
fn scenario() -> Scenario {
    Scenario::paper().reading(Readings::of(&TrackerScenario::jugglebot_like()))
}

fn dataset(seed: u64) -> Dataset {
    simulate(&scenario(), seed).expect("simulation").dataset
}

fn options() -> CalibrationOptions {
    CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    }
}

/// Every contact's residual against central differences of the problem's
/// own residual on every global column, at the initial state moved off the
/// design (so that no derivative vanishes by symmetry), and `J dg` of the
/// back-substitution against `J` applied to `dg`.
fn check_contacts<const G: usize, const P: usize, const R: usize, O>(
    problem: &CalibrationProblem<'_, O, G>,
    global: &DVector<f64>,
    groups: &[SVector<f64, G>],
) -> (f64, f64)
where
    O: ContactObservations<R, P>,
{
    let n = global.len();
    let contacts = [0, 3, 50, 188];
    let residual = |g: &DVector<f64>, i: usize| {
        let values = problem.prepare_global(g);
        let mut cache = problem.initial_cache(i);
        let mut out = Linearization::<G, P, R, ContactJacobian<R, G>>::zeros(n);
        let ball = problem.ball[problem.rows[i] as usize] as usize;
        problem
            .linearize(
                i,
                &values,
                &groups[ball],
                &SVector::zeros(),
                &mut cache,
                &mut out,
            )
            .expect("linearisation");
        out
    };
    let (mut worst_column, mut worst_step) = (0.0f64, 0.0f64);
    let mut row = vec![0.0; n];
    for &i in &contacts {
        let at = residual(global, i);
        for c in 0..n {
            let h = 1e-6 * global[c].abs().max(1.0);
            let (mut plus, mut minus) = (global.clone(), global.clone());
            plus[c] += h;
            minus[c] -= h;
            let numeric = (residual(&plus, i).residual - residual(&minus, i).residual) / (2.0 * h);
            let analytic = SVector::<f64, R>::from_fn(|r, _| {
                at.d_global.row(r, &mut row);
                row[c]
            });
            let scale = analytic.norm().max(1.0);
            worst_column = worst_column.max((numeric - analytic).norm() / scale);
        }
        // The back-substitution's step against the Jacobian applied.
        let dg = DVector::from_fn(n, |k, _| 1e-4 * ((k as f64) * 0.7).sin());
        let values = problem.prepare_global(global);
        let ball = problem.ball[problem.rows[i] as usize] as usize;
        let mut cache = problem.initial_cache(i);
        let mut out = Linearization::<G, P, R, ContactJacobian<R, G>>::zeros(n);
        let step = problem
            .linearize_along(
                i,
                &values,
                &groups[ball],
                &SVector::zeros(),
                &mut cache,
                &dg,
                &mut out,
            )
            .expect("back-substitution");
        let applied = at.d_global.apply(&dg);
        worst_step = worst_step.max((step - applied).norm() / applied.norm());
    }
    (worst_column, worst_step)
}

#[test]
fn contacts_have_the_derivatives_of_their_residuals_on_the_scales() {
    let dataset = dataset(1);
    let options = options();
    let (setup, observations) = Setup::new(&dataset, &options).unwrap();
    let scales = setup
        .layout
        .range(ParameterGroup::ActuatorScales)
        .expect("the scales are unknowns");
    assert_eq!(scales, N_PARAMS..N_PARAMS + 6);
    let Observations::Coordinates(observations) = observations else {
        panic!("simulation IV observes coordinates")
    };
    let problem = setup.problem::<_, 3>(&dataset, &options, observations);
    let state = setup.initial_state::<3, 2>(&dataset);
    assert_eq!(
        state.global.rows(scales.start, 6).as_slice(),
        dataset.machine.actuator.scale,
        "the scales start at the design's"
    );
    let mut global = state.global.clone();
    for (k, s) in scales.enumerate() {
        global[s] *= 1.0 + 0.003 * (k as f64 - 2.5);
    }
    let (columns, step) = check_contacts(&problem, &global, &state.groups);
    println!("worst relative column error {columns:.2e}, worst step error {step:.2e}");
    // Central differences err by O(h^2 f''') + O(eps |f| / h): about 1e-6
    // relative for whitened rows of order 1e3 at h = 1e-6 of the scale.
    assert!(columns < 1e-5, "worst relative column error {columns:.2e}");
    // The step is the same linear map evaluated two ways: rounding only.
    assert!(step < 1e-9, "worst relative step error {step:.2e}");
}

#[test]
fn radius_observations_have_the_derivatives_of_their_residuals_on_the_scales() {
    let dataset = dataset(2);
    let options = CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::III)
    };
    let (setup, observations) = Setup::new(&dataset, &options).unwrap();
    let Observations::Radius(observations) = observations else {
        panic!("simulation III observes radii")
    };
    let problem = setup.problem::<_, 3>(&dataset, &options, observations);
    let state = setup.initial_state::<3, 0>(&dataset);
    let (columns, step) = check_contacts(&problem, &state.global, &state.groups);
    assert!(columns < 1e-5, "worst relative column error {columns:.2e}");
    assert!(step < 1e-9, "worst relative step error {step:.2e}");
}

/// The true global block (33 and scales) of a simulated dataset.
fn truth(dataset: &Dataset) -> DVector<f64> {
    let machine = TrueMachine::of(dataset)
        .expect("simulated truth")
        .expect("canonical truth");
    let scales = dataset
        .truth
        .as_ref()
        .and_then(|t| t.actuator_scale)
        .expect("true scales");
    DVector::from_iterator(N_PARAMS + 6, machine.params.iter().copied().chain(scales))
}

#[test]
fn mean_nees_of_the_parameters_and_scales_is_their_number() {
    let options = options();
    let mut values = Vec::new();
    let mut worst_scale: f64 = 0.0;
    for seed in SEEDS {
        let dataset = dataset(seed);
        let run = calibrate(&dataset, &options, &mut |_| {}).expect("calibration");
        assert!(run.converged(), "seed {seed}: {:?}", run.status);
        assert_eq!(run.global.len(), N_PARAMS + 6);
        let covariance = run.global_covariance.as_ref().expect("a covariance");
        let error = &run.global - truth(&dataset);
        for k in N_PARAMS..N_PARAMS + 6 {
            worst_scale = worst_scale.max((error[k] / covariance[(k, k)].sqrt()).abs());
        }
        values.push(nees(&error, covariance).expect("positive definite"));
    }
    let (mean, standard_error) = mean_and_standard_error(&values);
    println!(
        "touches in rev: {} seeds, mean NEES {mean:.2} for {} parameters, standard error \
         {standard_error:.2}; worst scale error {worst_scale:.2} sigma",
        values.len(),
        N_PARAMS + 6
    );
    assert!(
        (mean - (N_PARAMS + 6) as f64).abs() <= STANDARD_ERRORS * standard_error,
        "mean NEES {mean:.2} is more than {STANDARD_ERRORS} standard errors \
         ({standard_error:.2}) from {}",
        N_PARAMS + 6
    );
    // 240 normal errors: beyond 4.5 sigma with probability about 2e-3.
    assert!(worst_scale < 4.5, "a scale {worst_scale:.2} sigma off");
}

/// calibration.json of touches with scales: the 33 then `s_1..s_6` with
/// their covariance, the calibrated actuator block in the readings' unit;
/// applied to the touches of 8 other campaigns of the same machine, each
/// ball's centre fitted on its first 5 touches (`parcal validate`), the
/// RMS of the other touches within 20 % of the RMS it predicts.
#[test]
fn the_record_carries_the_scales_and_validates() {
    let run = calibrate(&dataset(3), &options(), &mut |_| {}).expect("calibration");
    let record = run.record("converged".into());
    let names = &record.parameters.names;
    assert_eq!(names.len(), N_PARAMS + 6);
    assert_eq!(names[N_PARAMS], "s_1");
    assert_eq!(record.covariance.len(), N_PARAMS + 6);
    let machine = record.machine.as_ref().expect("the calibrated actuators");
    assert_eq!(machine.actuator.unit, "rev");
    assert_eq!(
        machine.actuator.scale.as_slice(),
        &record.parameters.values[N_PARAMS..]
    );
    // The touches determine the scales far better than their prior (2 %).
    let sigma = machine.actuator.scale_sigma.expect("their sigmas");
    let prior = dataset(3).machine.actuator.scale_sigma.expect("a prior");
    assert!(
        (0..6).all(|i| sigma[i] > 0.0 && sigma[i] < 0.1 * prior[i]),
        "{sigma:?} against the prior's {prior:?}"
    );
    let (mut observed, mut predicted) = (0.0, 0.0);
    for seed in 4..12 {
        let validation = validate_touches(&dataset(seed), &record, Some(5)).expect("validation");
        assert_eq!(validation.contacts, 27 * 2);
        observed += validation.rms().powi(2);
        predicted += validation.predicted_rms().powi(2);
    }
    let ratio = (predicted / observed).sqrt();
    println!("touches in rev: predicted / observed RMS of new touches {ratio:.3}");
    // 432 residuals: the pooled RMS has a relative standard error of about
    // 1 / sqrt(2 x 432) = 3.4 %.
    assert!((0.8..1.2).contains(&ratio), "predicted / observed {ratio}");
}
