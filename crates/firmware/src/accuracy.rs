//! How far the nozzle lands from where a firmware sends it: the position
//! errors of a firmware's parameters on a machine whose parameters are
//! others.
//!
//! The firmware, with parameters `f`, sends the nozzle to a target `t`
//! by the carriage readings `q = g(f, t)`; the machine, with parameters
//! `m`, puts it at `f_m(q)` (forward kinematics), so the error is
//!
//! ```text
//! e(t) = f(m, g(f, t)) - t.
//! ```
//!
//! Both parameter sets are first put in the linear delta's canonical
//! frame ([`LinearDelta::canonicalize`]: origin at the towers'
//! circumcentre, tower C at 90 degrees), so that two descriptions of the
//! same machine have no error. The mean of `e_z` at `z = 0` over the
//! printable disc is the first layer's height offset: what the user sets
//! by a first-layer test (the probe's trigger height, `G31 Z` or
//! `z_offset`), not the kinematics; it is reported and removed,
//! `e' = e - (0, 0, mean e_z(z = 0))`. Two figures summarise `e'` over the
//! [`Workspace`]: the first layer's flatness, `e'_z` at `z = 0` over the
//! printable disc, and the 3D error `|e'|` over the build cylinder.

use parcal_kinematics::delta::{DeltaParams, Limits, LinearDelta, Tolerances};
use parcal_kinematics::mechanism::Mechanism;

use crate::FirmwareError;

/// The most target points of one evaluation.
pub const MAX_POINTS: usize = 1_000_000;

/// Where the errors are evaluated: targets on a grid of spacing `step`
/// within the printable disc of radius `print_radius`, on levels `step`
/// apart from `z = 0` up to `height`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Workspace {
    /// The printable radius (mm).
    pub print_radius: f64,
    /// The build volume's height (mm).
    pub height: f64,
    /// The grid's spacing, horizontal and vertical (mm).
    pub step: f64,
}

impl Workspace {
    /// A printer's printable disc and the cylinder over it to half its
    /// homed height, on a 10 mm grid.
    pub fn of_printer(print_radius: f64, homed_height: f64) -> Self {
        Self {
            print_radius,
            height: homed_height / 2.0,
            step: 10.0,
        }
    }

    /// The targets at height `z`: the grid points of the printable disc.
    fn layer(&self, z: f64) -> Vec<[f64; 3]> {
        let n = (self.print_radius / self.step).floor() as i64;
        let mut points = Vec::new();
        for i in -n..=n {
            for j in -n..=n {
                let (x, y) = (i as f64 * self.step, j as f64 * self.step);
                if x.hypot(y) <= self.print_radius {
                    points.push([x, y, z]);
                }
            }
        }
        points
    }

    /// The number of levels and of points per level; an error for a
    /// non-positive size or more than [`MAX_POINTS`] points.
    fn check(&self) -> Result<(usize, usize), FirmwareError> {
        let Self {
            print_radius,
            height,
            step,
        } = *self;
        if !(print_radius > 0.0 && height >= 0.0 && step > 0.0 && print_radius.is_finite()) {
            return Err(FirmwareError::Calibration(format!(
                "the evaluated workspace (print radius {print_radius} mm, height {height} mm, step {step} mm) needs positive finite sizes"
            )));
        }
        let across = 2.0 * (print_radius / step).floor() + 1.0;
        let levels = (height / step).floor() + 1.0;
        if across * across * levels > MAX_POINTS as f64 {
            return Err(FirmwareError::Calibration(format!(
                "the evaluated workspace holds more than {MAX_POINTS} points at a step of {step} mm"
            )));
        }
        Ok((levels as usize, (across * across) as usize))
    }
}

/// The summary of the position errors over a [`Workspace`] (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PositionErrors {
    /// The first layer's height offset, the mean of `e_z` at `z = 0`
    /// (removed from the figures below).
    pub z_offset: f64,
    /// RMS of `e'_z` at `z = 0` over the printable disc.
    pub flatness_rms: f64,
    /// Largest `|e'_z|` at `z = 0`.
    pub flatness_max: f64,
    /// RMS of `|e'|` over the build cylinder.
    pub volume_rms: f64,
    /// Largest `|e'|` over the build cylinder.
    pub volume_max: f64,
}

