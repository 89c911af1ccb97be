//! calibration.json's words for runs of the paper scenario: what a record
//! says of a run that did not converge, and of a common radius error below
//! its minimal detectable bias.

use parcal_accuracy::MapGrid;
use parcal_calibrate::{CalibrationOptions, calibrate};
use parcal_simulate::{Scenario, simulate};
use parcal_workflows::evaluate::{TrueMachine, before_after};

/// A run stopped before it converged, at its initial state (no iteration,
/// or a zero time budget): its record says its state is not a
/// least-squares minimum and blames no observation, ball or prior.
#[test]
fn the_record_of_a_run_that_did_not_converge_blames_nothing() {
    let dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    for options in [
        CalibrationOptions {
            max_iterations: 0,
            ..CalibrationOptions::default()
        },
        CalibrationOptions {
            time_limit: Some(std::time::Duration::ZERO),
            ..CalibrationOptions::default()
        },
    ] {
        let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
        assert!(!run.converged(), "{:?}", run.status);
        let record = parcal_report::record::of_run(&run, &dataset);
        assert_eq!(record.verdict, "rejected");
        assert!(
            record.reasons[0].contains("not a least-squares minimum"),
            "{:?}",
            record.reasons
        );
        for sentence in record.reasons.iter().chain(&record.warnings) {
            for blame in [
                "normalised residual",
                "likely a blunder",
                "far worse than the noise allows",
                "contradicts the data",
                "global test",
            ] {
                assert!(!sentence.contains(blame), "{sentence}");
            }
        }
        assert!(record.diagnostics.unwrap().observations.is_none());
    }
}

/// The case: every ball's radius entered 5 um too large on the
/// paper scenario (seed 1) passes every test, being below the common
/// radius error's minimal detectable bias, while its true registered error
/// exceeds the predicted one; the run's record says how large an
/// undetectable common radius error could be and what it would add
/// (docs/verdicts.md, "Sensitivity to systematic errors").
#[test]
fn a_common_radius_error_below_its_mdb_passes_and_its_sensitivity_is_stated() {
    let mut dataset = simulate(&Scenario::paper(), 1).unwrap().dataset;
    let error = 0.005;
    for ball in &mut dataset.artefacts.balls {
        ball.radius += error;
    }
    let options = CalibrationOptions::default();
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    let record = parcal_report::record::of_run(&run, &dataset);
    let test = run.global_test.unwrap();
    let sensitivity = &record.diagnostics.as_ref().unwrap().systematic_sensitivity;
    let radius = sensitivity
        .iter()
        .find(|s| s.effect == "ball radius")
        .unwrap();
    let truth = TrueMachine::of(&dataset).unwrap().unwrap();
    let maps = before_after(Some(&truth), &run, &MapGrid::paper()).unwrap();
    let after = maps.after.unwrap();
    let (true_rms, predicted_rms) = (
        after.true_error.unwrap().registered_summary().rms,
        after.predicted.registered_summary().rms,
    );
    println!(
        "+{:.0} um on every radius: variance factor {:.3} in [{:.3}, {:.3}], verdict {}; true registered RMS {:.1} um, predicted {:.1} um; radius MDB {:.1} um, its registered map RMS {:.1} um, max {:.1} um",
        error * 1e3,
        test.variance_factor,
        test.interval.0,
        test.interval.1,
        record.verdict,
        true_rms * 1e3,
        predicted_rms * 1e3,
        radius.mdb * 1e3,
        radius.map_rms_um.unwrap(),
        radius.map_max_um.unwrap()
    );
    assert_eq!(record.verdict, "accepted", "{:?}", record.reasons);
    assert!(radius.mdb > error);
    let sentence = record
        .reasons
        .iter()
        .find(|r| r.starts_with("an undetectable common ball radius error of up to"))
        .unwrap();
    assert!(sentence.contains("to the registered error"), "{sentence}");
}
