//! `parcal import`: a printer's firmware configuration and probe log (or
//! the probes its firmware saved with its configuration, Klipper's) as a
//! mechanism dataset ([`parcal::firmware_import`], docs/delta.md).

use std::path::PathBuf;

use parcal::firmware_import::{
    FirmwareImportError, ImportOptions, MAX_SIGMA, ObservationFiles, Source, firmware_import,
    is_sigma,
};
use parcal::firmware_lines::FirmwareFormat;
use parcal::kinematics::delta::Tolerances;

#[derive(clap::Args)]
pub struct Args {
    #[command(subcommand)]
    firmware: Firmware,
}

#[derive(clap::Subcommand)]
enum Firmware {
    /// RepRapFirmware: config.g's M665, M666 and G31 lines, and the
    /// heights G30 S-1 reported.
    Reprapfirmware(FirmwareArgs),
    /// Klipper: printer.cfg's delta settings (the SAVE_CONFIG block
    /// included) and the probes, manual heights and part distances its
    /// DELTA_CALIBRATE and DELTA_ANALYZE saved, or the probe heights of
    /// --probes less the probe's z_offset.
    Klipper(FirmwareArgs),
    /// Marlin: the M665, M666 and M851 lines M503 reported, and the
    /// heights G30 reported at the probe's XY.
    Marlin(MarlinArgs),
}

#[derive(clap::Args)]
struct MarlinArgs {
    #[command(flatten)]
    files: FirmwareArgs,
    /// The printable radius (mm, Configuration.h's PRINTABLE_RADIUS, which
    /// M503 does not report).
    #[arg(long, value_name = "MM")]
    print_radius: f64,
    /// The radius trims of towers X, Y, Z the firmware was compiled with
    /// (mm, Configuration.h's DELTA_RADIUS_TRIM_TOWER, which M503 does not
    /// report; default 0,0,0): each tower stands at the delta radius plus
    /// its trim.
    #[arg(long, value_name = "X,Y,Z", value_parser = radius_trims)]
    radius_trims: Option<[f64; 3]>,
}

/// `--radius-trims` (also `parcal export`'s): three numbers, `X,Y,Z`
/// (mm); the import and the export check their values.
pub(crate) fn radius_trims(text: &str) -> Result<[f64; 3], String> {
    super::numbers(text, "three radius trims X,Y,Z (mm), one for each tower")
}

#[derive(clap::Args)]
struct FirmwareArgs {
    /// The firmware's configuration (config.g, printer.cfg, or what
    /// Marlin's M503 reported).
    #[arg(long)]
    config: PathBuf,
    /// The probe log: header x,y,z, the commanded XY of each probe (with
    /// Marlin, the probe's, as G30 takes them) and the height reported
    /// there (mm). Klipper's without it: the probes its DELTA_CALIBRATE
    /// saved in printer.cfg.
    #[arg(long)]
    probes: Option<PathBuf>,
    /// Part distances measured on a printed part: header
    /// x1,y1,z1,x2,y2,z2,distance, two commanded positions and the distance
    /// measured between them (mm). Klipper's without it: those its
    /// DELTA_ANALYZE saved in printer.cfg, if any.
    #[arg(long)]
    distances: Option<PathBuf>,
    /// Heights of the nozzle above the bed measured by hand (a gauge block
    /// or feeler gauge): header x,y,z,height, the commanded position and
    /// the height measured there (mm). Klipper's without it: those its
    /// DELTA_ANALYZE MANUAL_HEIGHT saved in printer.cfg, if any.
    #[arg(long)]
    heights: Option<PathBuf>,
    /// The dataset directory to write (it must not exist or be empty,
    /// unless --force).
    #[arg(long)]
    out: PathBuf,
    /// Replace an existing dataset at --out, as a whole.
    #[arg(long)]
    force: bool,
    #[command(flatten)]
    tolerances: ToleranceArgs,
}

