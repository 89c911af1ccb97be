//! All-or-nothing writes of files and of directories (datasets), the one
//! way parcal writes anything.
//!
//! A file is written to a hidden temporary beside its target, synced, given
//! the target's permissions if it replaces one, and renamed into place; a
//! directory is filled as a hidden sibling and renamed into place whole.
//! The files one run writes together (a report's HTML and Markdown, a plan
//! and its summary) are written as a set ([`write_set`]): every member to
//! its temporary first, renamed into place only when all are complete.
//! A symbolic link is written through: the file it points to is replaced,
//! in that file's directory. A target that exists and is not a regular file
//! (a directory, a device such as `/dev/null`, a pipe) is refused.
//! Temporaries are hidden (`.NAME.parcal-PID-XXXXXX.tmp`), registered so
//! that [`remove_in_flight`] removes them when the program is interrupted,
//! and removed by a later write into the same directory once their process
//! is gone. A large file's data goes to the device while it is being
//! written ([`WriteBehind`]), so that its sync waits only for the last part.

use std::fs::{self, File, Metadata};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use tempfile::{NamedTempFile, TempDir};

use crate::error::{DatasetError, Result};
use crate::temp::{self, InFlight};

pub use crate::temp::remove_in_flight;
pub use crate::write_behind::{SYNC_BEHIND, WriteBehind};

/// What a file is written through: buffered, its data synced behind the
/// writer.
pub type FileWriter<'f> = BufWriter<WriteBehind<'f>>;

/// Symbolic links followed before a path is taken as a loop (Linux's limit).
const MAX_LINKS: usize = 40;

