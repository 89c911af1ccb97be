//! calibration.json's diagnostics against the run they summarise, and the
//! report of one calibration rendered from them.

use parcal_calibrate::observation::ObservationId;
use std::path::Path;

use parcal_calibrate::{CalibrationOptions, calibrate};
use parcal_dataset::Dataset;
use parcal_report::calibration_report::{
    Format, Subject, global_sentence, predicted_accuracy, render, tests_sentence,
};
use parcal_report::diagnostics::LISTED;

fn paper_seed1() -> Dataset {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/paper-seed1");
    Dataset::read(&dir).unwrap()
}

#[test]
fn the_diagnostics_summarise_every_observation_s_test() {
    let dataset = paper_seed1();
    let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {}).unwrap();
    let record = parcal_report::record::of_run(&run, &dataset);
    let reliability = run.reliability.as_ref().unwrap();
    let d = record.diagnostics.as_ref().unwrap();
    let t = d.observations.as_ref().unwrap();

    // Every contact tested; the redundancy numbers of the contacts and of
    // the priors sum to the global test's redundancy (rounding of the
    // Schur levels, far below the 0.01 of a printed redundancy).
    assert_eq!(t.tested, dataset.measurements.len());
    let priors = d
        .variance_components
        .iter()
        .find(|c| c.group == "priors")
        .unwrap();
    let global = record.global_test.as_ref().unwrap().redundancy as f64;
    assert!(
        (t.redundancy + priors.redundancy - global).abs() < 1e-6,
        "{} + {} against {global}",
        t.redundancy,
        priors.redundancy
    );
    // The histograms count every row (each is checked) and every contact.
    assert_eq!(
        t.normalised_histogram.total() as usize,
        run.residual_rows + run.distances_used
    );
    assert_eq!(
        t.redundancy_histogram.total() as usize,
        dataset.measurements.len()
    );
    // The largest |w| first, as the run's worst contact, a bounded list.
    let worst = reliability.worst().unwrap();
    let ObservationId::Contact(row) = worst.observation() else {
        panic!("the worst observation of a ball-touch run is a contact")
    };
    assert_eq!(t.largest[0].line, Some(row as u64 + 2));
    assert_eq!(t.largest[0].normalised_residual, worst.normalised());
    assert!(t.largest.len() <= LISTED);
    let w = |k: usize| t.largest[k].normalised_residual.unwrap().abs();
    assert!((1..t.largest.len()).all(|k| w(k - 1) >= w(k)));
    // The uncontrolled, least redundancy first, counted as the run counts them.
    assert_eq!(t.uncontrolled, reliability.uncontrolled().count());
    assert!(
        t.least_controlled
            .iter()
            .all(|o| o.redundancy < t.uncontrolled_below)
    );
    // Every parameter attributed.
    assert_eq!(d.determined_by.len(), 33);
    assert_eq!(d.prior_sigma.len(), 33);

    // The file keeps them: written and read back alike.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("calibration.json");
    record.write(&path).unwrap();
    let read = parcal_dataset::Calibration::read(&path).unwrap();
    assert_eq!(read.diagnostics, record.diagnostics);

    // The page states them.
    let subject = Subject {
        calibration: &read,
        file: "calibration.json",
        accuracy: predicted_accuracy(&read, None),
    };
    let html = render(&subject, Format::Html).unwrap();
    let escaped = |s: &str| parcal_report::calibration_report::html::escape(s);
    assert!(html.contains(&escaped(&global_sentence(
        read.global_test.as_ref().unwrap()
    ))));
    assert!(html.contains(&escaped(&tests_sentence(t))));
    let registered = subject
        .accuracy
        .as_ref()
        .unwrap()
        .predicted
        .registered_summary();
    assert!(html.contains(&format!("registered RMS {:.2} µm", registered.rms * 1e3)));
}

/// Every ball's radius entered 20 um too small: calibration.json keeps the
/// test of a common radius error as the run made it, a reason names the
/// radius as the explanation, and the page has the systematic errors'
/// section with the test's numbers, and that of the sensitivity with its
/// sentence.
#[test]
fn a_common_radius_error_is_named_in_the_record_and_on_the_page() {
    let mut dataset = paper_seed1();
    for ball in &mut dataset.artefacts.balls {
        ball.radius -= 0.02;
    }
    let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {}).unwrap();
    let record = parcal_report::record::of_run(&run, &dataset);
    assert_eq!(record.verdict, "rejected");
    let test = &run.reliability.as_ref().unwrap().systematic[0];
    let kept = &record.diagnostics.as_ref().unwrap().systematic_tests;
    assert_eq!(
        kept.len(),
        run.reliability.as_ref().unwrap().systematic.len()
    );
    assert_eq!(kept[0].effect, "ball radius");
    assert_eq!(
        (kept[0].estimate, kept[0].sigma),
        (test.estimate, test.sigma)
    );
    assert_eq!(kept[0].outcome_without, "consistent");
    let sentence =
        parcal_report::sentences::systematic_sentence(test, run.global_test.as_ref().unwrap())
            .unwrap();
    assert!(sentence.starts_with("a common ball radius error explains the misfit"));
    assert!(record.reasons.contains(&sentence), "{:?}", record.reasons);

    let subject = Subject {
        calibration: &record,
        file: "calibration.json",
        accuracy: predicted_accuracy(&record, None),
    };
    let html = render(&subject, Format::Html).unwrap();
    assert!(html.contains("Systematic errors"));
    assert!(html.contains(&format!("{:+.3e}", test.estimate)));
    assert!(html.contains("explained by a common error of the entered data: ball radius"));
    // The verdict line says so too.
    assert!(html.contains("explained by a common ball radius error (Systematic errors, below)"));
    // And the sensitivity, with its sentence.
    let sensitivity = &record.diagnostics.as_ref().unwrap().systematic_sensitivity[0];
    assert!(html.contains("Sensitivity to systematic errors"));
    assert!(html.contains(&parcal_report::sentences::sensitivity_sentence(sensitivity)));
}

/// One reading 5 mm off, calibrated with the Cauchy loss: the page lists
/// the down-weighted observation with its line and weight.
#[test]
fn the_page_lists_the_down_weighted_observations() {
    let mut dataset = paper_seed1();
    let row = 38;
    dataset.measurements.q[row][2] += 5.0;
    let options = CalibrationOptions {
        loss: parcal_calibrate::Loss::Cauchy {
            k: parcal_calibrate::CAUCHY_K,
        },
        ..CalibrationOptions::default()
    };
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    let record = parcal_report::record::of_run(&run, &dataset);
    let listed = &record.down_weighted_observations;
    let blunder = listed
        .iter()
        .find(|d| d.line == Some(row as u64 + 2))
        .expect("the blunder down-weighted");
    let subject = Subject {
        calibration: &record,
        file: "calibration.json",
        accuracy: predicted_accuracy(&record, None),
    };
    let md = render(&subject, Format::Markdown).unwrap();
    assert!(md.contains("## Down-weighted observations"), "{md}");
    assert!(md.contains(&format!(
        "| measurements.csv | {} | {:.2e} |",
        row + 2,
        blunder.weight
    )));
}
