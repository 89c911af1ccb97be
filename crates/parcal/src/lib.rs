//! parcal as a library: calibrate a hexapod (a 6-6 Stewart platform) from
//! touches of calibration balls, poses and points measured by an
//! instrument, or both ([`calibrate`], one [`CalibrationRun`];
//! [`validate_calibration`]), or any parallel mechanism through the common
//! interface (a linear delta, a cable robot; [`calibrate_mechanism`]), with
//! a priori knowledge of its design tolerances (Sato et al., "Artefact
//! calibration of parallel mechanism", Meas. Sci. Technol. 15 (2004)
//! 1158), and see what the calibration buys.
//!
//! This crate is the front door: it re-exports what a user needs from the
//! workspace's crates, so that one dependency builds a dataset in memory or
//! reads one from files, calibrates it, maps the accuracy and simulates
//! campaigns. The root holds that workflow; each crate is also here whole:
//!
//! - [`dataset`]: the dataset format, reading and writing
//!   ([`Dataset::read`], [`Dataset::write`], snapshots);
//! - [`calibration`]: the calibration and its parts (set-up, problem,
//!   prior-data conflict tests, evaluation against a truth);
//! - [`accuracy`]: accuracy maps, predicted and true;
//! - [`simulation`]: simulated campaigns (the paper's scenario and others;
//!   a linear delta or a cable robot from a front end's options,
//!   [`simulation::mechanism`]);
//! - [`kinematics`]: geometry, inverse and forward kinematics, the 33
//!   canonical parameters;
//! - [`apply`]: applying a calibration (commands, corrected poses, exports;
//!   docs/apply.md);
//! - [`report`]: presentation (calibration.json's records in words,
//!   tables, maps);
//! - [`plan`]: planning the next measurements (`parcal plan`);
//! - [`firmware`]: printer firmware's configuration files, read and
//!   written (RepRapFirmware, Klipper, Marlin; a Hangprinter's anchors and
//!   spools);
//! - [`workflows`]: the workflows built on a calibration (evaluation
//!   against a truth, the paper's reproduction);
//! - [`command`]: a calibration as `parcal calibrate` makes it, with
//!   calibration.json's record, for every front end;
//! - [`maps`]: the accuracy maps as `parcal accuracy` makes them;
//! - [`report_pages`]: a calibration's report as `parcal report`
//!   renders it;
//! - [`firmware_import`]: a printer's firmware configuration and probe
//!   log as a mechanism dataset, as `parcal import` makes it;
//! - [`firmware_lines`]: a mechanism's calibration as its firmware's
//!   lines, as `parcal export` writes them;
//! - [`hexapod_export`]: a hexapod's calibration in the forms other tools
//!   load, as `parcal export` writes them;
//! - [`mechanism_machine`]: a mechanism's calibration as the machine.json
//!   of its next calibration, as `parcal export` writes it;
//! - [`hexapod_plan`]: a hexapod's plan (ball touches or instrument poses)
//!   as `parcal plan` asks for it;
//! - [`hexapod_simulation`]: a hexapod's simulated campaign (ball touches,
//!   instrument sessions, a plan's) as `parcal simulate` asks for it;
//! - [`correction_table`]: a hexapod calibration's correction table as
//!   `parcal compensate --table` makes it.
//!
//! # Example
//!
//! Touches of 27 balls made with the paper's true machine (table 2 of Sato
//! et al.), calibrated from its design values:
//!
//! ```
//! use parcal::kinematics::{Pose, Vec3, actuators, paper, params, rotation_zyx};
//! use parcal::{ArtefactFrame, Artefacts, Ball, CalibrationOptions, Dataset, Machine};
//! use parcal::{Measurements, PARAM_NAMES, PriorSigma, Repeatability, calibrate};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let (design, truth) = (paper::design(), paper::truth());
//! let machine = Machine {
//!     geometry: parcal::dataset::GeometryRecord {
//!         base_joints: design.base.map(Into::into),
//!         platform_joints: design.platform.map(Into::into),
//!         tool: design.tool.into(),
//!         leg_lengths: design.legs,
//!     },
//!     prior_sigma: PriorSigma { base: 0.1, platform: 0.1, tool: 0.1, leg: 0.1 },
//!     repeatability: Repeatability { actuator: 0.001, tool: 0.001, position: None, orientation: None },
//!     actuator: Default::default(),
//!     session_model: Default::default(),
//!     stroke: None,
//!     joint_limits: None,
//! };
//! // Balls of radius 5 mm on a 3 x 3 x 3 grid, each touched 7 times on its
//! // lower half, the platform tilted by up to 0.17 rad.
//! let (radius, mut balls, mut measurements) = (5.0, Vec::new(), Measurements::default());
//! for i in 0..27 {
//!     let grid = |k: u32| 60.0 * (k % 3) as f64 - 60.0;
//!     let centre = [grid(i), grid(i / 3), 400.0 + grid(i / 9) * 2.0 / 3.0];
//!     let (id, centre_sigma, radius_sigma) = (format!("b{i}"), 0.1, 0.001);
//!     balls.push(Ball { id, centre, centre_sigma, radius, radius_sigma });
//!     for j in 0..7 {
//!         let (azimuth, t) = (2.4 * j as f64, (7 * i + j) as f64);
//!         let u = Vec3::new(azimuth.cos(), azimuth.sin(), -0.3 - 0.3 * j as f64).normalize();
//!         let turn = rotation_zyx(0.17 * t.sin(), 0.17 * (1.3 * t).cos(), 0.17 * (0.7 * t).sin());
//!         let tip = Vec3::from(centre) + radius * u;
//!         let pose = Pose::from_parts((tip - turn * truth.tool).into(), turn);
//!         measurements.ball.push(i);
//!         measurements.q.push(actuators(&truth, &pose));
//!     }
//! }
//! let artefacts = Artefacts { frame: ArtefactFrame::Design, balls, distances: vec![] };
//! let dataset = Dataset { machine, artefacts, measurements, tracker: Default::default(), truth: None };
//!
//! let run = calibrate(&dataset, &CalibrationOptions::default(), &mut |_| {})?;
//! assert!(run.converged(), "{:?}", run.status);
//! let sigmas = run.sigmas().expect("a converged run has a covariance");
//! let prior = run.prior.as_ref().expect("the default options have a prior").covariance();
//! let true_params = params::to_params(&truth.canonicalize()?.geometry);
//! for (k, name) in PARAM_NAMES.iter().enumerate() {
//!     let error = run.params[k] - true_params[k];
//!     println!("{name:>4} {:9.4} mm +- {:.4} (error {error:+.4})", run.params[k], sigmas[k]);
//!     // The touches sharpen the prior, and the truth is within 3 sigma.
//!     assert!(sigmas[k] < prior[(k, k)].sqrt() && error.abs() < 3.0 * sigmas[k]);
//! }
//! # Ok(()) }
//! ```
//!
//! # Errors
//!
//! [`calibrate`] validates its dataset first ([`validate`]): a bad index, a
//! short array, a value that is not finite or a ball with too few contacts
//! is a [`CalibrateError`], never a panic. A `CalibrateError` names what
//! the calibration was given (a measurement row, 0-based; a ball; a field
//! of the [`Dataset`]), states its cause in its message, and gives its row
//! ([`CalibrateError::row`]) to a caller that read files and names the line
//! (row + 2 of measurements.csv). [`DatasetError`]s of reading and writing
//! name the file and line themselves.

