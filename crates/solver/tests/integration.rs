//! The integration tests of parcal-solver, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-solver --test integration <module>::`.

mod common;

mod convergence;
mod effects;
mod influence;
mod local;
mod monitor;
mod redundancy;
mod refine;
mod robust;
mod robustness;
mod schur_vs_dense;
