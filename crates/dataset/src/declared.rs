//! The mechanism a `machine.json` declares (its `"mechanism"` field; absent
//! for the hexapod, so that every dataset of version 1 stays one), read
//! before the rest so that each reader refuses the other's datasets with a
//! message pointing to the right one.

use std::path::Path;

use serde::Deserialize;

use crate::error::Result;
use crate::json;

/// The name of the hexapod in `"mechanism"`, the default.
pub const HEXAPOD: &str = "hexapod";

/// The `"mechanism"` of `machine.json` at `path`, `None` when absent (a
/// hexapod).
pub fn declared_mechanism(path: &Path) -> Result<Option<String>> {
    #[derive(Deserialize)]
    struct Declared {
        #[serde(default)]
        mechanism: Option<String>,
    }
    let declared: Declared = json::read(path, json::MACHINE)?;
    Ok(declared.mechanism)
}
