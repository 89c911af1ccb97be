//! The integration tests of parcal-dataset, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-dataset --test integration <module>::`.
//! `interrupt.rs` is a binary of its own (its doc says why).

mod common;

mod calibration_input;
mod errors;
mod fuzz;
mod inputs;
mod joint_limits;
mod mechanism_balls;
mod mechanism_machine;
mod mechanism_quantities;
mod mechanism_truth;
mod plausibility;
mod roundtrip;
mod scale;
mod snapshot;
mod stroke;
