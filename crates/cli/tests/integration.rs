//! The integration tests of parcal-cli, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-cli --test integration <module>::`.

mod common;

mod address_space;
mod apply;
mod cable_simulation;
mod cli;
mod delta;
mod delta_marlin;
mod hangprinter;
mod held_out;
mod hexapod_common;
mod outputs;
mod plan_mechanism;
mod reach;
mod report;
