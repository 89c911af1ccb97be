//! Reader and writer of parcal's dataset format, version 1: a hexapod's
//! dataset (below), and another mechanism's, a linear delta's or a cable
//! robot's ([`mechanism`]).
//!
//! A hexapod's dataset is one directory (lengths in mm, angles in rad):
//!
//! | file | content | type |
//! |---|---|---|
//! | `machine.json` | design geometry, tolerances, repeatability | [`Machine`] |
//! | `artefacts.json` | calibration balls, optional distances | [`Artefacts`] |
//! | `measurements.csv` | one row per contact: ball id, q1..q6, optional dir_x,dir_y,dir_z | [`Measurements`] |
//! | `truth.json` | simulated datasets only: the true values | [`Truth`] |
//!
//! and a calibration writes `calibration.json` ([`Calibration`]). The format is
//! specified in `docs/dataset-format.md`.
//!
//! Reading checks everything (shapes, finite and plausible numbers, sigmas,
//! ids, a geometry with canonical frames, consistency between the files)
//! and reports the first problem as a [`DatasetError`] that names the file
//! and the field or line; the same validation guards writing and snapshots.
//! Only regular files are read, JSON files up to [`JSON_CAP`] bytes and CSV
//! lines up to [`CSV_LINE_CAP`] bytes (`docs/reliability.md`). Writing is
//! atomic ([`atomic`]): each file, and a dataset directory as a whole. It is
//! deterministic (same data, same bytes) and exact: every
//! `f64` reads back bit for bit. [`Dataset::write_snapshot`] and
//! [`Dataset::read_snapshot`] store a whole dataset in a compact binary file
//! that loads millions of contacts in a fraction of a second.
//!
//! # Example
//!
//! ```
//! use parcal_dataset::*;
//!
//! # fn main() -> Result<(), DatasetError> {
//! let ring = |r: f64, z: f64| {
//!     std::array::from_fn(|i| {
//!         let a = i as f64 * std::f64::consts::PI / 3.0;
//!         [r * a.cos(), r * a.sin(), z]
//!     })
//! };
//! let dataset = Dataset {
//!     machine: Machine {
//!         geometry: GeometryRecord {
//!             base_joints: ring(100.0, 0.0),
//!             platform_joints: ring(50.0, 0.0),
//!             tool: [0.0, 0.0, 60.0],
//!             leg_lengths: [235.0; 6],
//!         },
//!         prior_sigma: PriorSigma { base: 0.1, platform: 0.1, tool: 0.1, leg: 0.1 },
//!         repeatability: Repeatability { actuator: 0.001, tool: 0.001, position: None, orientation: None },
//!         actuator: Actuator::default(),
//!         session_model: SessionModel::default(),
//!         stroke: None,
//!         joint_limits: None,
//!     },
//!     artefacts: Artefacts {
//!         frame: ArtefactFrame::Design,
//!         balls: vec![Ball {
//!             id: "b01".into(),
//!             centre: [0.0, 0.0, 400.0],
//!             centre_sigma: 0.1,
//!             radius: 5.0,
//!             radius_sigma: 0.001,
//!         }],
//!         distances: vec![],
//!     },
//!     measurements: Measurements {
//!         ball: vec![0; 4],
//!         q: vec![[100.0, 101.0, 102.0, 103.0, 104.0, 105.0 + 1.0 / 3.0]; 4],
//!         direction: None,
//!     },
//!     tracker: Tracker::default(),
//!     truth: None,
//! };
//!
//! let dir = tempfile::tempdir().unwrap();
//! dataset.write(dir.path())?;
//! let read = Dataset::read(dir.path())?;
//! assert_eq!(read, dataset);
//! assert_eq!(read.contacts_per_ball(), [4]);
//!
//! // Problems are reported with the file and the field or line:
//! std::fs::write(dir.path().join("measurements.csv"), "ball,q1,q2,q3,q4,q5,q6\nb02,1,2,3,4,5,6\n")
//!     .unwrap();
//! let error = Dataset::read(dir.path()).unwrap_err();
//! assert!(error.to_string().ends_with(
//!     "measurements.csv: line 2, column ball: unknown ball id \"b02\" (not in artefacts.json)"
//! ));
//! # Ok(())
//! # }
//! ```

mod artefacts;
pub mod atomic;
pub mod bounds;
mod calibration;
mod check;
pub mod checksum;
mod dataset;
mod declared;
mod error;
mod fields;
mod geometry;
mod input;
mod json;
mod machine;
mod measurements;
pub mod mechanism;
mod numbers;
mod quote;
mod session;
mod shape;
mod snapshot;
mod stroke;
mod table;
mod temp;
mod tracker;
mod truth;
mod validation;
mod write_behind;

pub use artefacts::{ArtefactFrame, Artefacts, Ball, Distance};
pub use calibration::{
    CalibratedMachine, Calibration, CentreEstimate, Diagnostics, DownWeightedObservation,
    ExternalReliabilityRecord, GlobalTestRecord, Histogram, IN_MEMORY, IterationSummary, MAX_BINS,
    MAX_ITERATIONS, MAX_LISTED, MAX_PARAMETERS, MAX_SENTENCES, ObservationCheck, ObservationTests,
    ParameterTable, Provenance, RemovedObservation, SystematicSensitivityRecord,
    SystematicTestRecord, VarianceComponentRecord, WeakDirectionRecord,
};
pub use check::{MAX_LENGTH_MM, MIN_SCALE, MIN_SIGMA, shown};
pub use dataset::{Dataset, MIN_CONTACTS_PER_BALL, ReadOptions, WriteOptions};
pub use declared::{HEXAPOD, declared_mechanism};
pub use error::DatasetError;
pub use geometry::GeometryRecord;
pub use input::JSON_CAP;
pub use machine::{Actuator, JointLimitsRecord, Machine, Repeatability, SessionModel};
pub use measurements::Measurements;
pub use numbers::{
    COMMANDS, read_labelled_numbers, read_numbers, read_optionally_labelled_numbers, write_numbers,
};
pub use parcal_kinematics::PriorSigma;
pub use session::{FrameRecord, SessionRecord};
pub use stroke::{OutsideStroke, STROKE_SIGMAS};
pub use table::CSV_LINE_CAP;
pub use tracker::{DEFAULT_SESSION, Points, Poses, Tracker};
pub use truth::Truth;
pub use validation::{NuisanceCandidate, PredictionTestRecord, ValidationRecord};

/// A point or vector: x, y, z in mm.
pub type Point3 = [f64; 3];

/// File name of the machine in a dataset directory.
pub const MACHINE_FILE: &str = "machine.json";
/// File name of the artefacts in a dataset directory.
pub const ARTEFACTS_FILE: &str = "artefacts.json";
/// File name of the measurements in a dataset directory.
pub const MEASUREMENTS_FILE: &str = "measurements.csv";
/// File name of the (optional) measured poses in a dataset directory.
pub const POSES_FILE: &str = "poses.csv";
/// File name of the (optional) measured tool points in a dataset directory.
pub const POINTS_FILE: &str = "points.csv";
/// File name of the (optional) truth in a dataset directory.
pub const TRUTH_FILE: &str = "truth.json";
/// Conventional file name of a validation result.
pub const VALIDATION_FILE: &str = "validation.json";
/// Conventional file name of a calibration result.
pub const CALIBRATION_FILE: &str = "calibration.json";
