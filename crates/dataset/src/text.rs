//! Plain text outputs (a HAL snippet, a summary), written atomically like
//! every file of the format.

use std::io::Write;
use std::path::Path;

use crate::atomic::{write_atomic, write_error};
use crate::error::Result;

/// Writes `text` to `path` atomically: the file is complete or absent (a
/// previous file of that name is left untouched on error).
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |w| {
        w.write_all(text.as_bytes()).map_err(write_error(path))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn text_is_written_whole_and_an_impossible_path_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.hal");
        write_text(&path, "setp x 1\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "setp x 1\n");
        let missing = dir.path().join("no/such/dir/a.hal");
        let error = write_text(&missing, "x").unwrap_err().to_string();
        assert!(error.contains("no/such/dir/a.hal"), "{error}");
    }
}
