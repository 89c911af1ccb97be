//! Shared set-up of parcal's benchmarks: a simulated campaign of a given size
//! and its calibration problem, warm (every contact's forward kinematics
//! starts from its design solution, as in an iteration after the first).

use nalgebra::{DVector, Vector2};
use parcal_calibrate::problem::{CalibrationProblem, CoordinateObservations};
use parcal_calibrate::setup::{Observations, Setup};
use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation};
use parcal_dataset::Dataset;
use parcal_kinematics::Params;
use parcal_simulate::{Scenario, simulate};
use parcal_solver::State;

/// Contacts per ball in every benchmark (the paper's 7).
pub const POINTS_PER_BALL: usize = 7;

/// The paper machine with `contacts / 7` balls filling the box, tilts up to
/// 10 degrees, seed 1.
pub fn campaign(contacts: usize) -> Dataset {
    let scenario = Scenario::scaled(
        contacts / POINTS_PER_BALL,
        POINTS_PER_BALL,
        10f64.to_radians(),
    );
    simulate(&scenario, 1).expect("simulation").dataset
}

/// Simulation IV with the propagated prior (the benchmark case).
pub fn options() -> CalibrationOptions {
    CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    }
}

/// The set-up of simulation IV on `dataset` and its coordinate observations.
pub fn setup(dataset: &Dataset) -> (Setup, CoordinateObservations) {
    let (setup, observations) = Setup::new(dataset, &options()).expect("setup");
    let Observations::Coordinates(observations) = observations else {
        unreachable!("simulation IV uses the coordinate observation")
    };
    (setup, observations)
}

/// The coordinate problem of `dataset` and a state a small step away from
/// the initial estimate (every parameter moved by 1e-3 mm); the solver's
/// caches are the design-FK poses ([`Setup::poses`]), so that each forward
/// kinematics takes the two Newton steps of an iteration in mid-run (late
/// iterations, which start from the predicted pose, take one).
pub fn warm_problem<'a>(
    dataset: &'a Dataset,
    setup: &'a Setup,
    observations: CoordinateObservations,
) -> (
    CalibrationProblem<'a, CoordinateObservations, 3>,
    State<3, 2>,
) {
    let problem = setup.problem(dataset, &options(), observations);
    let state = State {
        global: DVector::from_column_slice(
            (setup.initial_params + Params::repeat(1e-3)).as_slice(),
        ),
        groups: setup.initial_centres.clone(),
        points: vec![Vector2::zeros(); setup.order.len()],
    };
    (problem, state)
}

/// Prints the times of a loop's runs (ms) as made, then their mean,
/// median and fastest: the `step_loop` and `setup_loop` examples' output.
pub fn print_times(what: &str, mut times: Vec<f64>) {
    let listed: Vec<String> = times.iter().map(|t| format!("{t:.1}")).collect();
    println!("ms per {what}: {}", listed.join(", "));
    let mean = times.iter().sum::<f64>() / times.len() as f64;
    times.sort_by(f64::total_cmp);
    println!(
        "mean {mean:.1} median {:.1} min {:.1}",
        times[times.len() / 2],
        times[0]
    );
}
