//! All-or-nothing file writes: a temporary file beside the target
//! ([`tempfile::NamedTempFile`]), renamed into place once complete.

use std::fs::File;
use std::io::{self, BufWriter};
use std::path::Path;

use tempfile::NamedTempFile;

use crate::error::{DatasetError, Result};

/// Writes `path` through `fill`, atomically: until `fill` has succeeded and
/// the data is synced, nothing exists under `path` (a previous file of that
/// name is left untouched), and on any error the temporary file is removed.
/// The file gets the permissions `fs::write` would give it.
///
/// `fill` returns the crate's error type so that it can report errors of its
/// own (e.g. a serializer's) against `path`.
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<&File>) -> Result<()>,
{
    let tmp = create_temp(path)?;
    let mut writer = BufWriter::new(tmp.as_file());
    fill(&mut writer)?;
    writer
        .into_inner()
        .map_err(|e| DatasetError::io(path, "write", e.into_error()))?
        .sync_all()
        .map_err(|e| DatasetError::io(path, "write", e))?;
    // On failure the temporary file is dropped, which removes it.
    tmp.persist(path)
        .map_err(|e| DatasetError::io(path, "rename into place", e.error))?;
    Ok(())
}

/// A new hidden file `.NAME.XXXXXX.tmp` in the directory of `path`.
fn create_temp(path: &Path) -> Result<NamedTempFile> {
    let name = path.file_name().ok_or_else(|| {
        DatasetError::io(
            path,
            "write",
            io::Error::new(io::ErrorKind::InvalidInput, "not a file name"),
        )
    })?;
    // A bare file name has the parent "", which tempfile takes as the
    // current directory.
    let dir = path.parent().unwrap_or(Path::new(""));
    let mut prefix = std::ffi::OsString::from(".");
    prefix.push(name);
    prefix.push(".");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    // tempfile's default is owner-only (0o600); a dataset is as readable as
    // any file the user writes (0o666 less the umask).
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    builder
        .tempfile_in(dir)
        .map_err(|e| DatasetError::io(path, "create a temporary file beside it", e))
}

/// Maps an I/O error of a writer to the crate's error for `path`.
pub(crate) fn write_error(path: &Path) -> impl Fn(io::Error) -> DatasetError + '_ {
    move |e| DatasetError::io(path, "write", e)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::fs;
    use std::io::Write;

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn writes_the_file_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        write_atomic(&path, |w| w.write_all(b"hello").map_err(write_error(&path))).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"hello");
        assert_eq!(entries(dir.path()), ["a.txt"]);
    }

    #[test]
    fn failed_fill_leaves_nothing_and_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let fresh = dir.path().join("fresh.txt");
        let err = write_atomic(&fresh, |w| {
            w.write_all(b"half of it").map_err(write_error(&fresh))?;
            Err(DatasetError::field(&fresh, "x", "failed on purpose"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("failed on purpose"));
        assert!(entries(dir.path()).is_empty());

        let old = dir.path().join("old.txt");
        fs::write(&old, b"old content").unwrap();
        write_atomic(&old, |w| {
            w.write_all(b"new").map_err(write_error(&old))?;
            Err(DatasetError::field(&old, "x", "failed on purpose"))
        })
        .unwrap_err();
        assert_eq!(fs::read(&old).unwrap(), b"old content");
        assert_eq!(entries(dir.path()), ["old.txt"]);
    }

    #[cfg(unix)]
    #[test]
    fn the_file_is_as_readable_as_one_fs_write_makes() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        write_atomic(&path, |w| w.write_all(b"x").map_err(write_error(&path))).unwrap();
        let plain = dir.path().join("plain.txt");
        fs::write(&plain, b"x").unwrap();
        let mode = |p: &Path| fs::metadata(p).unwrap().permissions().mode();
        assert_eq!(mode(&path), mode(&plain));
    }

    #[test]
    fn failed_rename_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        // A non-empty directory stands where the file should go.
        let target = dir.path().join("target");
        fs::create_dir(&target).unwrap();
        fs::write(target.join("inside"), b"x").unwrap();
        let err = write_atomic(&target, |w| {
            w.write_all(b"data").map_err(write_error(&target))
        })
        .unwrap_err();
        assert!(err.to_string().contains("target"), "{err}");
        assert_eq!(entries(dir.path()), ["target"]);
    }
}