/// The position errors of a firmware with parameters `firmware` on the
/// machine with parameters `machine` (module documentation); an error for
/// a target either cannot reach.
pub fn position_errors(
    machine: &DeltaParams,
    firmware: &DeltaParams,
    workspace: &Workspace,
) -> Result<PositionErrors, FirmwareError> {
    let (levels, _) = workspace.check()?;
    // The kinematics only: no limits beyond reach.
    let limits = Limits::reach_only(workspace.print_radius);
    let delta = LinearDelta::new(machine, &Tolerances::default(), limits);
    let kinematics =
        |e: parcal_kinematics::mechanism::MechanismError| FirmwareError::Calibration(e.to_string());
    let canonical = |p: &DeltaParams| {
        delta
            .canonicalize(p.to_vector().as_slice())
            .map_err(kinematics)
    };
    let (m, f) = (canonical(machine)?, canonical(firmware)?);
    let error = |t: &[f64; 3]| -> Result<[f64; 3], FirmwareError> {
        let q = delta.inverse(f.as_slice(), t).map_err(kinematics)?;
        let x = delta
            .forward(m.as_slice(), q.as_slice(), t)
            .map_err(kinematics)?;
        Ok([x[0] - t[0], x[1] - t[1], x[2] - t[2]])
    };
    let first_layer = workspace
        .layer(0.0)
        .iter()
        .map(error)
        .collect::<Result<Vec<_>, _>>()?;
    let n_layer = first_layer.len() as f64;
    let z_offset = first_layer.iter().map(|e| e[2]).sum::<f64>() / n_layer;
    let flatness_squares = first_layer.iter().map(|e| (e[2] - z_offset).powi(2));
    let flatness_rms = (flatness_squares.sum::<f64>() / n_layer).sqrt();
    let flatness_max = first_layer
        .iter()
        .map(|e| (e[2] - z_offset).abs())
        .fold(0.0, f64::max);
    let (mut sum, mut max, mut n) = (0.0, 0.0f64, 0usize);
    for level in 0..levels {
        for target in workspace.layer(level as f64 * workspace.step) {
            let e = error(&target)?;
            let squared = e[0] * e[0] + e[1] * e[1] + (e[2] - z_offset).powi(2);
            sum += squared;
            max = max.max(squared.sqrt());
            n += 1;
        }
    }
    Ok(PositionErrors {
        z_offset,
        flatness_rms,
        flatness_max,
        volume_rms: (sum / n as f64).sqrt(),
        volume_max: max,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn printer() -> DeltaParams {
        let mut p = DeltaParams::symmetric(270.0, 135.0, 300.0);
        p.endstop = [0.2, -0.1, -0.1];
        p.angle = [0.2, -0.1, 0.0];
        p.tilt = [0.05, -0.02];
        p
    }

    #[test]
    fn the_same_machine_in_another_frame_has_no_error() {
        let machine = printer();
        // A rotation about z and a split of the radius into per-tower
        // corrections describe the same machine.
        let mut other = machine;
        let turn = 0.3f64;
        other.angle = machine.angle.map(|a| a + turn);
        let (sin, cos) = turn.to_radians().sin_cos();
        let [tx, ty] = machine.tilt;
        other.tilt = [cos * tx - sin * ty, sin * tx + cos * ty];
        other.radius -= 0.2;
        other.tower_radius = [0.2; 3];
        let workspace = Workspace::of_printer(110.0, 300.0);
        let errors = position_errors(&machine, &other, &workspace).unwrap();
        assert!(errors.volume_max < 1e-9, "{errors:?}");
    }

    #[test]
    fn an_endstop_error_lowers_the_nozzle_near_its_tower() {
        // The firmware believes carriage A stops 0.1 mm lower than it
        // does: at the centre every carriage contributes a third of it
        // (0.033 mm), the first layer tilts towards A; less its mean,
        // what remains is the tilt, within 0.1 mm.
        let machine = printer();
        let mut firmware = machine;
        firmware.endstop[0] -= 0.1;
        let workspace = Workspace::of_printer(110.0, 300.0);
        let errors = position_errors(&machine, &firmware, &workspace).unwrap();
        assert!(
            errors.z_offset > 0.02 && errors.z_offset < 0.05,
            "{errors:?}"
        );
        assert!(
            errors.flatness_max > 0.01 && errors.flatness_max < 0.1,
            "{errors:?}"
        );
        assert!(errors.flatness_rms < errors.flatness_max);
        assert!(errors.volume_max >= errors.flatness_max);
    }

    #[test]
    fn refuses_an_unbounded_workspace() {
        let machine = printer();
        for workspace in [
            Workspace {
                print_radius: 110.0,
                height: 150.0,
                step: 0.01,
            },
            Workspace {
                print_radius: 110.0,
                height: 150.0,
                step: 0.0,
            },
        ] {
            assert!(position_errors(&machine, &machine, &workspace).is_err());
        }
    }
}
