//! `parcal export`: a calibration in the forms other tools load
//! (docs/apply.md; a linear delta's firmware, docs/delta.md). The format
//! decides the mechanism: a calibration of another is refused.

use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::dataset::HEXAPOD;
use parcal::dataset::atomic::write_file;
use parcal::dataset::mechanism::MechanismCalibrationRecord;
use parcal::firmware_lines::{
    FirmwareFormat, FirmwareLinesError, firmware_lines, refused_print_radius,
};
use parcal::hexapod_export::{HexapodFormat, hexapod_export};
use parcal::mechanism_machine::{machine_path, mechanism_machine_json};

use parcal::command::{Recorded, read_either};

/// What to export.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    /// The calibrated machine.json (the design of the next calibration): a
    /// hexapod's in the design frame; a mechanism's from the machine.json
    /// it was calibrated from (--machine).
    MachineJson,
    /// A LinuxCNC genhexkins HAL snippet (setp of the 36 joint coordinates).
    Genhexkins,
    /// A human-readable summary with the covariance.
    Summary,
    /// A linear delta's M665/M666 lines for RepRapFirmware's config.g.
    Reprapfirmware,
    /// A linear delta's SAVE_CONFIG block for Klipper's printer.cfg.
    Klipper,
    /// A linear delta's M665/M666 lines and M500 for Marlin.
    Marlin,
    /// A cable robot's M669 anchors and M666 R spool radii for the
    /// Hangprinter's RepRapFirmware config.g.
    Hangprinter,
}

impl Format {
    /// The firmware this format writes a mechanism's lines for; `None`
    /// for the machine.json and a hexapod's formats.
    fn firmware(self) -> Option<FirmwareFormat> {
        match self {
            Self::MachineJson | Self::Genhexkins | Self::Summary => None,
            Self::Reprapfirmware => Some(FirmwareFormat::RepRapFirmware),
            Self::Klipper => Some(FirmwareFormat::Klipper),
            Self::Marlin => Some(FirmwareFormat::Marlin),
            Self::Hangprinter => Some(FirmwareFormat::Hangprinter),
        }
    }

    /// The mechanism whose calibration this format exports.
    fn mechanism(self) -> &'static str {
        self.firmware().map_or(HEXAPOD, FirmwareFormat::mechanism)
    }

    /// The format's name on the command line.
    fn name(self) -> String {
        clap::ValueEnum::to_possible_value(&self)
            .map(|value| value.get_name().to_string())
            .unwrap_or_default()
    }
}

#[derive(clap::Args)]
pub struct Args {
    /// The calibration (calibration.json; it carries the design).
    #[arg(long)]
    calibration: PathBuf,
    /// The form to write.
    #[arg(long, value_enum)]
    format: Format,
    /// The output file.
    #[arg(long)]
    out: PathBuf,
    /// Use a calibration whose verdict is "rejected".
    #[arg(long)]
    accept_rejected: bool,
    /// The printable radius of a delta (mm, M665 B, print_radius or
    /// Marlin's PRINTABLE_RADIUS) that --format reprapfirmware writes back
    /// and the cost is taken over. Default: the one the
    /// calibration carries from its dataset (parcal import keeps the
    /// firmware's).
    #[arg(long, value_name = "MM")]
    print_radius: Option<f64>,
    /// With --format marlin: the radius trims of towers X, Y, Z the
    /// firmware was compiled with (mm, DELTA_RADIUS_TRIM_TOWER). Default:
    /// the towers' radius corrections the calibration's prior states (those
    /// parcal import marlin was given, else 0,0,0).
    #[arg(long, value_name = "X,Y,Z", value_parser = super::import::radius_trims)]
    radius_trims: Option<[f64; 3]>,
    /// With --format klipper: the printer's printer.cfg, written to --out
    /// whole with its SAVE_CONFIG block updated as Klipper's SAVE_CONFIG
    /// would (its other sections and options kept: a saved
    /// [delta_calibrate], the probe's z_offset, a bed mesh).
    #[arg(long, value_name = "PRINTER_CFG")]
    config: Option<PathBuf>,
    /// With --format machine-json and a mechanism's calibration (a delta,
    /// a cable robot): the machine.json it was calibrated from, whose
    /// noise, tolerances and configured parameters the calibrated one
    /// keeps. Default: the one in the dataset the calibration names, else
    /// the one beside the calibration.
    #[arg(long, value_name = "MACHINE_JSON")]
    machine: Option<PathBuf>,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let inputs: Vec<PathBuf> = std::iter::once(&args.calibration)
        .chain(&args.config)
        .chain(&args.machine)
        .cloned()
        .collect();
    crate::outputs::check(&inputs, std::slice::from_ref(&args.out))?;
    anyhow::ensure!(
        args.machine.is_none() || matches!(args.format, Format::MachineJson),
        "--machine: a mechanism's machine.json is what --format machine-json starts from; --format {} does not read one",
        args.format.name()
    );
    match args.format.firmware() {
        Some(firmware) => export_firmware(args, firmware)?,
        None => {
            let text = match args.format {
                Format::MachineJson => machine_json(args)?,
                _ => hexapod_text(
                    args,
                    super::read_calibration(&args.calibration, args.accept_rejected).map_err(
                        |error| mismatch(&args.calibration, args.format).unwrap_or(error),
                    )?,
                )?,
            };
            write_file(&args.out, text.as_bytes())?;
        }
    }
    println!("{}", args.out.display());
    Ok(())
}

