//! `parcal report`: the report of one calibration, a self-contained HTML
//! page and its Markdown twin a metrologist can sign: verdict and tests
//! first.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::calibration::mechanism::MechanismData;
use parcal::dataset::HEXAPOD;
use parcal::dataset::atomic::write_set;
use parcal::dataset::mechanism::{MechanismCalibrationRecord, MechanismDataset};
use parcal::report::calibration_report::{Format, Subject, predicted_accuracy, render};
use parcal::report::mechanism::FromDataset;

/// The report's two files in its directory: the HTML page and the Markdown.
pub const REPORT_FILES: [(&str, Format); 2] = [
    ("report.html", Format::Html),
    ("report.md", Format::Markdown),
];

#[derive(clap::Args)]
pub struct Args {
    /// The calibration.json to report on (a rejected one too).
    calibration: PathBuf,
    /// The dataset it was computed from (directory or snapshot): its
    /// machine places the accuracy map, and a simulation's truth adds the
    /// true error. Without it, calibration.json's design machine is used.
    #[arg(long)]
    dataset: Option<PathBuf>,
    /// Use a dataset other than the one calibrated (its checksum differs).
    #[arg(long)]
    other_data: bool,
    /// The directory of report.html and report.md (default: the
    /// calibration's directory).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
}

pub fn run(args: &Args) -> anyhow::Result<()> {
    let directory = args
        .out
        .clone()
        .unwrap_or_else(|| directory_of(&args.calibration).to_path_buf());
    let mut inputs = args
        .dataset
        .as_deref()
        .map(crate::outputs::dataset_inputs)
        .unwrap_or_default();
    inputs.push(args.calibration.clone());
    if args.out.is_some() && !directory.exists() {
        std::fs::create_dir_all(&directory)
            .with_context(|| format!("{}: cannot create the directory", directory.display()))?;
    }
    crate::outputs::check(&inputs, &report_paths(&directory))?;
    let calibration = match super::read_either(&args.calibration)? {
        super::Recorded::Own(calibration) => *calibration,
        super::Recorded::Mechanism(record) => return write_mechanism(&record, args, &directory),
    };
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
    write(&subject, &directory)?;
    writeln!(
        std::io::stdout().lock(),
        "verdict: {}\nreport written to {}",
        if calibration.verdict.is_empty() {
            "none recorded"
        } else {
            &calibration.verdict
        },
        listed(&directory)
    )?;
    Ok(())
}

/// The directory a file is in (`.` for a bare name).
pub fn directory_of(file: &Path) -> &Path {
    match file.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    }
}

/// Writes the report of a mechanism's calibration `record` (read from
/// `args.calibration`) into `directory` (report.html and report.md, as a
/// set); with `args.dataset`, what it adds: a mechanism's probe residuals
/// over the bed, a simulated machine's truth (a hexapod's, through the
/// common path, has no probes).
fn write_mechanism(
    record: &MechanismCalibrationRecord,
    args: &Args,
    directory: &Path,
) -> anyhow::Result<()> {
    let (mut probes, mut truth) = (None, None);
    let mechanism_dataset;
    match &args.dataset {
        Some(path) if record.mechanism == HEXAPOD => {
            let dataset = super::read_dataset(path)?;
            let trackers: Vec<&str> = record.trackers.iter().map(|t| t.label.as_str()).collect();
            truth = super::truth::hexapod(&dataset, record.parameters.len(), &trackers)
                .map_err(|error| anyhow::anyhow!("{}: {error:#}", path.display()))?;
        }
        Some(path) => {
            mechanism_dataset = MechanismDataset::read(path)?;
            let data = MechanismData::from_dataset(&mechanism_dataset)
                .map_err(|error| anyhow::anyhow!("{}: {error}", path.display()))?;
            truth = super::truth::mechanism(path, &mechanism_dataset, &data)?;
            probes = Some(mechanism_dataset.probes.as_slice());
        }
        None => {}
    }
    let from_dataset = FromDataset {
        probes,
        truth: truth.as_ref().map(|t| t.values.as_slice()),
        true_frames: truth.as_ref().map(|t| t.frames.as_slice()),
    };
    let file = args.calibration.display().to_string();
    write_set(&[], || {
        write_mechanism_report(record, &file, from_dataset, directory)
    })?;
    writeln!(
        std::io::stdout().lock(),
        "{}\nreport written to {}",
        parcal::report::mechanism::verdict_sentence(record),
        listed(directory)
    )?;
    Ok(())
}

/// The report's files in `directory` ([`REPORT_FILES`]).
pub fn report_paths(directory: &Path) -> Vec<PathBuf> {
    REPORT_FILES
        .iter()
        .map(|(name, _)| directory.join(name))
        .collect()
}

/// `directory/report.html and directory/report.md`, for stdout.
pub fn listed(directory: &Path) -> String {
    let paths: Vec<String> = report_paths(directory)
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    paths.join(" and ")
}

/// Renders `subject` in both forms into `directory` ([`REPORT_FILES`]),
/// both rendered before either is written, and written as a set: both
/// new or both as they were.
pub fn write(subject: &Subject, directory: &Path) -> anyhow::Result<()> {
    let texts = REPORT_FILES
        .iter()
        .map(|(name, format)| Ok((directory.join(name), render(subject, *format)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    write_set(&[], || {
        texts
            .iter()
            .try_for_each(|(path, text)| parcal::report::write_text(path, text))
    })?;
    Ok(())
}

/// Writes the report of `record` (calibration.json at `file`), with the
/// residuals of the dataset's `probes` if given, into `directory`:
/// report.html and report.md ([`REPORT_FILES`]).
pub fn write_mechanism_report(
    record: &MechanismCalibrationRecord,
    file: &str,
    from_dataset: FromDataset<'_>,
    directory: &Path,
) -> anyhow::Result<()> {
    for (name, format) in REPORT_FILES {
        let text = parcal::report::mechanism::render(record, file, from_dataset, format)
            .map_err(|e| anyhow::anyhow!("{file}: cannot draw the report's figure: {e}"))?;
        parcal::report::write_text(&directory.join(name), &text)?;
    }
    Ok(())
}
