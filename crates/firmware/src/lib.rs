//! Printer firmware and parcal: the configurations of linear delta
//! printers and the calibration their firmware makes, reimplemented as
//! the baseline parcal is compared against.
//!
//! - [`rrf`]: RepRapFirmware's `M665`/`M666`/`G31` lines, read from a
//!   `config.g` and written back.
//! - [`klipper`]: Klipper's delta settings in a `printer.cfg`, read and
//!   written as its `SAVE_CONFIG` block.
//! - [`probes`]: probe heights (`probes.csv`, `x,y,z` as `G30 S-1`
//!   reports them).
//! - [`autocal`]: RepRapFirmware's 3- to 9-factor auto-calibration.
//! - [`accuracy`]: the position errors of a firmware's parameters on a
//!   machine (first-layer flatness, 3D error over the build volume).
//! - [`export`]: calibrated parameters written for a firmware, with what
//!   it cannot hold and what that costs.
//! - [`gcode`]: G-code lines as the firmware parses them.
//!
//! The kinematics are [`parcal_kinematics::delta`]'s, in the firmware's
//! conventions.

pub mod accuracy;
pub mod autocal;
mod error;
pub mod export;
mod files;
pub mod gcode;
pub mod klipper;
pub mod probes;
pub mod rrf;

pub use error::FirmwareError;
