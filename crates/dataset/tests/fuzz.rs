//! Fuzzing every reader on stable Rust: arbitrary bytes, and valid files
//! mutated (bits flipped, bytes set, tokens inserted, ranges deleted or
//! copied elsewhere, truncations). A reader must return `Ok` or `Err`,
//! never panic, and what it returns `Ok` must be valid.
//!
//! A short run is part of the test suite; `PARCAL_FUZZ_CASES=N` sets the
//! number of inputs per reader for a long one, `PARCAL_FUZZ_SEED=S` its
//! seed (default 1: the suite's run is the same every time;
//! docs/reliability.md).

use crate::common;

use std::cell::Cell;
use std::fs;
use std::path::{Path, PathBuf};

use common::*;
use parcal_dataset::*;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, RngSeed, TestRunner};

/// The value of environment variable `name`, or `default`.
fn setting<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Byte strings that matter to the formats, inserted by mutations.
const TOKENS: &[&[u8]] = &[
    b"1e999",
    b"-0",
    b"1e300",
    b"1e-300",
    b"0",
    b"-1",
    b"NaN",
    b"inf",
    b"\"",
    b"\"\"",
    b"{",
    b"}",
    b"[",
    b"]",
    b",",
    b":",
    b"null",
    b"true",
    b"\"format\": \"parcal-machine/1\",",
    b"\"format\": \"parcal-machine/2\",",
    b"\xEF\xBB\xBF",
    b"\n",
    b"\r\n",
    b"\x1b[31m",
    b"\xff\xfe",
    b"99999999999999999999999",
    b"b01",
    b"0,0,0",
];

/// One change to a file.
#[derive(Debug, Clone)]
enum Mutation {
    Flip(Index, u8),
    Set(Index, u8),
    Insert(Index, Vec<u8>),
    Delete(Index, usize),
    /// Copies `len` bytes from the first place to the second.
    Splice(Index, Index, usize),
    Truncate(Index),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let token = prop_oneof![
        3 => proptest::sample::select(TOKENS).prop_map(<[u8]>::to_vec),
        1 => proptest::collection::vec(any::<u8>(), 1..16),
    ];
    prop_oneof![
        3 => (any::<Index>(), 0u8..8).prop_map(|(i, b)| Mutation::Flip(i, 1 << b)),
        2 => (any::<Index>(), any::<u8>()).prop_map(|(i, b)| Mutation::Set(i, b)),
        3 => (any::<Index>(), token).prop_map(|(i, t)| Mutation::Insert(i, t)),
        2 => (any::<Index>(), 1usize..64).prop_map(|(i, n)| Mutation::Delete(i, n)),
        2 => (any::<Index>(), any::<Index>(), 1usize..256)
            .prop_map(|(a, b, n)| Mutation::Splice(a, b, n)),
        1 => any::<Index>().prop_map(Mutation::Truncate),
    ]
}

fn apply(bytes: &mut Vec<u8>, m: &Mutation) {
    if bytes.is_empty() {
        if let Mutation::Insert(_, t) = m {
            bytes.extend(t);
        }
        return;
    }
    let at = |i: &Index| i.index(bytes.len());
    match m {
        Mutation::Flip(i, bit) => {
            let k = at(i);
            bytes[k] ^= bit;
        }
        Mutation::Set(i, b) => {
            let k = at(i);
            bytes[k] = *b;
        }
        Mutation::Insert(i, t) => {
            let k = at(i);
            bytes.splice(k..k, t.iter().copied());
        }
        Mutation::Delete(i, n) => {
            let k = at(i);
            bytes.drain(k..(k + n).min(bytes.len()));
        }
        Mutation::Splice(from, to, n) => {
            let (a, b) = (at(from), at(to));
            let chunk = bytes[a..(a + n).min(bytes.len())].to_vec();
            bytes.splice(b..b, chunk);
        }
        Mutation::Truncate(i) => {
            let k = at(i);
            bytes.truncate(k);
        }
    }
}

/// Arbitrary bytes (one input in five) or `valid` mutated 1 to 5 times.
fn input(valid: Vec<u8>) -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        1 => proptest::collection::vec(any::<u8>(), 0..512),
        4 => proptest::collection::vec(mutation(), 1..6).prop_map(move |ms| {
            let mut bytes = valid.clone();
            for m in &ms {
                apply(&mut bytes, m);
            }
            bytes
        }),
    ]
}

/// Runs `read` on `PARCAL_FUZZ_CASES` inputs drawn from `strategy`; `read` says
/// whether the input was accepted. Prints how many were, so that a run
/// shows how deep the inputs got.
fn fuzz(
    name: &str,
    strategy: impl Strategy<Value = Vec<u8>>,
    read: impl Fn(&[u8]) -> Result<bool, TestCaseError>,
) {
    let mut runner = TestRunner::new(Config {
        cases: setting("PARCAL_FUZZ_CASES", 300),
        rng_seed: RngSeed::Fixed(setting("PARCAL_FUZZ_SEED", 1)),
        failure_persistence: None,
        ..Config::default()
    });
    let (inputs, accepted) = (Cell::new(0u64), Cell::new(0u64));
    let start = std::time::Instant::now();
    runner
        .run(&strategy, |bytes| {
            inputs.set(inputs.get() + 1);
            accepted.set(accepted.get() + u64::from(read(&bytes)?));
            Ok(())
        })
        .unwrap();
    eprintln!(
        "fuzz {name}: {} inputs, {} accepted, {:.1} s",
        inputs.get(),
        accepted.get(),
        start.elapsed().as_secs_f64()
    );
}

