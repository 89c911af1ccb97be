//! Positioning-accuracy maps of a hexapod model (docs/paper-scenario.md section 5; Sato et
//! al., Meas. Sci. Technol. 15 (2004) 1158, figs. 3, 7, 10).
//!
//! A grid of targets on a plane of the design frame ([`MapGrid`], the
//! paper's 21 x 21 points on z = 400 by default) is mapped into the
//! canonical frames with the design geometry's transforms
//! ([`CanonicalTargets`]); the model being assessed (33 canonical
//! parameters, paper eq. 3) is commanded to each target at the home
//! orientation. Two kinds of map, each absolute and registered (after the
//! best rigid motion of the whole grid, what a user sees after registering
//! the work frame):
//!
//! - [`predicted`]: `sqrt(trace)` of the tip covariance `J_f Σ_p J_fᵀ` for a
//!   parameter covariance `Σ_p` (the prior before calibration, the posterior
//!   after);
//! - [`true_error`] (simulation): the distance from the true machine's tip
//!   to the target, the truth given in its own canonical frames;
//!
//! with [`MapSummary`] (RMS, max), [`to_csv`] and the rigid registration
//! [`mod@kabsch`]. Lengths in mm (summaries display in um).
//!
//! ```
//! use parcal_accuracy::{MapGrid, predicted, true_error};
//! use parcal_kinematics::{N_PARAMS, paper, params};
//! use nalgebra::SMatrix;
//!
//! // Before calibration: the model is the design, the paper's prior.
//! let design = paper::design();
//! let model = params::to_params(&design.canonicalize()?.geometry);
//! let prior = SMatrix::<f64, N_PARAMS, N_PARAMS>::identity() * 0.1f64.powi(2);
//! let grid = MapGrid::square(100.0, 50.0, 400.0); // 5 x 5 points on z = 400
//! let prediction = predicted(&design, &model, &prior, &grid)?;
//! println!("predicted: {prediction}");
//!
//! // The true machine (table 2), in its own canonical frames.
//! let truth = paper::truth().canonicalize()?.geometry;
//! let actual = true_error(&design, &model, &truth, &grid)?;
//! // Millimetres absolute (the frames tilt), a tenth of that registered.
//! assert!(actual.absolute_summary().rms > 1.0);
//! assert!(actual.registered_summary().rms < 0.2);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

mod error;
mod grid;
pub mod kabsch;
mod map;
mod model;
mod output;
mod predicted;
mod truth;

pub use error::AccuracyError;
pub use grid::{CanonicalTargets, MapGrid};
pub use kabsch::{RigidMotion, kabsch};
pub use map::{AccuracyMap, MapSummary};
pub use output::to_csv;
pub use parcal_kinematics::ParamCovariance;
pub use predicted::{predicted, predicted_at, registered_jacobians, remove_rigid_motions};
pub use truth::{parameter_error, true_error, true_error_at, true_tips};
