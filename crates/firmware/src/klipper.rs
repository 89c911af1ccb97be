//! Klipper's linear delta configuration: the `printer.cfg` settings of its
//! delta kinematics, read as Klipper reads them (its main part, then the
//! `SAVE_CONFIG` block at the end overriding it), with the probes and part
//! distances its last `DELTA_CALIBRATE` saved ([`DeltaCalibrateResults`]), and
//! the `SAVE_CONFIG` block written as Klipper writes it after
//! `DELTA_CALIBRATE`.
//!
//! - `[printer]`: `kinematics: delta`, `delta_radius`, `print_radius`
//!   (default: the delta radius).
//! - `[stepper_a]`, `[stepper_b]`, `[stepper_c]`: `angle` (degrees,
//!   absolute; defaults 210, 330, 90), `arm_length` (B and C default to
//!   A's), `position_endstop` (mm; B and C default to A's).
//! - `[probe]`, `[bltouch]` or `[smart_effector]` ([`PROBE_SECTIONS`]): `z_offset`, the
//!   nozzle's height above the bed when the probe triggers (mm), which
//!   `PROBE_CALIBRATE` saves in the block.
//!
//! Klipper's homed carriage height is `position_endstop_i +
//! sqrt(arm_length_i^2 - delta_radius^2)`, the kinematics crate's
//! `H + e_i + sqrt(L_i^2 - R^2)`: its `position_endstop_i` is `H + e_i`,
//! read as `H` their mean and `e_i` the differences. Klipper has no bed
//! tilt in its kinematics (a bed mesh corrects the bed).
//!
//! The file: `[section]` headers, `key: value` or `key = value` options
//! (keys case-insensitive), `#` and `;` comments (inline after a space),
//! indented continuation lines (skipped: only gcode macros have them),
//! `[include ...]` not followed. Errors name the file and line.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use parcal_kinematics::delta::{DeltaParams, NOMINAL_ANGLE};

use crate::FirmwareError;
use crate::files::{bounded_number, read_capped};
use crate::rrf::MAX_CONFIG_BYTES;

mod delta_calibrate;
mod fit;
mod save_config;

pub use delta_calibrate::{DeltaCalibrateResults, MAX_ENTRIES};
pub use fit::{ReadDistance, ReadHeight, fit};
use save_config::SaveConfig;

/// The steppers of the towers.
const STEPPERS: [&str; 3] = ["stepper_a", "stepper_b", "stepper_c"];

/// The sections a probe's `z_offset` is read from and saved in, the first
/// a `printer.cfg` has: Klipper's probe, a BLTouch, a Duet Smart Effector
/// (each section saves its own, as `PROBE_CALIBRATE` does).
pub const PROBE_SECTIONS: [&str; 3] = ["probe", "bltouch", "smart_effector"];

/// The parameters of a linear delta as Klipper holds them.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KlipperDelta {
    /// `delta_radius` (mm).
    pub delta_radius: f64,
    /// `print_radius` (mm).
    pub print_radius: f64,
    /// Each tower's `angle` (degrees, counter-clockwise from +x).
    pub angles: [f64; 3],
    /// Each tower's `arm_length` (mm).
    pub arm_lengths: [f64; 3],
    /// Each tower's `position_endstop` (mm).
    pub position_endstops: [f64; 3],
}

impl KlipperDelta {
    /// The parameters in [`parcal_kinematics::delta`]'s form.
    pub fn to_params(&self) -> DeltaParams {
        let homed_height = self.position_endstops.iter().sum::<f64>() / 3.0;
        DeltaParams {
            endstop: self.position_endstops.map(|e| e - homed_height),
            homed_height,
            radius: self.delta_radius,
            tower_radius: [0.0; 3],
            angle: std::array::from_fn(|i| self.angles[i] - NOMINAL_ANGLE[i]),
            diagonal: self.arm_lengths,
            tilt: [0.0; 2],
        }
    }

