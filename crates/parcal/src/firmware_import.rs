//! A printer's firmware configuration and probe log (or the probes its
//! firmware saved with its configuration, Klipper's) as a mechanism
//! dataset, as `parcal import` makes it, for every front end
//! (docs/delta.md): the configured parameters the firmware ran with, also
//! the prior's means, the builder's tolerances as the prior's sigmas, and
//! each probe as a probe height at the commanded position where it
//! triggered, `(x, y, z + trigger height)` (Marlin's `G30` places the
//! probe at `x, y`: the nozzle is there less the probe's `M851 X Y`), the
//! trigger height an unknown with its own prior.

use std::path::{Path, PathBuf};

use parcal_dataset::mechanism::{MechanismDataset, MechanismMachine, Noise, ValuePrior};
use parcal_firmware::klipper::{DeltaCalibrateResults, read_printer};
use parcal_firmware::marlin;
use parcal_firmware::probes::{read_distances, read_heights, read_probes};
use parcal_firmware::rrf::read_config;
use parcal_firmware::{FirmwareError, MAX_MAGNITUDE};
use parcal_kinematics::delta::{DeltaParams, Limits, LinearDelta, RODS, Tolerances};
use parcal_kinematics::mechanism::Mechanism;

use crate::firmware_lines::{FirmwareFormat, check_radius_trims, is_print_radius};

/// The largest tolerance or standard deviation accepted (mm, degrees or
/// percent): beyond it a prior says nothing.
pub const MAX_SIGMA: f64 = 100.0;

/// The builder's tolerances (one standard deviation each) and the
/// measurements' noise.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub struct ImportOptions {
    /// The parameters' tolerances; by default a kit printer's
    /// ([`Tolerances::default`]).
    pub tolerances: Tolerances,
    /// The rods were cut as a matched set: each within this of the set's
    /// length (mm, at most the rods' tolerance).
    pub matched_rods: Option<f64>,
    /// The probe's repeatability (mm).
    pub probe_sigma: f64,
    /// The part distances' standard deviation, a calliper's (mm).
    pub distance_sigma: f64,
    /// The standard deviation of a height measured by hand (mm).
    pub height_sigma: f64,
    /// The trigger height's standard deviation about the configured one
    /// (RepRapFirmware's `G31 Z`; Klipper's `z_offset` with the probes it
    /// saved, else its probe's, else 0; Marlin's `-M851 Z`), a first-layer
    /// test's (mm).
    pub trigger_sigma: f64,
    /// The printable radius (mm) of a printer whose configuration states
    /// none: Marlin's, whose `PRINTABLE_RADIUS` is compiled in (needed
    /// for it, refused for the others, whose configuration states theirs).
    pub print_radius: Option<f64>,
    /// The radius trims of towers X, Y, Z (mm) of a Marlin compiled with
    /// them (`DELTA_RADIUS_TRIM_TOWER`, which `M503` does not report):
    /// the configured towers' own radius corrections (refused for the
    /// other firmwares, whose configuration states their geometry).
    pub radius_trims: Option<[f64; 3]>,
}

impl Default for ImportOptions {
    /// A kit printer's tolerances, a probe of 10 um, a calliper of 20 um,
    /// heights measured by hand and a trigger height known to 50 um.
    fn default() -> Self {
        Self {
            tolerances: Tolerances::default(),
            matched_rods: None,
            probe_sigma: 0.01,
            distance_sigma: 0.02,
            height_sigma: 0.05,
            trigger_sigma: 0.05,
            print_radius: None,
            radius_trims: None,
        }
    }
}

