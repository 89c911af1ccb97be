//! calibration.json checked as an input: a file whose verdict, geometry,
//! covariance, numbers, texts or lists cannot be a calibration's is
//! refused with the file and the field, and parcal's own records read back.

use crate::common;

use std::fs;
use std::path::{Path, PathBuf};
use std::time::Instant;

use common::*;
use parcal_dataset::*;
use serde_json::{Value, json};

/// `calibration` written to a new directory; the directory and the file.
fn written(calibration: &Calibration) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(CALIBRATION_FILE);
    calibration.write(&path).unwrap();
    (dir, path)
}

/// The reader's message on calibration.json of `dir` once `edit`ed.
fn refused_after(dir: &Path, edit: impl FnOnce(&mut Value)) -> String {
    edit_json(dir, CALIBRATION_FILE, edit);
    match Calibration::read(&dir.join(CALIBRATION_FILE)) {
        Ok(_) => panic!("the edited calibration.json should be refused"),
        Err(e) => e.to_string(),
    }
}

/// Asserts that `calibration`, written, then `edit`ed, is refused with a
/// message naming calibration.json and saying `expected`.
fn assert_refused(calibration: &Calibration, edit: impl FnOnce(&mut Value), expected: &str) {
    let (dir, _) = written(calibration);
    let err = refused_after(dir.path(), edit);
    assert_error(&err, dir.path(), CALIBRATION_FILE, expected);
}

/// [`calibration`] rejected by its global test: `s₀²` above the interval.
fn rejected() -> Calibration {
    let mut c = calibration();
    let test = c.global_test.as_mut().unwrap();
    test.cost = 300.0;
    test.variance_factor = 300.0 / 190.0;
    test.outcome = "too large".into();
    c.verdict = "rejected".into();
    c.reasons.push(
        "global test failed: the data do not fit their stated noise: a-posteriori variance factor 1.579".into(),
    );
    c
}

#[test]
fn an_accepted_verdict_typed_into_a_rejected_file_is_refused() {
    let (_dir, path) = written(&rejected());
    assert!(Calibration::read(&path).unwrap().is_rejected());
    assert_refused(
        &rejected(),
        |v| v["verdict"] = "accepted".into(),
        "field verdict: \"accepted\", but the global test failed (its outcome is \"too large\"): the calibration is rejected",
    );
    // The outcome edited too: the variance factor still says it.
    assert_refused(
        &rejected(),
        |v| {
            v["verdict"] = "accepted".into();
            v["global_test"]["outcome"] = "consistent".into();
        },
        "field global_test.outcome: \"consistent\", but the variance factor 1.5789473684210527 against the interval [0.8, 1.2] gives \"too large\"",
    );
    // The global test removed: the reasons still say it; an empty verdict
    // (used as accepted) is no better.
    assert_refused(
        &rejected(),
        |v| {
            v.as_object_mut().unwrap().remove("global_test");
            v["verdict"] = "".into();
        },
        "field verdict: no verdict (used as accepted), but reasons[1] says a test failed: \"global test failed:",
    );
    // A run that did not converge is never accepted.
    assert_refused(
        &calibration(),
        |v| {
            v["converged"] = false.into();
            v["covariance"] = json!([]);
            v["parameters"]["sigma"] = json!([0.0, 0.0, 0.0]);
        },
        "field verdict: \"accepted\", but the run did not converge (converged is false)",
    );
    assert_refused(
        &calibration(),
        |v| v["verdict"] = "ACCEPTED".into(),
        "field verdict: expected \"accepted\" or \"rejected\", found \"ACCEPTED\"",
    );
}

#[test]
fn a_canonical_geometry_other_than_the_parameters_is_refused() {
    // The reference calibration of an independent tool: 33 parameters.
    let reference = reference_dir().join("reference-III-paper.json");
    let dir = tempfile::tempdir().unwrap();
    fs::copy(&reference, dir.path().join(CALIBRATION_FILE)).unwrap();
    let err = refused_after(dir.path(), |v| {
        let l1 = &mut v["canonical"]["leg_lengths"][0];
        *l1 = (l1.as_f64().unwrap() + 10.0).into();
    });
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field canonical.leg_lengths[0]: 244.93714020233978 disagrees with parameters.values[12], l_1 = 234.93714020233978",
    );
    fs::copy(&reference, dir.path().join(CALIBRATION_FILE)).unwrap();
    let err = refused_after(dir.path(), |v| {
        v["canonical"]["base_joints"][1][0] = 1e-3.into()
    });
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field canonical.base_joints[1][0]: must be 0 in the canonical frames",
    );
    fs::copy(&reference, dir.path().join(CALIBRATION_FILE)).unwrap();
    let err = refused_after(dir.path(), |v| {
        let tool = &mut v["parameters"]["values"][32];
        *tool = (tool.as_f64().unwrap() * (1.0 + 1e-7)).into();
    });
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field canonical.tool[2]: ",
    );
}