/// Writes `path` through `fill`, atomically: until `fill` has succeeded and
/// the data is synced, nothing exists under `path` (a previous file of that
/// name is left untouched), and on any error the temporary file is removed.
/// A new file gets the permissions `fs::write` would give it; a replaced
/// one keeps its own.
///
/// `fill` returns the crate's error type so that it can report errors of its
/// own (e.g. a serializer's) against `path`.
pub fn write_atomic<F>(path: &Path, fill: F) -> Result<()>
where
    F: FnOnce(&mut FileWriter<'_>) -> Result<()>,
{
    let staged = stage(path, fill)?;
    // Within a set, the rename waits for the set's other members.
    let alone = SET.with_borrow_mut(|set| match set {
        Some(pending) => pending.join(staged).map(|()| None),
        None => Ok(Some(staged)),
    })?;
    match alone {
        Some(staged) => temp::renaming(|| staged.persist()),
        None => Ok(()),
    }
}

/// A file written to its hidden temporary beside its target and synced,
/// registered in flight, not yet renamed into place.
struct Staged {
    tmp: NamedTempFile,
    /// The file the rename replaces or creates ([`destination`]).
    target: PathBuf,
    /// The path as given, for messages.
    path: PathBuf,
    _in_flight: InFlight,
}

/// Writes `path`'s temporary through `fill` ([`write_atomic`]); on any
/// error the temporary is removed.
fn stage<F>(path: &Path, fill: F) -> Result<Staged>
where
    F: FnOnce(&mut FileWriter<'_>) -> Result<()>,
{
    let target = resolve(path)?;
    let existing = regular_or_absent(&target, path)?;
    let (tmp, in_flight) = create_temp(&target, path)?;
    if let Some(existing) = existing {
        tmp.as_file()
            .set_permissions(existing.permissions())
            .map_err(|e| {
                DatasetError::io(path, "keep the permissions of the file it replaces", e)
            })?;
    }
    let mut writer = BufWriter::new(WriteBehind::new(tmp.as_file()));
    fill(&mut writer)?;
    writer
        .into_inner()
        .map_err(|e| DatasetError::io(path, "write", e.into_error()))?
        .finish()
        .map_err(|e| DatasetError::io(path, "write", e))?;
    Ok(Staged {
        tmp,
        target: destination(path)?,
        path: path.to_path_buf(),
        _in_flight: in_flight,
    })
}

impl Staged {
    /// Renames the temporary into place (the caller holds
    /// [`temp::renaming`]); on failure the temporary is removed.
    fn persist(self) -> Result<()> {
        self.tmp
            .persist(&self.target)
            .map_err(|e| DatasetError::io(&self.path, "rename into place", e.error))?;
        sync_directory(&self.target);
        Ok(())
    }
}

/// The members of the set being written on this thread ([`write_set`]).
struct Pending {
    staged: Vec<Staged>,
    /// Files the set replaces as a group: removed at the commit unless
    /// the set writes them.
    replaces: Vec<PathBuf>,
}

thread_local! {
    /// The set [`write_set`] is writing on this thread, if any.
    static SET: std::cell::RefCell<Option<Pending>> = const { std::cell::RefCell::new(None) };
}

impl Pending {
    /// Adds `staged`; a file written twice in one set is an error (the
    /// second would silently replace the first).
    fn join(&mut self, staged: Staged) -> Result<()> {
        if let Some(first) = self.staged.iter().find(|s| s.target == staged.target) {
            return Err(DatasetError::io(
                &staged.path,
                "write",
                io::Error::other(format!(
                    "the same file as {}, written by the same run; give them different names",
                    first.path.display()
                )),
            ));
        }
        self.staged.push(staged);
        Ok(())
    }

    /// Renames every member into place, then removes the files of
    /// `replaces` the set did not write. A failed rename (the target
    /// changed under the run) stops there: the members not renamed are
    /// removed, those renamed stay.
    fn commit(self) -> Result<()> {
        let written: Vec<PathBuf> = self.staged.iter().map(|s| s.target.clone()).collect();
        for staged in self.staged {
            staged.persist()?;
        }
        for path in &self.replaces {
            let stale = destination(path)?;
            if written.contains(&stale) {
                continue;
            }
            match fs::remove_file(&stale) {
                Err(e) if e.kind() != io::ErrorKind::NotFound => {
                    return Err(DatasetError::io(
                        path,
                        "remove the file of an earlier run",
                        e,
                    ));
                }
                _ => {}
            }
        }
        Ok(())
    }
}

/// Writes a set of files, whole or not at all: every file that `write`
/// writes on this thread through this module ([`write_atomic`],
/// [`write_file`] and every writer built on them) goes to its temporary
/// first, and only when `write` has succeeded, every member written and
/// synced, are they renamed into place, one after the other, with an
/// interruption waiting for the renames; then the files of `replaces`
/// that the set did not write (the names an earlier run may have left)
/// are removed. On any error of `write` (a full disk on any member, a
/// failing serializer) every temporary is removed and every target,
/// including `replaces`, is left as it was. A file written twice in the
/// set is an error. A set written within a set joins it.
///
/// The renames are not one atomic act: a hard kill or a power loss
/// between two of them leaves a mixed set, which readers of a set that
/// matters (plan.csv and plan.json) detect by a checksum one member
/// records of the other.
pub fn write_set<T, E: From<DatasetError>>(
    replaces: &[PathBuf],
    write: impl FnOnce() -> std::result::Result<T, E>,
) -> std::result::Result<T, E> {
    let nested = SET.with_borrow_mut(|set| match set {
        Some(pending) => {
            pending.replaces.extend_from_slice(replaces);
            true
        }
        None => {
            *set = Some(Pending {
                staged: Vec::new(),
                replaces: replaces.to_vec(),
            });
            false
        }
    });
    if nested {
        return write();
    }
    /// Ends the set even if `write` panics: its temporaries are removed.
    struct End;
    impl Drop for End {
        fn drop(&mut self) {
            drop(SET.with_borrow_mut(Option::take));
        }
    }
    let end = End;
    let result = write();
    let pending = SET.with_borrow_mut(Option::take);
    drop(end);
    let value = result?;
    if let Some(pending) = pending {
        temp::renaming(|| pending.commit())?;
    }
    Ok(value)
}

/// The file a write of `path` replaces or creates: symbolic links
/// followed ([`resolve`]) and its directory canonical where it exists,
/// so that two paths of one destination compare equal whether or not
/// the file exists yet.
pub fn destination(path: &Path) -> Result<PathBuf> {
    let target = resolve(path)?;
    let name = file_name(&target, path)?;
    let directory = match parent(&target) {
        dir if dir.as_os_str().is_empty() => Path::new("."),
        dir => dir,
    };
    Ok(directory
        .canonicalize()
        .unwrap_or_else(|_| directory.to_path_buf())
        .join(name))
}

/// Writes `bytes` to the file `path` atomically, as [`write_atomic`] does:
/// for the files of other crates (reports, charts, accuracy maps).
pub fn write_file(path: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic(path, |w| w.write_all(bytes).map_err(write_error(path)))
}

/// Writes the directory `dir` as a set through `fill`, which writes the
/// files into the (empty, hidden) directory it is given: a sibling of
/// `dir` renamed into place once `fill` has succeeded. Until then `dir` is
/// as it was; on any error the new directory is removed.
///
/// An absent or empty `dir` is simply replaced. A non-empty one is an
/// error unless `replace`: then it is renamed aside, the new one renamed
/// in, and the old one removed (an interruption by a signal waits for the
/// two renames; only a hard kill or power loss between them leaves `dir`
/// absent, with the old dataset kept as the hidden sibling
/// `.NAME.parcal-PID-XXXXXX.old`, which no clean-up removes).
/// A replaced directory's permissions are kept.
pub fn write_dir(dir: &Path, replace: bool, fill: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let target = resolve(dir)?;
    let existing = check_dir(&target, dir, replace)?;
    let parent = parent(&target);
    if !parent.as_os_str().is_empty() {
        fs::create_dir_all(parent)
            .map_err(|e| DatasetError::io(parent, "create the directory", e))?;
    }
    temp::sweep(parent);
    let name = file_name(&target, dir)?;
    let mut builder = tempfile::Builder::new();
    let prefix = temp::prefix(name);
    builder.prefix(&prefix).suffix(temp::SUFFIX);
    // tempfile's default is owner-only; a dataset directory is as readable
    // as one `fs::create_dir` makes (0o777 less the umask).
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o777));
    let (new, _in_flight) = InFlight::create(|| builder.tempdir_in(parent), TempDir::path)
        .map_err(|e| DatasetError::io(dir, "create a temporary directory beside it", e))?;
    if let Some((replaced, _)) = &existing {
        fs::set_permissions(new.path(), replaced.permissions()).map_err(|e| {
            DatasetError::io(dir, "keep the permissions of the directory it replaces", e)
        })?;
    }
    fill(new.path())?;
    // The new directory's own entries (the files renamed into it).
    sync_directory(&new.path().join("."));
    match existing {
        Some((_, true)) => swap(new, &target, dir, &prefix),
        _ => {
            temp::renaming(|| fs::rename(new.path(), &target))
                .map_err(|e| DatasetError::io(dir, "rename into place", e))?;
            // Renamed: nothing left for the guard to remove.
            let _ = new.keep();
            sync_directory(&target);
            Ok(())
        }
    }
}

