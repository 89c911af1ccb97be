//! The per-ball goodness-of-fit check: a blunder in one contact flags its
//! ball, and only it; a sound calibration flags none.

use parcal_calibrate::{CalibrationOptions, PriorMode, Simulation, calibrate};
use parcal_simulate::{Scenario, simulate};

#[test]
fn a_blunder_flags_its_ball_and_only_it() {
    let options = CalibrationOptions {
        prior: PriorMode::Propagated,
        ..CalibrationOptions::simulation(Simulation::IV)
    };
    let mut dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    let sound = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert!(sound.converged());
    assert!(sound.balls.misfits.is_empty(), "{:?}", sound.balls.misfits);

    // 50 um on one actuator reading of ball 5 (its repeatability is 1 um).
    let ball = 5;
    let row = dataset
        .measurements
        .ball
        .iter()
        .position(|&b| b as usize == ball)
        .unwrap();
    dataset.measurements.q[row][0] += 0.05;
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert!(run.converged());
    let flagged: Vec<&str> = run.balls.misfits.iter().map(|m| m.id.as_str()).collect();
    assert_eq!(flagged, [dataset.artefacts.balls[ball].id.as_str()]);
    let misfit = &run.balls.misfits[0];
    assert_eq!(misfit.degrees_of_freedom, 7 - 3);
    // Ten times the mean of chi-square(4) and more.
    assert!(misfit.chi_square > 40.0, "{misfit:?}");
}
