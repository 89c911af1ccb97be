//! One module per subcommand.

pub mod accuracy;
pub mod calibrate;
pub mod compensate;
pub mod execute;
pub mod export;
pub mod import;
pub mod inspect;
pub mod mechanism;
pub mod mechanism_apply;
pub mod paper;
pub mod plan;
pub mod plan_mechanism;
pub mod report;
pub mod simulate;
pub mod simulate_mechanism;
pub mod validate;

use std::path::{Path, PathBuf};

use parcal::dataset::mechanism::MechanismCalibrationRecord;
use parcal::dataset::{Dataset, ReadOptions};
use parcal::report::calibration_report::{Subject, accuracy_with};
use parcal::workflows::evaluate::TrueMachine;

/// The binary snapshot `parcal simulate --binary` writes next to the text files.
pub const SNAPSHOT_FILE: &str = "dataset.bin";

/// Reads a dataset: a directory of text files, or a binary snapshot file
/// (`*.bin`, [`parcal::command::read_dataset`]). A dataset of another
/// mechanism than the hexapod is refused, saying which commands take it.
pub fn read_dataset(path: &Path) -> anyhow::Result<Dataset> {
    read_dataset_with(path, &ReadOptions::default())
}

/// [`read_dataset`] with `options` (for a directory of text files).
pub fn read_dataset_with(path: &Path, options: &ReadOptions) -> anyhow::Result<Dataset> {
    if let Some(mechanism) = mechanism::declared(path)? {
        anyhow::bail!(
            "{}: a {mechanism}'s dataset: this command reads a hexapod's; a {mechanism}'s is inspected (parcal inspect), calibrated (parcal calibrate), reported (parcal report), exported (parcal export), validated (parcal validate --calibration) and compensated (parcal compensate --targets)",
            path.display()
        );
    }
    Ok(parcal::command::read_dataset_with(path, options)?)
}

/// A calibration that was computed and written, but whose verdict is
/// "rejected": the binary exits with status 3.
#[derive(Debug)]
pub struct Rejected(pub String);

impl std::fmt::Display for Rejected {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Rejected {}

/// A validation written to `out`: [`Rejected`] with its `reasons` when it
/// rejects the calibration, `Ok` otherwise.
fn validation_outcome(rejected: bool, reasons: &[String], out: &Path) -> anyhow::Result<()> {
    if rejected {
        return Err(Rejected(format!(
            "{} (validation written to {})",
            reasons.join("; "),
            out.display()
        ))
        .into());
    }
    Ok(())
}

/// Notes on stderr when the dataset `dataset` (checksum `checksum`) is the
/// one the calibration at `calibration` (of `provenance`) calibrated: its
/// rows are then predicted in sample.
fn note_in_sample(
    provenance: Option<&parcal::dataset::Provenance>,
    checksum: String,
    dataset: &Path,
    calibration: &Path,
) {
    if provenance.is_some_and(|p| p.dataset_checksum == checksum) {
        eprintln!(
            "note: {} is the dataset {} calibrated (the same checksum): its rows are predicted in sample, so this checks the fit, not new data (give data not used for the fit, or --folds for a cross-validation)",
            dataset.display(),
            calibration.display()
        );
    }
}

/// Where a calibration whose verdict is rejected goes instead of `out`:
/// `NAME.rejected.EXT` beside it (`calibration.rejected.json`), so that a
/// rejected run never replaces an accepted calibration.
pub fn rejected_path(out: &Path) -> PathBuf {
    let stem = out.file_stem().unwrap_or_default();
    let mut name = stem.to_os_string();
    name.push(".rejected");
    if let Some(extension) = out.extension() {
        name.push(".");
        name.push(extension);
    }
    out.with_file_name(name)
}

/// Where `record` is written: `out`, or [`rejected_path`] if rejected.
pub fn calibration_destination(record: &parcal::dataset::Calibration, out: &Path) -> PathBuf {
    if record.is_rejected() {
        rejected_path(out)
    } else {
        out.to_path_buf()
    }
}

/// Checks, before a calibration starts, that both its destinations (`out`
/// and [`rejected_path`]) can be written and are none of the dataset's
/// files.
pub fn check_calibration_outputs(dataset: &Path, out: &Path) -> anyhow::Result<()> {
    crate::outputs::check(
        &crate::outputs::dataset_inputs(dataset),
        &[out.to_path_buf(), rejected_path(out)],
    )
}

/// The report `calibrate --report` writes beside its calibration.
pub struct ReportRequest<'a> {
    /// The directory of report.html and report.md.
    pub directory: PathBuf,
    /// A simulation's true machine, for the true error beside the
    /// predicted one.
    pub truth: Option<&'a TrueMachine>,
}