/// Renames the non-empty `target` aside and `new` in its place, then
/// removes the old directory.
fn swap(new: TempDir, target: &Path, dir: &Path, prefix: &std::ffi::OsStr) -> Result<()> {
    let parent = parent(target);
    // A fresh name for the old directory: reserve it, then rename over it
    // (a directory may replace an empty one).
    let (aside, aside_in_flight) = InFlight::create(
        || {
            tempfile::Builder::new()
                .prefix(prefix)
                .suffix(temp::ASIDE_SUFFIX)
                .tempdir_in(parent)
                .map(TempDir::keep)
        },
        PathBuf::as_path,
    )
    .map_err(|e| DatasetError::io(dir, "create a temporary directory beside it", e))?;
    temp::renaming(|| -> Result<()> {
        fs::rename(target, &aside)
            .map_err(|e| DatasetError::io(dir, "rename the old directory aside", e))?;
        if let Err(e) = fs::rename(new.path(), target) {
            // Put the old one back; the new one is removed with `new`.
            let _ = fs::rename(&aside, target);
            return Err(DatasetError::io(dir, "rename into place", e));
        }
        Ok(())
    })
    .inspect_err(|_| {
        let _ = fs::remove_dir(&aside);
    })?;
    let _ = new.keep();
    sync_directory(target);
    // The new set is in place; an old one that cannot be removed now stays
    // as the hidden `.NAME.parcal-PID-XXXXXX.old`.
    let _ = fs::remove_dir_all(&aside);
    drop(aside_in_flight);
    Ok(())
}

