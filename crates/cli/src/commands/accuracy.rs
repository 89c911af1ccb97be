//! `parcal accuracy`: the accuracy maps of docs/paper-scenario.md section 5 as CSV and SVG.

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use parcal::dataset::atomic::write_set;
use parcal::maps::{MapsError, accuracy_maps, calibrated_params};
use parcal::report::maps::{map_files, write_maps};
use parcal::report::tables;

#[derive(clap::Args)]
pub struct Args {
    /// Dataset directory, or a binary snapshot file (dataset.bin).
    dataset: PathBuf,
    /// A calibration.json to assess (its parameters and posterior covariance);
    /// without it only the design (before calibration) is assessed.
    #[arg(long)]
    calibration: Option<PathBuf>,
    /// Output directory for accuracy.csv and the SVG maps.
    #[arg(long)]
    out: PathBuf,
    /// Use a calibration whose verdict is "rejected".
    #[arg(long)]
    accept_rejected: bool,
    /// Use a calibration of another dataset (its checksum differs from this one's).
    #[arg(long)]
    other_data: bool,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let dataset = super::read_dataset(&args.dataset)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut inputs = crate::outputs::dataset_inputs(&args.dataset);
    inputs.extend(args.calibration.clone());
    crate::outputs::check(&inputs, &map_files(&args.out, ""))?;
    let calibrated = args
        .calibration
        .as_ref()
        .map(|path| -> anyhow::Result<_> {
            let calibration = super::read_calibration(path, args.accept_rejected)?;
            calibrated_params(&calibration, &dataset, args.other_data)
                .map_err(|error| match error {
                    MapsError::OtherData(_) => {
                        anyhow::anyhow!("{error}; give --other-data to map it here anyway")
                    }
                    error => error.into(),
                })
                .with_context(|| path.display().to_string())
        })
        .transpose()?;
    let maps = accuracy_maps(&dataset, calibrated.as_ref())?;
    // The maps as a set that replaces every map of an earlier run: a map
    // this run does not draw (the true ones without truth.json, those
    // after calibration without --calibration) does not stay beside the
    // new ones.
    let files = map_files(&args.out, "");
    let pictures = write_set(&files, || write_maps(&args.out, "", "accuracy", &maps))?;
    let mut stdout = std::io::stdout().lock();
    writeln!(
        stdout,
        "{}",
        tables::accuracy(&[("design (propagated prior) / calibration", &maps)])
    )?;
    writeln!(
        stdout,
        "wrote {} and {} SVG maps to {}",
        args.out.join("accuracy.csv").display(),
        pictures.len(),
        args.out.display()
    )?;
    Ok(())
}
