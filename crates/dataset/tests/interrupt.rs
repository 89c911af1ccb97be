//! An interruption mid-write (what `parcal`'s SIGINT/SIGTERM handler does):
//! `remove_in_flight` removes the temporaries of the writes under way, and
//! no write starts after it.
//! Alone in its test binary: it empties the process-wide registry.

use std::fs;
use std::path::Path;

use parcal_dataset::atomic::{remove_in_flight, write_dir, write_file};

#[test]
fn an_interruption_removes_the_writes_under_way_and_keeps_the_old_set() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("dataset");
    write_dir(&dir, false, |new| {
        write_file(&new.join("machine.json"), b"old")
    })
    .unwrap();
    let result = write_dir(&dir, true, |new: &Path| {
        write_file(&new.join("machine.json"), b"new")?;
        // The signal arrives here.
        remove_in_flight();
        assert!(!new.exists(), "the new directory is removed");
        write_file(&new.join("measurements.csv"), b"rows")
    });
    assert!(result.is_err(), "its directory is gone: the write fails");
    // Nor does any write start after it: no temporary is created.
    let error = write_file(&root.path().join("later.json"), b"late").unwrap_err();
    assert!(error.to_string().contains("interrupted"), "{error}");
    let names: Vec<_> = fs::read_dir(root.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["dataset"]);
    assert_eq!(fs::read(dir.join("machine.json")).unwrap(), b"old");
}
