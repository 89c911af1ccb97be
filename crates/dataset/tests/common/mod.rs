//! Helpers shared by the integration tests: a small valid dataset with
//! awkward values, and ways to damage its files.

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

/// Edits `file` of `dir` as text: the first `from` becomes `to` (for what
/// a JSON value cannot hold, such as a key given twice).
pub fn edit_text(dir: &Path, file: &str, from: &str, to: &str) {
    let path = dir.join(file);
    let text = fs::read_to_string(&path).unwrap();
    fs::write(&path, text.replacen(from, to, 1)).unwrap();
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

/// A calibration record with every field set, awkward values included,
/// that its reader accepts: the parameters are its canonical geometry's,
/// the covariance positive definite with the sigmas its diagonal's roots,
/// the verdict the one its tests give.
pub fn calibration() -> Calibration {
    let covariance: Vec<Vec<f64>> = vec![
        vec![0.0036, 1e-4, 0.0],
        vec![1e-4, 0.0049, -1.0 / 3.0 * 1e-4],
        vec![0.0, -1.0 / 3.0 * 1e-4, 5e-7],
    ];
    Calibration {
        canonical: GeometryRecord {
            base_joints: [
                [0.0, 0.0, -0.0],
                [0.0, 17.432, 0.0],
                [-0.0, 1.0 / 3.0, 0.0],
                [1.0 / 3.0, -0.0, 1e-17],
                [60.0, 1e-17, 2.0],
                [-60.0, 20.0, 3.0],
            ],
            platform_joints: [
                [0.0; 3],
                [0.0, 2.0, 0.0],
                [1e-17, 2.0, 0.0],
                [1e-17, 2.0, 3.0],
                [1e-17, 2.0, 3.0],
                [1e-17, 2.0, 3.0],
            ],
            tool: [0.0, 0.0, 60.0],
            leg_lengths: [123456.789012345; 6],
        },
        parameters: ParameterTable {
            names: vec!["y_b2".into(), "x_b3".into(), "y_b3".into()],
            values: vec![17.432, -0.0, 1.0 / 3.0],
            sigma: (0..3).map(|k| covariance[k][k].sqrt()).collect(),
        },
        covariance,
        ball_centres: std::collections::BTreeMap::from([(
            "b01".to_owned(),
            CentreEstimate {
                centre: [-60.0, -60.0, 360.0 + 1e-13],
                sigma: [0.02, 0.025, 0.02],
                radius: Some(5.0 + 3e-4),
                radius_sigma: Some(7e-4),
            },
        )]),
        prior: "none".into(),
        iterations: vec![IterationSummary {
            cost: 18029.824089807713,
            step_norm: 0.0,
            residual_rms: 0.02489452864196506,
        }],
        converged: true,
        status: "converged".into(),
        options: std::collections::BTreeMap::from([("sim".to_owned(), serde_json::json!("IV"))]),
        machine: None,
        sessions: Vec::new(),
        verdict: "accepted".into(),
        reasons: vec!["the solver converged".into()],
        warnings: vec![],
        global_test: Some(GlobalTestRecord {
            cost: 187.5,
            redundancy: 190,
            variance_factor: 187.5 / 190.0,
            level: 0.05,
            interval: [0.8, 1.2],
            outcome: "consistent".into(),
        }),
        provenance: Some(Provenance {
            parcal_version: "0.1.0".into(),
            dataset: "data/x".into(),
            dataset_checksum: "crc32:0123abcd".into(),
        }),
        removed_observations: vec![RemovedObservation {
            file: "measurements.csv".into(),
            line: Some(42),
            field: None,
            normalised_residual: -51.5,
            gross_error_sigmas: -60.25,
            variance_factor: [14.5, 1.0 / 3.0],
        }],
        down_weighted_observations: vec![DownWeightedObservation {
            file: "artefacts.json".into(),
            line: None,
            field: Some("distances[3]".into()),
            weight: 0.0125,
            residual_sigmas: 107.6,
        }],
        design: Some(Machine {
            stroke: Some([-5.0, 105.0]),
            ..dataset(ALL).machine
        }),
        diagnostics: Some(Diagnostics {
            variance_components: vec![VarianceComponentRecord {
                group: "ball touches".into(),
                cost: 12.5,
                redundancy: 10.25,
            }],
            observations: Some(ObservationTests {
                tested: 12,
                level: 0.05,
                critical_value: 3.04,
                redundancy: 10.25,
                uncontrolled_below: 0.1,
                uncontrolled: 1,
                largest: vec![ObservationCheck {
                    file: "artefacts.json".into(),
                    line: None,
                    field: Some("distances[3]".into()),
                    observes: "ball b01".into(),
                    redundancy: 0.5,
                    normalised_residual: Some(-2.5),
                    gross_error_sigmas: Some(-3.5),
                    mdb_sigmas: Some(6.25),
                }],
                least_controlled: vec![ObservationCheck {
                    file: "measurements.csv".into(),
                    line: Some(9),
                    field: None,
                    observes: "ball b01".into(),
                    redundancy: 0.0,
                    normalised_residual: None,
                    gross_error_sigmas: None,
                    mdb_sigmas: None,
                }],
                normalised_histogram: Histogram::of([-0.3, 0.1, 9.0], -5.0, 0.5, 20),
                redundancy_histogram: Histogram::of([0.0, 0.5, 0.75], 0.0, 0.125, 8),
            }),
            prior_sigma: vec![Some(0.1), None, Some(0.5)],
            determined_by: vec!["data".into(), "prior (not observed)".into(), "prior".into()],
            weak_directions: vec![WeakDirectionRecord {
                eigenvalue: 4.0,
                sigma: Some(0.5),
                dominant: vec![("y_b2".into(), 0.75)],
            }],
            external_reliability: vec![ExternalReliabilityRecord {
                observation: ObservationCheck {
                    file: "measurements.csv".into(),
                    line: Some(14),
                    field: None,
                    observes: "ball b02".into(),
                    redundancy: 0.75,
                    normalised_residual: Some(0.5),
                    gross_error_sigmas: Some(0.625),
                    mdb_sigmas: Some(5.5),
                },
                row: 2,
                row_redundancy: 0.25,
                row_mdb_sigmas: 8.5,
                bias_to_noise: 3.25,
                parameter_shift: vec![0.001, -0.0025, 0.5e-4],
                map_rms_um: Some(1.5),
                map_max_um: Some(4.25),
            }],
            systematic_tests: vec![SystematicTestRecord {
                effect: "ball radius".into(),
                estimate: 0.02,
                sigma: 0.0019,
                unit: "mm".into(),
                level: 0.001,
                critical_value: 3.29,
                variance_factor_without: 0.875,
                outcome_without: "consistent".into(),
            }],
            systematic_sensitivity: vec![SystematicSensitivityRecord {
                effect: "ball radius".into(),
                unit: "mm".into(),
                sigma: 0.0017,
                mdb: 0.0070,
                level: 0.001,
                power: 0.8,
                parameter_shift: vec![0.004, -0.002],
                map_rms_um: Some(3.5),
                map_max_um: Some(9.0),
            }],
        }),
    }
}
