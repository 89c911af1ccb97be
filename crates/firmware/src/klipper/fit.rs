//! Klipper's `DELTA_CALIBRATE` fit, reimplemented from its published
//! behaviour (`calculate_params` of klippy/extras/delta_calibrate.py): the
//! baseline beside RepRapFirmware's [`crate::autocal`].
//!
//! Klipper fits its delta settings to probes, to heights measured by hand
//! (`DELTA_ANALYZE MANUAL_HEIGHT`) and, in its enhanced calibration
//! (`DELTA_ANALYZE`), to distances measured on a printed part, every
//! position given by the carriages' readings `q` (its stable positions:
//! `q_i = −s_i d_i`, [`super::DeltaCalibrateResults`]) and placed by the
//! forward kinematics `f(p, q)` of the settings `p` tried:
//!
//! ```text
//! E(p) = w [Σ_m (z(f(p, q_m)) − h_m)² + Σ_k (z(f(p, q_k)) − z_offset)²]
//!        + Σ_j (|f(p, q_a,j) − f(p, q_b,j)| − d_j)²
//! ```
//!
//! over the manual heights `h_m`, the probes and the distances `d_j`, with
//! `w = D / (0.5 K)` for `K` probes and `D` distances (1 without
//! distances): a manual height weighs as a probe, but only the probes
//! count in `w`. It adjusts `delta_radius`, the angles of towers A and B
//! and the three `position_endstop`s, and with distances the three
//! `arm_length`s too, by coordinate descent: each parameter in turn is
//! moved by its step (1 mm or degree at first) up, else down; a move that
//! lowers `E` is kept and its step grows by 1.1, else the step shrinks by
//! 0.9; until the steps sum to less than 1e-5 or after 10 000 rounds. A
//! position the arms cannot reach makes `E` 9999999999999.9, as in
//! Klipper.

use nalgebra::Vector3;
use parcal_kinematics::delta::{Limits, LinearDelta, Tolerances};
use parcal_kinematics::mechanism::Mechanism;

use super::KlipperDelta;
use crate::FirmwareError;
use crate::probes::MAX_PROBE_POINTS;

/// The weight of the distances against the heights (Klipper's
/// `MEASURE_WEIGHT`).
const MEASURE_WEIGHT: f64 = 0.5;
/// The error of settings that cannot reach a position.
const UNREACHABLE: f64 = 9_999_999_999_999.9;
/// The steps' sum below which the descent stops.
const THRESHOLD: f64 = 1e-5;
/// The most rounds of the descent.
const MAX_ROUNDS: usize = 10_000;

/// A distance measured between the positions of two readings (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadDistance {
    /// The carriages' readings at the first position.
    pub first: [f64; 3],
    /// At the second.
    pub second: [f64; 3],
    /// The distance measured.
    pub distance: f64,
}

/// A height of the nozzle above the bed measured by hand at the position
/// of the carriages' readings (mm; Klipper's `manual_height{i}` at
/// `manual_height{i}_pos`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReadHeight {
    /// The carriages' readings.
    pub readings: [f64; 3],
    /// The height measured.
    pub height: f64,
}