impl ImportOptions {
    /// Every standard deviation by its option's name (`parcal import`'s
    /// long flag with `_` for `-`).
    pub fn sigmas(&self) -> [(&'static str, Option<f64>); 12] {
        let t = &self.tolerances;
        [
            ("diagonal_tolerance", Some(t.diagonal)),
            ("matched_rods", self.matched_rods),
            ("radius_tolerance", Some(t.radius)),
            ("tower_radius_tolerance", Some(t.tower_radius)),
            ("angle_tolerance", Some(t.angle)),
            ("endstop_tolerance", Some(t.endstop)),
            ("homed_height_tolerance", Some(t.homed_height)),
            ("tilt_tolerance", Some(t.tilt)),
            ("probe_sigma", Some(self.probe_sigma)),
            ("distance_sigma", Some(self.distance_sigma)),
            ("height_sigma", Some(self.height_sigma)),
            ("trigger_sigma", Some(self.trigger_sigma)),
        ]
    }

    /// Whether every standard deviation is one: finite, positive and at
    /// most [`MAX_SIGMA`]; and the matched rods' at most the rods'
    /// tolerance.
    pub fn check(&self) -> Result<(), FirmwareImportError> {
        if let Some((option, value)) = self
            .sigmas()
            .into_iter()
            .find_map(|(option, value)| value.filter(|&v| !is_sigma(v)).map(|v| (option, v)))
        {
            return Err(FirmwareImportError::Sigma { option, value });
        }
        let tolerance = self.tolerances.diagonal;
        match self.matched_rods {
            Some(matched) if matched > tolerance => {
                Err(FirmwareImportError::Matched { matched, tolerance })
            }
            _ => Ok(()),
        }
    }
}

/// Whether `value` is a standard deviation [`ImportOptions`] accepts.
pub fn is_sigma(value: f64) -> bool {
    value.is_finite() && value > 0.0 && value <= MAX_SIGMA
}

/// The files of observations given (each `None`: not given).
#[derive(Debug, Clone, Copy, Default)]
pub struct ObservationFiles<'a> {
    /// The probe log (header `x,y,z`).
    pub probes: Option<&'a Path>,
    /// Part distances (header `x1,y1,z1,x2,y2,z2,distance`).
    pub distances: Option<&'a Path>,
    /// Heights measured by hand (header `x,y,z,height`).
    pub heights: Option<&'a Path>,
}

/// Where a kind of observation was read from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Source {
    /// A file given.
    File(PathBuf),
    /// The firmware's configuration, which saved them.
    Saved(PathBuf),
}

impl std::fmt::Display for Source {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::File(path) => write!(f, "{}", path.display()),
            Self::Saved(path) => write!(f, "saved in {}", path.display()),
        }
    }
}

/// A firmware's files as a mechanism dataset.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct FirmwareImport {
    /// The dataset (not yet written).
    pub dataset: MechanismDataset,
    /// Where its probe heights came from.
    pub probes_from: Source,
    /// Where its part distances came from, if it has any.
    pub distances_from: Option<Source>,
    /// Where its heights measured by hand came from, if it has any.
    pub heights_from: Option<Source>,
}

/// Why a firmware's files cannot be imported.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FirmwareImportError {
    /// The format's files are not imported (only a linear delta's are).
    #[error(
        "{0}'s files are not imported: only a linear delta's firmware (reprapfirmware, klipper, marlin)"
    )]
    NotImported(&'static str),
    /// Marlin's settings state no printable radius and none was given.
    #[error("{}: Marlin's M503 reports no printable radius (PRINTABLE_RADIUS is compiled in)", config.display())]
    NoPrintRadius {
        /// The configuration.
        config: PathBuf,
    },
    /// A printable radius given that is not a positive length, or given
    /// for a firmware whose configuration states its own.
    #[error("print_radius: {0}")]
    PrintRadius(String),
    /// Radius trims given for a firmware other than Marlin, or that no
    /// delta with the configured radius and rods has.
    #[error("radius_trims: {0}")]
    RadiusTrims(String),
    /// No probe log was given and the configuration saved no probes.
    #[error("{}: no probe log given{}", config.display(),
        if *klipper { ", and no probes saved (run DELTA_CALIBRATE and SAVE_CONFIG)" } else { "" })]
    NoProbes {
        /// The configuration.
        config: PathBuf,
        /// Whether it is Klipper's, which saves its probes.
        klipper: bool,
    },
    /// A tolerance or noise is not a standard deviation.
    #[error("{option}: {value} is not a standard deviation in (0, {MAX_SIGMA}]")]
    Sigma {
        /// The option's name.
        option: &'static str,
        /// Its value.
        value: f64,
    },
    /// The matched rods' sigma is more than the rods' tolerance.
    #[error(
        "matched_rods: {matched} is more than diagonal_tolerance {tolerance}: the rods of a matched set are closer to one another than to the design"
    )]
    Matched {
        /// The matched rods' sigma.
        matched: f64,
        /// The rods' tolerance.
        tolerance: f64,
    },
    /// A file cannot be read, or says something the firmware would not.
    #[error(transparent)]
    Firmware(#[from] FirmwareError),
}

/// What a firmware's files say: the configured parameters, the printable
/// radius, the trigger height and the probe's horizontal offsets from the
/// nozzle where a probe log's positions are the probe's (Marlin's).
struct Configured {
    params: DeltaParams,
    print_radius: f64,
    trigger_height: f64,
    probe_xy: [f64; 2],
}