    /// Klipper's parameters of `params`; an error for a bed tilt or a
    /// per-tower radius correction, which Klipper cannot hold.
    pub fn from_params(params: &DeltaParams, print_radius: f64) -> Result<Self, FirmwareError> {
        if params.tilt != [0.0; 2] || params.tower_radius != [0.0; 3] {
            return Err(FirmwareError::Calibration(format!(
                "Klipper's delta holds no bed tilt ({:?} %) nor per-tower radius corrections ({:?} mm)",
                params.tilt, params.tower_radius
            )));
        }
        Ok(Self {
            delta_radius: params.radius,
            print_radius,
            angles: std::array::from_fn(|i| NOMINAL_ANGLE[i] + params.angle[i]),
            arm_lengths: params.diagonal,
            position_endstops: params.endstop.map(|e| params.homed_height + e),
        })
    }

    /// The `SAVE_CONFIG` block Klipper writes after `DELTA_CALIBRATE`
    /// (values to 1e-6, as Klipper writes them), to end a `printer.cfg`;
    /// with `z_offset`, the `[probe]` `z_offset` too, as
    /// `PROBE_CALIBRATE` writes it (to 1e-3).
    pub fn save_config_block(&self, z_offset: Option<f64>) -> String {
        let probe = z_offset.map(|z| (PROBE_SECTIONS[0], z));
        self.saved_in(SaveConfig::default(), probe).render()
    }

    /// `printer_cfg` as Klipper's `SAVE_CONFIG` would leave it with these
    /// settings: the text before its block, unchanged, and the block with
    /// `delta_radius` and each stepper's `angle`, `arm_length` and
    /// `position_endstop` set, and with `z_offset` the probe's (in the
    /// first of [`PROBE_SECTIONS`] the file has, else `[probe]`), its other
    /// sections and options (a saved `[delta_calibrate]`, a bed mesh) kept.
    pub fn saved_into<'a>(&self, printer_cfg: &'a str, z_offset: Option<f64>) -> (&'a str, String) {
        let (main, block) = SaveConfig::split(printer_cfg);
        let probe = z_offset.map(|z| (probe_section(main), z));
        (main, self.saved_in(block, probe).render())
    }

    /// `block` with these settings set, and `probe`'s `z_offset` in its
    /// section.
    fn saved_in(&self, mut block: SaveConfig, probe: Option<(&str, f64)>) -> SaveConfig {
        if let Some((section, z_offset)) = probe {
            block.set(section, "z_offset", &format!("{z_offset:.3}"));
        }
        block.set(
            "printer",
            "delta_radius",
            &format!("{:.6}", self.delta_radius),
        );
        for (i, stepper) in STEPPERS.iter().enumerate() {
            block.set(stepper, "angle", &format!("{:.6}", self.angles[i]));
            block.set(
                stepper,
                "arm_length",
                &format!("{:.6}", self.arm_lengths[i]),
            );
            let endstop = format!("{:.6}", self.position_endstops[i]);
            block.set(stepper, "position_endstop", &endstop);
        }
        block
    }
}

/// The options of a config file: `(section, key)` to value and line.
struct Options {
    path: PathBuf,
    values: HashMap<(String, String), (String, u64)>,
}

impl Options {
    /// The options of `text` (`path` names it in errors): its main part,
    /// then the `SAVE_CONFIG` block's, which override it.
    fn parse(text: &str, path: &Path) -> Result<Self, FirmwareError> {
        let numbered: Vec<(u64, &str)> = text
            .lines()
            .enumerate()
            .map(|(i, line)| (i as u64 + 1, line))
            .collect();
        let block_start = numbered
            .iter()
            .position(|(_, line)| save_config::is_marker(line))
            .unwrap_or(numbered.len());
        let mut options = Options {
            path: path.to_path_buf(),
            values: HashMap::new(),
        };
        options.read(&numbered[..block_start])?;
        let block: Vec<(u64, &str)> = numbered[block_start..]
            .iter()
            .skip(1)
            .filter_map(|(line, text)| {
                let rest = text.strip_prefix(save_config::PREFIX)?;
                let rest = rest.strip_prefix(' ').unwrap_or(rest);
                (rest != save_config::NOTICE).then_some((*line, rest))
            })
            .collect();
        options.read(&block)?;
        Ok(options)
    }

