//! Simulated artefact-calibration campaigns: the paper scenario of Sato et
//! al. (2004) and scaled variants, written as parcal datasets with their
//! truth (spec: paper-scenario.md section 3).
//!
//! ```
//! use parcal_simulate::{Scenario, simulate};
//!
//! let simulation = simulate(&Scenario::paper(), 1)?;
//! assert_eq!(simulation.summary.contacts, 189);
//! assert!(simulation.summary.worst_check < 8.0); // FK puts every tip back on its ball
//! # Ok::<(), parcal_simulate::SimulateError>(())
//! ```

mod campaign;
mod plate;
mod rng;
mod scenario;

pub use campaign::{Simulation, Summary, ball_id, simulate};
pub use plate::{Plate, PlatePairs};
pub use rng::Rng;
pub use scenario::Scenario;

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
}
