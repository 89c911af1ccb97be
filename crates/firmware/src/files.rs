//! Reading a text file whole, refusing one larger than its kind's cap
//! before reading it; the bound on every number a firmware's file holds.

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

/// The largest magnitude of a number a firmware's file may hold: a
/// length of 1 km in mm, far beyond any printer, the bound a dataset puts
/// on its lengths (`parcal_dataset::MAX_LENGTH_MM`), so that an import
/// names the file and line of a value its dataset would refuse.
pub const MAX_MAGNITUDE: f64 = 1e6;

/// `text` as a number within [`MAX_MAGNITUDE`]; else why not, quoting
/// `text` (not a number, not finite, or too large).
pub(crate) fn bounded_number(text: &str) -> Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v.abs() <= MAX_MAGNITUDE => Ok(v),
        Ok(v) if v.is_finite() => Err(format!(
            "'{text}' is beyond the {MAX_MAGNITUDE:e} a firmware's number may be (1 km in mm: a unit error?)"
        )),
        Ok(_) => Err(format!("'{text}' is not a finite number")),
        Err(_) => Err(format!("'{text}' is not a number")),
    }
}