    /// Reads numbered lines into the options, a later value of a key
    /// replacing an earlier one.
    fn read(&mut self, lines: &[(u64, &str)]) -> Result<(), FirmwareError> {
        let mut section: Option<String> = None;
        for &(line, text) in lines {
            let at = |message: String| FirmwareError::Line {
                path: self.path.clone(),
                line,
                message,
            };
            if text.starts_with([' ', '\t']) {
                // A continuation line (a macro's gcode).
                continue;
            }
            let text = strip_comment(text).trim();
            if text.is_empty() {
                continue;
            }
            if let Some(header) = text.strip_prefix('[') {
                let name = header
                    .strip_suffix(']')
                    .ok_or_else(|| at(format!("unclosed section header '{text}'")))?;
                section = Some(name.trim().to_string());
                continue;
            }
            let Some(split) = text.find([':', '=']) else {
                return Err(at(format!(
                    "'{text}' is neither a section nor a key: value"
                )));
            };
            let Some(section) = &section else {
                return Err(at(format!("'{text}' comes before any section")));
            };
            let key = text[..split].trim().to_lowercase();
            let value = text[split + 1..].trim().to_string();
            self.values.insert((section.clone(), key), (value, line));
        }
        Ok(())
    }

    /// The text of `section`/`key` and its line, if given.
    fn text(&self, section: &str, key: &str) -> Option<(&str, u64)> {
        (self.values.get(&(section.to_string(), key.to_string())))
            .map(|(value, line)| (value.as_str(), *line))
    }

    /// An error at `line` of the file.
    fn at(&self, line: u64, message: String) -> FirmwareError {
        FirmwareError::Line {
            path: self.path.clone(),
            line,
            message,
        }
    }

    /// The number of `section`/`key`, if given.
    fn float(&self, section: &str, key: &str) -> Result<Option<f64>, FirmwareError> {
        let Some((value, line)) = self.values.get(&(section.to_string(), key.to_string())) else {
            return Ok(None);
        };
        bounded_number(value)
            .map(Some)
            .map_err(|why| FirmwareError::Line {
                path: self.path.clone(),
                line: *line,
                message: format!("[{section}] {key}: {why}"),
            })
    }

    /// The number of `section`/`key`, required.
    fn required(&self, section: &str, key: &str) -> Result<f64, FirmwareError> {
        self.given(section, key, self.float(section, key)?)
    }

    /// `value`, `section`/`key`'s as read, or the error that it is not
    /// given.
    fn given(&self, section: &str, key: &str, value: Option<f64>) -> Result<f64, FirmwareError> {
        value.ok_or_else(|| FirmwareError::Configuration {
            path: self.path.clone(),
            message: format!("no {key} in [{section}] (includes are not followed)"),
        })
    }

    /// The number of `section`/`key`, if given, refused at its line unless
    /// positive (as Klipper refuses a radius: `above=0.`).
    fn positive(&self, section: &str, key: &str) -> Result<Option<f64>, FirmwareError> {
        match self.float(section, key)? {
            Some(value) if value <= 0.0 => {
                let (_, line) = &self.values[&(section.to_string(), key.to_string())];
                Err(self.at(
                    *line,
                    format!("[{section}] {key}: {value} must be positive"),
                ))
            }
            value => Ok(value),
        }
    }

    /// [`Options::positive`], required.
    fn required_positive(&self, section: &str, key: &str) -> Result<f64, FirmwareError> {
        self.given(section, key, self.positive(section, key)?)
    }
}

/// How [`parse_printer`] reads a stepper's number: [`Options::float`] or
/// [`Options::positive`].
type ReadNumber = fn(&Options, &str, &str) -> Result<Option<f64>, FirmwareError>;

/// The line without an inline comment (`#` or `;` at its start or after
/// whitespace).
fn strip_comment(text: &str) -> &str {
    let mut previous_blank = true;
    for (i, c) in text.char_indices() {
        if (c == '#' || c == ';') && previous_blank {
            return &text[..i];
        }
        previous_blank = c.is_whitespace();
    }
    text
}

/// The first of [`PROBE_SECTIONS`] that the main part of a `printer.cfg`,
/// `main`, opens, else `[probe]`.
fn probe_section(main: &str) -> &'static str {
    let opened = |name: &str| {
        main.lines()
            .map(|line| strip_comment(line).trim())
            .any(|line| {
                line.strip_prefix('[')
                    .and_then(|h| h.strip_suffix(']'))
                    .is_some_and(|h| h.trim() == name)
            })
    };
    (PROBE_SECTIONS.into_iter())
        .find(|name| opened(name))
        .unwrap_or(PROBE_SECTIONS[0])
}

