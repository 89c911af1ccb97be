//! The one error type of the crate.

use std::io;
use std::path::PathBuf;

/// Why a configuration or probe file could not be read, or a calibration
/// could not be made. `Display` is one sentence for the user, naming the
/// file and line where there is one.
#[derive(Debug, thiserror::Error)]
pub enum FirmwareError {
    /// The operating system refused to read or write a file.
    #[error("{}: cannot {action}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// `read` or `write`.
        action: &'static str,
        /// The underlying error.
        source: io::Error,
    },
    /// A file larger than its kind's cap, refused before it is read.
    #[error("{}: {size} bytes, more than the {limit} a {kind} may hold", path.display())]
    TooLarge {
        /// The file.
        path: PathBuf,
        /// Its size (bytes).
        size: u64,
        /// The cap (bytes).
        limit: u64,
        /// `configuration` or `probe file`.
        kind: &'static str,
    },
    /// A line the firmware would refuse or that parcal cannot use.
    #[error("{}: line {line}: {message}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// The line (1-based).
        line: u64,
        /// What is wrong, naming the command and parameter.
        message: String,
    },
    /// A configuration without the lines a linear delta needs.
    #[error("{}: {message}", path.display())]
    Configuration {
        /// The file.
        path: PathBuf,
        /// What is missing or inconsistent.
        message: String,
    },
    /// The auto-calibration refused its input or could not solve.
    #[error("auto-calibration: {0}")]
    Calibration(String),
}
