//! Which measurements to make next on any mechanism calibrated through
//! the generic engine (`parcal_calibrate::mechanism`: a linear delta, a
//! cable robot): greedily, the candidate whose measurement most reduces
//! the trace of the predicted covariance of a chosen group of parameters
//! (A-optimality), from a calibration's covariance or the design's prior
//! alone, linearised there. docs/cable-robots.md and docs/delta-measurements.md give
//! the figures.
//!
//! - [`candidate`]: a measurement a plan may choose, in the engine's
//!   observation kinds;
//! - [`information`]: its whitened rows `M` over the unknowns, with what
//!   an unknown pose absorbs projected out;
//! - [`greedy`]: the selection by Woodbury updates;
//! - [`workspace`]: the candidates on a grid over the mechanism's
//!   workspace;
//! - [`predict`]: the plan itself: start, selection, sigmas before and
//!   after, what stays at the prior;
//! - [`plan_file`]: the file to fill in (the dataset's own probes.csv or
//!   points.csv) and its JSON summary.

pub mod candidate;
pub mod greedy;
pub mod information;
pub mod plan_file;
pub mod predict;
pub mod workspace;

pub use candidate::{Candidate, Counts, Stage};
pub use greedy::Pick;
pub use predict::{
    MechanismPlan, PlanRequest, PlannedParameter, Start, TRIGGER_GROUP, default_group,
    linearisation_point, plan_mechanism, with_sigmas,
};
