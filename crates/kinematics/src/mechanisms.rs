//! The one list of the mechanisms parcal knows: each lives in its own
//! module and implements [`Mechanism`]; a file names its mechanism by one
//! of [`NAMES`] and [`by_name`] builds its typical design.

use crate::cable::CableRobot;
use crate::delta::LinearDelta;
use crate::hexapod::Hexapod;
use crate::mechanism::Mechanism;

/// The names of the known mechanisms, as files give them.
pub const NAMES: [&str; 3] = ["hexapod", "linear delta", "cable robot"];

/// The typical design of the mechanism named `name` (the paper's hexapod
/// with 0.1 mm tolerances, a kit linear delta, the Hangprinter v4), or
/// `None` for an unknown
/// name.
pub fn by_name(name: &str) -> Option<Box<dyn Mechanism>> {
    match name {
        "hexapod" => Some(Box::new(Hexapod::typical())),
        "linear delta" => Some(Box::new(LinearDelta::typical())),
        "cable robot" => Some(Box::new(CableRobot::typical())),
        _ => None,
    }
}

/// [`by_name`] within the printable radius `print_radius` (mm) when one
/// is given: a linear delta whose nozzle stays within it (its
/// firmware's `M665 B`, machine.json's `print_radius`); `None` for an
/// unknown name or a printable radius given to another mechanism.
pub fn by_name_within(name: &str, print_radius: Option<f64>) -> Option<Box<dyn Mechanism>> {
    match (name, print_radius) {
        (_, None) => by_name(name),
        ("linear delta", Some(radius)) => {
            Some(Box::new(LinearDelta::typical().within_print_radius(radius)))
        }
        _ => None,
    }
}

/// The typical cable robot ([`by_name`]) with elastic lines
/// ([`CableRobot::typical_elastic`]): each line's compliance among
/// `compliance_of_line`'s, pulled by `zero_loads` (N) at the encoder zero;
/// an error saying what does not fit its lines.
pub fn elastic_cable_robot(
    compliance_of_line: &[usize],
    zero_loads: &[f64],
) -> Result<Box<dyn Mechanism>, String> {
    match CableRobot::typical_elastic(compliance_of_line.to_vec(), zero_loads.to_vec()) {
        Ok(robot) => Ok(Box::new(robot)),
        Err(error) => Err(error.to_string()),
    }
}

/// The mechanism named `name` with the parameters `parameters` (name and
/// unit of each, in order) of a calibration's record: the typical design
/// ([`by_name`]) when they are its own, else its variant that has them (a
/// hexapod read in its actuators' unit `U`: the scales `s_1..s_6`, in
/// `mm/U`, after the 33; [`Hexapod::with_unknown_scales`]); `None` for an
/// unknown name or parameters no variant has. Its design values are the
/// typical design's: a record's values replace them.
pub fn with_parameters(name: &str, parameters: &[(&str, &str)]) -> Option<Box<dyn Mechanism>> {
    let has_them = |mechanism: &dyn Mechanism| {
        let own = mechanism.parameters();
        own.len() == parameters.len()
            && own
                .iter()
                .zip(parameters)
                .all(|(p, (name, unit))| p.name == *name && p.unit == *unit)
    };
    let typical = by_name(name)?;
    if has_them(typical.as_ref()) {
        return Some(typical);
    }
    let variant: Box<dyn Mechanism> = match name {
        "hexapod" => {
            let (_, unit) = parameters.get(crate::N_PARAMS)?;
            let unit = unit.strip_prefix("mm/")?;
            Box::new(Hexapod::typical().with_unknown_scales(unit, [1.0; 6], [1.0; 6]))
        }
        _ => return None,
    };
    has_them(variant.as_ref()).then_some(variant)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SCALE_NAMES;

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

    #[test]
    fn only_a_delta_is_built_within_a_printable_radius() {
        let delta = by_name_within("linear delta", Some(85.0)).unwrap();
        let params = crate::mechanism::design(delta.as_ref());
        delta
            .check_feasible(params.as_slice(), &[84.0, 0.0, 1.0])
            .unwrap();
        let beyond = delta.check_feasible(params.as_slice(), &[0.0, 86.0, 1.0]);
        assert!(
            beyond.unwrap_err().to_string().contains("print radius 85"),
            "beyond the printable radius"
        );
        for name in NAMES {
            let typical = by_name_within(name, None).unwrap();
            assert_eq!(typical.name(), name);
        }
        assert!(by_name_within("cable robot", Some(85.0)).is_none());
        assert!(by_name_within("hexapod", Some(85.0)).is_none());
    }

    #[test]
    fn a_record_names_its_variant() {
        fn view(parameters: &[(String, String)]) -> Vec<(&str, &str)> {
            parameters
                .iter()
                .map(|(name, unit)| (name.as_str(), unit.as_str()))
                .collect()
        }
        let typical = by_name("hexapod").unwrap();
        let mut parameters: Vec<(String, String)> = typical
            .parameters()
            .iter()
            .map(|p| (p.name.clone(), p.unit.to_string()))
            .collect();
        let found = with_parameters("hexapod", &view(&parameters)).unwrap();
        assert_eq!(found.parameters().len(), 33);
        parameters.extend(SCALE_NAMES.map(|name| (name.to_string(), "mm/rev".to_string())));
        let found = with_parameters("hexapod", &view(&parameters)).unwrap();
        assert_eq!(found.parameters().len(), 39);
        assert_eq!(found.actuators()[0].unit, "rev");
        // Scales in another unit than per mm, or a parameter of no variant.
        parameters[33].1 = "in/rev".to_string();
        assert!(with_parameters("hexapod", &view(&parameters)).is_none());
        parameters.truncate(34);
        assert!(with_parameters("hexapod", &view(&parameters)).is_none());
        assert!(with_parameters("linear delta", &view(&parameters)).is_none());
    }
}
