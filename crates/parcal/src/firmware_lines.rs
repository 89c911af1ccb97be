//! A mechanism's calibration as its firmware's configuration lines, as
//! `parcal export --format reprapfirmware | klipper | marlin | hangprinter`
//! writes them, for every front end: a linear delta's `M665`/`M666` lines
//! (RepRapFirmware's, Marlin's with `M500`) or Klipper's `SAVE_CONFIG`
//! block with what the firmware cannot hold and
//! what that costs (docs/delta.md, "Export: what the firmware can hold"),
//! and the probe's trigger height where the data determined it,
//! a cable robot's `M669` anchors and `M666 R` spool radii
//! (docs/cable-robots.md).

use std::path::Path;

use parcal_calibrate::mechanism::TRIGGER_HEIGHT;
use parcal_calibrate::mechanism::identifiability::PRIOR_BOUND;
use parcal_dataset::mechanism::{MechanismCalibrationRecord, ParameterRecord};
use parcal_dataset::shown;
use parcal_firmware::accuracy::{PositionErrors, Workspace};
use parcal_firmware::export::{Firmware, TriggerHeight, cost_sentence, export};
use parcal_firmware::hangprinter::HangprinterConfig;
use parcal_firmware::{FirmwareError, MAX_MAGNITUDE};
use parcal_kinematics::cable::CableRobot;
use parcal_kinematics::delta::DeltaParams;
use parcal_kinematics::mechanism::Mechanism;
use parcal_kinematics::mechanisms;

/// A firmware whose configuration lines a calibration is written as.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FirmwareFormat {
    /// A linear delta's `M665`/`M666` lines for RepRapFirmware.
    RepRapFirmware,
    /// A linear delta's `SAVE_CONFIG` block for Klipper.
    Klipper,
    /// A linear delta's `M665`/`M666` lines and `M500` for Marlin.
    Marlin,
    /// A cable robot's `M669` and `M666 R` lines for the Hangprinter's
    /// RepRapFirmware.
    Hangprinter,
}

impl FirmwareFormat {
    /// The formats by their names (`parcal export --format`'s).
    pub const NAMES: [(&'static str, Self); 4] = [
        ("reprapfirmware", Self::RepRapFirmware),
        ("klipper", Self::Klipper),
        ("marlin", Self::Marlin),
        ("hangprinter", Self::Hangprinter),
    ];

    /// The format named `name` ([`Self::NAMES`]), if any.
    pub fn by_name(name: &str) -> Option<Self> {
        crate::named::by_name(&Self::NAMES, name)
    }

    /// Its name ([`Self::NAMES`]).
    pub fn name(self) -> &'static str {
        crate::named::name_of(&Self::NAMES, &self)
    }

    /// The mechanism whose calibration it writes.
    pub fn mechanism(self) -> &'static str {
        match self {
            Self::RepRapFirmware | Self::Klipper | Self::Marlin => "linear delta",
            Self::Hangprinter => "cable robot",
        }
    }
}

/// A calibration written as a firmware's lines.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct FirmwareLines {
    /// The file's text: a delta's with comment lines saying what is lost
    /// and what it costs, then the firmware's lines; written into a
    /// configuration, its text before them.
    pub text: String,
    /// What the firmware cannot hold, one sentence each.
    pub lost: Vec<String>,
    /// A delta's: the position errors of the firmware reading `text` on
    /// the calibrated printer over its workspace, whose printable radius is
    /// the one written back.
    pub cost: Option<(PositionErrors, Workspace)>,
    /// A delta's probe's trigger height as written and read back (mm), if
    /// the data determined it ([`trigger_height`]).
    pub trigger_height: Option<f64>,
    /// Whether a delta's trigger height was written or kept as configured,
    /// and why, in one sentence (none without probe heights).
    pub trigger_sentence: Option<String>,
    /// Marlin's: the radius trims of towers X, Y, Z the lines are written
    /// for (mm, `DELTA_RADIUS_TRIM_TOWER`).
    pub radius_trims: Option<[f64; 3]>,
}

impl FirmwareLines {
    /// The cost in one sentence ([`cost_sentence`]), if any.
    pub fn cost_sentence(&self) -> Option<String> {
        self.cost
            .as_ref()
            .map(|(errors, workspace)| cost_sentence(errors, workspace))
    }
}