/// The text of `record`, a hexapod's own calibration, as `args.format`.
fn hexapod_text(args: &Args, record: parcal::dataset::Calibration) -> anyhow::Result<String> {
    anyhow::ensure!(
        args.radius_trims.is_none(),
        "--radius-trims: radius trims are Marlin's (DELTA_RADIUS_TRIM_TOWER, compiled in), not a {}'s",
        args.format.mechanism()
    );
    anyhow::ensure!(
        args.config.is_none(),
        "--config: --format {} is written alone: only Klipper's lines are written into a configuration (its printer.cfg)",
        args.format.name()
    );
    let format = HexapodFormat::by_name(&args.format.name())
        .expect("a hexapod's format is named as the facade names it");
    hexapod_export(&record, format).with_context(|| format!("{}", args.calibration.display()))
}

/// The calibrated machine.json of `args.calibration`: a hexapod's own
/// calibration's ([`hexapod_text`]), or a mechanism's from the machine.json
/// it was calibrated from (`--machine`, else its dataset's; the one read
/// is printed).
fn machine_json(args: &Args) -> anyhow::Result<String> {
    let path = &args.calibration;
    let record = match read_either(path) {
        Ok(Recorded::Mechanism(record)) if record.mechanism != HEXAPOD => record,
        Ok(Recorded::Own(record)) if args.machine.is_none() => {
            return hexapod_text(args, super::accepted(*record, path, args.accept_rejected)?);
        }
        Ok(Recorded::Own(_)) => anyhow::bail!(
            "--machine: {}: a hexapod's own calibration carries the design it started from",
            path.display()
        ),
        Ok(Recorded::Mechanism(_)) => {
            return Err(mismatch(path, args.format).unwrap_or_else(|| {
                anyhow::anyhow!("{}: a hexapod's common record", path.display())
            }));
        }
        Err(error) => return Err(error.into()),
    };
    let record = super::accepted(*record, path, args.accept_rejected)?;
    anyhow::ensure!(
        args.radius_trims.is_none() && args.config.is_none() && args.print_radius.is_none(),
        "--print-radius, --radius-trims and --config are a firmware's: --format machine-json keeps the printable radius of the machine.json it starts from"
    );
    let machine = machine_path(&record, args.machine.as_deref(), Some(path))
        .map_err(|error| anyhow::anyhow!("{}: {error} (--machine)", path.display()))?;
    crate::outputs::check(
        std::slice::from_ref(&machine),
        std::slice::from_ref(&args.out),
    )?;
    if args.machine.is_none() {
        println!("machine: {}", machine.display());
    }
    Ok(mechanism_machine_json(&record, &machine)?)
}

