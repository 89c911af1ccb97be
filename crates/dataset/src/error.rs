//! The one error type of the crate.

use std::io;
use std::path::{Path, PathBuf};

use crate::quote::quoted;

/// Why a dataset, calibration file or snapshot could not be read or written.
///
/// Every variant names the file (its full path) and, where it applies, the
/// field (JSON, as a path such as `balls[3].radius`) or the line and column
/// (CSV). `Display` is one sentence meant for the user.
#[derive(Debug, thiserror::Error)]
pub enum DatasetError {
    /// A required file does not exist.
    #[error("{}: required file not found", path.display())]
    MissingFile {
        /// The file that was looked for.
        path: PathBuf,
    },

    /// The operating system refused to read or write a file.
    #[error("{}: cannot {action}: {source}", path.display())]
    Io {
        /// The file concerned.
        path: PathBuf,
        /// What was being done ("read", "write", "rename into place", ...).
        action: &'static str,
        /// The underlying error.
        source: io::Error,
    },

    /// A file refused before its content is parsed: not a regular file
    /// (a directory, a FIFO, a device), or larger than the cap of its kind.
    #[error("{}: {message}", path.display())]
    Refused {
        /// The file concerned.
        path: PathBuf,
        /// Why it is refused.
        message: String,
    },

    /// A JSON file is not well-formed JSON, or its top level is not an
    /// object of the expected kind.
    #[error("{}: line {line}, column {column}: {message}", path.display())]
    Json {
        /// The file concerned.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column.
        column: usize,
        /// What is wrong.
        message: String,
    },

    /// A JSON file's `format` field names another kind of file, a major
    /// version this crate does not read, or is malformed.
    #[error("{}: format {} {message}", path.display(), quoted(format))]
    Format {
        /// The file concerned.
        path: PathBuf,
        /// The value of its `format` field.
        format: String,
        /// What is wrong with it.
        message: String,
    },

    /// A field of a JSON file (or of the in-memory data about to be written
    /// to it) is missing, of the wrong type or shape, or has a bad value.
    #[error("{}: field {field}: {message}", path.display())]
    Field {
        /// The file concerned.
        path: PathBuf,
        /// Path of the field, e.g. `base_joints[2][1]` or `balls[3].radius`.
        field: String,
        /// What is wrong, with the JSON line and column when known.
        message: String,
    },

    /// A line of a CSV file is wrong.
    #[error("{}: line {line}{}: {message}", path.display(), column_suffix(column))]
    Csv {
        /// The file concerned.
        path: PathBuf,
        /// 1-based line number in the file (the header is line 1).
        line: u64,
        /// The column concerned, by its header name, if one is.
        column: Option<String>,
        /// What is wrong.
        message: String,
    },

    /// A ball has fewer contacts than `ReadOptions::min_contacts_per_ball`.
    #[error(
        "{}: ball {} has {count} contacts, fewer than the minimum of {min}{}",
        path.display(),
        quoted(ball),
        others_suffix(*others)
    )]
    TooFewContacts {
        /// The measurements file.
        path: PathBuf,
        /// Id of the first ball (in artefacts order) that is short.
        ball: String,
        /// Its number of contacts.
        count: usize,
        /// The minimum asked for.
        min: usize,
        /// How many other balls are short too.
        others: usize,
    },

    /// A binary snapshot is not one, is of another version, or is damaged.
    #[error("{}: {message}", path.display())]
    Snapshot {
        /// The snapshot file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Shorthand for results of this crate.
pub type Result<T, E = DatasetError> = std::result::Result<T, E>;

fn column_suffix(column: &Option<String>) -> String {
    column
        .as_ref()
        .map_or_else(String::new, |c| format!(", column {c}"))
}

fn others_suffix(others: usize) -> String {
    match others {
        0 => String::new(),
        1 => " (1 other ball is short too)".to_owned(),
        n => format!(" ({n} other balls are short too)"),
    }
}

impl DatasetError {
    /// An I/O error of `action` ("write", "rename into place") on `path`.
    pub fn io(path: &Path, action: &'static str, source: io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            action,
            source,
        }
    }

    pub(crate) fn field(path: &Path, field: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Field {
            path: path.to_path_buf(),
            field: field.into(),
            message: message.into(),
        }
    }

    pub(crate) fn csv(
        path: &Path,
        line: u64,
        column: Option<&str>,
        message: impl Into<String>,
    ) -> Self {
        Self::Csv {
            path: path.to_path_buf(),
            line,
            column: column.map(str::to_owned),
            message: message.into(),
        }
    }

    pub(crate) fn refused(path: &Path, message: impl Into<String>) -> Self {
        Self::Refused {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn snapshot(path: &Path, message: impl Into<String>) -> Self {
        Self::Snapshot {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}
