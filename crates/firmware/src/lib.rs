//! Printer firmware and parcal: the configurations of linear delta
//! printers and the calibration their firmware makes, reimplemented as
//! the baseline parcal is compared against, and the Hangprinter's
//! (a cable robot's) anchors and spool radii.
//!
//! - [`rrf`]: RepRapFirmware's `M665`/`M666`/`G31` lines, read from a
//!   `config.g` and written back.
//! - [`klipper`]: Klipper's delta settings in a `printer.cfg`, read with
//!   the probes and part distances its `DELTA_CALIBRATE` saved, and
//!   written as its `SAVE_CONFIG` block; its `DELTA_CALIBRATE` fit.
//! - [`marlin`]: Marlin's `M665`/`M666`/`M851` settings, read from an
//!   `M503` report and written back.
//! - [`probes`]: probe heights (`probes.csv`, `x,y,z` as `G30 S-1`
//!   reports them).
//! - [`autocal`]: RepRapFirmware's 3- to 9-factor auto-calibration.
//! - [`accuracy`]: the position errors of a firmware's parameters on a
//!   machine (first-layer flatness, 3D error over the build volume).
//! - [`export`]: calibrated parameters written for a firmware, with what
//!   it cannot hold and what that costs.
//! - [`hangprinter`]: a Hangprinter's anchors and spool radii (`M669`,
//!   `M666 R`), written from a cable robot's calibration and read back.
//! - [`gcode`]: G-code lines as the firmware parses them.
//!
//! The kinematics are [`parcal_kinematics::delta`]'s and
//! [`parcal_kinematics::cable`]'s, in the firmware's conventions.

pub mod accuracy;
pub mod autocal;
mod error;
pub mod export;
mod files;
pub mod gcode;
pub mod hangprinter;
pub mod klipper;
pub mod marlin;
pub mod probes;
pub mod rrf;

pub use error::FirmwareError;
pub use files::MAX_MAGNITUDE;
