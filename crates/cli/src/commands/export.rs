//! `parcal export`: a calibration in the forms other tools load
//! (docs/apply.md).

use std::path::PathBuf;

use anyhow::Context;
use parcal_apply::AppliedModel;
use parcal_apply::genhexkins::hal_snippet;
use parcal_apply::machine::calibrated_machine;
use parcal_apply::summary::summary;
use parcal_dataset::atomic::write_file;

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
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    crate::outputs::check(
        std::slice::from_ref(&args.calibration),
        std::slice::from_ref(&args.out),
    )?;
    let record = super::read_calibration(&args.calibration, args.accept_rejected)?;
    let model = AppliedModel::from_record(&record)
        .with_context(|| format!("{}", args.calibration.display()))?;
    match args.format {
        Format::MachineJson => calibrated_machine(&record, &model)?.write(&args.out)?,
        Format::Genhexkins => write_file(&args.out, hal_snippet(&model).as_bytes())?,
        Format::Summary => write_file(&args.out, summary(&record, &model).as_bytes())?,
    }
    println!("{}", args.out.display());
    Ok(())
}