/// The dataset of the printer configured in `config` (`format`'s file:
/// RepRapFirmware's config.g, Klipper's printer.cfg), probed as the log at
/// `files.probes` says (header `x,y,z`: the commanded XY and the height
/// reported there, mm), measured as `files.distances` says (header
/// `x1,y1,z1,x2,y2,z2,distance`) and as `files.heights` says (header
/// `x,y,z,height`, the nozzle's height above the bed measured by hand at a
/// commanded position); with Klipper each of them, when not given, what
/// its `DELTA_CALIBRATE` and `DELTA_ANALYZE` saved in printer.cfg (a file
/// given replaces what was saved, each kind its own).
pub fn firmware_import(
    format: FirmwareFormat,
    config: &Path,
    files: &ObservationFiles<'_>,
    options: &ImportOptions,
) -> Result<FirmwareImport, FirmwareImportError> {
    options.check()?;
    match (format, options.print_radius) {
        (FirmwareFormat::Marlin, Some(r)) if !is_print_radius(r) => {
            return Err(FirmwareImportError::PrintRadius(format!(
                "{} is not a positive number of mm up to {MAX_MAGNITUDE:e} (1 km)",
                parcal_dataset::shown(r)
            )));
        }
        (FirmwareFormat::RepRapFirmware | FirmwareFormat::Klipper, Some(_)) => {
            return Err(FirmwareImportError::PrintRadius(format!(
                "{}'s configuration states its own (M665 B, print_radius): the option is Marlin's",
                format.name()
            )));
        }
        _ => {}
    }
    check_radius_trims(format, options.radius_trims).map_err(FirmwareImportError::RadiusTrims)?;
    let (mut configured, saved) = match format {
        FirmwareFormat::RepRapFirmware => {
            let config = read_config(config)?;
            let configured = Configured {
                params: config.delta.to_params(),
                print_radius: config.delta.print_radius,
                trigger_height: config.probe.trigger_height,
                probe_xy: [0.0; 2],
            };
            (configured, DeltaCalibrateResults::default())
        }
        FirmwareFormat::Marlin => {
            let settings = marlin::read_config(config)?;
            let settings = settings
                .with_radius_trims(options.radius_trims.unwrap_or_default())
                .map_err(FirmwareImportError::RadiusTrims)?;
            let configured = Configured {
                params: settings.to_params(),
                print_radius: options.print_radius.ok_or_else(|| {
                    FirmwareImportError::NoPrintRadius {
                        config: config.to_path_buf(),
                    }
                })?,
                trigger_height: settings.trigger_height(),
                probe_xy: settings.probe_xy(),
            };
            (configured, DeltaCalibrateResults::default())
        }
        FirmwareFormat::Klipper => {
            let printer = read_printer(config)?;
            // A probe log's heights are PROBE's less the probe's z_offset:
            // each commanded position is PROBE's, at the z_offset.
            let configured = Configured {
                params: printer.delta.to_params(),
                print_radius: printer.delta.print_radius,
                trigger_height: printer.z_offset.unwrap_or_default(),
                probe_xy: [0.0; 2],
            };
            (configured, printer.saved)
        }
        FirmwareFormat::Hangprinter => {
            return Err(FirmwareImportError::NotImported(format.name()));
        }
    };
    let (probes, probes_from) = match files.probes {
        Some(path) => {
            let [dx, dy] = configured.probe_xy;
            let commanded = (read_probes(path)?.iter())
                .map(|p| [p.x - dx, p.y - dy, p.z + configured.trigger_height])
                .collect();
            (commanded, Source::File(path.to_path_buf()))
        }
        None if !saved.probes.is_empty() => {
            configured.trigger_height = saved.z_offset.unwrap_or_default();
            (saved.probes, Source::Saved(config.to_path_buf()))
        }
        None => {
            return Err(FirmwareImportError::NoProbes {
                config: config.to_path_buf(),
                klipper: format == FirmwareFormat::Klipper,
            });
        }
    };
    let (distances, distances_from) =
        file_or_saved(files.distances, read_distances, saved.distances, config)?;
    let (heights, heights_from) =
        file_or_saved(files.heights, read_heights, saved.manual_heights, config)?;
    let observations = Observed {
        probes,
        heights,
        distances,
    };
    Ok(FirmwareImport {
        dataset: dataset(&configured, observations, options),
        probes_from,
        distances_from,
        heights_from,
    })
}

