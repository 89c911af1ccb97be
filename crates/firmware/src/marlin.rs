//! Marlin 2.x's linear delta settings: the `M665`, `M666` and `M851`
//! lines that `M503` reports (each maybe after `echo:`, as Marlin prints
//! them, or `Recv: echo:`, as a host's terminal shows them), read in
//! order, each given parameter replacing the value before it; and the
//! calibration lines written for Marlin to execute and save (`M500`).
//! Conventions from Marlin's source (docs/delta-marlin.md):
//!
//! - `M665 L R H X Y Z A B C` (`gcode/calibrate/M665.cpp`): diagonal rod
//!   `L`, delta radius `R`, delta height `H` (mm), the tower angle trims of
//!   towers X, Y, Z (degrees) and their diagonal rod trims `A B C` (mm).
//!   `S` (segments per second) and an older Marlin's `B` (its calibration
//!   radius, reported without `A` and `C`) are not read.
//! - Towers (`module/delta.cpp`, `recalc_delta_settings`): tower X, Y, Z
//!   at `210 + X`, `330 + Y`, `90 + Z` degrees counter-clockwise from +x,
//!   at radius `R` plus their radius trims (`DELTA_RADIUS_TRIM_TOWER`,
//!   compiled in and not reported: zero unless the caller states them,
//!   [`MarlinConfig::with_radius_trims`]), rods `L + A`, `L + B`, `L + C`:
//!   towers X, Y, Z are towers A, B, C of [`parcal_kinematics::delta`],
//!   with its angles, rods and per-tower radius corrections.
//! - `M666 X Y Z` (`gcode/calibrate/M666.cpp`): endstop adjustments (mm),
//!   refused when positive. Homing (`module/motion.cpp`, `homeaxis`) moves
//!   each carriage down by its adjustment from the endstop and calls that
//!   the carriage of the nozzle at `(0, 0, H - M851 Z)`
//!   (`set_axis_is_at_home`; `- M851 Z` only with a probe), so the
//!   carriage at its endstop is at `H - M851 Z + sqrt(L_i^2 - R^2) -
//!   M666_i`: parcal's endstop correction is `-M666_i` and its homed
//!   height `H - M851 Z`.
//! - `M851 X Y Z` (`gcode/probe/M851.cpp`, `module/probe.cpp`): the probe's
//!   offsets from the nozzle (mm). `probe_at_point` reports the nozzle's
//!   height at the trigger plus `M851 Z`: the trigger height (the nozzle's
//!   height above the bed when the probe triggers) is `-M851 Z`. `G30 X Y`
//!   (`gcode/probe/G30.cpp`) places the probe at `X Y`, the nozzle at
//!   `X Y` less the `M851 X Y` offsets.
//!
//! Marlin's values not in the file are compiled in (`Configuration.h`),
//! which parcal cannot know: the file must give `M665 L R H X Y Z` and
//! `M666 X Y Z`, as `M503` reports them. `M665 A B C` are zero when not
//! given (a Marlin without them has no per-tower rods); no `M851`: no
//! probe, the trigger height zero.

use std::path::Path;

use parcal_kinematics::delta::DeltaParams;

use crate::FirmwareError;
use crate::files::read_capped;
use crate::gcode::{Command, parse_line};
use crate::rrf::{MAX_CONFIG_BYTES, check_rods, homed_below_the_bed};

/// The parameters of a linear delta as Marlin holds them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarlinDelta {
    /// Diagonal rod (mm, `M665 L`).
    pub diagonal_rod: f64,
    /// Diagonal rod trims of towers X, Y, Z (mm, `M665 A B C`).
    pub rod_trims: [f64; 3],
    /// Delta radius (mm, `M665 R`).
    pub radius: f64,
    /// Radius trims of towers X, Y, Z (mm, `DELTA_RADIUS_TRIM_TOWER`):
    /// compiled in, not reported by `M503`, zero as read
    /// ([`MarlinConfig::with_radius_trims`]).
    pub radius_trims: [f64; 3],
    /// Delta height (mm, `M665 H`): the homed nozzle's height plus
    /// `M851 Z` with a probe.
    pub height: f64,
    /// Tower angle trims of towers X, Y, Z (degrees, `M665 X Y Z`).
    pub angle_trims: [f64; 3],
    /// Endstop adjustments of towers X, Y, Z (mm, `M666 X Y Z`, each at
    /// most zero).
    pub endstop_adjustments: [f64; 3],
}