/// A `printer.cfg`'s delta: its settings and the measurements its last
/// `DELTA_CALIBRATE` saved.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct KlipperPrinter {
    /// The delta settings.
    pub delta: KlipperDelta,
    /// The probe's `z_offset` (mm), from the first of [`PROBE_SECTIONS`]
    /// that gives one.
    pub z_offset: Option<f64>,
    /// The `[delta_calibrate]` measurements, at the positions of the
    /// settings' parameters (none saved: empty).
    pub saved: DeltaCalibrateResults,
}

/// Reads a `printer.cfg`'s delta settings and saved measurements.
pub fn read_printer(path: &Path) -> Result<KlipperPrinter, FirmwareError> {
    parse_printer(&read_capped(path, MAX_CONFIG_BYTES, "configuration")?, path)
}

/// [`read_printer`] of a text already read (`path` names it in errors).
pub fn parse_printer(text: &str, path: &Path) -> Result<KlipperPrinter, FirmwareError> {
    let options = Options::parse(text, path)?;
    let delta = delta_settings(&options)?;
    let saved = delta_calibrate::read(&options, &delta.to_params())?;
    let z_offset = probe_z_offset(&options)?;
    Ok(KlipperPrinter {
        delta,
        z_offset,
        saved,
    })
}

/// The probe's `z_offset`, from whichever of [`PROBE_SECTIONS`] gives one;
/// an error naming the second's line when two do (Klipper runs one probe,
/// and refuses a `printer.cfg` with both).
fn probe_z_offset(options: &Options) -> Result<Option<f64>, FirmwareError> {
    let mut found: Option<(&str, f64)> = None;
    for section in PROBE_SECTIONS {
        let Some(z) = options.float(section, "z_offset")? else {
            continue;
        };
        if let Some((first, _)) = found {
            let (_, line) = &options.values[&(section.to_string(), "z_offset".to_string())];
            return Err(FirmwareError::Line {
                path: options.path.clone(),
                line: *line,
                message: format!(
                    "[{section}] z_offset: the file gives [{first}] a z_offset too; Klipper runs one probe"
                ),
            });
        }
        found = Some((section, z));
    }
    Ok(found.map(|(_, z)| z))
}

/// The delta settings of a `printer.cfg`'s options.
fn delta_settings(options: &Options) -> Result<KlipperDelta, FirmwareError> {
    let path = options.path.as_path();
    let kinematics = options
        .values
        .get(&("printer".to_string(), "kinematics".to_string()));
    match kinematics {
        Some((value, _)) if value == "delta" => {}
        Some((value, line)) => {
            return Err(FirmwareError::Line {
                path: path.to_path_buf(),
                line: *line,
                message: format!("kinematics '{value}': not a linear delta"),
            });
        }
        None => {
            return Err(FirmwareError::Configuration {
                path: path.to_path_buf(),
                message: "no kinematics in [printer]: not a printer configuration".into(),
            });
        }
    }
    let delta_radius = options.required_positive("printer", "delta_radius")?;
    let print_radius = options
        .positive("printer", "print_radius")?
        .unwrap_or(delta_radius);
    let arm_a = options.required(STEPPERS[0], "arm_length")?;
    let endstop_a = options.required_positive(STEPPERS[0], "position_endstop")?;
    let mut delta = KlipperDelta {
        delta_radius,
        print_radius,
        angles: NOMINAL_ANGLE,
        arm_lengths: [arm_a; 3],
        position_endstops: [endstop_a; 3],
    };
    for (i, stepper) in STEPPERS.iter().enumerate() {
        // The nozzle homes above the bed: each carriage's endstop height
        // is positive.
        let given: [(&str, &mut f64, ReadNumber); 3] = [
            ("angle", &mut delta.angles[i], Options::float),
            ("arm_length", &mut delta.arm_lengths[i], Options::float),
            (
                "position_endstop",
                &mut delta.position_endstops[i],
                Options::positive,
            ),
        ];
        for (key, slot, read) in given {
            if let Some(v) = read(options, stepper, key)? {
                *slot = v;
            }
        }
        if delta.arm_lengths[i] <= delta_radius {
            return Err(FirmwareError::Configuration {
                path: path.to_path_buf(),
                message: format!(
                    "[{stepper}] arm_length {} is not longer than delta_radius {delta_radius}",
                    delta.arm_lengths[i]
                ),
            });
        }
    }
    Ok(delta)
}
