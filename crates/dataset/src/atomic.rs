//! All-or-nothing file writes: write to a temporary name beside the target,
//! then rename it into place.

use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::{DatasetError, Result};

/// Writes `path` through `fill`, atomically: until `fill` has succeeded and
/// the data is flushed, nothing exists under `path` (a previous file of that
/// name is left untouched), and on any error the temporary file is removed.
///
/// `fill` returns the crate's error type so that it can report errors of its
/// own (e.g. a serializer's) against `path`.
pub(crate) fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let (tmp, file) = create_temp(path)?;
    let result = fill_and_sync(path, file, fill).and_then(|()| {
        fs::rename(&tmp, path).map_err(|e| DatasetError::io(path, "rename into place", e))
    });
    if result.is_err() {
        // Best effort: the error being reported matters more than this one.
        let _ = fs::remove_file(&tmp);
    }
    result
}

fn fill_and_sync<F>(path: &Path, file: File, fill: F) -> Result<()>
where
    F: FnOnce(&mut BufWriter<File>) -> Result<()>,
{
    let mut writer = BufWriter::new(file);
    fill(&mut writer)?;
    let file = writer
        .into_inner()
        .map_err(|e| DatasetError::io(path, "write", e.into_error()))?;
    file.sync_all()
        .map_err(|e| DatasetError::io(path, "write", e))
}

/// Creates a new, uniquely named hidden file in the directory of `path`.
fn create_temp(path: &Path) -> Result<(PathBuf, File)> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let name = path
        .file_name()
        .ok_or_else(|| {
            DatasetError::io(
                path,
                "write",
                io::Error::new(io::ErrorKind::InvalidInput, "not a file name"),
            )
        })?
        .to_string_lossy();
    loop {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let tmp = path.with_file_name(format!(".{name}.tmp-{}-{n}", std::process::id()));
        match OpenOptions::new().write(true).create_new(true).open(&tmp) {
            Ok(file) => return Ok((tmp, file)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(e) => {
                return Err(DatasetError::io(
                    path,
                    "create a temporary file beside it",
                    e,
                ));
            }
        }
    }
}

/// Maps an I/O error of a writer to the crate's error for `path`.
pub(crate) fn write_error(path: &Path) -> impl Fn(io::Error) -> DatasetError + '_ {
    move |e| DatasetError::io(path, "write", e)
}

#[cfg(test)]
mod tests {
    use super::*;
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