/// The settings Klipper's `DELTA_CALIBRATE` fits to probes that triggered
/// at the readings `probes` with the probe's `z_offset`, to the heights
/// measured by hand `manual_heights` and to `distances`, if any (module
/// doc), starting from `configured`.
pub fn fit(
    configured: &KlipperDelta,
    probes: &[[f64; 3]],
    z_offset: f64,
    manual_heights: &[ReadHeight],
    distances: &[ReadDistance],
) -> Result<KlipperDelta, FirmwareError> {
    if probes.len() < 3
        || probes.len() > MAX_PROBE_POINTS
        || manual_heights.len() > MAX_PROBE_POINTS
        || distances.len() > MAX_PROBE_POINTS
    {
        return Err(FirmwareError::Calibration(format!(
            "Klipper's fit takes 3 to {MAX_PROBE_POINTS} probes and at most as many manual heights and distances, got {}, {} and {}",
            probes.len(),
            manual_heights.len(),
            distances.len()
        )));
    }
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if !(z_offset.is_finite()
        && probes.iter().all(|q| finite(q))
        && (manual_heights.iter()).all(|m| finite(&m.readings) && m.height.is_finite())
        && (distances.iter())
            .all(|d| finite(&d.first) && finite(&d.second) && d.distance.is_finite()))
    {
        return Err(FirmwareError::Calibration(
            "Klipper's fit takes finite readings, z_offset, manual heights and distances".into(),
        ));
    }
    // Klipper's `height_positions`: the manual heights, then the probes,
    // each the height its readings should be at.
    let height_positions: Vec<(f64, &[f64; 3])> = (manual_heights.iter())
        .map(|m| (m.height, &m.readings))
        .chain(probes.iter().map(|q| (z_offset, q)))
        .collect();
    let extended = !distances.is_empty();
    let z_weight = if extended {
        distances.len() as f64 / (MEASURE_WEIGHT * probes.len() as f64)
    } else {
        1.0
    };
    // Only the kinematics: the settings tried come with each evaluation.
    let limits = Limits::reach_only(f64::INFINITY);
    let delta = LinearDelta::new(&configured.to_params(), &Tolerances::default(), limits);
    let error = |settings: &KlipperDelta| -> f64 {
        let params = settings.to_params().to_vector();
        let at = |q: &[f64; 3]| {
            (delta.forward(params.as_slice(), q, &[]))
                .ok()
                .map(|x| Vector3::new(x[0], x[1], x[2]))
        };
        let mut heights = 0.0;
        for &(goal, q) in &height_positions {
            let Some(x) = at(q) else {
                return UNREACHABLE;
            };
            heights += (x.z - goal).powi(2);
        }
        let mut total = z_weight * heights;
        for d in distances {
            let (Some(a), Some(b)) = (at(&d.first), at(&d.second)) else {
                return UNREACHABLE;
            };
            total += ((a - b).norm() - d.distance).powi(2);
        }
        total
    };
    let adjusted = if extended { 9 } else { 6 };
    let mut settings = *configured;
    let mut step = [1.0; 9];
    let mut best = error(&settings);
    for _ in 0..MAX_ROUNDS {
        if step[..adjusted].iter().sum::<f64>() <= THRESHOLD {
            break;
        }
        for (k, step) in step.iter_mut().enumerate().take(adjusted) {
            let original = *parameter(&mut settings, k);
            let improved = [original + *step, original - *step]
                .into_iter()
                .any(|tried| {
                    *parameter(&mut settings, k) = tried;
                    let e = error(&settings);
                    let better = e < best;
                    if better {
                        best = e;
                    }
                    better
                });
            if improved {
                *step *= 1.1;
            } else {
                *parameter(&mut settings, k) = original;
                *step *= 0.9;
            }
        }
    }
    Ok(settings)
}

