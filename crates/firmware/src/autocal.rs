//! RepRapFirmware's delta auto-calibration (`G32` after `G30 P... S<n>`),
//! reimplemented from its published behaviour: the baseline parcal is
//! compared against.
//!
//! The firmware works in its motor coordinates: carriage `i` at height
//! `m_i` (mm), homed at `Z_i^home` ([`LinearDelta::homed_carriage_heights`]).
//! For each probe point it takes the carriage heights `m` that put the
//! nozzle at `(x, y, 0)`. Then, twice (a fixed number of Gauss-Newton
//! iterations):
//!
//! 1. the derivatives `D_kj = dz_k / dv_j` of the forward kinematics'
//!    height at `m` with respect to the factors, by central differences of
//!    0.2 (mm or degrees) — except the tilts, `dz/dv = -x/B`, `-y/B`
//!    (`B` the printable radius, which scales the tilt factors);
//! 2. the normal equations `D^T D v = -D^T (z + c)`, with `z` the reported
//!    heights and `c` the heights predicted so far (zero at first);
//! 3. the factors applied ([`apply`]): the endstop corrections move the
//!    homed carriage heights by `v_1..3` (and with them every `m`), a change
//!    of radius or rods is compensated in the endstop corrections so that
//!    the homed carriage heights move by `v_1..3` only, and the endstop
//!    corrections are normalised to mean zero (the mean goes into `H`);
//! 4. `c_k` is the forward kinematics' height at the moved `m`; the
//!    expected deviation is the RMS of `z + c`.
//!
//! The factor sets: 3 = the endstops; 4 = + delta radius; 6 = + angle
//! corrections of towers X and Y; 7 = + one change common to the three
//! rods; 8 = 6 + the bed tilt; 9 = 7 + the bed tilt. Tower Z's angle
//! correction is never changed (it fixes the frame's rotation), nor the
//! rods' differences.
//!
//! Since the firmware's inverse kinematics is `m_i = z + ...`, a probe that
//! triggered at reported height `z_k` put the carriages at `m + z_k`, and
//! a calibrated model brings those to height 0: that is the model at `m`
//! giving `-z_k`.

use nalgebra::{DMatrix, DVector};
use parcal_kinematics::delta::{Limits, LinearDelta, Tolerances};
use parcal_kinematics::mechanism::Mechanism;

use crate::FirmwareError;
use crate::probes::{MAX_PROBE_POINTS, ProbePoint};
use crate::rrf::RrfDelta;

/// The firmware's perturbation for its derivatives (mm or degrees).
const PERTURBATION: f64 = 0.2;
/// Gauss-Newton iterations the firmware makes.
const ITERATIONS: usize = 2;
/// The factor counts the firmware supports.
pub const FACTOR_COUNTS: [usize; 6] = [3, 4, 6, 7, 8, 9];

/// The result of an auto-calibration.
#[derive(Debug, Clone, PartialEq)]
pub struct AutoCalibration {
    /// The calibrated parameters.
    pub delta: RrfDelta,
    /// The RMS of the reported heights (mm).
    pub deviation_before: f64,
    /// The RMS of the heights the calibrated parameters predict (mm).
    pub deviation_after: f64,
}

/// The factor `j` of an `n`-factor calibration as the firmware numbers
/// its derivatives: 0-2 endstops, 3 radius, 4-5 angles, 6 rods, 7-8 tilt
/// (8 factors skip the rods).
fn derivative_index(factors: usize, j: usize) -> usize {
    if factors == 8 && j >= 6 { j + 1 } else { j }
}

/// The firmware's kinematics at one parameter set.
struct Firmware {
    delta: LinearDelta,
    params: DVector<f64>,
    homed: [f64; 3],
}

impl Firmware {
    fn new(rrf: &RrfDelta) -> Result<Self, FirmwareError> {
        let params = rrf.to_params();
        // The kinematics only: no limits beyond reach.
        let limits = Limits::reach_only(rrf.print_radius);
        let delta = LinearDelta::new(&params, &Tolerances::default(), limits);
        let params = params.to_vector();
        let homed = delta
            .homed_carriage_heights(params.as_slice())
            .map_err(|e| FirmwareError::Calibration(e.to_string()))?;
        Ok(Self {
            delta,
            params,
            homed,
        })
    }

    /// The carriage heights `m` at nozzle position `(x, y, z)` (the
    /// firmware's `Transform`).
    fn transform(&self, x: f64, y: f64, z: f64) -> Option<[f64; 3]> {
        let q = self
            .delta
            .inverse(self.params.as_slice(), &[x, y, z])
            .ok()?;
        Some(std::array::from_fn(|i| q[i] + self.homed[i]))
    }

    /// The nozzle position at carriage heights `m` (`ForwardTransform`).
    fn forward_transform(&self, m: &[f64; 3]) -> Option<DVector<f64>> {
        let q: [f64; 3] = std::array::from_fn(|i| m[i] - self.homed[i]);
        self.delta
            .forward(self.params.as_slice(), &q, &[0.0; 3])
            .ok()
    }

    /// `dz/dv_j` at carriage heights `m` (`ComputeDerivative`).
    fn derivative(&self, rrf: &RrfDelta, j: usize, m: &[f64; 3]) -> Option<f64> {
        let (mut high, mut low) = (*rrf, *rrf);
        let (mut m_high, mut m_low) = (*m, *m);
        match j {
            0..=2 => {
                m_high[j] += PERTURBATION;
                m_low[j] -= PERTURBATION;
            }
            3 => {
                high.radius += PERTURBATION;
                low.radius -= PERTURBATION;
            }
            4 | 5 => {
                high.angle_corrections[j - 4] += PERTURBATION;
                low.angle_corrections[j - 4] -= PERTURBATION;
            }
            6 => {
                high.diagonals = high.diagonals.map(|l| l + PERTURBATION);
                low.diagonals = low.diagonals.map(|l| l - PERTURBATION);
            }
            _ => {
                let position = self.forward_transform(m)?;
                return Some(-position[j - 7] / rrf.print_radius);
            }
        }
        let z_high = Firmware::new(&high).ok()?.forward_transform(&m_high)?[2];
        let z_low = Firmware::new(&low).ok()?.forward_transform(&m_low)?[2];
        Some((z_high - z_low) / (2.0 * PERTURBATION))
    }
}

