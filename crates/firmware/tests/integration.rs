//! The integration tests of parcal-firmware, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-firmware --test integration <module>::`.

mod autocal;
mod config;
mod delta_calibrate;
mod fuzz;
mod klipper;
mod marlin;
