//! One module per subcommand.

pub mod accuracy;
pub mod calibrate;
pub mod inspect;
pub mod paper;
pub mod plan;
pub mod simulate;
pub mod validate;

use std::path::Path;

use parcal_dataset::Dataset;

/// The binary snapshot `parcal simulate --binary` writes next to the text files.
pub const SNAPSHOT_FILE: &str = "dataset.bin";

/// Reads a dataset: a directory of text files, or a binary snapshot file
/// (`*.bin`). A directory holding a snapshot is read from the text files.
pub fn read_dataset(path: &Path) -> anyhow::Result<Dataset> {
    Ok(if path.is_file() {
        Dataset::read_snapshot(path)?
    } else {
        Dataset::read(path)?
    })
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

/// Stamps `record` with its provenance (this parcal, the dataset given as
/// `path` and its checksum), writes it to `out`, and turns a rejected
/// verdict into [`Rejected`].
pub fn write_calibration(
    mut record: parcal_dataset::Calibration,
    dataset: &Dataset,
    path: &Path,
    out: &Path,
) -> anyhow::Result<()> {
    record.provenance = Some(parcal_dataset::Provenance {
        parcal_version: env!("CARGO_PKG_VERSION").to_string(),
        dataset: path.display().to_string(),
        dataset_checksum: dataset.checksum(),
    });
    record.write(out)?;
    if record.is_rejected() {
        let failed: Vec<&str> = record
            .reasons
            .iter()
            .filter(|r| {
                r.contains("failed") || r.starts_with("the solver") && !r.ends_with("converged")
            })
            .map(String::as_str)
            .collect();
        return Err(Rejected(format!(
            "{} (written to {}; accuracy and validate refuse it without --accept-rejected)",
            failed.join("; "),
            out.display()
        ))
        .into());
    }
    Ok(())
}

/// Reads a calibration to apply: refuses a rejected one unless
/// `accept_rejected`.
pub fn read_calibration(
    path: &Path,
    accept_rejected: bool,
) -> anyhow::Result<parcal_dataset::Calibration> {
    let record = parcal_dataset::Calibration::read(path)?;
    anyhow::ensure!(
        !record.is_rejected() || accept_rejected,
        "{}: the calibration was rejected ({}); give --accept-rejected to use it anyway",
        path.display(),
        record.reasons.join("; ")
    );
    Ok(record)
}
