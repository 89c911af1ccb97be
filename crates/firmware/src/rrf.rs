//! RepRapFirmware's linear delta configuration: the `M665`, `M666` and
//! `G31` lines of `config.g` (or `config-override.g`), read as the
//! firmware executes them, in order, each given parameter replacing the
//! value before it, and the calibration lines written as the firmware
//! writes them (`M500`). Where `config.g` loads `config-override.g`
//! (`M501`, or `M98 P"config-override.g"`), the firmware runs that file's
//! lines there, so they are read there too, from beside `config.g`; a
//! configuration that loads an override not beside it is refused, since
//! the printer runs values parcal would not see.
//!
//! - `M665 L R H B X Y Z`: diagonal rods (`L` one value for all towers,
//!   or `a:b:c`; with two values the third is the first, as the firmware
//!   fills them), delta radius, homed height, printable radius, and the
//!   angle corrections of towers X, Y, Z (degrees; positive turns the
//!   tower counter-clockwise seen from above).
//! - `M666 X Y Z A B`: endstop corrections of towers X, Y, Z (mm; the
//!   homed carriage heights are `H + sqrt(L_i^2 - R^2) + e_i`, so a
//!   positive correction raises the firmware's idea of where that carriage
//!   stops, making the nozzle go lower near that tower), and bed tilt
//!   along X and Y (percent: the carriages rise by `(A x + B y)/100`).
//! - `G31 X Y Z` (Z probe 0, or `K0`): the probe's offsets from the nozzle
//!   and its trigger height (mm).
//!
//! Towers X, Y, Z of the firmware are towers A, B, C of
//! [`parcal_kinematics::delta`], at 210, 330 and 90 degrees.

use std::path::{Path, PathBuf};

use parcal_kinematics::delta::DeltaParams;

use crate::FirmwareError;
use crate::files::read_capped;
use crate::gcode::{Command, parse_line};

/// The largest configuration file read (bytes): a `config.g` is a few
/// kilobytes.
pub const MAX_CONFIG_BYTES: u64 = 1 << 20;

/// The parameters of a linear delta as RepRapFirmware holds them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RrfDelta {
    /// Diagonal rod lengths of towers X, Y, Z (mm, `M665 L`).
    pub diagonals: [f64; 3],
    /// Delta radius (mm, `M665 R`).
    pub radius: f64,
    /// Homed height (mm, `M665 H`).
    pub homed_height: f64,
    /// Printable radius (mm, `M665 B`).
    pub print_radius: f64,
    /// Tower angle corrections (degrees, `M665 X Y Z`).
    pub angle_corrections: [f64; 3],
    /// Endstop corrections (mm, `M666 X Y Z`).
    pub endstop_adjustments: [f64; 3],
    /// Bed tilt along X and Y (percent, `M666 A B`).
    pub tilt: [f64; 2],
}

impl Default for RrfDelta {
    /// The firmware's defaults before any `M665`/`M666`.
    fn default() -> Self {
        Self {
            diagonals: [215.0; 3],
            radius: 105.6,
            homed_height: 240.0,
            print_radius: 80.0,
            angle_corrections: [0.0; 3],
            endstop_adjustments: [0.0; 3],
            tilt: [0.0; 2],
        }
    }
}

/// The Z probe's configuration (`G31`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ZProbe {
    /// Trigger height (mm, `G31 Z`): the nozzle's height above the bed
    /// when the probe triggers.
    pub trigger_height: f64,
    /// Offsets of the probe from the nozzle (mm, `G31 X Y`).
    pub offset: [f64; 2],
}

impl Default for ZProbe {
    /// The firmware's defaults (trigger height 0.7 mm, no offset).
    fn default() -> Self {
        Self {
            trigger_height: 0.7,
            offset: [0.0; 2],
        }
    }
}

/// What a configuration file says of a linear delta.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RrfConfig {
    /// The delta's parameters.
    pub delta: RrfDelta,
    /// The Z probe.
    pub probe: ZProbe,
}

impl RrfDelta {
    /// The parameters in [`parcal_kinematics::delta`]'s form (no per-tower
    /// radius corrections: the firmware has none).
    pub fn to_params(&self) -> DeltaParams {
        DeltaParams {
            endstop: self.endstop_adjustments,
            homed_height: self.homed_height,
            radius: self.radius,
            tower_radius: [0.0; 3],
            angle: self.angle_corrections,
            diagonal: self.diagonals,
            tilt: self.tilt,
        }
    }