/// Applies the solved factors `v` to `rrf` as the firmware's `Adjust` does
/// (module documentation, step 3).
pub fn apply(rrf: &RrfDelta, factors: usize, v: &[f64]) -> RrfDelta {
    let mut next = *rrf;
    let old_radius = rrf.radius;
    if factors >= 4 {
        next.radius += v[3];
    }
    for tower in 0..3 {
        if factors >= 4 {
            let old_rise = (rrf.diagonals[tower].powi(2) - old_radius.powi(2)).sqrt();
            if factors == 7 || factors == 9 {
                next.diagonals[tower] += v[6];
            }
            let new_rise = (next.diagonals[tower].powi(2) - next.radius.powi(2)).sqrt();
            next.endstop_adjustments[tower] += old_rise - new_rise;
        }
        next.endstop_adjustments[tower] += v[tower];
    }
    let mean = next.endstop_adjustments.iter().sum::<f64>() / 3.0;
    next.endstop_adjustments = next.endstop_adjustments.map(|e| e - mean);
    next.homed_height += mean;
    if factors >= 6 {
        next.angle_corrections[0] += v[4];
        next.angle_corrections[1] += v[5];
        let tilt = match factors {
            8 => Some((v[6], v[7])),
            9 => Some((v[7], v[8])),
            _ => None,
        };
        if let Some((x, y)) = tilt {
            next.tilt[0] += 100.0 * x / rrf.print_radius;
            next.tilt[1] += 100.0 * y / rrf.print_radius;
        }
    }
    next
}

/// RepRapFirmware's `factors`-factor auto-calibration of `rrf` from the
/// probe heights `probes` (module documentation). Errors: an unsupported
/// factor count, fewer points than factors, a point the parameters cannot
/// reach, a non-finite value, more than [`MAX_PROBE_POINTS`] points,
/// singular normal equations.
pub fn auto_calibrate(
    rrf: &RrfDelta,
    probes: &[ProbePoint],
    factors: usize,
) -> Result<AutoCalibration, FirmwareError> {
    if !FACTOR_COUNTS.contains(&factors) {
        return Err(FirmwareError::Calibration(format!(
            "{factors} factors requested; RepRapFirmware calibrates 3, 4, 6, 7, 8 or 9"
        )));
    }
    if let Some(k) = probes
        .iter()
        .position(|p| !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()))
    {
        return Err(FirmwareError::Calibration(format!(
            "probe point {} has a value that is not a finite number",
            k + 1
        )));
    }
    if probes.len() > MAX_PROBE_POINTS {
        return Err(FirmwareError::Calibration(format!(
            "{} probe points, more than the {MAX_PROBE_POINTS} a calibration takes",
            probes.len()
        )));
    }
    if probes.len() < factors {
        return Err(FirmwareError::Calibration(format!(
            "{} probe points cannot determine {factors} factors",
            probes.len()
        )));
    }
    let unreachable = |k: usize| {
        FirmwareError::Calibration(format!(
            "probe point {} at ({}, {}) is unreachable with the current parameters",
            k + 1,
            probes[k].x,
            probes[k].y
        ))
    };
    let n = probes.len();
    let mut current = *rrf;
    let firmware = Firmware::new(&current)?;
    let mut motors = probes
        .iter()
        .enumerate()
        .map(|(k, p)| {
            firmware
                .transform(p.x, p.y, 0.0)
                .ok_or_else(|| unreachable(k))
        })
        .collect::<Result<Vec<_>, _>>()?;
    let heights = DVector::from_iterator(n, probes.iter().map(|p| p.z));
    let deviation_before = heights.norm() / (n as f64).sqrt();
    let mut corrections = DVector::zeros(n);
    let mut deviation_after = deviation_before;
    for _ in 0..ITERATIONS {
        let firmware = Firmware::new(&current)?;
        let mut derivatives = DMatrix::zeros(n, factors);
        for (k, m) in motors.iter().enumerate() {
            for j in 0..factors {
                derivatives[(k, j)] = firmware
                    .derivative(&current, derivative_index(factors, j), m)
                    .ok_or_else(|| unreachable(k))?;
            }
        }
        let normal = derivatives.tr_mul(&derivatives);
        let right = -derivatives.tr_mul(&(&heights + &corrections));
        let solution = normal
            .lu()
            .solve(&right)
            .filter(|v| v.iter().all(|x| x.is_finite()))
            .ok_or_else(|| {
                FirmwareError::Calibration(
                    "the normal equations are singular: choose different probe points".into(),
                )
            })?;
        current = apply(&current, factors, solution.as_slice());
        let firmware = Firmware::new(&current)?;
        for (k, m) in motors.iter_mut().enumerate() {
            for (axis, value) in m.iter_mut().enumerate() {
                *value += solution[axis];
            }
            corrections[k] = firmware
                .forward_transform(m)
                .ok_or_else(|| unreachable(k))?[2];
        }
        deviation_after = (&heights + &corrections).norm() / (n as f64).sqrt();
    }
    Ok(AutoCalibration {
        delta: current,
        deviation_before,
        deviation_after,
    })
}
