//! External reliability on the accuracy map against brute force: the
//! reading of the least reliable contact moved so that its row's whitened
//! residual changes by `±1`, the dataset calibrated again, and the
//! parameter shift and its registered map compared with calibration.json's
//! `diagnostics.external_reliability`.

use std::path::Path;

use nalgebra::{Matrix3x6, Vector3, Vector6};
use parcal_accuracy::{MapGrid, parameter_error};
use parcal_calibrate::observation::ObservationId;
use parcal_calibrate::{CalibrationOptions, WeightModel, calibrate};
use parcal_dataset::Dataset;
use parcal_kinematics::{ForwardOptions, Params, Vec3, forward, forward_from_home, params};

fn paper_seed1() -> Dataset {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/paper-seed1");
    Dataset::read(&dir).unwrap()
}

/// The tool tip of `geometry` at actuator values `q` and `dT/dq` by
/// central differences (step 1e-6 mm: the tip is smooth in `q`).
fn tip_and_derivative(
    geometry: &parcal_kinematics::Geometry,
    q: &[f64; 6],
) -> (Vec3, Matrix3x6<f64>) {
    let options = ForwardOptions::default();
    let pose = forward_from_home(geometry, q, &options).unwrap().pose;
    let tip =
        |q: &[f64; 6]| geometry.tool_tip(&forward(geometry, q, &pose, &options).unwrap().pose);
    let h = 1e-6;
    let mut d = Matrix3x6::zeros();
    for l in 0..6 {
        let (mut plus, mut minus) = (*q, *q);
        plus[l] += h;
        minus[l] -= h;
        d.set_column(l, &((tip(&plus) - tip(&minus)) / (2.0 * h)));
    }
    (tip(q), d)
}

/// With diagonal weights a contact's rows are its coordinates
/// `(C + r u − T) / σ`, `σ² = σ_a² + σ_t²` (the radius per ball): moving
/// the tip by `−δσ` along row `j`'s axis adds `δ` to that row alone. The
/// readings that do it are `Δq = J_q⁺ ΔT` (first order). The central
/// difference over `δ = ±1` leaves `O(δ²)` and the part of the solution's
/// derivative that Gauss-Newton's normal matrix leaves out (the residuals
/// times the observation's curvature): under 2 % here, as in the solver's
/// test (`crates/solver/tests/influence.rs`).
#[test]
fn an_mdb_added_to_the_least_reliable_reading_moves_parameters_and_map_as_predicted() {
    let dataset = paper_seed1();
    let options = CalibrationOptions {
        weighting: WeightModel::Diagonal,
        ..CalibrationOptions::default()
    };
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert!(run.converged());
    let record = parcal_report::record::of_run(&run, &dataset);
    let stored = &record.diagnostics.as_ref().unwrap().external_reliability;
    let external = &run.reliability.as_ref().unwrap().external;
    assert_eq!(stored.len(), 5, "the five least reliable observations");
    let first = &external[0];
    let ObservationId::Contact(row) = first.observation else {
        panic!("a ball-touch run's least reliable observation is a contact")
    };
    assert_eq!(stored[0].observation.line, Some(row as u64 + 2));
    assert_eq!(stored[0].row, first.row);
    // Largest λ first, and the first is the run's least reliable.
    assert!(
        stored
            .windows(2)
            .all(|w| w[0].bias_to_noise >= w[1].bias_to_noise)
    );
    let (least, lambda) = run.reliability.as_ref().unwrap().least_reliable(1)[0];
    assert_eq!(least, first.observation);
    assert!((lambda - stored[0].bias_to_noise).abs() < 1e-9);

    let repeatability = &dataset.machine.repeatability;
    let sigma = (repeatability.actuator.powi(2) + repeatability.tool.powi(2)).sqrt();
    let geometry = params::from_params(&run.params);
    let q = dataset.measurements.q[row];
    let (_, d_q) = tip_and_derivative(&geometry, &q);
    let moved = |delta: f64| -> Params {
        let mut tip_shift = Vector3::zeros();
        tip_shift[first.row] = -delta * sigma;
        let pseudo_inverse = d_q.transpose() * (d_q * d_q.transpose()).try_inverse().unwrap();
        let dq: Vector6<f64> = pseudo_inverse * tip_shift;
        let mut data = dataset.clone();
        for l in 0..6 {
            data.measurements.q[row][l] += dq[l];
        }
        let again = calibrate(&data, &options, &mut |_| {}).unwrap();
        assert!(again.converged());
        again.params - run.params
    };
    let central = (moved(1.0) - moved(-1.0)) / 2.0;
    let mdb = first.minimal_detectable_bias;
    let predicted = Params::from_fn(|k, _| first.global_shift[k] / mdb);
    // In the parameters' own noise (posterior covariance of the 33).
    let information = run.covariance.unwrap().try_inverse().unwrap();
    let sigmas = |v: &Params| v.dot(&(information * v)).sqrt();
    let diff = sigmas(&(central - predicted)) / sigmas(&predicted);
    println!(
        "row {} of measurements.csv line {}: shift per row sigma {:.4} parameter sigmas, the re-calibration's differs by {:.1}%",
        first.row,
        row + 2,
        sigmas(&predicted),
        100.0 * diff
    );
    assert!(diff < 0.02, "{diff}");

    // The registered map of one MDB's shift, brute force against stored.
    let map = parameter_error(
        &run.design,
        &run.params,
        &(central * mdb),
        &MapGrid::paper(),
    )
    .unwrap()
    .registered_summary();
    let (rms, max) = (stored[0].map_rms_um.unwrap(), stored[0].map_max_um.unwrap());
    println!(
        "map: RMS {rms:.3} um stored, {:.3} um brute force; max {max:.3} um, {:.3} um",
        1e3 * map.rms,
        1e3 * map.max
    );
    assert!((1e3 * map.rms - rms).abs() < 0.02 * rms);
    assert!((1e3 * map.max - max).abs() < 0.02 * max);
}