/// What an `M503` report says of a linear delta.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarlinConfig {
    /// The delta's parameters.
    pub delta: MarlinDelta,
    /// The probe's offsets from the nozzle (mm, `M851 X Y Z`), if the
    /// printer has a probe.
    pub probe_offset: Option<[f64; 3]>,
}

impl MarlinConfig {
    /// The probe's trigger height, `-M851 Z` (zero without a probe).
    pub fn trigger_height(&self) -> f64 {
        self.probe_offset.map_or(0.0, |[_, _, z]| -z) + 0.0
    }

    /// The probe's horizontal offsets from the nozzle, `M851 X Y` (zero
    /// without a probe): `G30 X Y` probes with the nozzle at `X Y` less
    /// these.
    pub fn probe_xy(&self) -> [f64; 2] {
        self.probe_offset.map_or([0.0; 2], |[x, y, _]| [x, y])
    }

    /// These settings on a Marlin compiled with the radius trims `trims`
    /// (mm, `DELTA_RADIUS_TRIM_TOWER` of towers X, Y, Z); an error, naming
    /// the tower, for a trim not finite or one that puts its tower at no
    /// positive radius its rod reaches beyond.
    pub fn with_radius_trims(mut self, trims: [f64; 3]) -> Result<Self, String> {
        let d = &self.delta;
        for (i, trim) in trims.iter().enumerate() {
            let tower = ["X", "Y", "Z"][i];
            let radius = d.radius + trim;
            let rod = d.diagonal_rod + d.rod_trims[i];
            if !trim.is_finite() || radius <= 0.0 || radius >= rod {
                return Err(format!(
                    "tower {tower}'s radius trim {trim} mm puts it at radius {radius} mm: it must be positive and shorter than its diagonal rod ({rod} mm)"
                ));
            }
        }
        self.delta.radius_trims = trims;
        Ok(self)
    }

    /// The parameters in [`parcal_kinematics::delta`]'s form (module
    /// documentation): the radius trims as the towers' own radius
    /// corrections, no bed tilt (Marlin's delta has none).
    pub fn to_params(&self) -> DeltaParams {
        let d = &self.delta;
        DeltaParams {
            endstop: d.endstop_adjustments.map(|a| -a + 0.0),
            homed_height: d.height + self.trigger_height(),
            radius: d.radius,
            tower_radius: d.radius_trims,
            angle: d.angle_trims,
            diagonal: d.rod_trims.map(|t| d.diagonal_rod + t),
            tilt: [0.0; 2],
        }
    }
}

impl MarlinDelta {
    /// Marlin's parameters of `params` for a probe of trigger height
    /// `trigger_height` (`M851 Z` its negative; zero without a probe) on a
    /// Marlin compiled with the radius trims `radius_trims` (mm): the same
    /// machine in the frame where the towers' own radius corrections are
    /// those trims ([`DeltaParams::with_tower_radius`]), the endstop
    /// adjustments as `M666` takes them, the highest zero and the others
    /// below it (the homed height taking the difference, which changes no
    /// carriage's endstop height), the rod the towers' mean to 0.001 mm and
    /// each tower's trim from it. An error for what Marlin cannot hold: a
    /// bed tilt (drop it first), or trims no frame near the towers has.
    pub fn from_params(
        params: &DeltaParams,
        trigger_height: f64,
        radius_trims: [f64; 3],
    ) -> Result<Self, FirmwareError> {
        if params.tilt != [0.0; 2] {
            return Err(FirmwareError::Calibration(format!(
                "a bed tilt of {} %, {} %, which Marlin's delta cannot hold",
                params.tilt[0], params.tilt[1]
            )));
        }
        let params = params
            .with_tower_radius(radius_trims)
            .map_err(|e| FirmwareError::Calibration(format!("Marlin's radius trims: {e}")))?;
        let lowest = params.endstop.iter().copied().fold(f64::INFINITY, f64::min);
        let diagonal_rod = thousandths(params.diagonal.iter().sum::<f64>() / 3.0);
        Ok(Self {
            diagonal_rod,
            rod_trims: params.diagonal.map(|l| l - diagonal_rod),
            radius: params.radius,
            radius_trims,
            height: params.homed_height + lowest - trigger_height,
            angle_trims: params.angle,
            endstop_adjustments: params.endstop.map(|e| lowest - e),
        })
    }

