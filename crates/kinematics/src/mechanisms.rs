//! The one list of the mechanisms parcal knows: each lives in its own
//! module and implements [`Mechanism`]; a file names its mechanism by one
//! of [`NAMES`] and [`by_name`] builds its typical design.

use crate::cable::CableRobot;
use crate::delta::LinearDelta;
use crate::hexapod::Hexapod;
use crate::mechanism::Mechanism;
use crate::{PriorSigma, paper};

/// The names of the known mechanisms, as files give them.
pub const NAMES: [&str; 3] = ["hexapod", "linear delta", "cable robot"];

/// The typical design of the mechanism named `name` (the paper's hexapod
/// with 0.1 mm tolerances, a kit linear delta, the Hangprinter v4), or
/// `None` for an unknown
/// name.
pub fn by_name(name: &str) -> Option<Box<dyn Mechanism>> {
    match name {
        "hexapod" => {
            let prior = PriorSigma {
                base: 0.1,
                platform: 0.1,
                tool: 0.1,
                leg: 0.1,
            };
            let hexapod = Hexapod::new(&paper::design(), &prior).ok()?;
            Some(Box::new(hexapod))
        }
        "linear delta" => Some(Box::new(LinearDelta::typical())),
        "cable robot" => Some(Box::new(CableRobot::typical())),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_listed_mechanism_is_built_under_its_name() {
        for name in NAMES {
            let mechanism = by_name(name).expect(name);
            assert_eq!(mechanism.name(), name);
            let design = crate::mechanism::design(mechanism.as_ref());
            crate::mechanism::check_params(mechanism.as_ref(), design.as_slice()).unwrap();
        }
        assert!(by_name("scara").is_none());
    }
}
