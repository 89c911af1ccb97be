//! One module per subcommand.

pub mod accuracy;
pub mod calibrate;
pub mod inspect;
pub mod paper;
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