/// Checks, before any work, that `path` can be written as a file: it is
/// absent or a regular file (through symbolic links), and its directory
/// exists and takes a new file (one is created and removed).
pub fn check_file(path: &Path) -> Result<()> {
    let target = resolve(path)?;
    regular_or_absent(&target, path)?;
    create_temp(&target, path).map(drop)
}

/// Checks, before any work, that [`write_dir`] can write `dir`: it is
/// absent, an empty directory, or (with `replace`) a directory; and the
/// nearest existing directory above it takes a new file.
pub fn check_dir_target(dir: &Path, replace: bool) -> Result<()> {
    let target = resolve(dir)?;
    check_dir(&target, dir, replace)?;
    let mut above = parent(&target);
    while !above.as_os_str().is_empty() && !above.exists() {
        above = parent(above);
    }
    let probe = above.join(file_name(&target, dir)?);
    create_temp(&probe, dir).map(drop)
}

/// Follows the symbolic links of `path` (itself; its directories need not
/// be followed to write there) to the file to write.
pub fn resolve(path: &Path) -> Result<PathBuf> {
    let mut current = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&current) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let link = fs::read_link(&current)
                    .map_err(|e| DatasetError::io(path, "follow the symbolic link", e))?;
                current = parent(&current).join(link);
            }
            Ok(_) => return Ok(current),
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(current),
            Err(e) => return Err(DatasetError::io(path, "write", e)),
        }
    }
    Err(DatasetError::io(
        path,
        "follow the symbolic link",
        io::Error::other(format!("more than {MAX_LINKS} links (a loop?)")),
    ))
}

/// The metadata of `target` if it is a regular file, `None` if it does not
/// exist, an error (naming `path`) if it is anything else.
fn regular_or_absent(target: &Path, path: &Path) -> Result<Option<Metadata>> {
    match fs::metadata(target) {
        Ok(meta) if meta.is_file() => Ok(Some(meta)),
        Ok(meta) => Err(DatasetError::io(
            path,
            "write",
            io::Error::other(format!(
                "it exists and is not a regular file but {}; parcal replaces only regular files",
                kind(&meta)
            )),
        )),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(DatasetError::io(path, "write", e)),
    }
}

/// `None` for an absent `target`, else its metadata and whether it is a
/// non-empty directory (an error unless `replace`); anything but a
/// directory is an error.
fn check_dir(target: &Path, dir: &Path, replace: bool) -> Result<Option<(Metadata, bool)>> {
    let meta = match fs::metadata(target) {
        Ok(meta) => meta,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(DatasetError::io(dir, "write", e)),
    };
    let refuse = |message: String| Err(DatasetError::io(dir, "write", io::Error::other(message)));
    if !meta.is_dir() {
        return refuse(format!("it exists and is {}, not a directory", kind(&meta)));
    }
    let full = fs::read_dir(target)
        .map_err(|e| DatasetError::io(dir, "read", e))?
        .next()
        .is_some();
    if full && !replace {
        return Err(DatasetError::io(
            dir,
            "write",
            io::Error::new(
                io::ErrorKind::AlreadyExists,
                "the directory exists and is not empty",
            ),
        ));
    }
    Ok(Some((meta, full)))
}

