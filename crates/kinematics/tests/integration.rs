//! The integration tests of parcal-kinematics, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-kinematics --test integration <module>::`.

mod cable_model;
mod hangprinter;
mod kinematics;