/// The `k`-th setting Klipper adjusts: `delta_radius`, the angles of
/// towers A and B, the three `position_endstop`s, the three `arm_length`s.
fn parameter(settings: &mut KlipperDelta, k: usize) -> &mut f64 {
    match k {
        0 => &mut settings.delta_radius,
        1 | 2 => &mut settings.angles[k - 1],
        3..=5 => &mut settings.position_endstops[k - 3],
        _ => &mut settings.arm_lengths[k - 6],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::delta::{DeltaParams, probe_rings};

    /// A printer configured symmetric, truly off in what Klipper fits.
    fn printer() -> (KlipperDelta, KlipperDelta) {
        let configured =
            KlipperDelta::from_params(&DeltaParams::symmetric(270.0, 135.0, 300.0), 100.0).unwrap();
        let mut truth = configured;
        truth.delta_radius += 0.4;
        truth.angles[0] += 0.2;
        truth.angles[1] -= 0.15;
        truth.position_endstops = [300.25, 299.9, 300.1];
        truth.arm_lengths = [270.3, 269.8, 270.1];
        (configured, truth)
    }

    /// The readings that put `truth`'s nozzle at `x`.
    fn readings(truth: &KlipperDelta, x: [f64; 3]) -> [f64; 3] {
        let params = truth.to_params().to_vector();
        let delta = LinearDelta::typical();
        let q = delta.inverse(params.as_slice(), &x).unwrap();
        [q[0], q[1], q[2]]
    }

    #[test]
    fn noiseless_probes_and_distances_give_the_true_settings() {
        let (configured, truth) = printer();
        let z_offset = 0.7;
        let probes: Vec<[f64; 3]> = (probe_rings(95.0, 3, 12).iter())
            .map(|&[x, y]| readings(&truth, [x, y, z_offset]))
            .collect();
        let distances: Vec<ReadDistance> = [(0.0f64, 180.0f64), (60.0, 240.0), (120.0, 300.0)]
            .iter()
            .map(|&(a, b)| {
                let at = |angle: f64| {
                    let (s, c) = angle.to_radians().sin_cos();
                    [90.0 * c, 90.0 * s, 0.2]
                };
                let (first, second) = (at(a), at(b));
                ReadDistance {
                    first: readings(&truth, first),
                    second: readings(&truth, second),
                    distance: (Vector3::from(first) - Vector3::from(second)).norm(),
                }
            })
            .collect();
        let fitted = fit(&configured, &probes, z_offset, &[], &distances).unwrap();
        // The descent stops when its steps sum to 1e-5, but moving one
        // setting at a time it creeps along the valleys of correlated
        // settings (the rods against the radius and the angles): it stops
        // within a few thousandths of the truth, not at it.
        let close = |a: f64, b: f64| (a - b).abs() < 5e-3;
        assert!(close(fitted.delta_radius, truth.delta_radius), "{fitted:?}");
        for i in 0..3 {
            assert!(close(fitted.angles[i], truth.angles[i]), "{fitted:?}");
            assert!(
                close(fitted.position_endstops[i], truth.position_endstops[i]),
                "{fitted:?}"
            );
            assert!(
                close(fitted.arm_lengths[i], truth.arm_lengths[i]),
                "{fitted:?}"
            );
        }
        // Probes alone leave the rods as configured.
        let heights_only = fit(&configured, &probes, z_offset, &[], &[]).unwrap();
        assert_eq!(heights_only.arm_lengths, configured.arm_lengths);
        assert!(fit(&configured, &probes[..2], z_offset, &[], &[]).is_err());
        assert!(fit(&configured, &probes, f64::NAN, &[], &[]).is_err());
    }

    /// The nozzle's true height on `truth` where `fitted` sends it to the
    /// bed's centre at z = 0: the first layer's absolute height error.
    fn centre_height(truth: &KlipperDelta, fitted: &KlipperDelta) -> f64 {
        let delta = LinearDelta::typical();
        let sent = fitted.to_params().to_vector();
        let q = delta.inverse(sent.as_slice(), &[0.0; 3]).unwrap();
        let reached = truth.to_params().to_vector();
        delta
            .forward(reached.as_slice(), q.as_slice(), &[0.0; 3])
            .unwrap()[2]
    }

    #[test]
    fn manual_heights_weigh_as_probes_on_the_bed_height() {
        // Off in the six settings fitted without distances, the rods right.
        let (configured, mut truth) = printer();
        truth.arm_lengths = configured.arm_lengths;
        // The probe triggers d above the bed where its z_offset says 0.7.
        let (z_offset, d) = (0.7, 0.1);
        let points = probe_rings(95.0, 3, 12);
        let probes: Vec<[f64; 3]> = (points.iter())
            .map(|&[x, y]| readings(&truth, [x, y, z_offset + d]))
            .collect();
        // Each probe point measured again by hand on a 5 and a 10 mm gauge
        // block, exactly.
        let manual: Vec<ReadHeight> = [5.0, 10.0]
            .into_iter()
            .flat_map(|gauge| points.iter().map(move |&[x, y]| [x, y, gauge]))
            .map(|x| ReadHeight {
                readings: readings(&truth, x),
                height: x[2],
            })
            .collect();
        // With the settings true but for a common height s (the three
        // endstops moved together move the nozzle by s at any readings),
        // E = K (d + s)² + M s², least at s = −d K / (K + M): the fitted
        // z = 0 is d K / (K + M) above the bed. Any other setting moves
        // the heights by a pattern g(x, y) (hardly changing over 10 mm of
        // height), whose product with these residuals, d M / (K + M) at
        // the probes and −d K / (K + M) at the manual heights, is
        // d K M / (K + M) (mean of g over the probes − over the manual
        // heights): zero here, the manual heights at the probes' points,
        // so that this is the least squares. Elsewhere the radius's bowl
        // would take part of the offset.
        // The descent stops when its steps sum to THRESHOLD, each setting
        // then within its step of where moving it alone lowers E no more;
        // the centre's height moves by a third of each endstop's change,
        // by R / sqrt(L² − R²) ≈ 0.58 of the radius's and not at first
        // order with an angle: within THRESHOLD of the least squares'.
        let (k, m) = (probes.len() as f64, manual.len() as f64);
        for (heights, wanted) in [(&[][..], d), (&manual[..], d * k / (k + m))] {
            let fitted = fit(&configured, &probes, z_offset, heights, &[]).unwrap();
            let height = centre_height(&truth, &fitted);
            assert!(
                (height - wanted).abs() < THRESHOLD,
                "{} manual heights: {height} mm against {wanted}",
                heights.len()
            );
        }
        let mut unmeasured = manual.clone();
        unmeasured[3].height = f64::INFINITY;
        assert!(fit(&configured, &probes, z_offset, &unmeasured, &[]).is_err());
        let too_many = vec![manual[0]; MAX_PROBE_POINTS + 1];
        assert!(fit(&configured, &probes, z_offset, &too_many, &[]).is_err());
    }
}
