//! The integration tests of parcal-plan, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-plan --test integration <module>::`.

mod common;

mod mechanism_distances;
mod mechanism_heights;
mod mechanism_plan;
mod plan_then_calibrate;
mod plan_tracker_poses;