/// What a file that is not regular is, for a message.
fn kind(meta: &Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let t = meta.file_type();
        if t.is_char_device() || t.is_block_device() {
            return "a device";
        }
        if t.is_fifo() {
            return "a pipe";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    if meta.is_dir() {
        "a directory"
    } else if meta.is_file() {
        "a regular file"
    } else {
        "a special file"
    }
}

/// The directory of `path` ("" for a bare name: the current directory).
fn parent(path: &Path) -> &Path {
    path.parent().unwrap_or(Path::new(""))
}

/// The last component of `target`, or an error naming `path`.
fn file_name<'a>(target: &'a Path, path: &Path) -> Result<&'a std::ffi::OsStr> {
    target.file_name().ok_or_else(|| {
        DatasetError::io(
            path,
            "write",
            io::Error::new(io::ErrorKind::InvalidInput, "not a file name"),
        )
    })
}

/// A new hidden temporary file beside `target`, registered in flight;
/// errors name `path`.
fn create_temp(target: &Path, path: &Path) -> Result<(NamedTempFile, InFlight)> {
    let name = file_name(target, path)?;
    // A bare file name has the parent "", which tempfile takes as the
    // current directory.
    let dir = parent(target);
    temp::sweep(dir);
    let prefix = temp::prefix(name);
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(temp::SUFFIX);
    // tempfile's default is owner-only (0o600); a dataset is as readable as
    // any file the user writes (0o666 less the umask).
    #[cfg(unix)]
    builder.permissions(std::os::unix::fs::PermissionsExt::from_mode(0o666));
    InFlight::create(|| builder.tempfile_in(dir), NamedTempFile::path)
        .map_err(|e| DatasetError::io(path, "create a temporary file beside it", e))
}