    /// The firmware's parameters of `params` with printable radius
    /// `print_radius`; an error when a tower has a radius correction of
    /// its own, which the firmware cannot hold (canonicalise first:
    /// [`parcal_kinematics::delta::LinearDelta`]'s canonical frame has
    /// none).
    pub fn from_params(params: &DeltaParams, print_radius: f64) -> Result<Self, FirmwareError> {
        refuse_tower_radius(params, "RepRapFirmware")?;
        Ok(Self {
            diagonals: params.diagonal,
            radius: params.radius,
            homed_height: params.homed_height,
            print_radius,
            angle_corrections: params.angle,
            endstop_adjustments: params.endstop,
            tilt: params.tilt,
        })
    }

    /// The lines RepRapFirmware writes for its calibration (`M500`,
    /// `WriteCalibrationParameters`), which it reads back with the values
    /// as written: lengths and angles to 0.001, the printable radius to
    /// 0.1; the tilt to 0.001 % (the firmware writes 0.01 %, a step of
    /// 0.01 mm across 100 mm).
    pub fn calibration_lines(&self) -> String {
        let [la, lb, lc] = self.diagonals;
        let [ax, ay, az] = self.angle_corrections;
        let [ex, ey, ez] = self.endstop_adjustments;
        let [tx, ty] = self.tilt;
        format!(
            "; Delta parameters\n\
             M665 L{la:.3}:{lb:.3}:{lc:.3} R{:.3} H{:.3} B{:.1} X{ax:.3} Y{ay:.3} Z{az:.3}\n\
             M666 X{ex:.3} Y{ey:.3} Z{ez:.3} A{tx:.3} B{ty:.3}\n",
            self.radius, self.homed_height, self.print_radius
        )
    }

    /// `M665`: the parameters it gives replace those before.
    fn configure_m665(&mut self, command: &Command) -> Result<(), String> {
        if let Some(values) = command.floats('L')? {
            if values.len() > 3 {
                return Err(format!(
                    "M665 L gives {} diagonals: parcal reads deltas of three towers",
                    values.len()
                ));
            }
            for i in 0..3 {
                self.diagonals[i] = values.get(i).copied().unwrap_or(values[0]);
            }
        }
        let mut scalars = [
            &mut self.radius,
            &mut self.print_radius,
            &mut self.homed_height,
        ];
        command.each_float(&['R', 'B', 'H'], |k, v| {
            *scalars[k] = v;
            Ok(())
        })?;
        command.each_float(&['X', 'Y', 'Z'], |i, v| {
            self.angle_corrections[i] = v;
            Ok(())
        })
    }

    /// `M666`: the parameters it gives replace those before.
    fn configure_m666(&mut self, command: &Command) -> Result<(), String> {
        command.each_float(&['X', 'Y', 'Z'], |i, v| {
            self.endstop_adjustments[i] = v;
            Ok(())
        })?;
        command.each_float(&['A', 'B'], |i, v| {
            self.tilt[i] = v;
            Ok(())
        })
    }

    /// Refuses a geometry no delta has: a non-positive radius, printable
    /// radius or homed height (the nozzle homes above the bed), a rod not
    /// longer than the radius.
    fn check(&self) -> Result<(), String> {
        if !(self.radius > 0.0 && self.print_radius > 0.0) {
            return Err(format!(
                "delta radius {} and printable radius {} must be positive",
                self.radius, self.print_radius
            ));
        }
        if self.homed_height <= 0.0 {
            return Err(homed_below_the_bed("homed height", self.homed_height));
        }
        check_rods(&self.diagonals, self.radius)
    }
}

/// Refuses a tower's radius correction of its own, which `firmware`
/// (RepRapFirmware, Marlin) cannot hold: the parameters go to the
/// canonical frame first ([`parcal_kinematics::delta::LinearDelta`]'s has
/// none).
pub(crate) fn refuse_tower_radius(
    params: &DeltaParams,
    firmware: &str,
) -> Result<(), FirmwareError> {
    match params.tower_radius.iter().position(|r| *r != 0.0) {
        Some(i) => Err(FirmwareError::Calibration(format!(
            "tower {} has a radius correction of {} mm of its own, which {firmware} cannot hold: express the parameters in the canonical frame first",
            ["X", "Y", "Z"][i],
            params.tower_radius[i]
        ))),
        None => Ok(()),
    }
}

/// Why a homed nozzle height `height` (RepRapFirmware's `M665 H`,
/// Marlin's delta height) is refused: it is not above the bed, where every
/// probe point lies.
pub(crate) fn homed_below_the_bed(name: &str, height: f64) -> String {
    format!("{name} {height} mm must be positive: the nozzle homes above the bed")
}