#[test]
fn a_covariance_that_is_not_one_is_refused() {
    let c = calibration();
    assert_refused(
        &c,
        |v| v["covariance"] = json!([[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]),
        "field covariance[0][0]: a variance must be positive, found 0 (parameter \"y_b2\")",
    );
    // Correlation 0.005 / (0.06 * 0.07) = 1.19 between the first two.
    assert_refused(
        &c,
        |v| {
            v["covariance"][0][1] = 0.005.into();
            v["covariance"][1][0] = 0.005.into();
        },
        "field covariance[1]: the covariance is not positive semi-definite: its first 2 rows and columns (to parameter \"x_b3\")",
    );
    assert_refused(
        &c,
        |v| v["covariance"][0][1] = 2e-4.into(),
        "field covariance[0][1]: 0.0002 differs from covariance[1][0] = 0.0001: a covariance is symmetric",
    );
    assert_refused(
        &c,
        |v| v["parameters"]["sigma"][1] = 0.5.into(),
        "field parameters.sigma[1]: 0.5 is not the square root of covariance[1][1] = 0.0049 (0.0",
    );
    assert_refused(
        &c,
        |v| v["covariance"] = json!([]),
        "field parameters.sigma[0]: 0.06 without a covariance",
    );
}

#[test]
fn a_run_that_did_not_converge_has_no_posterior_accuracy() {
    let mut c = calibration();
    c.converged = false;
    c.status = "iteration limit reached without convergence".into();
    c.verdict = "rejected".into();
    let mut record = c.clone();
    assert_error(
        &record
            .write(&PathBuf::from("x").join(CALIBRATION_FILE))
            .unwrap_err()
            .to_string(),
        Path::new("x"),
        CALIBRATION_FILE,
        "field covariance: the run did not converge (converged is false): it has no posterior covariance",
    );
    // Without the covariance, no sigma either: what parcal writes reads.
    record.covariance.clear();
    record.parameters.sigma = vec![0.0; 3];
    let (dir, path) = written(&Calibration {
        ball_centres: record
            .ball_centres
            .iter()
            .map(|(id, e)| {
                let none = CentreEstimate {
                    sigma: [0.0; 3],
                    radius_sigma: Some(0.0),
                    ..*e
                };
                (id.clone(), none)
            })
            .collect(),
        ..record.clone()
    });
    assert!(!Calibration::read(&path).unwrap().converged);
    let err = refused_after(dir.path(), |v| {
        v["ball_centres"]["b01"]["sigma"][2] = 0.02.into()
    });
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field ball_centres.b01: without a covariance (none was computed, or the run did not converge) there is no posterior sigma",
    );
}

#[test]
fn numbers_out_of_their_domain_are_refused() {
    assert_refused(
        &calibration(),
        |v| v["parameters"]["sigma"][0] = (-0.06).into(),
        "field parameters.sigma[0]: must not be negative, found -0.06",
    );
    assert_refused(
        &calibration(),
        |v| v["ball_centres"]["b01"]["radius"] = (-5.0).into(),
        "field ball_centres.b01.radius: must be positive, found -5",
    );

    let machine = |scale: f64| {
        let mut c = calibration();
        c.machine = Some(CalibratedMachine {
            geometry: c.canonical.clone(),
            actuator: Actuator {
                unit: "rev".into(),
                scale: [71.0, 71.0, 71.0, 71.0, 71.0, scale],
                scale_sigma: Some([0.0; 6]),
            },
        });
        c.write(&tempfile::tempdir().unwrap().path().join(CALIBRATION_FILE))
            .map_err(|e| e.to_string())
    };
    assert!(machine(71.5).is_ok());
    for (scale, says) in [
        (1e-300, "a scale of 1e-300 mm per unit is implausible"),
        (-1.0, "must be positive, found -1"),
    ] {
        let err = machine(scale).unwrap_err();
        assert!(
            err.contains(&format!("field machine.actuator.scale[5]: {says}")),
            "{err}"
        );
        // The design's scale, as machine.json's.
        assert_refused(
            &calibration(),
            |v| v["design"]["actuator"] = json!({"unit": "rev", "scale": [1, 1, 1, 1, 1, scale]}),
            &format!("field design.actuator.scale[5]: {says}"),
        );
    }
}

#[test]
fn texts_with_control_characters_are_refused() {
    assert_refused(
        &calibration(),
        |v| v["reasons"][0] = "ok\u{1b}[2J".into(),
        "field reasons[0]: \"ok\\u{1b}[2J\" has a control character",
    );
    assert_refused(
        &calibration(),
        |v| v["options"]["sim"] = json!(["IV\r"]),
        "field options.sim[0]: \"IV\\r\" has a control character",
    );
    let dir = tempfile::tempdir().unwrap();
    let mut c = calibration();
    c.parameters.names[2] = "y_b3\u{7}".into();
    assert!(
        c.write(&dir.path().join("other.json"))
            .unwrap_err()
            .to_string()
            .contains("field parameters.names[2]: \"y_b3\\u{7}\" has a control character")
    );
}

#[test]
fn seven_million_diagnostic_entries_are_refused_while_parsing() {
    let (dir, path) = written(&calibration());
    let text = fs::read_to_string(&path).unwrap();
    let histogram = "\"counts\": [";
    let at = text.find(histogram).unwrap() + histogram.len();
    let inflated = format!("{}{}{}", &text[..at], "0, ".repeat(7_000_000), &text[at..]);
    fs::write(&path, inflated).unwrap();
    let started = Instant::now();
    let err = Calibration::read(&path).unwrap_err().to_string();
    eprintln!("refused in {:?}", started.elapsed());
    assert_error(
        &err,
        dir.path(),
        CALIBRATION_FILE,
        "field diagnostics.observations.normalised_histogram.counts: expected at most 1000 elements, found more",
    );
    for (field, bound) in [
        ("iterations", MAX_ITERATIONS),
        ("reasons", MAX_SENTENCES),
        ("removed_observations", MAX_LISTED),
    ] {
        assert_refused(
            &calibration(),
            |v| {
                let first = v[field][0].clone();
                v[field] = Value::Array(vec![first; bound + 1]);
            },
            &format!("field {field}: expected at most {bound} elements, found more"),
        );
    }
}