impl ReportRequest<'_> {
    /// Checks, before a calibration starts, that the report's files can be
    /// written and are none of the dataset's files nor the calibration's
    /// destinations (`out` and [`rejected_path`]), which do not exist yet.
    pub fn check(&self, dataset: &Path, out: &Path) -> anyhow::Result<()> {
        let files = report::either_verdicts_report_paths(&self.directory);
        for destination in [out.to_path_buf(), rejected_path(out)] {
            let directory = report::directory_of(&destination);
            let clash = files.iter().find(|file| {
                file.file_name() == destination.file_name()
                    && directory.canonicalize().ok()
                        == report::directory_of(file).canonicalize().ok()
            });
            if let Some(file) = clash {
                anyhow::bail!(
                    "{}: the report would overwrite the calibration written there; give --out another name",
                    file.display()
                );
            }
        }
        crate::outputs::check(&crate::outputs::dataset_inputs(dataset), &files)
    }

    /// Its files beside a calibration `rejected` or not
    /// ([`report::calibration_report_paths`]).
    pub fn paths(&self, rejected: bool) -> Vec<PathBuf> {
        report::calibration_report_paths(&self.directory, rejected)
    }
}

/// Stamps `record` with its provenance (this parcal, the dataset given as
/// `path` and its checksum), writes it to its
/// [`calibration_destination`] and, if asked, its report beside it (a
/// rejected calibration's too, under the rejected names: the report says
/// why); a rejected verdict
/// comes back as [`Rejected`] (which says where it went and that `out` is
/// kept), for the caller to return once it has said what was written.
pub fn write_calibration(
    mut record: parcal::dataset::Calibration,
    dataset: &Dataset,
    path: &Path,
    out: &Path,
    report: Option<&ReportRequest>,
) -> anyhow::Result<Option<Rejected>> {
    record.provenance = Some(parcal::command::provenance(
        dataset.checksum(),
        &path.display().to_string(),
    ));
    let destination = calibration_destination(&record, out);
    // The calibration and its report: all new, or all as they were.
    parcal::dataset::atomic::write_set(&[], || -> anyhow::Result<()> {
        record.write(&destination)?;
        if let Some(request) = report {
            let file = destination.display().to_string();
            let subject = Subject {
                calibration: &record,
                file: &file,
                accuracy: accuracy_with(&record, Some(&dataset.machine), request.truth),
            };
            report::write(&subject, &request.paths(record.is_rejected()))?;
        }
        Ok(())
    })?;
    if record.is_rejected() {
        let failed: Vec<&str> = record
            .reasons
            .iter()
            .filter(|r| {
                r.contains("failed") || r.starts_with("the solver") && !r.ends_with("converged")
            })
            .map(String::as_str)
            .collect();
        let kept = if out.exists() {
            format!("; {} is left as it was", out.display())
        } else {
            String::new()
        };
        return Ok(Some(Rejected(format!(
            "{} (written to {}{kept}; accuracy and validate refuse it without --accept-rejected)",
            failed.join("; "),
            destination.display()
        ))));
    }
    Ok(None)
}

/// Reads a calibration to apply: refuses a rejected one unless
/// `accept_rejected`.
pub fn read_calibration(
    path: &Path,
    accept_rejected: bool,
) -> anyhow::Result<parcal::dataset::Calibration> {
    accepted(
        parcal::dataset::Calibration::read(path)?,
        path,
        accept_rejected,
    )
}

/// A calibration's record with a verdict: the hexapod's own, or a
/// mechanism's.
pub trait Judged {
    /// Whether its verdict is "rejected".
    fn rejected(&self) -> bool;
    /// Why, in words.
    fn reasons(&self) -> &[String];
}

impl Judged for parcal::dataset::Calibration {
    fn rejected(&self) -> bool {
        self.is_rejected()
    }
    fn reasons(&self) -> &[String] {
        &self.reasons
    }
}

impl Judged for MechanismCalibrationRecord {
    fn rejected(&self) -> bool {
        !self.accepted
    }
    fn reasons(&self) -> &[String] {
        &self.reasons
    }
}

/// `record`, read from `path`, refused when rejected unless
/// `accept_rejected`.
pub fn accepted<R: Judged>(record: R, path: &Path, accept_rejected: bool) -> anyhow::Result<R> {
    anyhow::ensure!(
        !record.rejected() || accept_rejected,
        "{}: the calibration was rejected ({}); give --accept-rejected to use it anyway",
        path.display(),
        record.reasons().join("; ")
    );
    Ok(record)
}

/// `N` numbers separated by commas, an option's value; an error saying
/// the text is not `what`, or naming the value that is not a number.
pub(crate) fn numbers<const N: usize>(text: &str, what: &str) -> Result<[f64; N], String> {
    let values: Vec<&str> = text.split(',').collect();
    if values.len() != N {
        return Err(format!("{text:?} is not {what}"));
    }
    let mut numbers = [0.0; N];
    for (number, value) in numbers.iter_mut().zip(values) {
        *number = (value.trim().parse::<f64>()).map_err(|error| format!("{value:?}: {error}"))?;
    }
    Ok(numbers)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_rejected_calibration_goes_beside_the_accepted_one() {
        for (out, rejected) in [
            ("d/calibration.json", "d/calibration.rejected.json"),
            ("big.json", "big.rejected.json"),
            ("d/result", "d/result.rejected"),
        ] {
            assert_eq!(rejected_path(Path::new(out)), Path::new(rejected));
        }
    }
}
