//! Klipper's `DELTA_CALIBRATE` fit, reimplemented from its published
//! behaviour: the baseline beside RepRapFirmware's [`crate::autocal`].
//!
//! Klipper fits its delta settings to probes and, in its enhanced
//! calibration (`DELTA_ANALYZE`), to distances measured on a printed part,
//! every position given by the carriages' readings `q` (its stable
//! positions: `q_i = −s_i d_i`, [`super::DeltaCalibrateResults`]) and
//! placed by the forward kinematics `f(p, q)` of the settings `p` tried:
//!
//! ```text
//! E(p) = w Σ_k (z(f(p, q_k)) − z_offset)² + Σ_j (|f(p, q_a,j) − f(p, q_b,j)| − d_j)²
//! ```
//!
//! with `w = D / (0.5 K)` for `K` probes and `D` distances (1 without
//! distances). It adjusts `delta_radius`, the angles of towers A and B and
//! the three `position_endstop`s, and with distances the three
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

/// The settings Klipper's `DELTA_CALIBRATE` fits to probes that triggered
/// at the readings `probes` with the probe's `z_offset`, and to
/// `distances` if any (module doc), starting from `configured`.
pub fn fit(
    configured: &KlipperDelta,
    probes: &[[f64; 3]],
    z_offset: f64,
    distances: &[ReadDistance],
) -> Result<KlipperDelta, FirmwareError> {
    if probes.len() < 3 || probes.len() > MAX_PROBE_POINTS || distances.len() > MAX_PROBE_POINTS {
        return Err(FirmwareError::Calibration(format!(
            "Klipper's fit takes 3 to {MAX_PROBE_POINTS} probes and at most as many distances, got {} and {}",
            probes.len(),
            distances.len()
        )));
    }
    let finite = |v: &[f64]| v.iter().all(|x| x.is_finite());
    if !(z_offset.is_finite()
        && probes.iter().all(|q| finite(q))
        && (distances.iter())
            .all(|d| finite(&d.first) && finite(&d.second) && d.distance.is_finite()))
    {
        return Err(FirmwareError::Calibration(
            "Klipper's fit takes finite readings, z_offset and distances".into(),
        ));
    }
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
        for q in probes {
            let Some(x) = at(q) else {
                return UNREACHABLE;
            };
            heights += (x.z - z_offset).powi(2);
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
        let fitted = fit(&configured, &probes, z_offset, &distances).unwrap();
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
        let heights_only = fit(&configured, &probes, z_offset, &[]).unwrap();
        assert_eq!(heights_only.arm_lengths, configured.arm_lengths);
        assert!(fit(&configured, &probes[..2], z_offset, &[]).is_err());
        assert!(fit(&configured, &probes, f64::NAN, &[]).is_err());
    }
}
