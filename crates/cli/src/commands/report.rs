//! `parcal report`: the report of one calibration, a self-contained HTML
//! page (or Markdown) a metrologist can sign: verdict and tests first.

use std::io::Write;
use std::path::PathBuf;

use parcal_report::calibration_report::{Format, Subject, predicted_accuracy, render};

#[derive(Clone, Copy, clap::ValueEnum)]
enum ReportFormat {
    /// One self-contained HTML page (inline SVG figures, no script).
    Html,
    /// Markdown (figures only by their caption).
    Markdown,
}

#[derive(clap::Args)]
pub struct Args {
    /// The calibration.json to report on (a rejected one too).
    #[arg(long)]
    calibration: PathBuf,
    /// The dataset it was computed from (directory or snapshot): its
    /// machine places the accuracy map, and a simulation's truth adds the
    /// true error. Without it, calibration.json's design machine is used.
    #[arg(long)]
    dataset: Option<PathBuf>,
    /// Use a dataset other than the one calibrated (its checksum differs).
    #[arg(long)]
    other_data: bool,
    /// The report's file.
    #[arg(long)]
    out: PathBuf,
    /// The report's form.
    #[arg(long, value_enum, default_value = "html")]
    format: ReportFormat,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let mut inputs = args
        .dataset
        .as_deref()
        .map(crate::outputs::dataset_inputs)
        .unwrap_or_default();
    inputs.push(args.calibration.clone());
    crate::outputs::check(&inputs, std::slice::from_ref(&args.out))?;
    let calibration = parcal_dataset::Calibration::read(&args.calibration)?;
    let dataset = args
        .dataset
        .as_deref()
        .map(super::read_dataset)
        .transpose()?;
    if let (Some(dataset), Some(provenance)) = (&dataset, &calibration.provenance) {
        anyhow::ensure!(
            args.other_data || provenance.dataset_checksum == dataset.checksum(),
            "{}: the calibration is of another dataset ({}, checksum {}; this one's is {}); give --other-data to report with it anyway",
            args.calibration.display(),
            provenance.dataset,
            provenance.dataset_checksum,
            dataset.checksum()
        );
    }
    let file = args.calibration.display().to_string();
    let subject = Subject {
        calibration: &calibration,
        file: &file,
        accuracy: predicted_accuracy(&calibration, dataset.as_ref()),
    };
    let format = match args.format {
        ReportFormat::Html => Format::Html,
        ReportFormat::Markdown => Format::Markdown,
    };
    parcal_report::write_text(&args.out, &render(&subject, format)?)?;
    writeln!(
        std::io::stdout().lock(),
        "verdict: {}\nreport written to {}",
        if calibration.verdict.is_empty() {
            "none recorded"
        } else {
            &calibration.verdict
        },
        args.out.display()
    )?;
    Ok(())
}