/// Refuses rods no delta has: one not longer than the delta radius
/// `radius` (towers named X, Y, Z, as RepRapFirmware and Marlin name
/// them).
pub(crate) fn check_rods(diagonals: &[f64; 3], radius: f64) -> Result<(), String> {
    match diagonals.iter().position(|l| *l <= radius) {
        Some(i) => Err(format!(
            "the diagonal rod of tower {} ({} mm) is not longer than the delta radius ({} mm)",
            ["X", "Y", "Z"][i],
            diagonals[i],
            radius
        )),
        None => Ok(()),
    }
}

impl ZProbe {
    /// `G31`: the parameters it gives replace those before; a `G31` for
    /// another probe (`K1`...) is skipped.
    fn configure(&mut self, command: &Command) -> Result<(), String> {
        if command.float('K')?.is_some_and(|k| k != 0.0) {
            return Ok(());
        }
        if let Some(z) = command.float('Z')? {
            self.trigger_height = z;
        }
        command.each_float(&['X', 'Y'], |i, v| {
            self.offset[i] = v;
            Ok(())
        })
    }
}

/// Reads the delta and probe configuration of a `config.g`.
pub fn read_config(path: &Path) -> Result<RrfConfig, FirmwareError> {
    parse_config(&read_capped(path, MAX_CONFIG_BYTES, "configuration")?, path)
}

/// The file `M501` loads, beside `config.g`.
pub const OVERRIDE_FILE: &str = "config-override.g";

/// [`read_config`] of a text already read (`path` names it in errors; the
/// override it loads is read from beside it). Lines other than `M665`,
/// `M666`, `G31` and the override's loading are skipped; a configuration
/// without `M665` is not a delta's.
pub fn parse_config(text: &str, path: &Path) -> Result<RrfConfig, FirmwareError> {
    let mut config = RrfConfig {
        delta: RrfDelta::default(),
        probe: ZProbe::default(),
    };
    let mut last_m665 = None;
    run_lines(text, path, &mut config, &mut last_m665, true)?;
    let Some((path, line)) = last_m665 else {
        return Err(FirmwareError::Configuration {
            path: path.to_path_buf(),
            message: "no M665 line: not a linear delta's configuration".into(),
        });
    };
    config
        .delta
        .check()
        .map_err(|message| FirmwareError::Line {
            path,
            line,
            message,
        })?;
    Ok(config)
}

/// The lines of `text` (file `path`) run into `config` in order, the place
/// of the last `M665` into `last_m665`; with `loads_override`, the
/// override's lines run where the text loads it (module doc).
fn run_lines(
    text: &str,
    path: &Path,
    config: &mut RrfConfig,
    last_m665: &mut Option<(PathBuf, u64)>,
    loads_override: bool,
) -> Result<(), FirmwareError> {
    for (index, line) in text.lines().enumerate() {
        let line_number = index as u64 + 1;
        let at_line = |message: String| FirmwareError::Line {
            path: path.to_path_buf(),
            line: line_number,
            message,
        };
        let Some(command) = parse_line(line).map_err(at_line)? else {
            continue;
        };
        let applied = match (command.letter, command.number) {
            ('M', 665) => {
                *last_m665 = Some((path.to_path_buf(), line_number));
                config.delta.configure_m665(&command)
            }
            ('M', 666) => config.delta.configure_m666(&command),
            ('G', 31) => config.probe.configure(&command),
            _ => Ok(()),
        };
        applied.map_err(at_line)?;
        if loads_override && loads_the_override(&command) {
            let file = path.with_file_name(OVERRIDE_FILE);
            if !file.is_file() {
                return Err(at_line(format!(
                    "{}{} loads {OVERRIDE_FILE}, whose values the printer runs: give the printer's {OVERRIDE_FILE} beside this file (or take the line out if the printer has none)",
                    command.letter, command.number
                )));
            }
            let text = read_capped(&file, MAX_CONFIG_BYTES, "configuration")?;
            run_lines(&text, &file, config, last_m665, false)?;
        }
    }
    Ok(())
}

/// Whether `command` loads the override: `M501`, or `M98` of
/// [`OVERRIDE_FILE`] (quoted or not, with or without its folder).
fn loads_the_override(command: &Command) -> bool {
    match (command.letter, command.number) {
        ('M', 501) => true,
        ('M', 98) => command
            .get('P')
            .map(|p| p.trim_matches('"'))
            .is_some_and(|p| p.rsplit(['/', ':']).next() == Some(OVERRIDE_FILE)),
        _ => false,
    }
}