/// Why a calibration cannot be written as a firmware's lines.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum FirmwareLinesError {
    /// The calibration is of another mechanism than the format's.
    #[error("a {found} calibration; {format} exports a {expected}'s")]
    OtherMechanism {
        /// The calibration's mechanism.
        found: String,
        /// The format's name.
        format: &'static str,
        /// The format's mechanism.
        expected: &'static str,
    },
    /// Neither the caller nor the calibration gives a delta's printable
    /// radius.
    #[error(
        "the calibration states no printable radius (its dataset's machine.json has no print_radius)"
    )]
    NoPrintRadius,
    /// The printable radius given is not a positive length within
    /// [`MAX_MAGNITUDE`].
    #[error("{}", refused_print_radius("the printable radius", *.0))]
    PrintRadius(f64),
    /// The record lacks one of its mechanism's parameters.
    #[error("no parameter {name} of the {mechanism}")]
    MissingParameter {
        /// The parameter's name.
        name: String,
        /// The mechanism's name.
        mechanism: String,
    },
    /// Radius trims were given for a format other than Marlin's, or one
    /// of them is not a finite length within [`MAX_MAGNITUDE`].
    #[error("{0}")]
    RadiusTrims(String),
    /// A configuration to write into was given for a format written alone.
    #[error(
        "{0}'s lines are written alone: only Klipper's are written into a configuration (its printer.cfg)"
    )]
    Into(&'static str),
    /// The firmware cannot hold the calibrated machine.
    #[error(transparent)]
    Firmware(#[from] FirmwareError),
}

/// Refuses radius trims for a format other than Marlin's, and trims not
/// finite or beyond [`MAX_MAGNITUDE`] (each named by its tower); why, in
/// one sentence.
pub fn check_radius_trims(format: FirmwareFormat, trims: Option<[f64; 3]>) -> Result<(), String> {
    let Some(trims) = trims else {
        return Ok(());
    };
    if format != FirmwareFormat::Marlin {
        return Err(format!(
            "radius trims are Marlin's (DELTA_RADIUS_TRIM_TOWER, compiled in): {}'s configuration states its own geometry",
            format.name()
        ));
    }
    match trims
        .iter()
        .position(|t| !t.is_finite() || t.abs() > MAX_MAGNITUDE)
    {
        Some(i) => Err(format!(
            "tower {}'s radius trim must be a finite number of mm within {MAX_MAGNITUDE:e}, got {}",
            ["X", "Y", "Z"][i],
            shown(trims[i])
        )),
        None => Ok(()),
    }
}

/// Whether `radius` (mm) may be a printable radius: positive and at most
/// [`MAX_MAGNITUDE`], the dataset's bound on a length.
pub fn is_print_radius(radius: f64) -> bool {
    radius > 0.0 && radius <= MAX_MAGNITUDE
}

/// Why `radius` (mm), a printable radius named `name` (the front end's
/// word for it), is refused ([`is_print_radius`]).
pub fn refused_print_radius(name: &str, radius: f64) -> String {
    format!(
        "{name} must be a positive number of mm up to {MAX_MAGNITUDE:e} (1 km), got {}",
        shown(radius)
    )
}

/// `record` written as `format`'s lines, or with Klipper into the
/// `printer.cfg` at `into` (the whole file, its `SAVE_CONFIG` block
/// updated: [`parcal_firmware::klipper::KlipperDelta::saved_into`]); a
/// delta's printable radius is `print_radius` if given, else the one the
/// record carries from its dataset; Marlin's lines for a firmware compiled
/// with the radius trims `radius_trims` of towers X, Y, Z (mm,
/// `DELTA_RADIUS_TRIM_TOWER`) if given, else with the towers' radius
/// corrections the record's prior states (the configured ones: those
/// `parcal import marlin` was given, zero by default). Whether a rejected
/// calibration may be used is the caller's decision.
pub fn firmware_lines(
    record: &MechanismCalibrationRecord,
    format: FirmwareFormat,
    print_radius: Option<f64>,
    radius_trims: Option<[f64; 3]>,
    into: Option<&Path>,
) -> Result<FirmwareLines, FirmwareLinesError> {
    if into.is_some() && format != FirmwareFormat::Klipper {
        return Err(FirmwareLinesError::Into(format.name()));
    }
    check_radius_trims(format, radius_trims).map_err(FirmwareLinesError::RadiusTrims)?;
    if record.mechanism != format.mechanism() {
        return Err(FirmwareLinesError::OtherMechanism {
            found: record.mechanism.clone(),
            format: format.name(),
            expected: format.mechanism(),
        });
    }
    let values = mechanism_values(record, |p| p.value)?;
    let firmware = match format {
        FirmwareFormat::RepRapFirmware => Firmware::RepRapFirmware,
        FirmwareFormat::Klipper => Firmware::Klipper,
        FirmwareFormat::Marlin => Firmware::Marlin {
            radius_trims: match radius_trims {
                Some(trims) => trims,
                None => {
                    DeltaParams::from_slice(&mechanism_values(record, |p| p.prior_mean)?)
                        .tower_radius
                }
            },
        },
        FirmwareFormat::Hangprinter => {
            let config = HangprinterConfig::from_params(&CableRobot::typical(), &values)?;
            let lost = lines_compliance(record);
            let said: String = (lost.iter())
                .map(|l| format!("; parcal: lost: {l}\n"))
                .collect();
            return Ok(FirmwareLines {
                text: format!("{said}{}", config.lines()),
                lost,
                cost: None,
                trigger_height: None,
                trigger_sentence: None,
                radius_trims: None,
            });
        }
    };
    let print_radius = print_radius
        .or(record.print_radius)
        .ok_or(FirmwareLinesError::NoPrintRadius)?;
    if !is_print_radius(print_radius) {
        return Err(FirmwareLinesError::PrintRadius(print_radius));
    }
    let calibrated = DeltaParams::from_slice(&values);
    let workspace = Workspace::of_printer(print_radius, calibrated.homed_height);
    let trigger = trigger_height(record);
    let exported = export(
        &calibrated,
        trigger,
        print_radius,
        firmware,
        into,
        &workspace,
    )?;
    Ok(FirmwareLines {
        text: exported.text,
        lost: exported.lost,
        cost: Some((exported.cost, workspace)),
        trigger_height: exported.trigger_height,
        trigger_sentence: exported.trigger_sentence,
        radius_trims: match firmware {
            Firmware::Marlin { radius_trims } => Some(radius_trims),
            Firmware::RepRapFirmware | Firmware::Klipper => None,
        },
    })
}

/// The probe's trigger height as `record` leaves it: determined when its
/// sigma is below [`PRIOR_BOUND`] of its prior's (or it had no prior), as
/// the calibration's own statements judge it, else at its prior; absent
/// without probe heights, or without a sigma to judge by.
pub fn trigger_height(record: &MechanismCalibrationRecord) -> TriggerHeight {
    let Some(trigger) = record.parameter(TRIGGER_HEIGHT) else {
        return TriggerHeight::Absent;
    };
    match (trigger.sigma, trigger.sigma_ratio) {
        (Some(_), Some(ratio)) if ratio >= PRIOR_BOUND => TriggerHeight::AtPrior {
            ratio,
            configured: trigger.prior_mean,
        },
        (Some(_), _) => TriggerHeight::Determined(trigger.value),
        (None, _) => TriggerHeight::Absent,
    }
}

/// The values of `record`'s mechanism parameters, in the mechanism's
/// order, found by name (a record of a known mechanism: the format's).
/// What a cable robot's lines for the Hangprinter lose: each compliance
/// of elastic lines the calibration estimated, one sentence each.
fn lines_compliance(record: &MechanismCalibrationRecord) -> Vec<String> {
    let rigid = CableRobot::typical();
    (record.parameters.iter())
        .filter(|p| p.name != TRIGGER_HEIGHT && !rigid.parameters().iter().any(|r| r.name == p.name))
        .map(|p| {
            let sigma = p.sigma.map_or(String::new(), |s| format!(" +- {s:.2}"));
            format!(
                "{} = {:.2}{sigma} {} (the lines' compliance): M669 and M666 R hold the anchors and spool radii alone",
                p.name, p.value, p.unit
            )
        })
        .collect()
}

fn mechanism_values(
    record: &MechanismCalibrationRecord,
    value: impl Fn(&ParameterRecord) -> f64,
) -> Result<Vec<f64>, FirmwareLinesError> {
    let mechanism =
        mechanisms::by_name(&record.mechanism).expect("the format's mechanism is a known one");
    mechanism
        .parameters()
        .iter()
        .map(|p| {
            record.parameter(&p.name).map(&value).ok_or_else(|| {
                FirmwareLinesError::MissingParameter {
                    name: p.name.clone(),
                    mechanism: record.mechanism.clone(),
                }
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_calibrate::mechanism::{MechanismData, MechanismOptions, calibrate_mechanism};
    use parcal_simulate::delta::{DeltaScenario, simulate_delta};

    /// A simulated printer's calibration (printable radius 100 mm).
    fn printer() -> MechanismCalibrationRecord {
        calibrated(&DeltaScenario::typical())
    }

    /// The calibration of the printer `scenario` simulates, seed 3.
    fn calibrated(scenario: &DeltaScenario) -> MechanismCalibrationRecord {
        let dataset = simulate_delta(scenario, 3).unwrap();
        let data = MechanismData::from_dataset(&dataset).unwrap();
        calibrate_mechanism(&data, &MechanismOptions::default(), &mut |_| {})
            .unwrap()
            .record()
    }

    #[test]
    fn the_trigger_height_is_written_where_the_data_determine_it() {
        // Probe heights alone leave it at its prior: not written.
        let probes = printer();
        let at_prior = trigger_height(&probes);
        assert!(
            matches!(at_prior, TriggerHeight::AtPrior { ratio, .. } if ratio >= PRIOR_BOUND),
            "{at_prior:?}"
        );
        let lines =
            firmware_lines(&probes, FirmwareFormat::RepRapFirmware, None, None, None).unwrap();
        assert_eq!(lines.trigger_height, None);
        assert!(!lines.text.contains("\nG31"), "{}", lines.text);
        // Five heights measured by hand determine it: written, read back.
        let heights = calibrated(&DeltaScenario {
            manual_heights: 5,
            height_sigma: 0.02,
            ..DeltaScenario::typical()
        });
        let value = heights.parameter(TRIGGER_HEIGHT).unwrap().value;
        assert_eq!(trigger_height(&heights), TriggerHeight::Determined(value));
        let formats = [
            FirmwareFormat::RepRapFirmware,
            FirmwareFormat::Klipper,
            FirmwareFormat::Marlin,
        ];
        for format in formats {
            let lines = firmware_lines(&heights, format, None, None, None).unwrap();
            let written = lines.trigger_height.unwrap();
            assert!((written - value).abs() <= 5e-4, "{written} for {value}");
            let text = format!("{written:.3}");
            assert!(lines.text.contains(&text), "{}", lines.text);
        }
        // No probe heights, or no sigma to judge by: absent.
        let mut without = heights.clone();
        without.parameters.retain(|p| p.name != TRIGGER_HEIGHT);
        assert_eq!(trigger_height(&without), TriggerHeight::Absent);
        let mut unjudged = heights;
        (unjudged.parameters.iter_mut())
            .filter(|p| p.name == TRIGGER_HEIGHT)
            .for_each(|p| p.sigma = None);
        assert_eq!(trigger_height(&unjudged), TriggerHeight::Absent);
    }

    #[test]
    fn each_format_is_found_by_its_name_and_writes_a_known_mechanism() {
        for (name, format) in FirmwareFormat::NAMES {
            assert_eq!(FirmwareFormat::by_name(name), Some(format));
            assert_eq!(format.name(), name);
            assert!(mechanisms::by_name(format.mechanism()).is_some());
        }
        assert_eq!(FirmwareFormat::by_name("smoothieware"), None);
    }

    #[test]
    fn a_printers_lines_take_its_printable_radius_unless_one_is_given() {
        let record = printer();
        assert_eq!(record.print_radius, Some(100.0));
        let carried =
            firmware_lines(&record, FirmwareFormat::RepRapFirmware, None, None, None).unwrap();
        let (_, workspace) = carried.cost.unwrap();
        assert_eq!(workspace.print_radius, 100.0);
        assert!(carried.text.contains(" B100.0 "), "{}", carried.text);
        assert!(carried.cost_sentence().unwrap().contains("radius 100.0 mm"));
        // Klipper's SAVE_CONFIG holds no printable radius: it bounds the
        // workspace the cost is taken over.
        let given =
            firmware_lines(&record, FirmwareFormat::Klipper, Some(90.0), None, None).unwrap();
        assert!(given.cost_sentence().unwrap().contains("radius 90.0 mm"));
        assert_eq!(given.cost.unwrap().1.print_radius, 90.0);

        let unstated = MechanismCalibrationRecord {
            print_radius: None,
            ..record.clone()
        };
        let error =
            firmware_lines(&unstated, FirmwareFormat::Klipper, None, None, None).unwrap_err();
        assert!(
            matches!(error, FirmwareLinesError::NoPrintRadius),
            "{error}"
        );
        for radius in [0.0, -5.0, f64::NAN, f64::INFINITY] {
            let error = firmware_lines(&record, FirmwareFormat::Klipper, Some(radius), None, None)
                .unwrap_err();
            assert!(
                matches!(error, FirmwareLinesError::PrintRadius(_)),
                "{error}"
            );
        }
    }

    #[test]
    fn a_calibration_of_another_mechanism_or_without_a_parameter_is_named() {
        let record = printer();
        let error =
            firmware_lines(&record, FirmwareFormat::Hangprinter, None, None, None).unwrap_err();
        assert_eq!(
            error.to_string(),
            "a linear delta calibration; hangprinter exports a cable robot's"
        );
        let mut partial = record.clone();
        partial.parameters.retain(|p| p.name != "radius");
        let error =
            firmware_lines(&partial, FirmwareFormat::RepRapFirmware, None, None, None).unwrap_err();
        assert_eq!(error.to_string(), "no parameter radius of the linear delta");
        let into = Some(Path::new("printer.cfg"));
        let error =
            firmware_lines(&record, FirmwareFormat::RepRapFirmware, None, None, into).unwrap_err();
        assert_eq!(
            error.to_string(),
            "reprapfirmware's lines are written alone: only Klipper's are written into a configuration (its printer.cfg)"
        );
    }
}
