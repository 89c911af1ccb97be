//! `parcal.import_firmware`: a printer's firmware configuration and probe
//! log as a mechanism dataset, as `parcal import reprapfirmware | klipper |
//! marlin` makes it (docs/delta.md, docs/delta-marlin.md).

use std::path::PathBuf;

use parcal::firmware_import::{
    FirmwareImportError, ImportOptions, ObservationFiles, firmware_import,
};
use parcal::firmware_lines::FirmwareFormat;
use pyo3::prelude::*;

use super::dataset::MechanismDataset;
use crate::error::to_py;

/// The linear delta configured in `config` (`firmware`'s file:
/// `"reprapfirmware"`'s config.g, `"klipper"`'s printer.cfg, what
/// `"marlin"`'s M503 reported, whose printable radius `print_radius` gives
/// and whose compiled-in radius trims `radius_trims` give, mm, towers X, Y,
/// Z, default none) as a
/// `parcal.MechanismDataset`, as `parcal import` makes it: the configured
/// parameters as the prior's means, the tolerances (mm, degrees, percent;
/// `None` a kit printer's, docs/delta.md) as its sigmas, the probe log at
/// `probes` (a CSV with header `x,y,z`, the commanded XY and the height
/// reported there; Marlin's G30 takes the probe's XY) as probe heights,
/// the part distances at `distances`
/// (header `x1,y1,z1,x2,y2,z2,distance`) and the heights measured by hand
/// at `heights` (header `x,y,z,height`). With Klipper, each of the three
/// not given is what its DELTA_CALIBRATE and DELTA_ANALYZE saved in
/// printer.cfg. `dataset.write(path)` writes the command's files
/// byte for byte.
#[pyfunction]
#[pyo3(signature = (
    firmware,
    config,
    *,
    probes=None,
    distances=None,
    heights=None,
    diagonal_tolerance=None,
    matched_rods=None,
    radius_tolerance=None,
    tower_radius_tolerance=None,
    angle_tolerance=None,
    endstop_tolerance=None,
    homed_height_tolerance=None,
    tilt_tolerance=None,
    probe_sigma=None,
    distance_sigma=None,
    height_sigma=None,
    trigger_sigma=None,
    print_radius=None,
    radius_trims=None,
))]
#[allow(clippy::too_many_arguments)]
pub fn import_firmware(
    py: Python<'_>,
    firmware: &str,
    config: PathBuf,
    probes: Option<PathBuf>,
    distances: Option<PathBuf>,
    heights: Option<PathBuf>,
    diagonal_tolerance: Option<f64>,
    matched_rods: Option<f64>,
    radius_tolerance: Option<f64>,
    tower_radius_tolerance: Option<f64>,
    angle_tolerance: Option<f64>,
    endstop_tolerance: Option<f64>,
    homed_height_tolerance: Option<f64>,
    tilt_tolerance: Option<f64>,
    probe_sigma: Option<f64>,
    distance_sigma: Option<f64>,
    height_sigma: Option<f64>,
    trigger_sigma: Option<f64>,
    print_radius: Option<f64>,
    radius_trims: Option<[f64; 3]>,
) -> PyResult<MechanismDataset> {
    let format = match FirmwareFormat::by_name(firmware) {
        Some(
            format @ (FirmwareFormat::RepRapFirmware
            | FirmwareFormat::Klipper
            | FirmwareFormat::Marlin),
        ) => format,
        _ => {
            return Err(to_py(format!(
                "firmware: expected reprapfirmware, klipper or marlin, got {firmware:?}"
            )));
        }
    };
    let mut options = ImportOptions::default();
    let t = &mut options.tolerances;
    for (value, given) in [
        (&mut t.diagonal, diagonal_tolerance),
        (&mut t.radius, radius_tolerance),
        (&mut t.tower_radius, tower_radius_tolerance),
        (&mut t.angle, angle_tolerance),
        (&mut t.endstop, endstop_tolerance),
        (&mut t.homed_height, homed_height_tolerance),
        (&mut t.tilt, tilt_tolerance),
        (&mut options.probe_sigma, probe_sigma),
        (&mut options.distance_sigma, distance_sigma),
        (&mut options.height_sigma, height_sigma),
        (&mut options.trigger_sigma, trigger_sigma),
    ] {
        if let Some(given) = given {
            *value = given;
        }
    }
    options.matched_rods = matched_rods;
    options.print_radius = print_radius;
    options.radius_trims = radius_trims;
    let imported = py
        .detach(|| {
            let files = ObservationFiles {
                probes: probes.as_deref(),
                distances: distances.as_deref(),
                heights: heights.as_deref(),
            };
            firmware_import(format, &config, &files, &options)
        })
        .map_err(|error| match error {
            FirmwareImportError::NoProbes { .. } => {
                to_py(format!("{error}: give probes= (a CSV with header x,y,z)"))
            }
            FirmwareImportError::NoPrintRadius { .. } => {
                to_py(format!("{error}: give print_radius= (mm)"))
            }
            error => to_py(error),
        })?;
    MechanismDataset::in_memory(imported.dataset)
}
