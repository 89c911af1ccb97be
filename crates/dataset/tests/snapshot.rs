//! Binary snapshots: exact round trip, refusal of anything damaged, speed.

use crate::common;

use std::fs;

use common::*;
use parcal_dataset::*;

fn snapshot_of(parts: Parts) -> (tempfile::TempDir, std::path::PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("data.parcal");
    dataset(parts).write_snapshot(&path).unwrap();
    (dir, path)
}

fn snapshot_error(path: &std::path::Path) -> String {
    Dataset::read_snapshot(path).unwrap_err().to_string()
}

#[test]
fn snapshot_round_trip_is_bitwise_identical() {
    for parts in [ALL, NONE] {
        let (_dir, path) = snapshot_of(parts);
        assert_bitwise_eq(&Dataset::read_snapshot(&path).unwrap(), &dataset(parts));
    }
}

#[test]
fn snapshot_missing_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("absent.parcal");
    assert_eq!(
        snapshot_error(&path),
        format!("{}: required file not found", path.display())
    );
}

#[test]
fn snapshot_wrong_magic() {
    let dir = written(NONE);
    let path = dir.path().join(MACHINE_FILE);
    assert_eq!(
        snapshot_error(&path),
        format!(
            "{}: is not a parcal dataset snapshot (wrong magic header)",
            path.display()
        )
    );
}

#[test]
fn snapshot_of_another_version() {
    // Versions 1 (a checksum of its own), 2 (no instrument data), 3 (no
    // stroke) and 4 (no joint limits), and a future version alike.
    for version in [1u32, 2, 3, 4, 7] {
        let (_dir, path) = snapshot_of(NONE);
        let mut bytes = fs::read(&path).unwrap();
        bytes[8..12].copy_from_slice(&version.to_le_bytes());
        fs::write(&path, bytes).unwrap();
        assert_eq!(
            snapshot_error(&path),
            format!(
                "{}: has snapshot version {version}; this parcal reads version 5 \
                 (write the snapshot again from the dataset's files)",
                path.display()
            )
        );
    }
}

#[test]
fn snapshot_truncated() {
    let (_dir, path) = snapshot_of(ALL);
    let bytes = fs::read(&path).unwrap();
    for len in [0, 5, 8, 20, 23, 24, 25, bytes.len() / 2, bytes.len() - 1] {
        fs::write(&path, &bytes[..len]).unwrap();
        let err = snapshot_error(&path);
        assert!(
            err.starts_with(&format!("{}: is truncated", path.display())),
            "{len}: {err}"
        );
    }
}

#[test]
fn snapshot_corrupt() {
    let (_dir, path) = snapshot_of(ALL);
    let bytes = fs::read(&path).unwrap();
    for at in [24, 100, bytes.len() / 2, bytes.len() - 1] {
        let mut damaged = bytes.clone();
        damaged[at] ^= 0x10;
        fs::write(&path, &damaged).unwrap();
        assert_eq!(
            snapshot_error(&path),
            format!("{}: is corrupt: checksum mismatch", path.display()),
            "byte {at}"
        );
    }
    let mut longer = bytes.clone();
    longer.extend_from_slice(b"junk");
    fs::write(&path, &longer).unwrap();
    assert_eq!(
        snapshot_error(&path),
        format!(
            "{}: is corrupt: 4 bytes past the {}-byte payload",
            path.display(),
            bytes.len() - 24
        )
    );
}

#[test]
fn snapshot_of_an_invalid_dataset_is_not_written() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("data.parcal");
    let mut bad = dataset(ALL);
    bad.machine.prior_sigma.tool = 0.0;
    assert_eq!(
        bad.write_snapshot(&path).unwrap_err().to_string(),
        format!(
            "{}: field prior_sigma.tool: must be positive, found 0",
            path.display()
        )
    );
    assert!(!path.exists());
}