pub use parcal_accuracy as accuracy;
pub use parcal_apply as apply;
pub use parcal_calibrate as calibration;
pub use parcal_dataset as dataset;
pub use parcal_firmware as firmware;
pub use parcal_kinematics as kinematics;
pub use parcal_plan as plan;
pub use parcal_report as report;
pub use parcal_simulate as simulation;
pub use parcal_workflows as workflows;

pub mod command;
pub mod correction_table;
pub mod firmware_import;
pub mod firmware_lines;
pub mod hexapod_export;
pub mod hexapod_plan;
pub mod hexapod_simulation;
pub mod maps;
pub mod mechanism_machine;
mod named;
pub mod report_pages;

// The data: a dataset in memory, its files, a calibration's record.
pub use parcal_dataset::{
    ArtefactFrame, Artefacts, Ball, Calibration, Dataset, DatasetError, Distance, Machine,
    Measurements, Point3, PriorSigma, ReadOptions, Repeatability, Truth, WriteOptions,
};

// Calibration.
pub use parcal_calibrate::{
    CalibrateError, CalibrationOptions, CalibrationRun, MIN_CONTACTS_PER_BALL, Method, Observation,
    ParamCovariance, PriorMode, RadiusModel, WeightModel, calibrate, validate,
};
pub use parcal_kinematics::{KinematicsError, N_PARAMS, PARAM_NAMES, Params};

// Instrument measurements (poses, points, in sessions): what a
// calibration gives of them, and a calibration applied to data it was not
// fitted on.
pub use parcal_calibrate::cross_validation::{CrossValidation, cross_validate};
pub use parcal_calibrate::instruments::{
    Calibrated, InstrumentResult, Validation, validate_calibration,
};
pub use parcal_dataset::{Actuator, Points, Poses, SessionModel, Tracker, ValidationRecord};

// Any mechanism through the common interface (docs/mechanisms.md): its
// dataset, calibration and record, its validation on held-out data and
// its compensated commands (docs/delta.md); every kind for a linear delta
// or a cable robot, ball touches for a hexapod
// (`MechanismData::from_hexapod_touches`).
pub use parcal_calibrate::mechanism::{
    CalibratedMechanism, Compensation, MechanismCalibration, MechanismCalibrationError,
    MechanismData, MechanismOptions, MechanismValidation, calibrate_mechanism,
    compensate_mechanism, validate_mechanism,
};
pub use parcal_dataset::mechanism::{
    MechanismCalibrationRecord, MechanismDataset, MechanismValidationRecord,
};

// What a calibration buys: accuracy maps before and after.
pub use parcal_accuracy::{AccuracyError, AccuracyMap, MapGrid, MapSummary};
pub use parcal_workflows::evaluate::{Accuracy, BeforeAfter, before_after};

// Simulated campaigns.
pub use parcal_simulate::{Scenario, SimulateError, simulate};
