//! The integration tests of parcal-calibrate, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-calibrate --test integration <module>::`.

#[path = "support/mean.rs"]
mod mean;
#[path = "support/nees.rs"]
mod nees;

mod cable_simulation;
mod dense_reference;
mod hangprinter;
mod hangprinter_validation;
mod hexapod_common;
mod instruments;
mod large_tilts;
mod mechanism_cross_validation;
mod mechanism_data;
mod mechanism_delta;
mod mechanism_validation;
mod misfit;
mod reference;
mod trackers;
mod validation;
