//! The tests' simulated machines and held-out observations of them, and
//! the checks of predicted rows the modules' tests share: derivatives
//! against central differences, noise against the rows' `χ²`.

use nalgebra::{DVector, Isometry3, Vector3};
use parcal_kinematics::delta::LinearDelta;
use parcal_kinematics::mechanism::{Mechanism, design, prior_sigma};
use parcal_observe::mechanism::{Actuation, BallTouch, TrackerPoint};

use super::super::data::Observations;
use super::predict::predict;
use super::rows::PredictedRows;

/// A typical delta, its configured (design) parameters and a true
/// machine a few tenths away.
pub(super) fn delta() -> (LinearDelta, DVector<f64>, DVector<f64>) {
    let delta = LinearDelta::typical();
    let configured = design(&delta);
    let mut truth = configured.clone();
    for (k, value) in truth.iter_mut().enumerate() {
        *value += 0.3 * ((k as f64) * 1.3).sin();
    }
    (delta, configured, truth)
}

/// `K` touches of a ball of centre `centre` by the delta of true
/// parameters `truth` whose controller runs `configured`: the tool
/// point at `centre + (radius + ε_k) u_k`, `u_k` on the upper cap
/// (polar angles up to 70°, a golden-angle spiral), `ε_k` from
/// `error`, the commanded position the controller reports for it.
pub(super) fn touches(
    (delta, configured, truth): &(LinearDelta, DVector<f64>, DVector<f64>),
    centre: Vector3<f64>,
    radius: f64,
    k: usize,
    mut error: impl FnMut() -> f64,
) -> Vec<BallTouch> {
    let lowest = 70f64.to_radians().cos();
    (0..k)
        .map(|i| {
            let polar = (1.0 - (1.0 - lowest) * (i as f64 + 0.5) / k as f64).acos();
            let azimuth = 2.399_963 * i as f64;
            let u = Vector3::new(
                polar.sin() * azimuth.cos(),
                polar.sin() * azimuth.sin(),
                polar.cos(),
            );
            let x = centre + (radius + error()) * u;
            let readings = delta.inverse(truth.as_slice(), x.as_slice()).unwrap();
            let commanded = delta
                .forward(configured.as_slice(), readings.as_slice(), x.as_slice())
                .unwrap();
            BallTouch::new(
                0,
                Actuation::Commanded([commanded[0], commanded[1], commanded[2]]),
                0.01,
            )
        })
        .collect()
}

/// The rows of ball 0 of `observations` at `params`.
pub(super) fn ball_rows(
    machine: &(LinearDelta, DVector<f64>, DVector<f64>),
    params: &DVector<f64>,
    observations: &Observations,
    reference: Option<usize>,
) -> PredictedRows {
    let (delta, configured, _) = machine;
    let mut predicted = predict(
        delta,
        params,
        configured.as_slice(),
        observations,
        reference,
    )
    .unwrap();
    assert_eq!(predicted.len(), 1);
    predicted.remove(0)
}

/// `G = dr'/dθ` of the rows `at` the true parameters against central
/// differences of the rows of `observations` over the parameters,
/// steps of 1e-4 of their prior sigmas, to 1e-6 of `G`'s largest.
pub(super) fn assert_derivatives_match_differences(
    machine: &(LinearDelta, DVector<f64>, DVector<f64>),
    observations: &Observations,
    reference: Option<usize>,
    at: &PredictedRows,
) {
    let truth = &machine.2;
    let steps = prior_sigma(&machine.0) * 1e-4;
    for j in 0..truth.len() {
        let (mut plus, mut minus) = (truth.clone(), truth.clone());
        plus[j] += steps[j];
        minus[j] -= steps[j];
        let column = (ball_rows(machine, &plus, observations, reference).residuals
            - ball_rows(machine, &minus, observations, reference).residuals)
            / (2.0 * steps[j]);
        let error = (&column - at.d_global.column(j)).amax();
        assert!(
            error < 1e-6 * at.d_global.amax(),
            "column {j}: {error:e} against {:e}",
            at.d_global.amax()
        );
    }
}

/// `T/n = Σ r'ᵀ D⁻¹ r' / n` over the predicted rows of each of `sets`
/// (`n` rows in all) at the true machine: within 4 standard errors
/// (`4 √(2/n)`) of 1, the mean of `χ²(n) / n`.
pub(super) fn assert_rows_have_their_stated_noise(
    what: &str,
    machine: &(LinearDelta, DVector<f64>, DVector<f64>),
    reference: Option<usize>,
    sets: impl Iterator<Item = Observations>,
) {
    let (mut statistic, mut rows) = (0.0, 0);
    for observations in sets {
        let predicted = ball_rows(machine, &machine.2, &observations, reference);
        let noise = predicted.noise.clone().cholesky().unwrap();
        statistic += predicted.residuals.dot(&noise.solve(&predicted.residuals));
        rows += predicted.residuals.len();
    }
    let ratio = statistic / rows as f64;
    let bound = 4.0 * (2.0 / rows as f64).sqrt();
    eprintln!("{what}: T/n = {ratio:.4} over {rows} rows (1 ± {bound:.4})");
    assert!(
        (ratio - 1.0).abs() < bound,
        "T/n = {ratio:.4}, bound {bound:.4}"
    );
}

/// A tracker's frame far from the mechanism's, turned about all axes.
pub(super) fn far_frame() -> Isometry3<f64> {
    Isometry3::new(
        Vector3::new(900.0, -400.0, 120.0),
        Vector3::new(0.1, -0.05, 2.0),
    )
}

/// The frame of a tracker's placement `draw` of a simulation: on a
/// circle of 1 km about the mechanism, turned by `draw` radians.
pub(super) fn placement(draw: usize) -> Isometry3<f64> {
    let turn = draw as f64;
    Isometry3::new(
        Vector3::new(1000.0 * turn.cos(), 1000.0 * turn.sin(), 50.0),
        Vector3::new(0.0, 0.1, turn),
    )
}

/// One tracker's `k` points at commanded positions, measured by the
/// delta of true parameters `truth` through the frame `frame`, each
/// coordinate off by `error()`, of the correlated weight below.
pub(super) fn tracked(
    (delta, configured, truth): &(LinearDelta, DVector<f64>, DVector<f64>),
    frame: &Isometry3<f64>,
    k: usize,
    mut error: impl FnMut() -> f64,
) -> Observations {
    let covariance = nalgebra::Matrix3::new(1e-4, 2e-5, 0.0, 2e-5, 1.5e-4, -3e-5, 0.0, -3e-5, 4e-4);
    let weight = parcal_observe::CoordinateWhitening::from_covariance(&covariance).unwrap();
    let factor = covariance.cholesky().unwrap().l();
    let tracker_points = (0..k)
        .map(|j| {
            let t = j as f64;
            let at = Actuation::Commanded([
                70.0 * (1.9 * t).cos(),
                60.0 * (1.3 * t).sin(),
                15.0 + 11.0 * t,
            ]);
            let reached = at
                .tool_point(delta, truth.as_slice(), configured.as_slice(), None)
                .unwrap();
            let noise = factor * Vector3::new(error(), error(), error());
            let seen = frame.transform_point(&reached.point.into()).coords + noise;
            TrackerPoint {
                tracker: 0,
                at,
                measured: seen.into(),
                weight,
            }
        })
        .collect();
    Observations {
        trackers: vec![crate::mechanism::data::Tracker::new("T")],
        tracker_points,
        ..Default::default()
    }
}
