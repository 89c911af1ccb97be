//! `parcal export`: a calibration in the forms other tools load
//! (docs/apply.md; a linear delta's firmware, docs/delta.md). The format
//! decides the mechanism: a calibration of another is refused.

use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::apply::AppliedModel;
use parcal::apply::genhexkins::hal_snippet;
use parcal::apply::machine::calibrated_machine;
use parcal::apply::summary::summary;
use parcal::dataset::HEXAPOD;
use parcal::dataset::atomic::write_file;
use parcal::dataset::mechanism::MechanismCalibrationRecord;
use parcal::firmware::accuracy::Workspace;
use parcal::firmware::export::{Firmware, cost_sentence, export};
use parcal::firmware::hangprinter::HangprinterConfig;
use parcal::kinematics::cable::CableRobot;
use parcal::kinematics::delta::{DeltaParams, N_PARAMS};
use parcal::kinematics::mechanisms;

use super::Recorded;

/// What to export.
#[derive(Clone, Copy, clap::ValueEnum)]
enum Format {
    /// The calibrated machine.json in the design frame (the design of the
    /// next calibration).
    MachineJson,
    /// A LinuxCNC genhexkins HAL snippet (setp of the 36 joint coordinates).
    Genhexkins,
    /// A human-readable summary with the covariance.
    Summary,
    /// A linear delta's M665/M666 lines for RepRapFirmware's config.g.
    Reprapfirmware,
    /// A linear delta's SAVE_CONFIG block for Klipper's printer.cfg.
    Klipper,
    /// A cable robot's M669 anchors and M666 R spool radii for the
    /// Hangprinter's RepRapFirmware config.g.
    Hangprinter,
}

impl Format {
    /// The mechanism whose calibration this format exports.
    fn mechanism(self) -> &'static str {
        match self {
            Self::MachineJson | Self::Genhexkins | Self::Summary => HEXAPOD,
            Self::Reprapfirmware | Self::Klipper => "linear delta",
            Self::Hangprinter => "cable robot",
        }
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
    /// The printable radius of a delta (mm, M665 B or print_radius) that
    /// --format reprapfirmware and klipper write back. Default: the one the
    /// calibration carries from its dataset (parcal import keeps the
    /// firmware's).
    #[arg(long, value_name = "MM")]
    print_radius: Option<f64>,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    crate::outputs::check(
        std::slice::from_ref(&args.calibration),
        std::slice::from_ref(&args.out),
    )?;
    match args.format {
        Format::Reprapfirmware => export_delta(args, Firmware::RepRapFirmware)?,
        Format::Klipper => export_delta(args, Firmware::Klipper)?,
        Format::Hangprinter => export_hangprinter(args)?,
        Format::MachineJson | Format::Genhexkins | Format::Summary => export_hexapod(args)?,
    }
    println!("{}", args.out.display());
    Ok(())
}

/// Exports a hexapod's calibration as `args.format`.
fn export_hexapod(args: &Args) -> anyhow::Result<()> {
    let record = super::read_calibration(&args.calibration, args.accept_rejected)
        .map_err(|error| mismatch(&args.calibration, args.format).unwrap_or(error))?;
    let model = AppliedModel::from_record(&record)
        .with_context(|| format!("{}", args.calibration.display()))?;
    let text = match args.format {
        Format::MachineJson => return Ok(calibrated_machine(&record, &model)?.write(&args.out)?),
        Format::Genhexkins => hal_snippet(&model),
        _ => summary(&record, &model),
    };
    write_file(&args.out, text.as_bytes())?;
    Ok(())
}

/// The error of a calibration at `path` that is of another mechanism than
/// `format` exports, or a hexapod's through the common path (whose record
/// has neither the design nor its frames) for a hexapod's format, if it
/// is one (read as either kind of calibration).
fn mismatch(path: &Path, format: Format) -> Option<anyhow::Error> {
    let mechanism = match super::read_either(path).ok()? {
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

/// Exports a linear delta's calibration for `firmware`: what the
/// firmware cannot hold and what that costs are printed and written in
/// the file's comment lines.
fn export_delta(args: &Args, firmware: Firmware) -> anyhow::Result<()> {
    let path = &args.calibration;
    let record = mechanism_record(args)?;
    let print_radius = print_radius(args, &record)?;
    let calibrated = delta_parameters(&record, path)?;
    let workspace = Workspace::of_printer(print_radius, calibrated.homed_height);
    let exported = export(&calibrated, print_radius, firmware, &workspace)
        .with_context(|| format!("{}", path.display()))?;
    write_file(&args.out, exported.text.as_bytes())?;
    for sentence in &exported.lost {
        println!("lost: {sentence}");
    }
    println!("cost: {}", cost_sentence(&exported.cost, &workspace));
    Ok(())
}

/// The printable radius a delta's export writes back: `--print-radius`,
/// else the one the calibration's record carries from its dataset
/// (machine.json's, which `parcal import` takes from the firmware).
fn print_radius(args: &Args, record: &MechanismCalibrationRecord) -> anyhow::Result<f64> {
    if let Some(radius) = args.print_radius {
        anyhow::ensure!(
            radius.is_finite() && radius > 0.0,
            "--print-radius must be a positive number of mm, got {radius}"
        );
        return Ok(radius);
    }
    match record.print_radius {
        Some(radius) => {
            println!("printable radius: {radius} mm (the calibration's dataset's)");
            Ok(radius)
        }
        None => anyhow::bail!(
            "{}: the calibration states no printable radius (its dataset's machine.json has no print_radius): --format {} needs --print-radius (M665 B or print_radius)",
            args.calibration.display(),
            args.format.name()
        ),
    }
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

/// Exports a cable robot's calibration as the Hangprinter's `M669` and
/// `M666 R` lines.
fn export_hangprinter(args: &Args) -> anyhow::Result<()> {
    let path = &args.calibration;
    let record = mechanism_record(args)?;
    let robot = CableRobot::typical();
    let values = named_values(&record, path)?;
    let config = HangprinterConfig::from_params(&robot, &values)
        .with_context(|| format!("{}", path.display()))?;
    write_file(&args.out, config.lines().as_bytes())?;
    Ok(())
}

/// The delta's parameters of a calibration record, by name.
fn delta_parameters(
    record: &MechanismCalibrationRecord,
    path: &Path,
) -> anyhow::Result<DeltaParams> {
    let values = named_values(record, path)?;
    anyhow::ensure!(
        values.len() == N_PARAMS,
        "{}: not a linear delta's parameters",
        path.display()
    );
    Ok(DeltaParams::from_slice(&values))
}

/// The values of a calibration record's mechanism parameters, in the
/// mechanism's order, by name.
fn named_values(record: &MechanismCalibrationRecord, path: &Path) -> anyhow::Result<Vec<f64>> {
    let mechanism = mechanisms::by_name(&record.mechanism).with_context(|| {
        format!(
            "{}: unknown mechanism {:?}",
            path.display(),
            record.mechanism
        )
    })?;
    mechanism
        .parameters()
        .iter()
        .map(|p| {
            record.parameter(&p.name).map(|r| r.value).with_context(|| {
                format!(
                    "{}: no parameter {} of the {}",
                    path.display(),
                    p.name,
                    record.mechanism
                )
            })
        })
        .collect()
}