    /// The lines Marlin executes to take these parameters: `M665` and
    /// `M666`, lengths and angles to 0.001 (Marlin holds them as 32-bit
    /// floats, a few 1e-5 mm at 300 mm); after a comment naming the radius
    /// trims they are for, when not zero.
    pub fn calibration_lines(&self) -> String {
        let [ta, tb, tc] = self.rod_trims.map(thousandths);
        let [ax, ay, az] = self.angle_trims.map(thousandths);
        let [ex, ey, ez] = self.endstop_adjustments.map(thousandths);
        let trims = match self.radius_trims {
            [0.0, 0.0, 0.0] => String::new(),
            [x, y, z] => format!(
                "; for a Marlin compiled with DELTA_RADIUS_TRIM_TOWER {{ {x}, {y}, {z} }}\n"
            ),
        };
        format!(
            "{trims}; Delta parameters\n\
             M665 L{:.3} R{:.3} H{:.3} X{ax:.3} Y{ay:.3} Z{az:.3} A{ta:.3} B{tb:.3} C{tc:.3}\n\
             M666 X{ex:.3} Y{ey:.3} Z{ez:.3}\n",
            self.diagonal_rod, self.radius, self.height
        )
    }
}

/// `value` rounded to 0.001, a value that rounds to zero written without
/// a sign.
pub(crate) fn thousandths(value: f64) -> f64 {
    (value * 1000.0).round() / 1000.0 + 0.0
}

/// The settings read so far: each `None` until a line gives it.
#[derive(Default)]
struct Given {
    diagonal_rod: Option<f64>,
    radius: Option<f64>,
    height: Option<f64>,
    angle_trims: [Option<f64>; 3],
    rod_trims: [f64; 3],
    endstop_adjustments: [Option<f64>; 3],
    probe_offset: Option<[f64; 3]>,
}

impl Given {
    /// `M665`: the parameters it gives replace those before.
    fn m665(&mut self, command: &Command) -> Result<(), String> {
        let mut scalars = [&mut self.diagonal_rod, &mut self.radius, &mut self.height];
        command.each_float(&['L', 'R', 'H'], |k, v| {
            *scalars[k] = Some(v);
            Ok(())
        })?;
        command.each_float(&['X', 'Y', 'Z'], |i, v| {
            self.angle_trims[i] = Some(v);
            Ok(())
        })?;
        // A `B` without `A` or `C` is an older Marlin's calibration radius:
        // a Marlin with rod trims reports the three.
        if command.get('A').is_none() && command.get('C').is_none() {
            return Ok(());
        }
        command.each_float(&['A', 'B', 'C'], |i, v| {
            self.rod_trims[i] = v;
            Ok(())
        })
    }

    /// `M666`: the adjustments it gives replace those before; a positive
    /// one is refused, as Marlin refuses it.
    fn m666(&mut self, command: &Command) -> Result<(), String> {
        const LETTERS: [char; 3] = ['X', 'Y', 'Z'];
        command.each_float(&LETTERS, |i, v| {
            if v > 0.0 {
                return Err(format!(
                    "M666 parameter {}: {v} is positive; Marlin refuses it (M666 offsets must be <= 0)",
                    LETTERS[i]
                ));
            }
            self.endstop_adjustments[i] = Some(v);
            Ok(())
        })
    }

    /// `M851`: the offsets it gives replace those before (zero until
    /// given).
    fn m851(&mut self, command: &Command) -> Result<(), String> {
        let mut offset = self.probe_offset.unwrap_or_default();
        command.each_float(&['X', 'Y', 'Z'], |i, v| {
            offset[i] = v;
            Ok(())
        })?;
        self.probe_offset = Some(offset);
        Ok(())
    }

