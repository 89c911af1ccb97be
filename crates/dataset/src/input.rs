//! Opening the files a dataset is read from: regular files only (after
//! following symbolic links), never read without a bound. A FIFO would
//! block the reader, a device such as `/dev/zero` or an endless stream
//! would grow a buffer until memory runs out; both are refused with a
//! message naming the file.

use std::fs::{self, File, FileType, Metadata};
use std::io::{self, Read};
use std::path::Path;

use crate::error::{DatasetError, Result};

/// The largest JSON file read: 1 GiB. The largest JSON file of a
/// 10^6-contact campaign is its truth.json (one contact point per row),
/// about a tenth of this; its artefacts.json (142857 balls) is smaller.
pub const JSON_CAP: u64 = 1 << 30;

/// An open input file.
pub(crate) struct Input {
    pub(crate) file: File,
    /// Its length in bytes when it was opened.
    pub(crate) len: u64,
}

/// Opens `path` for reading: `None` if it does not exist, an error if it
/// is not a regular file.
pub(crate) fn open(path: &Path) -> Result<Option<Input>> {
    let metadata = match fs::metadata(path) {
        Ok(metadata) => metadata,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(DatasetError::io(path, "read", e)),
    };
    // Checked before opening: opening a FIFO blocks until a writer comes.
    regular(path, &metadata)?;
    let file = File::open(path).map_err(|e| DatasetError::io(path, "read", e))?;
    // And again on what was opened, in case the file was replaced meanwhile.
    let metadata = file
        .metadata()
        .map_err(|e| DatasetError::io(path, "read", e))?;
    regular(path, &metadata)?;
    Ok(Some(Input {
        file,
        len: metadata.len(),
    }))
}

/// Opens a required file: its absence is [`DatasetError::MissingFile`].
pub(crate) fn open_required(path: &Path) -> Result<Input> {
    open(path)?.ok_or_else(|| DatasetError::MissingFile {
        path: path.to_path_buf(),
    })
}

/// The whole of JSON file `path`, at most [`JSON_CAP`] bytes; `None` if it
/// does not exist.
pub(crate) fn read_json(path: &Path) -> Result<Option<Vec<u8>>> {
    read_at_most(path, JSON_CAP)
}

/// The whole of file `path`, at most `cap` bytes (refused by its length
/// before it is read, and read through `take`, so that a file growing
/// while it is read is stopped too); `None` if it does not exist.
fn read_at_most(path: &Path, cap: u64) -> Result<Option<Vec<u8>>> {
    let too_large = || {
        DatasetError::refused(
            path,
            format!("is larger than {cap} bytes, the most a JSON file may have"),
        )
    };
    let Some(Input { file, len }) = open(path)? else {
        return Ok(None);
    };
    if len > cap {
        return Err(too_large());
    }
    let mut bytes = Vec::with_capacity(len as usize);
    file.take(cap + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| DatasetError::io(path, "read", e))?;
    if bytes.len() as u64 > cap {
        return Err(too_large());
    }
    Ok(Some(bytes))
}

fn regular(path: &Path, metadata: &Metadata) -> Result<()> {
    if metadata.is_file() {
        return Ok(());
    }
    Err(DatasetError::refused(
        path,
        format!(
            "is {}, not a regular file (a dataset is read from regular files only)",
            kind(&metadata.file_type())
        ),
    ))
}

/// What a file that is not a regular file is.
fn kind(file_type: &FileType) -> &'static str {
    if file_type.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if file_type.is_char_device() {
            return "a character device";
        }
        if file_type.is_block_device() {
            return "a block device";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    "a special file"
}

/// The UTF-8 byte order mark, which a file may start with (RFC 8259
/// section 8.1 lets a JSON parser ignore it; CSV files from spreadsheets
/// often have one). Reading skips it.
pub(crate) const BOM: &[u8] = b"\xEF\xBB\xBF";

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    #[test]
    fn a_directory_a_fifo_and_a_device_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let err = open(dir.path()).err().unwrap().to_string();
        assert!(
            err.ends_with(
                "is a directory, not a regular file (a dataset is read from regular files only)"
            ),
            "{err}"
        );
        let fifo = dir.path().join("fifo");
        let status = std::process::Command::new("mkfifo").arg(&fifo).status();
        if status.is_ok_and(|s| s.success()) {
            // Would block forever if opened.
            let err = open(&fifo).err().unwrap().to_string();
            assert!(
                err.contains("fifo: is a FIFO (named pipe), not a regular file"),
                "{err}"
            );
        }
        let zero = dir.path().join("zero.json");
        std::os::unix::fs::symlink("/dev/zero", &zero).unwrap();
        let err = read_json(&zero).err().unwrap().to_string();
        assert!(
            err.contains("zero.json: is a character device, not a regular file"),
            "{err}"
        );
        assert!(open(&dir.path().join("absent")).unwrap().is_none());
    }

    /// A file over the cap is refused before it is read (its length) and,
    /// should it grow meanwhile, on what was read.
    #[test]
    fn a_file_over_the_cap_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.json");
        fs::write(&path, b"0123456789").unwrap();
        assert_eq!(read_at_most(&path, 10).unwrap().unwrap(), b"0123456789");
        let err = read_at_most(&path, 9).err().unwrap().to_string();
        assert!(
            err.ends_with("a.json: is larger than 9 bytes, the most a JSON file may have"),
            "{err}"
        );
    }
}