/// The sensitivity to a common radius error against brute force on the
/// paper scenario (seed 1): every ball's radius entered one minimal
/// detectable bias too large, and too small, the dataset calibrated
/// again; the registered map of the parameters' central difference
/// matches calibration.json's `systematic_sensitivity` within 2 % in RMS
/// and max (the central difference removes the effect's second order; the
/// parameters' own check is `crates/calibrate/tests/verdicts.rs`), and
/// the reasons and the page state it.
#[test]
fn an_undetected_common_radius_error_moves_the_map_as_predicted() {
    let dataset = paper_seed1();
    let options = CalibrationOptions::default();
    let run = calibrate(&dataset, &options, &mut |_| {}).unwrap();
    assert!(run.converged());
    let record = parcal_report::record::of_run(&run, &dataset);
    let stored = &record.diagnostics.as_ref().unwrap().systematic_sensitivity;
    assert_eq!(stored.len(), 1, "the radius alone without distances");
    let radius = &stored[0];
    assert_eq!(
        (radius.effect.as_str(), radius.unit.as_str()),
        ("ball radius", "mm")
    );
    let shifted = |t: f64| -> Params {
        let mut data = dataset.clone();
        for ball in &mut data.artefacts.balls {
            ball.radius += t;
        }
        let again = calibrate(&data, &options, &mut |_| {}).unwrap();
        assert!(again.converged());
        again.params
    };
    let central = (shifted(radius.mdb) - shifted(-radius.mdb)) / 2.0;
    let map = parameter_error(&run.design, &run.params, &central, &MapGrid::paper())
        .unwrap()
        .registered_summary();
    let (rms, max) = (radius.map_rms_um.unwrap(), radius.map_max_um.unwrap());
    println!(
        "radius MDB {:.2} um: map RMS {rms:.2} um stored, {:.2} um brute force; max {max:.2} um, {:.2} um",
        radius.mdb * 1e3,
        1e3 * map.rms,
        1e3 * map.max
    );
    assert!((1e3 * map.rms - rms).abs() < 0.02 * rms);
    assert!((1e3 * map.max - max).abs() < 0.02 * max);
    let sentence = format!(
        "an undetectable common ball radius error of up to {:.1} um",
        radius.mdb * 1e3
    );
    assert!(
        record.reasons.iter().any(|r| r.starts_with(&sentence)),
        "{:?}",
        record.reasons
    );
}
