//! `parcal report`: the report of one calibration, a self-contained HTML
//! page and its Markdown twin a metrologist can sign: verdict and tests
//! first.

use std::io::Write;
use std::path::{Path, PathBuf};

use anyhow::Context;
use parcal::calibration::mechanism::MechanismData;
use parcal::command::{Recorded, read_either};
use parcal::dataset::HEXAPOD;
use parcal::dataset::atomic::write_set;
use parcal::dataset::mechanism::{MechanismCalibrationRecord, MechanismDataset};
use parcal::report::calibration_report::{Format, Subject, render};
use parcal::report::mechanism::FromDataset;
use parcal::report_pages::{
    ReportDataset, ReportPageError, hexapod_report, mechanism_page, mechanism_report,
};

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
    let calibration = match read_either(&args.calibration)? {
        Recorded::Own(calibration) => *calibration,
        Recorded::Mechanism(record) => return write_mechanism(&record, args, &directory),
    };
    let dataset = args
        .dataset
        .as_deref()
        .map(super::read_dataset)
        .transpose()?;
    let file = args.calibration.display().to_string();
    let texts = REPORT_FILES.map(|(name, format)| {
        hexapod_report(
            &calibration,
            &file,
            dataset.as_ref(),
            args.other_data,
            format,
        )
        .map(|text| (directory.join(name), text))
    });
    let texts = texts
        .into_iter()
        .collect::<Result<Vec<_>, _>>()
        .map_err(|error| match error {
            ReportPageError::OtherData { .. } => anyhow::anyhow!(
                "{}: {error}; give --other-data to report with it anyway",
                args.calibration.display()
            ),
            error => anyhow::anyhow!("{file}: {error}"),
        })?;
    write_texts(&texts)?;
    writeln!(
        std::io::stdout().lock(),
        "verdict: {}\nreport written to {}",
        if calibration.verdict.is_empty() {
            "none recorded"
        } else {
            &calibration.verdict
        },
        listed(&report_paths(&directory))
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
/// set); with `args.dataset`, what it adds: a mechanism's probe and manual
/// height residuals over the bed, a simulated machine's truth (a
/// hexapod's, through the common path, has neither).
fn write_mechanism(
    record: &MechanismCalibrationRecord,
    args: &Args,
    directory: &Path,
) -> anyhow::Result<()> {
    let file = args.calibration.display().to_string();
    let hexapod;
    let mechanism;
    let dataset = match &args.dataset {
        Some(path) if record.mechanism == HEXAPOD => {
            hexapod = super::read_dataset(path)?;
            Some((path, ReportDataset::Hexapod(&hexapod)))
        }
        Some(path) => {
            let dataset = MechanismDataset::read(path)?;
            let data = MechanismData::from_dataset(&dataset)
                .map_err(|error| anyhow::anyhow!("{}: {error}", path.display()))?;
            mechanism = (dataset, data);
            Some((path, ReportDataset::Mechanism(&mechanism.0, &mechanism.1)))
        }
        None => None,
    };
    let texts = REPORT_FILES.map(|(name, format)| {
        mechanism_report(
            record,
            &file,
            dataset.map(|(_, d)| d),
            args.other_data,
            format,
        )
        .map(|text| (directory.join(name), text))
    });
    let texts = texts
        .into_iter()
        .collect::<Result<Vec<_>, _>>()
        .map_err(|error| match (&error, dataset) {
            (ReportPageError::OtherData { .. }, _) => {
                anyhow::anyhow!("{file}: {error}; give --other-data to report with it anyway")
            }
            (ReportPageError::Figure(_), _) | (_, None) => anyhow::anyhow!("{file}: {error}"),
            (_, Some((path, _))) => anyhow::anyhow!("{}: {error}", path.display()),
        })?;
    write_texts(&texts)?;
    writeln!(
        std::io::stdout().lock(),
        "{}\nreport written to {}",
        parcal::report::mechanism::verdict_sentence(record),
        listed(&report_paths(directory))
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

/// The report's files that `calibrate --report` writes in `directory`
/// beside a calibration: [`report_paths`], or for a rejected one their
/// rejected names ([`super::rejected_path`]: `report.rejected.html`), so
/// that its report never replaces an accepted calibration's.
pub fn calibration_report_paths(directory: &Path, rejected: bool) -> Vec<PathBuf> {
    let paths = report_paths(directory);
    match rejected {
        true => paths
            .iter()
            .map(|path| super::rejected_path(path))
            .collect(),
        false => paths,
    }
}

/// The report's files `calibrate --report` may write in `directory`,
/// whatever the verdict ([`calibration_report_paths`] of both): what is
/// checked before the calibration runs.
pub fn either_verdicts_report_paths(directory: &Path) -> Vec<PathBuf> {
    [false, true]
        .map(|rejected| calibration_report_paths(directory, rejected))
        .concat()
}

/// `paths`, for stdout: `directory/report.html and directory/report.md`.
pub fn listed(paths: &[PathBuf]) -> String {
    let paths: Vec<String> = paths.iter().map(|p| p.display().to_string()).collect();
    paths.join(" and ")
}

/// Renders `subject` in both forms ([`REPORT_FILES`]) into `paths` (in
/// their order), both rendered before either is written
/// ([`write_texts`]).
pub fn write(subject: &Subject, paths: &[PathBuf]) -> anyhow::Result<()> {
    let texts = (REPORT_FILES.iter().zip(paths))
        .map(|((_, format), path)| Ok((path.clone(), render(subject, *format)?)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    write_texts(&texts)
}

/// Writes the report's files, each `(path, text)` rendered before, as a
/// set: all new or all as they were.
fn write_texts(texts: &[(PathBuf, String)]) -> anyhow::Result<()> {
    write_set(&[], || {
        texts
            .iter()
            .try_for_each(|(path, text)| parcal::report::write_text(path, text))
    })?;
    Ok(())
}

/// Writes the report of `record` (calibration.json at `file`), with what
/// `from_dataset` adds (the residuals of the dataset's probes and manual
/// heights over the bed, if given), into `paths`: its HTML and Markdown
/// forms ([`REPORT_FILES`]).
pub fn write_mechanism_report(
    record: &MechanismCalibrationRecord,
    file: &str,
    from_dataset: FromDataset<'_>,
    paths: &[PathBuf],
) -> anyhow::Result<()> {
    for ((_, format), path) in REPORT_FILES.iter().zip(paths) {
        let text = mechanism_page(record, file, from_dataset, *format)
            .map_err(|error| anyhow::anyhow!("{file}: {error}"))?;
        parcal::report::write_text(path, &text)?;
    }
    Ok(())
}
