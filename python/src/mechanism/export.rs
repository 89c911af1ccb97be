//! `parcal.export`: a mechanism's calibration as its firmware's
//! lines, as `parcal export --format reprapfirmware | klipper |
//! hangprinter` writes them (docs/delta.md, docs/cable-robots.md).

use parcal::firmware_lines::{FirmwareFormat, FirmwareLinesError, firmware_lines};
use std::path::PathBuf;

use pyo3::prelude::*;
use pyo3::types::PyDict;

use super::calibration_record;
use crate::error::to_py;

/// `calibration` (a `parcal.MechanismCalibration`, or a calibration.json's
/// path) written as `format`'s lines (`"reprapfirmware"`, `"klipper"`: a
/// linear delta's; `"hangprinter"`: a cable robot's), as `parcal export`
/// writes them. A delta's printable radius is `print_radius` (mm) if
/// given, else the one the calibration carries from its dataset. With
/// `"klipper"` and `config` (the printer's printer.cfg), `text` is that
/// whole file with its SAVE_CONFIG block updated as Klipper's SAVE_CONFIG
/// would, its other sections and options kept.
///
/// Returns a dict: `text` (the file's text), `lost` (what the firmware
/// cannot hold, one sentence each), and for a delta `print_radius` (the
/// one written back), `cost` (the position errors of the firmware reading
/// `text` on the calibrated printer, mm: `z_offset`, `flatness_rms`,
/// `flatness_max`, `volume_rms`, `volume_max`) and `cost_sentence`, as
/// `parcal export` prints it; `None` for a cable robot. A rejected
/// calibration is used only with `accept_rejected`.
#[pyfunction(name = "export")]
#[pyo3(signature = (calibration, format, *, print_radius=None, config=None, accept_rejected=false))]
pub fn export_firmware<'py>(
    py: Python<'py>,
    calibration: &Bound<'py, PyAny>,
    format: &str,
    print_radius: Option<f64>,
    config: Option<PathBuf>,
    accept_rejected: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let format = FirmwareFormat::by_name(format).ok_or_else(|| {
        let names: Vec<&str> = FirmwareFormat::NAMES
            .iter()
            .map(|(name, _)| *name)
            .collect();
        to_py(format!(
            "format: expected one of {}, got {format:?}",
            names.join(", ")
        ))
    })?;
    let (record, name) = calibration_record(calibration, accept_rejected)?;
    let lines =
        firmware_lines(&record, format, print_radius, config.as_deref()).map_err(|error| {
            match error {
                FirmwareLinesError::NoPrintRadius => to_py(format!(
                    "{name}: {error}: give print_radius (mm, the firmware's M665 B or print_radius)"
                )),
                FirmwareLinesError::PrintRadius(radius) => to_py(format!(
                    "print_radius must be a positive number of mm, got {radius}"
                )),
                FirmwareLinesError::Into(_) => to_py(format!("config: {error}")),
                error => to_py(format!("{name}: {error}")),
            }
        })?;
    let dict = PyDict::new(py);
    dict.set_item("text", &lines.text)?;
    dict.set_item("lost", &lines.lost)?;
    dict.set_item("cost_sentence", lines.cost_sentence())?;
    match lines.cost {
        Some((errors, workspace)) => {
            let cost = PyDict::new(py);
            cost.set_item("z_offset", errors.z_offset)?;
            cost.set_item("flatness_rms", errors.flatness_rms)?;
            cost.set_item("flatness_max", errors.flatness_max)?;
            cost.set_item("volume_rms", errors.volume_rms)?;
            cost.set_item("volume_max", errors.volume_max)?;
            dict.set_item("print_radius", workspace.print_radius)?;
            dict.set_item("cost", cost)?;
        }
        None => {
            dict.set_item("print_radius", py.None())?;
            dict.set_item("cost", py.None())?;
        }
    }
    Ok(dict)
}
