//! Reading a text file whole, refusing one larger than its kind's cap
//! before reading it.

use std::path::Path;

use crate::FirmwareError;

/// The text of `path`, refused when larger than `limit` bytes.
pub(crate) fn read_capped(
    path: &Path,
    limit: u64,
    kind: &'static str,
) -> Result<String, FirmwareError> {
    let io = |action, source| FirmwareError::Io {
        path: path.to_path_buf(),
        action,
        source,
    };
    let size = std::fs::metadata(path).map_err(|e| io("read", e))?.len();
    if size > limit {
        return Err(FirmwareError::TooLarge {
            path: path.to_path_buf(),
            size,
            limit,
            kind,
        });
    }
    std::fs::read_to_string(path).map_err(|e| io("read", e))
}