/// The builder's tolerances (one standard deviation each) and the probe's
/// noise; the defaults are a kit printer's ([`Tolerances::default`]).
#[derive(clap::Args)]
pub struct ToleranceArgs {
    /// Diagonal rods, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().diagonal, value_parser = sigma)]
    diagonal_tolerance: f64,
    /// The rods were cut as a matched set: each within MM of the set's
    /// length (at most the rods' tolerance), so that their differences
    /// are known far better than their length.
    #[arg(long, value_name = "MM", value_parser = sigma)]
    matched_rods: Option<f64>,
    /// Delta radius, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().radius, value_parser = sigma)]
    radius_tolerance: f64,
    /// Each tower's own radius, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().tower_radius, value_parser = sigma)]
    tower_radius_tolerance: f64,
    /// Tower angles, degrees.
    #[arg(long, value_name = "DEG", default_value_t = Tolerances::default().angle, value_parser = sigma)]
    angle_tolerance: f64,
    /// Endstops, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().endstop, value_parser = sigma)]
    endstop_tolerance: f64,
    /// Homed height, mm.
    #[arg(long, value_name = "MM", default_value_t = Tolerances::default().homed_height, value_parser = sigma)]
    homed_height_tolerance: f64,
    /// Bed tilt, percent.
    #[arg(long, value_name = "PERCENT", default_value_t = Tolerances::default().tilt, value_parser = sigma)]
    tilt_tolerance: f64,
    /// The probe's repeatability, mm.
    #[arg(long, value_name = "MM", default_value_t = ImportOptions::default().probe_sigma, value_parser = sigma)]
    probe_sigma: f64,
    /// The part distances' standard deviation (a calliper's), mm.
    #[arg(long, value_name = "MM", default_value_t = ImportOptions::default().distance_sigma, value_parser = sigma)]
    distance_sigma: f64,
    /// The standard deviation of a height measured by hand, mm.
    #[arg(long, value_name = "MM", default_value_t = ImportOptions::default().height_sigma, value_parser = sigma)]
    height_sigma: f64,
    /// The trigger height's standard deviation about the configured one
    /// (G31 Z; Klipper's z_offset with the probes it saved, else 0;
    /// Marlin's -M851 Z), mm: a first-layer test's.
    #[arg(long, value_name = "MM", default_value_t = ImportOptions::default().trigger_sigma, value_parser = sigma)]
    trigger_sigma: f64,
}

impl ToleranceArgs {
    fn options(&self) -> ImportOptions {
        let mut options = ImportOptions::default();
        options.tolerances = Tolerances {
            endstop: self.endstop_tolerance,
            homed_height: self.homed_height_tolerance,
            radius: self.radius_tolerance,
            tower_radius: self.tower_radius_tolerance,
            angle: self.angle_tolerance,
            diagonal: self.diagonal_tolerance,
            tilt: self.tilt_tolerance,
        };
        options.matched_rods = self.matched_rods;
        options.probe_sigma = self.probe_sigma;
        options.distance_sigma = self.distance_sigma;
        options.height_sigma = self.height_sigma;
        options.trigger_sigma = self.trigger_sigma;
        options
    }
}

/// A standard deviation ([`is_sigma`]).
fn sigma(text: &str) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|e| format!("{e}"))?;
    if is_sigma(value) {
        Ok(value)
    } else {
        Err(format!(
            "{text} is not a standard deviation in (0, {MAX_SIGMA}]"
        ))
    }
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let (format, firmware, files, marlin) = match &args.firmware {
        Firmware::Reprapfirmware(files) => (
            FirmwareFormat::RepRapFirmware,
            "RepRapFirmware",
            files,
            None,
        ),
        Firmware::Klipper(files) => (FirmwareFormat::Klipper, "Klipper", files, None),
        Firmware::Marlin(marlin) => (
            FirmwareFormat::Marlin,
            "Marlin",
            &marlin.files,
            Some(marlin),
        ),
    };
    let mut options = files.tolerances.options();
    options.print_radius = marlin.map(|m| m.print_radius);
    options.radius_trims = marlin.and_then(|m| m.radius_trims);
    let imported = firmware_import(
        format,
        &files.config,
        &ObservationFiles {
            probes: files.probes.as_deref(),
            distances: files.distances.as_deref(),
            heights: files.heights.as_deref(),
        },
        &options,
    )
    .map_err(|error| match error {
        FirmwareImportError::NoProbes { .. } => {
            anyhow::anyhow!("{error}: give --probes (header x,y,z)")
        }
        FirmwareImportError::PrintRadius(reason) => {
            anyhow::anyhow!("--print-radius: {reason}")
        }
        FirmwareImportError::RadiusTrims(reason) => {
            anyhow::anyhow!("--radius-trims: {reason}")
        }
        error => error.into(),
    })?;
    let dataset = &imported.dataset;
    let from =
        |source: Option<&Source>| source.map(|from| format!(" ({from})")).unwrap_or_default();
    let heights = match imported.heights_from {
        Some(_) => format!(
            ", {} heights measured by hand{}",
            dataset.heights.len(),
            from(imported.heights_from.as_ref())
        ),
        None => String::new(),
    };
    dataset.write_with(&files.out, files.force)?;
    println!(
        "{}: {firmware}'s configuration ({}), {} probe heights ({}){heights} and {} part distances{}",
        files.out.display(),
        files.config.display(),
        dataset.probes.len(),
        imported.probes_from,
        dataset.distances.len(),
        from(imported.distances_from.as_ref()),
    );
    Ok(())
}
