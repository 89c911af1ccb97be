//! A mechanism calibration as the design of the next one: the
//! `machine.json` the calibration was made from, its design (the priors'
//! means) now the calibrated parameters `p̂` and its trigger height the
//! calibrated one. What the record does not hold stays as that file has
//! it: the parameters the controller runs with (`configured`, until its
//! firmware is given the calibration's lines), the builder's tolerances
//! and matched sets (the priors' sigmas), the noise, the printable radius
//! and the lines' elasticity, as a hexapod's calibrated machine keeps its
//! design's priors and repeatability.

use parcal_dataset::mechanism::{MechanismCalibrationRecord, MechanismMachine, ValuePrior};

use super::error::MechanismCalibrationError;
use super::result::TRIGGER_HEIGHT;

/// `machine` with `record`'s estimates as its design (module doc). The
/// record must be a calibration of `machine`: the same mechanism, lines
/// and printable radius, and each parameter's prior mean the machine's
/// design value, to the bit (both are written as the shortest decimals
/// that read back the same); an error names the first that differs.
pub fn calibrated_machine(
    record: &MechanismCalibrationRecord,
    machine: &MechanismMachine,
) -> Result<MechanismMachine, MechanismCalibrationError> {
    let other = |what: &str, reason: String| MechanismCalibrationError::InvalidData {
        what: what.to_string(),
        reason: format!("{reason}: the calibration was not made from this machine.json"),
    };
    if record.mechanism != machine.mechanism {
        return Err(other(
            "mechanism",
            format!(
                "the calibration is a {}'s, machine.json a {}'s",
                record.mechanism, machine.mechanism
            ),
        ));
    }
    if record.elasticity != machine.elasticity {
        return Err(other(
            "elasticity",
            "the calibration's elastic lines are not machine.json's".to_string(),
        ));
    }
    if record.print_radius != machine.print_radius {
        return Err(other(
            "print_radius",
            format!(
                "the calibration's printable radius is {}, machine.json's {}",
                stated(record.print_radius),
                stated(machine.print_radius)
            ),
        ));
    }
    let mechanism = machine
        .mechanism()
        .ok_or_else(|| other("mechanism", format!("unknown {}", machine.mechanism)))?;
    let estimate = |name: &str, design: f64| {
        let recorded = (record.parameters.iter())
            .find(|p| p.name == name)
            .ok_or_else(|| other(name, "the calibration has no such parameter".to_string()))?;
        if recorded.prior_mean.to_bits() != design.to_bits() {
            return Err(other(
                name,
                format!(
                    "the calibration's prior mean is {}, machine.json's design {design}",
                    recorded.prior_mean
                ),
            ));
        }
        Ok(recorded.value)
    };
    let design = (mechanism.parameters().iter())
        .zip(&machine.design)
        .map(|(p, &design)| estimate(&p.name, design))
        .collect::<Result<Vec<f64>, _>>()?;
    let estimated = record.parameters.iter().any(|p| p.name == TRIGGER_HEIGHT);
    let trigger_height = match machine.trigger_height {
        Some(prior) if estimated => Some(ValuePrior {
            value: estimate(TRIGGER_HEIGHT, prior.value)?,
            ..prior
        }),
        None if estimated => {
            return Err(other(
                TRIGGER_HEIGHT,
                "the calibration estimated one, machine.json states none".to_string(),
            ));
        }
        unestimated => unestimated,
    };
    Ok(MechanismMachine {
        design,
        trigger_height,
        ..machine.clone()
    })
}

/// A printable radius in words.
fn stated(radius: Option<f64>) -> String {
    radius.map_or_else(|| "not stated".to_string(), |r| format!("{r} mm"))
}
