//! The hidden temporaries of the atomic writer: their names, the registry
//! of those in flight (removed by [`remove_in_flight`] when the program is
//! interrupted) and the removal of stale ones left by a process that died.
//!
//! A temporary of the target `NAME` is `.NAME.parcal-PID-XXXXXX.tmp` in the
//! target's directory: PID is the writing process, XXXXXX random. A name of
//! that form whose process no longer runs is stale.

use std::collections::BTreeSet;
use std::ffi::{OsStr, OsString};
use std::fs;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard};

/// Marks the names of parcal's temporaries, before the writer's PID.
const MARK: &str = ".parcal-";
/// The suffix of every temporary.
pub(crate) const SUFFIX: &str = ".tmp";
/// The suffix of an old dataset renamed aside while a new one replaces it:
/// not a temporary, so never removed as a stale one (a hard kill between
/// the two renames leaves the old dataset there, found by its name).
pub(crate) const ASIDE_SUFFIX: &str = ".old";

/// The temporaries of this process that exist now.
static IN_FLIGHT: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());
/// Held while a temporary is created and registered, or renamed into place
/// (and an old dataset aside), so that an interruption removes temporaries
/// before or after, never between the two steps.
static CHANGING: Mutex<()> = Mutex::new(());
/// Set by [`remove_in_flight`]: no temporary is created after it.
static HALTED: AtomicBool = AtomicBool::new(false);
/// Directories already swept of stale temporaries by this process.
static SWEPT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

/// Locks `mutex`, ignoring a panic of another holder (the data are paths).
fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// The prefix of a temporary of the target named `name`:
/// `.NAME.parcal-PID-` (the random part and [`SUFFIX`] follow).
pub(crate) fn prefix(name: &OsStr) -> OsString {
    let mut prefix = OsString::from(".");
    prefix.push(name);
    prefix.push(format!("{MARK}{}-", std::process::id()));
    prefix
}

/// A temporary registered as in flight until dropped (the file or directory
/// itself is removed, or renamed into place, by its owner).
pub(crate) struct InFlight(PathBuf);

impl InFlight {
    /// Runs `create` (creates a temporary) and registers the path that
    /// `path` names in what it made, so that [`remove_in_flight`] finds the
    /// temporary registered or not yet created, never unregistered. Once
    /// the program is interrupted it creates nothing: an `Interrupted`
    /// error.
    pub(crate) fn create<T>(
        create: impl FnOnce() -> io::Result<T>,
        path: impl FnOnce(&T) -> &Path,
    ) -> io::Result<(T, Self)> {
        let _guard = lock(&CHANGING);
        if HALTED.load(Ordering::SeqCst) {
            return Err(io::Error::new(
                io::ErrorKind::Interrupted,
                "the program is interrupted",
            ));
        }
        let made = create()?;
        let path = path(&made).to_path_buf();
        lock(&IN_FLIGHT).push(path.clone());
        Ok((made, Self(path)))
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        let mut registry = lock(&IN_FLIGHT);
        if let Some(i) = registry.iter().position(|p| *p == self.0) {
            registry.swap_remove(i);
        }
    }
}

/// Runs `rename` (renames into place) so that [`remove_in_flight`] waits
/// for it to finish.
pub(crate) fn renaming<T>(rename: impl FnOnce() -> T) -> T {
    let _guard = lock(&CHANGING);
    rename()
}

/// Removes every temporary file and directory of this process that is in
/// flight: what an interrupted program calls before it exits (`parcal`
/// does on SIGINT and SIGTERM). A creation or a rename into place under
/// way finishes first, so each target is left whole, old or new, and no
/// temporary is left unregistered; none is created after it. Errors are
/// ignored: there is nobody left to tell.
pub fn remove_in_flight() {
    let _changing = lock(&CHANGING);
    HALTED.store(true, Ordering::SeqCst);
    for path in lock(&IN_FLIGHT).drain(..) {
        match fs::symlink_metadata(&path) {
            Ok(meta) if meta.is_dir() => {
                let _ = fs::remove_dir_all(&path);
            }
            Ok(_) => {
                let _ = fs::remove_file(&path);
            }
            Err(_) => {}
        }
    }
}

/// Removes from `dir`, once per process, the stale temporaries: those whose
/// writer is no longer running. Only where the running processes can be
/// listed (`/proc`); elsewhere nothing is removed. Errors are ignored: a
/// stale temporary that stays is harmless.
pub(crate) fn sweep(dir: &Path) {
    let proc = Path::new("/proc/self");
    if !proc.exists() || !lock(&SWEPT).insert(dir.to_path_buf()) {
        return;
    }
    let Ok(entries) = fs::read_dir(if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    }) else {
        return;
    };
    for entry in entries.flatten() {
        let Some(pid) = writer(&entry.file_name()) else {
            continue;
        };
        if pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists() {
            continue;
        }
        let path = entry.path();
        let _ = match entry.file_type() {
            Ok(kind) if kind.is_dir() => fs::remove_dir_all(&path),
            _ => fs::remove_file(&path),
        };
    }
}

/// The PID of the writer of the temporary `name`, if it is one of ours.
fn writer(name: &OsStr) -> Option<u32> {
    let name = name.to_str()?;
    let stem = name.strip_prefix('.')?.strip_suffix(SUFFIX)?;
    let (_, tail) = stem.rsplit_once(MARK)?;
    let (pid, random) = tail.split_once('-')?;
    let random_ok = !random.is_empty() && random.chars().all(|c| c.is_ascii_alphanumeric());
    random_ok.then(|| pid.parse().ok()).flatten()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_temporary_names_its_writer() {
        let mut name = prefix(OsStr::new("calibration.json"));
        name.push("Ab3xYz");
        name.push(SUFFIX);
        assert!(
            name.to_str()
                .unwrap()
                .starts_with(".calibration.json.parcal-")
        );
        assert_eq!(writer(&name), Some(std::process::id()));
        for other in [
            "calibration.json",
            ".calibration.json.tmp",
            ".a.parcal-12-.tmp",
            ".a.parcal-x1-abc.tmp",
            "a.parcal-12-abc.tmp",
            ".a.parcal-12-abc.tmp.bak",
        ] {
            assert_eq!(writer(OsStr::new(other)), None, "{other}");
        }
        assert_eq!(writer(OsStr::new(".a.b.parcal-12-abc.tmp")), Some(12));
    }
}
