//! The integration tests of parcal-workflows, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-workflows --test integration <module>::`.

mod common;

mod batch;
mod determinism;
mod instruments_monte_carlo;
mod mirror;
mod mixed;
mod monte_carlo;
mod nees_decomposition;
mod plate;
mod radius_model;
mod regression;
mod robust;
mod scale;
mod seeds;
mod snooping;
mod touch_scales;
mod verdicts;