/// A valid dataset with everything: ball touches with directions,
/// distances and truth, and poses and points in two sessions.
fn full_dataset() -> Dataset {
    let mut d = dataset(ALL);
    d.machine.repeatability.position = Some(0.01);
    d.machine.repeatability.orientation = Some(1e-4);
    let q = |r: usize| std::array::from_fn(|k| 100.0 + (r * 6 + k) as f64 / 7.0);
    d.tracker = Tracker {
        sessions: vec!["day 1".into(), "2".into()],
        poses: Poses {
            session: vec![0, 1, 0],
            q: (0..3).map(q).collect(),
            position: vec![[1.0, 2.0, 700.0], [-1.5, 0.25, 650.0], [0.0, 0.0, 600.0]],
            orientation: vec![
                [0.0, 0.0, 0.0, 1.0],
                [0.6, 0.0, 0.0, 0.8],
                [0.0, 0.6, 0.0, 0.8],
            ],
        },
        points: Points {
            session: vec![1, 1, 0],
            q: (3..6).map(q).collect(),
            position: vec![[1.0, 2.0, 760.0], [3.0, -4.0, 700.5], [0.0, 0.0, 1.0 / 3.0]],
        },
    };
    let truth = d.truth.as_mut().unwrap();
    let session = |label: &str| SessionRecord {
        label: label.into(),
        tracker_frame: FrameRecord::IDENTITY,
        body_frame: FrameRecord::IDENTITY,
        leg_offsets: [0.0; 6],
    };
    truth.sessions = vec![session("day 1"), session("2")];
    d
}

/// Fuzzes the reader of `file` of a dataset directory: the other files
/// stay valid, `file` is replaced by each input and the dataset read.
fn fuzz_dataset_file(file: &str) {
    let dir = tempfile::tempdir().unwrap();
    let original = full_dataset();
    original.write(dir.path()).unwrap();
    let path = dir.path().join(file);
    let valid = fs::read(&path).unwrap();
    fuzz(file, input(valid), |bytes| {
        fs::write(&path, bytes).unwrap();
        let read = Dataset::read(dir.path());
        if let Ok(read) = &read {
            prop_assert!(read.validate().is_ok(), "{file}: read but invalid");
        }
        Ok(read.is_ok())
    });
}

#[test]
fn fuzz_machine_json() {
    fuzz_dataset_file(MACHINE_FILE);
}

#[test]
fn fuzz_artefacts_json() {
    fuzz_dataset_file(ARTEFACTS_FILE);
}

#[test]
fn fuzz_truth_json() {
    fuzz_dataset_file(TRUTH_FILE);
}

#[test]
fn fuzz_measurements_csv() {
    fuzz_dataset_file(MEASUREMENTS_FILE);
}

#[test]
fn fuzz_poses_csv() {
    fuzz_dataset_file(POSES_FILE);
}

#[test]
fn fuzz_points_csv() {
    fuzz_dataset_file(POINTS_FILE);
}

/// A calibration with every optional part.
/// [`calibration`] with a calibrated machine and a truth's sessions.
fn full_calibration() -> Calibration {
    let d = full_dataset();
    Calibration {
        machine: Some(CalibratedMachine {
            geometry: d.machine.geometry.clone(),
            actuator: Actuator::default(),
        }),
        sessions: d.truth.unwrap().sessions,
        ..calibration()
    }
}

#[test]
fn fuzz_calibration_json() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(CALIBRATION_FILE);
    full_calibration().write(&path).unwrap();
    let valid = fs::read(&path).unwrap();
    fuzz(CALIBRATION_FILE, input(valid), |bytes| {
        fs::write(&path, bytes).unwrap();
        Ok(Calibration::read(&path).is_ok())
    });
}

/// The snapshot of the full dataset, and a path to write inputs to.
fn snapshot() -> (tempfile::TempDir, PathBuf, Vec<u8>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("d.parcal");
    full_dataset().write_snapshot(&path).unwrap();
    let valid = fs::read(&path).unwrap();
    (dir, path, valid)
}

fn read_snapshot(path: &Path, bytes: &[u8]) -> Result<bool, TestCaseError> {
    fs::write(path, bytes).unwrap();
    let read = Dataset::read_snapshot(path);
    if let Ok(read) = &read {
        prop_assert!(read.validate().is_ok(), "snapshot read but invalid");
    }
    Ok(read.is_ok())
}

/// The whole file mutated: mostly refused by the header or the checksum.
#[test]
fn fuzz_snapshot_file() {
    let (_dir, path, valid) = snapshot();
    fuzz("snapshot file", input(valid), |bytes| {
        read_snapshot(&path, bytes)
    });
}

/// The payload mutated behind a header made to match it (length and
/// checksum): the decoding and the validation see every input.
#[test]
fn fuzz_snapshot_payload() {
    const HEADER: usize = 24;
    let (_dir, path, valid) = snapshot();
    let payload = valid[HEADER..].to_vec();
    fuzz("snapshot payload", input(payload), |payload| {
        let mut bytes = valid[..HEADER].to_vec();
        bytes[12..20].copy_from_slice(&(payload.len() as u64).to_le_bytes());
        bytes[20..24].copy_from_slice(&crc32fast::hash(payload).to_le_bytes());
        bytes.extend(payload);
        read_snapshot(&path, &bytes)
    });
}