/// The error of a calibration at `path` that is of another mechanism than
/// `format` exports, or a hexapod's through the common path (whose record
/// has neither the design nor its frames) for a hexapod's format, if it
/// is one (read as either kind of calibration).
fn mismatch(path: &Path, format: Format) -> Option<anyhow::Error> {
    let mechanism = match read_either(path).ok()? {
        Recorded::Mechanism(record)
            if record.mechanism == HEXAPOD && format.mechanism() == HEXAPOD =>
        {
            return Some(anyhow::anyhow!(
                "{}: a hexapod's calibration through the common path, a mechanism's record (its parameters in the canonical frames, without the design it started from); --format {} exports the hexapod's own calibration (parcal calibrate without --common)",
                path.display(),
                format.name()
            ));
        }
        Recorded::Mechanism(record) => record.mechanism,
        Recorded::Own(_) => HEXAPOD.to_string(),
    };
    mismatch_of(path, &mechanism, format)
}

/// The error of a calibration of `mechanism` at `path` when `format`
/// exports another mechanism's.
fn mismatch_of(path: &Path, mechanism: &str, format: Format) -> Option<anyhow::Error> {
    (mechanism != format.mechanism()).then(|| {
        anyhow::anyhow!(
            "{}: a {mechanism} calibration; --format {} exports a {}'s",
            path.display(),
            format.name(),
            format.mechanism()
        )
    })
}

/// Exports a linear delta's or a cable robot's calibration as `format`'s
/// lines: what the firmware cannot hold and what that costs are printed
/// (and written in a delta's comment lines), as is the printable radius
/// the calibration carries when `--print-radius` does not give one.
fn export_firmware(args: &Args, format: FirmwareFormat) -> anyhow::Result<()> {
    let path = &args.calibration;
    let record = mechanism_record(args)?;
    let lines = firmware_lines(
        &record,
        format,
        args.print_radius,
        args.radius_trims,
        args.config.as_deref(),
    )
    .map_err(|error| match error {
        FirmwareLinesError::NoPrintRadius => anyhow::anyhow!(
            "{}: {error}: --format {} needs --print-radius (M665 B or print_radius)",
            path.display(),
            format.name()
        ),
        FirmwareLinesError::PrintRadius(radius) => {
            anyhow::anyhow!(refused_print_radius("--print-radius", radius))
        }
        FirmwareLinesError::Into(_) => anyhow::anyhow!("--config: {error}"),
        FirmwareLinesError::RadiusTrims(_) => anyhow::anyhow!("--radius-trims: {error}"),
        error => anyhow::anyhow!("{}: {error}", path.display()),
    })?;
    if let Some((_, workspace)) = lines.cost.filter(|_| args.print_radius.is_none()) {
        println!(
            "printable radius: {} mm (the calibration's dataset's)",
            workspace.print_radius
        );
    }
    if let Some(trims @ [x, y, z]) = lines.radius_trims.filter(|_| args.radius_trims.is_none())
        && trims != [0.0; 3]
    {
        println!(
            "radius trims: {x}, {y}, {z} mm (DELTA_RADIUS_TRIM_TOWER, the calibration's prior's; --radius-trims states others)"
        );
    }
    write_file(&args.out, lines.text.as_bytes())?;
    for sentence in &lines.lost {
        println!("lost: {sentence}");
    }
    if let Some(sentence) = lines.cost_sentence() {
        println!("cost: {sentence}");
    }
    if let Some(sentence) = &lines.trigger_sentence {
        println!("{sentence}");
    }
    Ok(())
}

/// The calibration record of `args`, of the mechanism `args.format`
/// exports, accepted or `--accept-rejected`.
fn mechanism_record(args: &Args) -> anyhow::Result<MechanismCalibrationRecord> {
    let path = &args.calibration;
    let record = MechanismCalibrationRecord::read(path)
        .map_err(|error| mismatch(path, args.format).unwrap_or_else(|| error.into()))?;
    if let Some(error) = mismatch_of(path, &record.mechanism, args.format) {
        return Err(error);
    }
    anyhow::ensure!(
        record.accepted || args.accept_rejected,
        "{}: the calibration was rejected ({}); give --accept-rejected to use it anyway",
        path.display(),
        record.reasons.join("; ")
    );
    Ok(record)
}