/// The rows of the file at `path` if given (read by `read`), else those
/// `saved` in the configuration `config`, and where they came from (none
/// if there are none).
fn file_or_saved<const N: usize>(
    path: Option<&Path>,
    read: fn(&Path) -> Result<Vec<[f64; N]>, FirmwareError>,
    saved: Vec<[f64; N]>,
    config: &Path,
) -> Result<(Vec<[f64; N]>, Option<Source>), FirmwareError> {
    Ok(match path {
        Some(path) => (read(path)?, Some(Source::File(path.to_path_buf()))),
        None if !saved.is_empty() => (saved, Some(Source::Saved(config.to_path_buf()))),
        None => (Vec::new(), None),
    })
}

/// The observations of a firmware's files.
struct Observed {
    /// Each probe's commanded position at its trigger.
    probes: Vec<[f64; 3]>,
    /// Heights measured by hand: the commanded position, the height.
    heights: Vec<[f64; 4]>,
    /// Part distances.
    distances: Vec<[f64; 7]>,
}

/// The mechanism dataset of a firmware's configuration and what was
/// measured on the printer it configures.
fn dataset(
    configured: &Configured,
    observed: Observed,
    options: &ImportOptions,
) -> MechanismDataset {
    let Observed {
        probes,
        heights,
        distances,
    } = observed;
    // The kinematics only: the files state no joint or travel limits.
    let limits = Limits::reach_only(configured.print_radius);
    let delta = LinearDelta::new(&configured.params, &options.tolerances, limits);
    let mut machine = MechanismMachine::of(&delta);
    for parameter in delta.parameters() {
        if !machine
            .tolerances
            .iter()
            .any(|(group, _)| group == parameter.group)
        {
            machine
                .tolerances
                .push((parameter.group.to_string(), Some(parameter.prior_sigma)));
        }
    }
    if let Some(sigma) = options.matched_rods {
        machine.matched.push((RODS.to_string(), sigma));
    }
    machine.noise = Noise {
        probe: Some(options.probe_sigma),
        distance: (!distances.is_empty()).then_some(options.distance_sigma),
        height: (!heights.is_empty()).then_some(options.height_sigma),
        ..Noise::default()
    };
    machine.trigger_height = Some(ValuePrior {
        value: configured.trigger_height,
        sigma: Some(options.trigger_sigma),
    });
    machine.print_radius = Some(configured.print_radius);
    MechanismDataset {
        machine,
        probes,
        heights,
        distances,
        ..MechanismDataset::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A firmware's file refuses, naming its line, any number a dataset
    /// would refuse as a length: an import never writes a dataset its own
    /// check refuses.
    #[test]
    fn a_firmware_number_is_bounded_as_a_datasets_length() {
        assert_eq!(
            parcal_firmware::MAX_MAGNITUDE,
            parcal_dataset::MAX_LENGTH_MM
        );
    }

    #[test]
    fn a_tolerance_that_is_not_a_standard_deviation_is_named() {
        assert!(ImportOptions::default().check().is_ok());
        let named = |options: ImportOptions| match options.check() {
            Err(FirmwareImportError::Sigma { option, value }) => (option, value.to_string()),
            other => panic!("{other:?}"),
        };
        let mut options = ImportOptions::default();
        options.tolerances.angle = 0.0;
        assert_eq!(named(options), ("angle_tolerance", "0".to_string()));
        let options = ImportOptions {
            matched_rods: Some(f64::NAN),
            ..ImportOptions::default()
        };
        assert_eq!(named(options), ("matched_rods", "NaN".to_string()));
        // Matched rods closer to the design than the rods' tolerance says.
        let loose = ImportOptions {
            matched_rods: Some(0.8),
            ..ImportOptions::default()
        };
        let error = loose.check().unwrap_err().to_string();
        assert!(
            error.starts_with("matched_rods: 0.8 is more than diagonal_tolerance 0.5"),
            "{error}"
        );
        let options = ImportOptions {
            trigger_sigma: MAX_SIGMA * 1.5,
            ..ImportOptions::default()
        };
        assert_eq!(named(options), ("trigger_sigma", "150".to_string()));
    }

    #[test]
    fn a_cable_robots_files_are_not_imported() {
        let error = firmware_import(
            FirmwareFormat::Hangprinter,
            Path::new("config.g"),
            &ObservationFiles::default(),
            &ImportOptions::default(),
        )
        .unwrap_err();
        assert!(matches!(
            error,
            FirmwareImportError::NotImported("hangprinter")
        ));
    }
}