    /// The delta; an error (made by `at` for the command whose setting it
    /// is) for the first setting no line gave, or a geometry no delta has.
    fn delta(
        &self,
        at: impl Fn(&'static str, String) -> FirmwareError,
    ) -> Result<MarlinDelta, FirmwareError> {
        let missing = |command: &'static str, letter: char, what: &str| {
            at(
                command,
                format!(
                    "no {command} {letter} ({what}) given: M503 reports it, and parcal cannot know the value compiled into the firmware"
                ),
            )
        };
        let xyz = ['X', 'Y', 'Z'];
        let delta = MarlinDelta {
            diagonal_rod: (self.diagonal_rod)
                .ok_or_else(|| missing("M665", 'L', "diagonal rod"))?,
            rod_trims: self.rod_trims,
            radius: (self.radius).ok_or_else(|| missing("M665", 'R', "delta radius"))?,
            radius_trims: [0.0; 3],
            height: (self.height).ok_or_else(|| missing("M665", 'H', "delta height"))?,
            angle_trims: all(&self.angle_trims)
                .map_err(|i| missing("M665", xyz[i], "tower angle trim"))?,
            endstop_adjustments: all(&self.endstop_adjustments)
                .map_err(|i| missing("M666", xyz[i], "endstop adjustment"))?,
        };
        let rods = delta.rod_trims.map(|t| delta.diagonal_rod + t);
        if delta.radius <= 0.0 {
            return Err(at(
                "M665",
                format!("delta radius {} must be positive", delta.radius),
            ));
        }
        if delta.height <= 0.0 {
            return Err(at(
                "M665",
                homed_below_the_bed("delta height", delta.height),
            ));
        }
        check_rods(&rods, delta.radius).map_err(|message| at("M665", message))?;
        Ok(delta)
    }
}

/// The three values, or the index of the first not given.
fn all(values: &[Option<f64>; 3]) -> Result<[f64; 3], usize> {
    let mut out = [0.0; 3];
    for (i, value) in values.iter().enumerate() {
        out[i] = value.ok_or(i)?;
    }
    Ok(out)
}

/// Reads the delta and probe settings of an `M503` report.
pub fn read_config(path: &Path) -> Result<MarlinConfig, FirmwareError> {
    parse_config(&read_capped(path, MAX_CONFIG_BYTES, "configuration")?, path)
}

/// [`read_config`] of a text already read (`path` names it in errors).
/// Lines other than `M665`, `M666`, `M851`, `G20` and `G21` are skipped
/// (Marlin's report headings, `ok`, other settings); values in inches
/// (after `G20`) are refused; a report without `M665` is not a delta's.
pub fn parse_config(text: &str, path: &Path) -> Result<MarlinConfig, FirmwareError> {
    let mut given = Given::default();
    let mut inches = false;
    // The last M665 and M666 lines.
    let mut last = [None; 2];
    for (index, line) in text.lines().enumerate() {
        let line_number = index as u64 + 1;
        let at_line = |message: String| FirmwareError::Line {
            path: path.to_path_buf(),
            line: line_number,
            message,
        };
        let Some(command) = parse_line(reported(line)).map_err(at_line)? else {
            continue;
        };
        let number = match (command.letter, command.number) {
            ('G', 20) => {
                inches = true;
                continue;
            }
            ('G', 21) => {
                inches = false;
                continue;
            }
            ('M', number @ (665 | 666 | 851)) => number,
            _ => continue,
        };
        if inches {
            return Err(at_line(format!(
                "M{number} in inches (G20 before it): parcal reads Marlin's settings in mm; send G21, then M503"
            )));
        }
        let applied = match number {
            665 => {
                last[0] = Some(line_number);
                given.m665(&command)
            }
            666 => {
                last[1] = Some(line_number);
                given.m666(&command)
            }
            _ => given.m851(&command),
        };
        applied.map_err(at_line)?;
    }
    if last[0].is_none() {
        return Err(FirmwareError::Configuration {
            path: path.to_path_buf(),
            message: "no M665 line: not a linear delta's settings (M503 of a delta reports M665)"
                .into(),
        });
    }
    // A setting missing is named at the last line of its command, or the
    // file when there is none.
    let delta = given.delta(
        |command, message| match last[usize::from(command == "M666")] {
            Some(line) => FirmwareError::Line {
                path: path.to_path_buf(),
                line,
                message,
            },
            None => FirmwareError::Configuration {
                path: path.to_path_buf(),
                message: format!("no {command} line: {message}"),
            },
        },
    )?;
    Ok(MarlinConfig {
        delta,
        probe_offset: given.probe_offset,
    })
}

/// A line of Marlin's report without the prefixes its printing and a
/// host's terminal put before the command (`echo:`, `Recv: echo:`).
fn reported(line: &str) -> &str {
    let line = line.trim_start();
    let line = line.strip_prefix("Recv:").map_or(line, str::trim_start);
    line.strip_prefix("echo:").unwrap_or(line)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn prefixes_are_those_marlin_and_hosts_print() {
        assert_eq!(reported("echo:  M665 L250"), "  M665 L250");
        assert_eq!(reported("Recv: echo:  M666 X0"), "  M666 X0");
        assert_eq!(reported("M851 Z-1"), "M851 Z-1");
        assert_eq!(reported("Send: M503"), "Send: M503");
    }
}
