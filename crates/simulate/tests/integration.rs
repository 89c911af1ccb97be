//! The integration tests of parcal-simulate, one module per subject, in one
//! test binary (one link, one instance of the generic code):
//! `cargo test -p parcal-simulate --test integration <module>::`.

mod simulate;
mod tracker;
