//! What Klipper's `DELTA_CALIBRATE` and `DELTA_ANALYZE` saved in a
//! `printer.cfg`: the `[delta_calibrate]` section of its `SAVE_CONFIG`
//! block, read as Klipper restores it.
//!
//! - `height{i} = z`, `height{i}_pos = sa, sb, sc`: probe `i` triggered at
//!   the stable position `s` with the probe's `z_offset` `z` (the nozzle's
//!   height above the bed at the trigger). Every probe of one calibration
//!   has the same `z_offset`; heights that differ are refused.
//! - `distance{i} = d`, `distance{i}_pos1`, `distance{i}_pos2`: a distance
//!   `d` measured on a printed part (Klipper's calibration object, enhanced
//!   delta calibration) between two stable positions.
//! - `manual_height{i} = h`, `manual_height{i}_pos`: the nozzle measured
//!   by hand `h` above the bed at a stable position
//!   (`DELTA_ANALYZE MANUAL_HEIGHT`), a height of its own rather than the
//!   probe's trigger height.
//!
//! Each list is read from `i = 0` to the first index missing, at most
//! [`MAX_ENTRIES`], as Klipper reads it.
//!
//! A *stable position* counts each tower's steps down from the point where
//! its endstop triggered, so that it describes a position whatever
//! parameters are configured: carriage `i` is at `Z_i = Z_i^home − s_i
//! d_i`, `d_i` its stepper's step distance (`rotation_distance /
//! (full_steps_per_rotation × microsteps × gear ratio)`, or an older
//! configuration's `step_distance`), so that the readings of
//! [`parcal_kinematics::delta`] are `q_i = −s_i d_i` and the nozzle is at
//! the forward kinematics of the configured parameters at them: the
//! commanded position a probe log would give.

use nalgebra::DVector;
use parcal_kinematics::delta::{DeltaParams, Limits, LinearDelta, Tolerances};
use parcal_kinematics::mechanism::Mechanism;

use super::{Options, STEPPERS};
use crate::FirmwareError;

/// The section Klipper saves its calibration's measurements in.
const SECTION: &str = "delta_calibrate";

/// The most entries of each list Klipper reads (`height0` to `height998`).
pub const MAX_ENTRIES: usize = 999;

/// The measurements `DELTA_CALIBRATE` and `DELTA_ANALYZE` saved in a
/// `printer.cfg`'s `[delta_calibrate]` section (`height{i}` and
/// `height{i}_pos`, `manual_height{i}` and `manual_height{i}_pos`,
/// `distance{i}` and `distance{i}_pos1`, `_pos2`; at most [`MAX_ENTRIES`]
/// of each), as
/// positions of the nozzle under the configured parameters: a stable
/// position `s`, each tower's steps down from its endstop, is the delta's
/// readings `q_i = −s_i d_i` (`d_i` the stepper's step distance, from
/// `rotation_distance`, `microsteps`, `full_steps_per_rotation` and
/// `gear_ratio`, or `step_distance`), at which the configured parameters'
/// forward kinematics puts the nozzle.
#[derive(Debug, Clone, PartialEq, Default)]
#[non_exhaustive]
pub struct DeltaCalibrateResults {
    /// The probes' `z_offset` (mm), if any probe was saved.
    pub z_offset: Option<f64>,
    /// The nozzle's position at each probe's trigger (mm).
    pub probes: Vec<[f64; 3]>,
    /// Each height measured by hand: the nozzle's position and the height
    /// measured there (`x, y, z, h`, mm).
    pub manual_heights: Vec<[f64; 4]>,
    /// Each part distance: its two positions and the distance measured
    /// (`x1, y1, z1, x2, y2, z2, d`, mm).
    pub distances: Vec<[f64; 7]>,
}

/// Reads the `[delta_calibrate]` measurements of `options`, their
/// positions those of the configured parameters `configured`.
pub(super) fn read(
    options: &Options,
    configured: &DeltaParams,
) -> Result<DeltaCalibrateResults, FirmwareError> {
    let heights = entries(options, "height", &["_pos"])?;
    let manual = entries(options, "manual_height", &["_pos"])?;
    let distances = entries(options, "distance", &["_pos1", "_pos2"])?;
    if heights.is_empty() && manual.is_empty() && distances.is_empty() {
        return Ok(DeltaCalibrateResults::default());
    }
    let steps = step_distances(options)?;
    let delta = Stable::new(configured, steps);
    let z_offset = heights.first().map(|h| h.value);
    let probes = (heights.iter())
        .map(|h| {
            if Some(h.value) != z_offset {
                return Err(options.at(
                    h.line,
                    format!(
                        "[{SECTION}] height{}: z_offset {} differs from height0's {}: \
                         the probes of one calibration share the probe's z_offset",
                        h.index,
                        h.value,
                        z_offset.unwrap_or(f64::NAN)
                    ),
                ));
            }
            delta.position(&h.positions[0], options, h.line)
        })
        .collect::<Result<_, _>>()?;
    let manual_heights = (manual.iter())
        .map(|m| {
            let [x, y, z] = delta.position(&m.positions[0], options, m.line)?;
            Ok([x, y, z, m.value])
        })
        .collect::<Result<_, FirmwareError>>()?;
    let distances = (distances.iter())
        .map(|d| {
            let first = delta.position(&d.positions[0], options, d.line)?;
            let second = delta.position(&d.positions[1], options, d.line)?;
            Ok([
                first[0], first[1], first[2], second[0], second[1], second[2], d.value,
            ])
        })
        .collect::<Result<_, FirmwareError>>()?;
    Ok(DeltaCalibrateResults {
        z_offset,
        probes,
        manual_heights,
        distances,
    })
}

