//! The accuracy maps of the paper scenario against the figures an
//! independent implementation measured (reference/paper-seed1/README.md,
//! um, on the paper's grid, against the true geometry of table 2):
//!
//! | case | true absolute RMS | true registered RMS | predicted absolute RMS |
//! |---|---|---|---|
//! | before calibration (design) | 4073 | 97.3 | 584 (paper prior) |
//! | IV, propagated prior | 3165 | 16.4 | 2891 |
//! | III, paper prior | 4051 | 17.1 | 40.3 |
//!
//! parcal maps the targets with the design's canonical transforms (what a
//! user has) and agrees within 0.2 % (absolute) and 3 % (registered). The
//! reference mapped the targets of its TRUE maps with the truth's own
//! transforms (and its predicted maps with the design's); with that mapping
//! parcal reproduces every printed figure to its last digit.

use parcal_accuracy::{
    AccuracyMap, CanonicalTargets, MapGrid, ParamCovariance, predicted, true_error, true_error_at,
};
use parcal_kinematics::{Params, paper, params};

/// Relative deviation of `value` from `reference`.
fn deviation(value: f64, reference: f64) -> f64 {
    (value - reference).abs() / reference
}

/// Reads a fixture: the parameter values, then the covariance.
fn fixture(name: &str) -> (Params, ParamCovariance) {
    let path = format!("{}/fixtures/{name}.txt", env!("CARGO_MANIFEST_DIR"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let rows: Vec<Vec<f64>> = text
        .lines()
        .filter(|line| !line.starts_with('#'))
        .map(|line| {
            line.split_whitespace()
                .map(|v| v.parse().unwrap())
                .collect()
        })
        .collect();
    assert_eq!(rows.len(), 34, "{path}");
    let values = Params::from_column_slice(&rows[0]);
    let covariance = ParamCovariance::from_fn(|r, c| rows[1 + r][c]);
    (values, covariance)
}

/// One case of the table: the model, its covariance and the reference
/// figures (mm): true absolute, true registered, predicted absolute RMS.
struct Case {
    name: &'static str,
    model: Params,
    covariance: ParamCovariance,
    reference: [f64; 3],
}

fn cases() -> Vec<Case> {
    let design = params::to_params(&paper::design().canonicalize().unwrap().geometry);
    let (iv, iv_covariance) = fixture("reference-IV-propagated");
    let (iii, iii_covariance) = fixture("reference-III-paper");
    vec![
        Case {
            name: "before calibration (design, paper prior)",
            model: design,
            covariance: ParamCovariance::identity() * 0.1f64.powi(2),
            reference: [4.073, 0.0973, 0.584],
        },
        Case {
            name: "IV, propagated prior",
            model: iv,
            covariance: iv_covariance,
            reference: [3.165, 0.0164, 2.891],
        },
        Case {
            name: "III, paper prior",
            model: iii,
            covariance: iii_covariance,
            reference: [4.051, 0.0171, 0.0403],
        },
    ]
}

fn check(case: &str, what: &str, value: f64, reference: f64, tolerance: f64) {
    let off = deviation(value, reference);
    println!(
        "{case}: {what} RMS {:.1} um (reference {:.1} um, {:+.2} %)",
        1e3 * value,
        1e3 * reference,
        100.0 * (value - reference) / reference
    );
    assert!(
        off < tolerance,
        "{case}: {what} off by {:.2} %",
        100.0 * off
    );
}

#[test]
fn maps_with_the_design_transforms_agree_with_the_reference() {
    let design = paper::design();
    let truth = paper::truth().canonicalize().unwrap().geometry;
    let grid = MapGrid::paper();
    for case in cases() {
        let prediction = predicted(&design, &case.model, &case.covariance, &grid).unwrap();
        let actual = true_error(&design, &case.model, &truth, &grid).unwrap();
        println!("{}: predicted {prediction}", case.name);
        println!("{}: true      {actual}", case.name);
        let [true_absolute, true_registered, predicted_absolute] = case.reference;
        let absolute = actual.absolute_summary().rms;
        check(case.name, "true absolute", absolute, true_absolute, 0.01);
        let registered = actual.registered_summary().rms;
        check(
            case.name,
            "true registered",
            registered,
            true_registered,
            0.04,
        );
        let rms = prediction.absolute_summary().rms;
        check(
            case.name,
            "predicted absolute",
            rms,
            predicted_absolute,
            0.01,
        );
        registered_never_exceeds_absolute(&prediction);
    }
}

#[test]
fn true_maps_with_the_truths_own_transforms_reproduce_the_reference() {
    let grid = MapGrid::paper();
    let truth = paper::truth();
    let truth_canonical = truth.canonicalize().unwrap().geometry;
    let targets = CanonicalTargets::new(&truth, &grid).unwrap();
    for case in cases() {
        let actual = true_error_at(&targets, &case.model, &truth_canonical).unwrap();
        println!("{} (truth-mapped targets): true {actual}", case.name);
        let [true_absolute, true_registered, _] = case.reference;
        // The reference prints 4 significant digits (3 for 16.4, 17.1).
        let absolute = actual.absolute_summary().rms;
        check(case.name, "true absolute", absolute, true_absolute, 0.0005);
        let registered = actual.registered_summary().rms;
        check(
            case.name,
            "true registered",
            registered,
            true_registered,
            0.004,
        );
    }
}

fn registered_never_exceeds_absolute(map: &AccuracyMap) {
    for (a, r) in map.absolute.iter().zip(&map.registered) {
        assert!(r <= a, "registered {r} > absolute {a}");
    }
}
