//! `parcal.export`: a calibration in the form other tools load, as
//! `parcal export --format` writes it: a hexapod's own calibration as
//! machine.json, a LinuxCNC genhexkins snippet or a summary
//! (`parcal::hexapod_export`, docs/apply.md); a linear delta's or a cable
//! robot's as its firmware's lines (`parcal::firmware_lines`,
//! docs/delta.md, docs/cable-robots.md).

use std::path::{Path, PathBuf};

use parcal::command::Recorded;
use parcal::dataset::HEXAPOD;
use parcal::dataset::mechanism::MechanismMachine;
use parcal::dataset::{IN_MEMORY, MACHINE_FILE};
use parcal::firmware_lines::{
    FirmwareFormat, FirmwareLinesError, firmware_lines, refused_print_radius,
};
use parcal::hexapod_export::{HexapodFormat, hexapod_export};
use parcal::mechanism_machine::{
    MachineExportError, calibrated_machine_json, machine_path, mechanism_machine_json,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::convert::through_file;
use crate::error::to_py;
use crate::recorded::recorded;

/// `calibration` (a `parcal.Calibration`, a `parcal.MechanismCalibration`,
/// or a calibration.json's path) written as `format`, as `parcal export`
/// writes it: a hexapod's own calibration as `"machine-json"`,
/// `"genhexkins"` or `"summary"`; a linear delta's as `"reprapfirmware"`,
/// `"klipper"` or `"marlin"`, a cable robot's as `"hangprinter"`. A delta's printable
/// radius is `print_radius` (mm) if given, else the one the calibration
/// carries from its dataset. With `"marlin"`, `radius_trims` (mm, towers
/// X, Y, Z) are those the firmware was compiled with
/// (`DELTA_RADIUS_TRIM_TOWER`), by default the towers' radius corrections
/// the calibration's prior states (those `parcal.import_firmware` was
/// given). With `"klipper"` and `config` (the printer's
/// printer.cfg), `text` is that whole file with its SAVE_CONFIG block
/// updated as Klipper's SAVE_CONFIG would, its other sections and options
/// kept.
///
/// Returns a dict: `text` (the file's text), `lost` (what the firmware
/// cannot hold, one sentence each), and for a delta `print_radius` (the
/// one written back), `cost` (the position errors of the firmware reading
/// `text` on the calibrated printer, mm: `z_offset`, `flatness_rms`,
/// `flatness_max`, `volume_rms`, `volume_max`) and `cost_sentence`, as
/// `parcal export` prints it, `trigger_height` (the probe's, mm, written
/// where the data determine it, else `None`) and `trigger_sentence`
/// (whether it was written or kept, and why), and for Marlin
/// `radius_trims` (the trims the lines are written for); `None` for a
/// hexapod or a cable robot. A rejected calibration is used only with
/// `accept_rejected`.
///
/// A linear delta's or a cable robot's calibration as `"machine-json"` is
/// the machine.json it was calibrated from (`machine`: its path, or its
/// content as a dict, a `MechanismDataset`'s `machine`; by default the one
/// in the dataset the calibration names, else the one beside the
/// calibration's file) with the calibrated parameters as
/// its design and the calibrated trigger height
/// (`parcal::mechanism_machine`).
#[pyfunction]
#[pyo3(signature = (calibration, format, *, print_radius=None, radius_trims=None, config=None, machine=None, accept_rejected=false))]
#[allow(clippy::too_many_arguments)]
pub fn export<'py>(
    py: Python<'py>,
    calibration: &Bound<'py, PyAny>,
    format: &str,
    print_radius: Option<f64>,
    radius_trims: Option<[f64; 3]>,
    config: Option<PathBuf>,
    machine: Option<&Bound<'py, PyAny>>,
    accept_rejected: bool,
) -> PyResult<Bound<'py, PyDict>> {
    let wanted = match (
        HexapodFormat::by_name(format),
        FirmwareFormat::by_name(format),
    ) {
        (Some(hexapod), _) => Wanted::Hexapod(hexapod),
        (None, Some(firmware)) => Wanted::Firmware(firmware),
        (None, None) => {
            let names: Vec<&str> = (HexapodFormat::NAMES.iter().map(|(name, _)| *name))
                .chain(FirmwareFormat::NAMES.iter().map(|(name, _)| *name))
                .collect();
            return Err(to_py(format!(
                "format: expected one of {}, got {format:?}",
                names.join(", ")
            )));
        }
    };
    let (recorded, path) = recorded(calibration)?;
    let name = path
        .as_ref()
        .map_or(IN_MEMORY.to_string(), |path| path.display().to_string());
    let (rejected, reasons) = match &recorded {
        Recorded::Own(record) => (record.is_rejected(), &record.reasons),
        Recorded::Mechanism(record) => (!record.accepted, &record.reasons),
    };
    if rejected && !accept_rejected {
        return Err(to_py(format!(
            "{name}: the calibration was rejected ({}); give accept_rejected=True to use it anyway",
            reasons.join("; ")
        )));
    }
    let machine_json = matches!(wanted, Wanted::Hexapod(HexapodFormat::MachineJson));
    if machine.is_some() && !machine_json {
        return Err(to_py(format!(
            "machine: a mechanism's machine.json is what \"machine-json\" starts from; {format} does not read one"
        )));
    }
    let (record, format) = match (recorded, wanted) {
        (_, Wanted::Hexapod(_)) if radius_trims.is_some() => {
            return Err(to_py(format!(
                "radius_trims: radius trims are Marlin's (DELTA_RADIUS_TRIM_TOWER, compiled in); {format} exports a {HEXAPOD}'s"
            )));
        }
        (Recorded::Mechanism(record), Wanted::Hexapod(_))
            if machine_json && record.mechanism != HEXAPOD =>
        {
            if print_radius.is_some() || config.is_some() {
                return Err(to_py(
                    "print_radius and config are a firmware's: \"machine-json\" keeps the printable radius of the machine.json it starts from",
                ));
            }
            let failed = |e: MachineExportError| to_py(format!("{name}: {e} (machine=)"));
            let text = match machine {
                Some(content) if content.is_instance_of::<PyDict>() => {
                    let read = through_file(
                        content,
                        "parcal-machine/1",
                        MACHINE_FILE,
                        MechanismMachine::read,
                    )?;
                    let path = Path::new(IN_MEMORY).join(MACHINE_FILE);
                    calibrated_machine_json(&record, &read, &path)
                }
                given => {
                    let given: Option<PathBuf> = given.map(|path| path.extract()).transpose()?;
                    machine_path(&record, given.as_deref(), path.as_deref())
                        .and_then(|path| mechanism_machine_json(&record, &path))
                }
            }
            .map_err(failed)?;
            return without_firmware(py, text);
        }
        (Recorded::Own(_), Wanted::Hexapod(_)) if machine.is_some() => {
            return Err(to_py(format!(
                "machine: {name}: a hexapod's own calibration carries the design it started from"
            )));
        }
        (Recorded::Own(record), Wanted::Hexapod(hexapod)) => {
            let text =
                hexapod_export(&record, hexapod).map_err(|e| to_py(format!("{name}: {e}")))?;
            return without_firmware(py, text);
        }
        (Recorded::Mechanism(record), Wanted::Hexapod(_)) if record.mechanism == HEXAPOD => {
            return Err(to_py(format!(
                "{name}: a hexapod's calibration through the common path, a mechanism's record (its parameters in the canonical frames, without the design it started from); {format} exports the hexapod's own calibration (parcal.calibrate without common=True)"
            )));
        }
        (Recorded::Mechanism(record), Wanted::Hexapod(_)) => {
            return Err(to_py(format!(
                "{name}: a {} calibration; {format} exports a {HEXAPOD}'s",
                record.mechanism
            )));
        }
        (Recorded::Own(_), Wanted::Firmware(firmware)) => {
            return Err(to_py(format!(
                "{name}: a {HEXAPOD} calibration; {format} exports a {}'s",
                firmware.mechanism()
            )));
        }
        (Recorded::Mechanism(record), Wanted::Firmware(firmware)) => (record, firmware),
    };
    let lines = firmware_lines(
        &record,
        format,
        print_radius,
        radius_trims,
        config.as_deref(),
    )
    .map_err(|error| match error {
        FirmwareLinesError::NoPrintRadius => to_py(format!(
            "{name}: {error}: give print_radius (mm, the firmware's M665 B or print_radius)"
        )),
        FirmwareLinesError::PrintRadius(radius) => {
            to_py(refused_print_radius("print_radius", radius))
        }
        FirmwareLinesError::Into(_) => to_py(format!("config: {error}")),
        FirmwareLinesError::RadiusTrims(_) => to_py(format!("radius_trims: {error}")),
        error => to_py(format!("{name}: {error}")),
    })?;
    let dict = PyDict::new(py);
    dict.set_item("text", &lines.text)?;
    dict.set_item("lost", &lines.lost)?;
    dict.set_item("cost_sentence", lines.cost_sentence())?;
    dict.set_item("trigger_height", lines.trigger_height)?;
    dict.set_item("trigger_sentence", &lines.trigger_sentence)?;
    dict.set_item("radius_trims", lines.radius_trims)?;
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

/// The dict of `text`, a file no firmware reads: nothing lost, no
/// firmware's figures.
fn without_firmware(py: Python<'_>, text: String) -> PyResult<Bound<'_, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("text", text)?;
    dict.set_item("lost", Vec::<String>::new())?;
    for key in [
        "print_radius",
        "cost",
        "cost_sentence",
        "trigger_height",
        "trigger_sentence",
        "radius_trims",
    ] {
        dict.set_item(key, py.None())?;
    }
    Ok(dict)
}

/// What a format exports.
enum Wanted {
    /// A hexapod's own calibration.
    Hexapod(HexapodFormat),
    /// A mechanism's, as its firmware's lines.
    Firmware(FirmwareFormat),
}
