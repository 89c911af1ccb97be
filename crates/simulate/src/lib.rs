//! Simulated calibration campaigns written as parcal datasets with their
//! truth: artefact campaigns (the paper scenario of Sato et al. 2004 and
//! scaled variants, docs/paper-scenario.md section 3) and instrument
//! campaigns (platform poses or tool points seen by a laser tracker or
//! motion capture, in sessions: [`simulate_tracker`]), and both of one true
//! machine in one dataset ([`simulate_mixed`]); linear delta printers as
//! mechanism datasets ([`delta`]); cable robots' encoder readings with a
//! few measured positions ([`simulate_cable`]); either from a front end's
//! options, held-out data of a simulated one included ([`mechanism`]).
//!
//! ```
//! use parcal_simulate::{Scenario, simulate};
//!
//! let simulation = simulate(&Scenario::paper(), 1)?;
//! assert_eq!(simulation.summary.contacts, 189);
//! assert!(simulation.summary.worst_check < 8.0); // FK puts every tip back on its ball
//! # Ok::<(), parcal_simulate::SimulateError>(())
//! ```
//!
//! ```
//! use parcal_simulate::{TrackerScenario, simulate_tracker};
//!
//! let simulation = simulate_tracker(&TrackerScenario::paper_like(), 1)?;
//! let tracker = &simulation.dataset.tracker;
//! assert_eq!(tracker.sessions, ["1", "2", "3"]);
//! assert_eq!((tracker.poses.len(), tracker.points.len()), (150, 150));
//! # Ok::<(), parcal_simulate::SimulateError>(())
//! ```

mod cable;
mod campaign;
pub mod delta;
mod execute;
pub mod mechanism;
mod mixed;
mod plate;
mod rng;
mod scenario;
mod tracker;

use parcal_dataset::bounds::{Count, check_product};

pub use cable::{
    CableSample, CableScenario, CableSimulation, MAX_LOAD, measure_cable, measure_cable_dataset,
    simulate_cable, simulate_cable_dataset,
};
pub use campaign::{Simulation, Summary, ball_id, random_plan, simulate};
pub use execute::{MachineLimits, execute};
pub use mixed::simulate_mixed;
pub use plate::{Plate, PlatePairs};
pub use rng::Rng;
pub use scenario::{PlannedTouch, Readings, Scenario};
pub use tracker::{
    FrameSpread, TrackerKind, TrackerScenario, Workspace, re_mounted, simulate_tracker,
};

/// The most rows a simulated campaign may have: contacts, poses plus
/// points, or calibrated distances. Ten times the largest campaign whose
/// calibration is measured (`docs/performance.md`), and a few GB of memory
/// and disk at most (`docs/reliability.md` gives the figures). A fixed
/// bound, the same on every machine, so that a size given by mistake
/// (`--balls 1000000000`) is an error before anything is allocated rather
/// than an abort of the allocator.
pub const MAX_ROWS: usize = 10_000_000;

/// The bounds of each count of a campaign that sizes it (balls, contacts
/// per ball, sessions, rows per session, plate pairs): at least 1, at most
/// [`MAX_ROWS`], the bound on their product ([`check_rows`]).
pub const COUNT: Count = Count::new(
    1,
    MAX_ROWS,
    "the most rows a simulated campaign may have: a few GB of memory and disk",
);

/// The product of `counts` (name, value), the rows of a campaign: an error
/// naming every factor if it exceeds [`MAX_ROWS`] (overflow included).
pub fn check_rows(counts: &[(&str, usize)]) -> Result<usize, SimulateError> {
    check_product(
        counts,
        MAX_ROWS,
        "rows, the most a simulated campaign may have",
    )
    .map_err(SimulateError::TooLarge)
}

/// Why a simulation failed.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// A contact could not be simulated or failed its check.
    #[error("ball {ball}, contact {point}: {reason}")]
    Contact {
        /// The ball (0-based).
        ball: usize,
        /// The contact of that ball (0-based).
        point: usize,
        /// Why.
        reason: String,
    },
    /// The ball plate asked for cannot be made.
    #[error("ball plate: {0}")]
    Plate(String),
    /// The campaign would have more than [`MAX_ROWS`] rows.
    #[error("too large: {0}")]
    TooLarge(String),
    /// A mechanism's simulation cannot be made (a count, a sigma, a pose
    /// the machine cannot reach).
    #[error("mechanism simulation: {0}")]
    Mechanism(String),
    /// A front end's options of a simulated mechanism are refused (a
    /// count out of its bounds, a sigma out of its range, an option of
    /// another mechanism, held-out data that cannot be made): the message
    /// names the option ([`mechanism`]).
    #[error("{0}")]
    Options(String),
    /// An instrument scenario's counts, ranges or sigmas make no sense.
    #[error("instrument scenario: {0}")]
    Scenario(String),
    /// A row of actuator commands could not be run ([`execute`]).
    #[error("command row {row}: {reason}")]
    Command {
        /// The row (1-based).
        row: usize,
        /// Why.
        reason: String,
    },
    /// A row of an instrument campaign could not be simulated.
    #[error("session {session}, {file} row {row}: {reason}")]
    Row {
        /// The session (1-based).
        session: usize,
        /// `poses` or `points`.
        file: &'static str,
        /// The row of that file in that session (1-based).
        row: usize,
        /// Why.
        reason: String,
    },
}
