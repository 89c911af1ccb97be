//! Helpers shared by the integration tests: a small valid dataset with
//! awkward values, and ways to damage its files.

#![allow(dead_code)] // each test binary uses a different subset

use std::fs;
use std::path::{Path, PathBuf};

use parcal_dataset::*;
use serde_json::Value;
use tempfile::TempDir;

/// Floats that are easy to get wrong when written as text (within the
/// plausibility bound of a length, `MAX_LENGTH_MM`).
pub const AWKWARD: [f64; 8] = [
    1.0 / 3.0,
    1e-17,
    -0.0,
    123456.789012345,
    0.1 + 0.2,
    5e-324,
    -999999.9999999999,
    2.0 / 3.0 * 1e-300,
];

fn awkward(i: usize) -> f64 {
    AWKWARD[i % AWKWARD.len()]
}

/// Which optional parts to include.
#[derive(Debug, Clone, Copy)]
pub struct Parts {
    pub truth: bool,
    pub directions: bool,
    pub distances: bool,
}

pub const ALL: Parts = Parts {
    truth: true,
    directions: true,
    distances: true,
};
pub const NONE: Parts = Parts {
    truth: false,
    directions: false,
    distances: false,
};

fn points<const N: usize>(seed: usize) -> [Point3; N] {
    std::array::from_fn(|i| std::array::from_fn(|j| awkward(seed + 3 * i + j) + (i * j) as f64))
}

/// A valid dataset: 3 balls ("b01", "b02", "plate-3"), 5 contacts each
/// (interleaved), values drawn from [`AWKWARD`].
pub fn dataset(parts: Parts) -> Dataset {
    let balls: Vec<Ball> = ["b01", "b02", "plate-3"]
        .iter()
        .enumerate()
        .map(|(i, id)| Ball {
            id: (*id).to_owned(),
            centre: points::<1>(i)[0],
            centre_sigma: 0.1 + awkward(i).abs(),
            radius: 5.0 + awkward(i + 1),
            radius_sigma: MIN_SIGMA + i as f64,
        })
        .collect();
    let rows = 15;
    let ball: Vec<u32> = (0..rows).map(|r| (r % 3) as u32).collect();
    let q: Vec<[f64; 6]> = (0..rows)
        .map(|r| std::array::from_fn(|k| awkward(r + k)))
        .collect();
    Dataset {
        machine: Machine {
            geometry: GeometryRecord {
                base_joints: points(1),
                platform_joints: points(2),
                tool: [0.0, -0.0, 60.0 + 1.0 / 3.0],
                leg_lengths: std::array::from_fn(|k| 235.0 + awkward(k)),
            },
            prior_sigma: PriorSigma {
                base: 0.1,
                platform: 1.0 / 3.0,
                tool: MIN_SIGMA,
                leg: 123456.789012345,
            },
            repeatability: Repeatability {
                actuator: 0.001,
                tool: 1.0 / 3.0 * 1e-11,
                position: None,
                orientation: None,
            },
            actuator: Default::default(),
            session_model: Default::default(),
            stroke: None,
            joint_limits: None,
        },
        artefacts: Artefacts {
            frame: if parts.distances {
                ArtefactFrame::Canonical
            } else {
                ArtefactFrame::Design
            },
            balls,
            distances: if parts.distances {
                vec![
                    Distance {
                        a: 0,
                        b: 2,
                        length: 60.0003,
                        sigma: 1.0 / 3.0,
                    },
                    Distance {
                        a: 1,
                        b: 0,
                        length: 123456.789012345,
                        sigma: 1.0 / 3.0 * 1e-11,
                    },
                ]
            } else {
                vec![]
            },
        },
        measurements: Measurements {
            ball,
            q,
            direction: parts
                .directions
                .then(|| (0..rows).map(|r| points::<1>(r + 5)[0]).collect()),
        },
        truth: parts.truth.then(|| Truth {
            geometry: GeometryRecord {
                base_joints: points(3),
                platform_joints: points(4),
                tool: [awkward(1), awkward(2), 60.411],
                leg_lengths: std::array::from_fn(|k| 234.9 + awkward(k + 3)),
            },
            ball_centres: (0..3).map(|i| points::<1>(i + 7)[0]).collect(),
            ball_radii: vec![5.0, 1.0 / 3.0, 1e-17],
            contacts: (0..rows).map(|r| points::<1>(r + 11)[0]).collect(),
            actuator_scale: None,
            sessions: Vec::new(),
        }),
        tracker: Default::default(),
    }
}

/// A temporary directory holding `dataset(parts)`.
pub fn written(parts: Parts) -> TempDir {
    let dir = tempfile::tempdir().unwrap();
    dataset(parts).write(dir.path()).unwrap();
    dir
}

/// Edits a JSON file of `dir` through `serde_json::Value`.
pub fn edit_json(dir: &Path, file: &str, edit: impl FnOnce(&mut Value)) {
    let path = dir.join(file);
    let mut value: Value = serde_json::from_slice(&fs::read(&path).unwrap()).unwrap();
    edit(&mut value);
    fs::write(&path, serde_json::to_vec_pretty(&value).unwrap()).unwrap();
}

/// Replaces `measurements.csv` of `dir` by `text`.
pub fn write_csv(dir: &Path, text: &str) {
    fs::write(dir.join(MEASUREMENTS_FILE), text).unwrap();
}

/// The message of the error from reading `dir`.
pub fn read_error(dir: &Path) -> String {
    read_error_with(dir, &ReadOptions::default())
}

pub fn read_error_with(dir: &Path, options: &ReadOptions) -> String {
    match Dataset::read_with(dir, options) {
        Ok(_) => panic!("reading {} should fail", dir.display()),
        Err(e) => e.to_string(),
    }
}

/// Asserts `message` is about `file` of `dir` and contains `expected`.
pub fn assert_error(message: &str, dir: &Path, file: &str, expected: &str) {
    let prefix = format!("{}: ", dir.join(file).display());
    assert!(
        message.starts_with(&prefix),
        "error should name {file}:\n  {message}"
    );
    assert!(
        message.contains(expected),
        "error should say {expected:?}:\n  {message}"
    );
}

/// Bitwise equality of everything in two values, through their postcard
/// encoding (which stores every f64 as its 8 bytes).
pub fn assert_bitwise_eq<T: serde::Serialize + std::fmt::Debug + PartialEq>(a: &T, b: &T) {
    assert_eq!(a, b);
    assert!(
        postcard::to_stdvec(a).unwrap() == postcard::to_stdvec(b).unwrap(),
        "equal but not bitwise equal (e.g. -0.0 against 0.0)"
    );
}

/// The reference dataset written by an independent tool.
pub fn reference_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/reference-paper-seed1")
}