/// One saved measurement: `{name}{index}` and its stable positions.
struct Entry {
    index: usize,
    value: f64,
    positions: Vec<[f64; 3]>,
    line: u64,
}

/// `{name}0`, `{name}1`, ... to the first missing, each with its stable
/// positions `{name}{i}{suffix}`.
fn entries(options: &Options, name: &str, suffixes: &[&str]) -> Result<Vec<Entry>, FirmwareError> {
    let mut entries = Vec::new();
    for index in 0..MAX_ENTRIES {
        let key = format!("{name}{index}");
        let Some((_, line)) = options.text(SECTION, &key) else {
            break;
        };
        let value = options.required(SECTION, &key)?;
        let positions = (suffixes.iter())
            .map(|suffix| stable_position(options, &format!("{key}{suffix}"), line))
            .collect::<Result<_, _>>()?;
        entries.push(Entry {
            index,
            value,
            positions,
            line,
        });
    }
    Ok(entries)
}

/// The stable position `key` (`sa, sb, sc`); its absence is an error at
/// `line`, the measurement's.
fn stable_position(options: &Options, key: &str, line: u64) -> Result<[f64; 3], FirmwareError> {
    let Some((text, at)) = options.text(SECTION, key) else {
        return Err(options.at(line, format!("[{SECTION}] {key}: missing")));
    };
    let values: Vec<Option<f64>> = (text.split(','))
        .map(|v| v.trim().parse::<f64>().ok().filter(|v| v.is_finite()))
        .collect();
    match values[..] {
        [Some(a), Some(b), Some(c)] => Ok([a, b, c]),
        _ => Err(options.at(
            at,
            format!("[{SECTION}] {key}: '{text}' is not a stable position (three numbers)"),
        )),
    }
}

/// Each tower stepper's step distance (mm): `rotation_distance /
/// (full_steps_per_rotation × microsteps × gear ratio)`, or `step_distance`.
fn step_distances(options: &Options) -> Result<[f64; 3], FirmwareError> {
    let mut steps = [0.0; 3];
    for (step, stepper) in steps.iter_mut().zip(STEPPERS) {
        // Each a positive length or count, refused at its line.
        let positive = |key: &str, whole: bool, default: Option<f64>| {
            let value = match default {
                Some(default) => options.float(stepper, key)?.unwrap_or(default),
                None => options.required(stepper, key)?,
            };
            if value > 0.0 && (!whole || value.fract() == 0.0) {
                return Ok(value);
            }
            let (_, line) = options.text(stepper, key).unwrap_or_default();
            let kind = if whole { "integer" } else { "length (mm)" };
            Err(options.at(
                line,
                format!("[{stepper}] {key}: {value} is not a positive {kind}"),
            ))
        };
        *step = if options.text(stepper, "step_distance").is_some() {
            positive("step_distance", false, None)?
        } else {
            positive("rotation_distance", false, None)?
                / (positive("full_steps_per_rotation", true, Some(200.0))?
                    * positive("microsteps", true, None)?
                    * gear_ratio(options, stepper)?)
        };
        if !(step.is_normal() && *step > 0.0) {
            return Err(FirmwareError::Configuration {
                path: options.path.clone(),
                message: format!("[{stepper}]'s step distance, {step} mm, is not a usable length"),
            });
        }
    }
    Ok(steps)
}

/// `gear_ratio: a:b, c:d, ...` as the product `a/b · c/d · ...` (1 when
/// absent).
fn gear_ratio(options: &Options, stepper: &str) -> Result<f64, FirmwareError> {
    let Some((text, line)) = options.text(stepper, "gear_ratio") else {
        return Ok(1.0);
    };
    let mut ratio = 1.0;
    for pair in text.split(',') {
        let parts: Vec<Option<f64>> = (pair.split(':'))
            .map(|v| {
                v.trim()
                    .parse::<f64>()
                    .ok()
                    .filter(|v| v.is_finite() && *v > 0.0)
            })
            .collect();
        match parts[..] {
            [Some(a), Some(b)] => ratio *= a / b,
            _ => {
                return Err(options.at(
                    line,
                    format!("[{stepper}] gear_ratio: '{text}' is not a list of a:b ratios"),
                ));
            }
        }
    }
    Ok(ratio)
}

/// The configured delta and its steppers' step distances: stable
/// positions to the nozzle's position (module doc).
struct Stable {
    delta: LinearDelta,
    params: DVector<f64>,
    steps: [f64; 3],
}

impl Stable {
    fn new(configured: &DeltaParams, steps: [f64; 3]) -> Self {
        // Only the kinematics: no limit applies to a position reached.
        let limits = Limits::reach_only(f64::INFINITY);
        Self {
            delta: LinearDelta::new(configured, &Tolerances::default(), limits),
            params: configured.to_vector(),
            steps,
        }
    }

    /// The nozzle at stable position `s`, read at `line` of `options`.
    fn position(
        &self,
        s: &[f64; 3],
        options: &Options,
        line: u64,
    ) -> Result<[f64; 3], FirmwareError> {
        let readings: [f64; 3] = std::array::from_fn(|i| -s[i] * self.steps[i]);
        let position = self
            .delta
            .forward(self.params.as_slice(), &readings, &[])
            .map_err(|e| options.at(line, format!("[{SECTION}] stable position {s:?}: {e}")))?;
        Ok([position[0], position[1], position[2]])
    }
}