/// Makes a rename into `path`'s directory durable (best effort: not every
/// platform can sync a directory).
fn sync_directory(path: &Path) {
    let dir = parent(path);
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    if let Ok(handle) = File::open(dir) {
        let _ = handle.sync_all();
    }
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

    #[cfg(unix)]
    #[test]
    fn a_replaced_file_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("secret.json");
        fs::write(&path, b"old").unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o600)).unwrap();
        write_file(&path, b"new").unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        let mode = fs::metadata(&path).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode, 0o600);
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_written_through() {
        let (links, files) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
        let target = files.path().join("real.csv");
        fs::write(&target, b"old").unwrap();
        let link = links.path().join("link.csv");
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_file(&link, b"new").unwrap();
        assert!(
            fs::symlink_metadata(&link)
                .unwrap()
                .file_type()
                .is_symlink()
        );
        assert_eq!(fs::read(&target).unwrap(), b"new");
        assert_eq!(entries(links.path()), ["link.csv"]);
        assert_eq!(entries(files.path()), ["real.csv"]);
        // A dangling link creates the file it names.
        let dangling = links.path().join("dangling.csv");
        std::os::unix::fs::symlink(files.path().join("made.csv"), &dangling).unwrap();
        write_file(&dangling, b"made").unwrap();
        assert_eq!(fs::read(files.path().join("made.csv")).unwrap(), b"made");
    }

    #[test]
    fn a_target_that_is_not_a_regular_file_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let error = write_file(dir.path(), b"x").unwrap_err().to_string();
        assert!(
            error.contains("is not a regular file but a directory"),
            "{error}"
        );
        #[cfg(unix)]
        {
            use std::os::unix::fs::FileTypeExt;
            // Refused before anything is created, so safe even as root.
            let null = Path::new("/dev/null");
            let error = write_file(null, b"x").unwrap_err().to_string();
            assert!(error.contains("not a regular file but a device"), "{error}");
            assert!(fs::metadata(null).unwrap().file_type().is_char_device());
            assert!(check_file(null).is_err());
        }
    }

    #[test]
    fn a_disk_error_while_writing_keeps_the_old_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("accuracy.csv");
        fs::write(&path, b"good").unwrap();
        let error = write_atomic(&path, |w| {
            w.write_all(b"half").map_err(write_error(&path))?;
            Err(write_error(&path)(io::Error::from(
                io::ErrorKind::StorageFull,
            )))
        })
        .unwrap_err();
        assert!(
            error.to_string().contains("accuracy.csv: cannot write"),
            "{error}"
        );
        assert_eq!(fs::read(&path).unwrap(), b"good");
        assert_eq!(entries(dir.path()), ["accuracy.csv"]);
    }

    #[test]
    fn check_file_finds_a_place_that_cannot_be_written() {
        let dir = tempfile::tempdir().unwrap();
        check_file(&dir.path().join("new.json")).unwrap();
        assert!(entries(dir.path()).is_empty(), "the probe is removed");
        // Under a regular file: refused whoever runs the test (root too).
        let file = dir.path().join("file");
        fs::write(&file, b"x").unwrap();
        let error = check_file(&file.join("out.json")).unwrap_err().to_string();
        assert!(error.contains("out.json"), "{error}");
        assert!(check_file(&dir.path().join("missing/out.json")).is_err());
    }

    /// A process that has exited: its PID is free.
    #[cfg(unix)]
    fn dead_pid() -> u32 {
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        pid
    }

    #[cfg(unix)]
    #[test]
    fn stale_temporaries_of_a_dead_writer_are_removed_on_the_next_write() {
        if !Path::new("/proc/self").exists() {
            eprintln!("skipped: no /proc to tell running processes");
            return;
        }
        let dir = tempfile::tempdir().unwrap();
        let dead = dead_pid();
        let stale_file = format!(".a.csv.parcal-{dead}-Xy12ab.tmp");
        let stale_dir = format!(".data.parcal-{dead}-Zz98cd.tmp");
        fs::write(dir.path().join(&stale_file), b"x").unwrap();
        fs::create_dir(dir.path().join(&stale_dir)).unwrap();
        fs::write(dir.path().join(&stale_dir).join("machine.json"), b"x").unwrap();
        // Kept: a running writer's (PID 1), a user's file, and an old
        // dataset a dead writer had renamed aside (data, not a temporary).
        let live = ".a.csv.parcal-1-Xy12ab.tmp";
        fs::write(dir.path().join(live), b"x").unwrap();
        fs::write(dir.path().join(".notes.tmp"), b"x").unwrap();
        let aside = format!(".data.parcal-{dead}-Qq11ee.old");
        fs::create_dir(dir.path().join(&aside)).unwrap();
        let path = dir.path().join("b.csv");
        write_file(&path, b"b").unwrap();
        assert_eq!(entries(dir.path()), [live, &aside, ".notes.tmp", "b.csv"]);
    }

    #[test]
    fn a_directory_is_written_as_a_set() {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("a/dataset");
        let fill = |content: &'static [u8]| {
            move |new: &Path| {
                write_file(&new.join("one"), content)?;
                write_file(&new.join("two"), content)
            }
        };
        write_dir(&dir, false, fill(b"1")).unwrap();
        assert_eq!(entries(&dir), ["one", "two"]);
        // Not replaced without `replace`.
        let error = write_dir(&dir, false, fill(b"2")).unwrap_err().to_string();
        assert!(error.contains("exists and is not empty"), "{error}");
        assert_eq!(fs::read(dir.join("one")).unwrap(), b"1");
        // A failure midway leaves the old set whole and no temporaries.
        let error = write_dir(&dir, true, |new: &Path| {
            write_file(&new.join("one"), b"3")?;
            Err(DatasetError::field(
                &new.join("two"),
                "x",
                "failed on purpose",
            ))
        })
        .unwrap_err();
        assert!(error.to_string().contains("failed on purpose"));
        assert_eq!(fs::read(dir.join("one")).unwrap(), b"1");
        assert_eq!(entries(&root.path().join("a")), ["dataset"]);
        // Replaced as a whole: a file of the old set does not stay.
        fs::write(dir.join("stale"), b"old").unwrap();
        write_dir(&dir, true, fill(b"4")).unwrap();
        assert_eq!(entries(&dir), ["one", "two"]);
        assert_eq!(fs::read(dir.join("two")).unwrap(), b"4");
        assert_eq!(entries(&root.path().join("a")), ["dataset"]);
        // An empty directory is simply filled; a file is refused.
        let empty = root.path().join("empty");
        fs::create_dir(&empty).unwrap();
        write_dir(&empty, false, fill(b"5")).unwrap();
        assert_eq!(entries(&empty), ["one", "two"]);
        let error = write_dir(&dir.join("one"), true, fill(b"6")).unwrap_err();
        assert!(error.to_string().contains("not a directory"), "{error}");
    }

    #[test]
    fn a_set_is_written_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let (html, md, stale) = (
            dir.path().join("report.html"),
            dir.path().join("report.md"),
            dir.path().join("old.svg"),
        );
        let write_pair = |text: &'static [u8], fail: bool| {
            write_set(std::slice::from_ref(&stale), || -> Result<()> {
                write_file(&html, text)?;
                if fail {
                    // A full disk while the second member is written.
                    return write_atomic(&md, |w| {
                        w.write_all(b"half").map_err(write_error(&md))?;
                        Err(write_error(&md)(io::Error::from(
                            io::ErrorKind::StorageFull,
                        )))
                    });
                }
                write_file(&md, text)
            })
        };
        write_pair(b"first", false).unwrap();
        fs::write(&stale, b"of an earlier run").unwrap();
        let error = write_pair(b"second", true).unwrap_err().to_string();
        assert!(error.contains("report.md: cannot write"), "{error}");
        assert_eq!(fs::read(&html).unwrap(), b"first", "the first member kept");
        assert_eq!(fs::read(&md).unwrap(), b"first");
        assert_eq!(entries(dir.path()), ["old.svg", "report.html", "report.md"]);
        write_pair(b"third", false).unwrap();
        assert_eq!(fs::read(&html).unwrap(), b"third");
        assert_eq!(fs::read(&md).unwrap(), b"third");
        // The stale file of the group is gone with the commit.
        assert_eq!(entries(dir.path()), ["report.html", "report.md"]);
        // One file twice in a set: refused, nothing written.
        let roundabout = dir.path().join(".").join("report.html");
        let error = write_set(&[], || -> Result<()> {
            write_file(&html, b"a")?;
            write_file(&roundabout, b"b")
        })
        .unwrap_err()
        .to_string();
        assert!(error.contains("the same file as"), "{error}");
        assert_eq!(fs::read(&html).unwrap(), b"third");
        assert_eq!(entries(dir.path()), ["report.html", "report.md"]);
    }

    #[cfg(unix)]
    #[test]
    fn a_directory_is_as_readable_as_a_plain_one_and_keeps_its_permissions() {
        use std::os::unix::fs::PermissionsExt;
        let root = tempfile::tempdir().unwrap();
        let mode = |p: &Path| fs::metadata(p).unwrap().permissions().mode() & 0o777;
        let plain = root.path().join("plain");
        fs::create_dir(&plain).unwrap();
        let dir = root.path().join("d");
        write_dir(&dir, false, |new| write_file(&new.join("f"), b"x")).unwrap();
        assert_eq!(mode(&dir), mode(&plain));
        fs::set_permissions(&dir, fs::Permissions::from_mode(0o700)).unwrap();
        write_dir(&dir, true, |new| write_file(&new.join("f"), b"y")).unwrap();
        assert_eq!(mode(&dir), 0o700);
    }
}
