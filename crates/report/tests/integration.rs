//! The integration tests of parcal-report, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-report --test integration <module>::`.

mod calibration_report;
mod external_reliability;
mod hexapod_common;
mod paper;
mod records;
