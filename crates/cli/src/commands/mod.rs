//! One module per subcommand.

pub mod accuracy;
pub mod calibrate;
pub mod inspect;
pub mod paper;
pub mod simulate;
