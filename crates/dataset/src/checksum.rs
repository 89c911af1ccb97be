//! Checksums that tie together the files one run writes as a set
//! ([`crate::atomic::write_set`]): one member records the checksum of
//! another (plan.json of plan.csv), so that a reader tells a mismatched
//! pair (a run killed between the renames) from a whole one.

use std::io::Read;
use std::path::Path;

use crate::error::{DatasetError, Result};
use crate::input::{open_required, read_json};

/// The checksum of `bytes`: `crc32:` and its CRC-32 in hex, as
/// [`crate::Dataset::checksum`] writes it.
pub fn of_bytes(bytes: &[u8]) -> String {
    format!("crc32:{:08x}", crc32fast::hash(bytes))
}

/// The checksum ([`of_bytes`]) of the regular file `path`, streamed.
pub fn of_file(path: &Path) -> Result<String> {
    let mut file = open_required(path)?.file;
    let mut hasher = crc32fast::Hasher::new();
    let mut buffer = vec![0u8; 1 << 16];
    loop {
        let n = file
            .read(&mut buffer)
            .map_err(|e| DatasetError::io(path, "read", e))?;
        if n == 0 {
            break;
        }
        hasher.update(&buffer[..n]);
    }
    Ok(format!("crc32:{:08x}", hasher.finalize()))
}

/// The string `field` of the JSON object in `path` (read within
/// [`crate::JSON_CAP`]): `None` if the file or the field is absent.
pub fn recorded(path: &Path, field: &str) -> Result<Option<String>> {
    let Some(bytes) = read_json(path)? else {
        return Ok(None);
    };
    let value: serde_json::Value = serde_json::from_slice(&bytes)
        .map_err(|e| DatasetError::refused(path, format!("is not JSON: {e}")))?;
    match value.get(field) {
        None => Ok(None),
        Some(serde_json::Value::String(text)) => Ok(Some(text.clone())),
        Some(_) => Err(DatasetError::field(path, field, "is not a string")),
    }
}
