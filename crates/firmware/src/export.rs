//! A calibrated linear delta in a firmware's configuration, with what the
//! firmware cannot hold and what that costs.
//!
//! The calibrated parameters are put in the canonical frame
//! ([`LinearDelta::canonicalize`]), where the per-tower radius
//! corrections and tower C's angle correction are zero: a gauge that no
//! firmware needs. What remains is written as the firmware writes it
//! (RepRapFirmware's `M665`/`M666` lines, Klipper's `SAVE_CONFIG` block,
//! alone or in the printer's `printer.cfg`, Marlin's `M665`/`M666` lines
//! and `M500`), read back by this crate's reader of that firmware, and the
//! machine the
//! firmware will then believe in is compared with the calibrated one by
//! [`position_errors`]: the cost of the export, rounding included. The
//! probe's trigger height is written too where the data determined it
//! ([`TriggerHeight`]: RepRapFirmware's `G31 Z`, Klipper's `z_offset`,
//! Marlin's `M851 Z`, its negative), and read back. Marlin's `M665 H`
//! counts the probe's `M851 Z` ([`crate::marlin`]): it is written for the
//! trigger height written, else the configured one. Marlin's towers
//! stand at the delta radius plus the radius trims it was compiled with
//! (`DELTA_RADIUS_TRIM_TOWER`): its lines are written for the machine in
//! the frame of those trims ([`MarlinDelta::from_params`]), and read back
//! with them.

use std::path::Path;

use parcal_kinematics::delta::{DeltaParams, Limits, LinearDelta, Tolerances};
use parcal_kinematics::mechanism::Mechanism;

use crate::FirmwareError;
use crate::accuracy::{PositionErrors, Workspace, position_errors};
use crate::files::read_capped;
use crate::klipper::{KlipperDelta, parse_printer};
use crate::marlin::{self, MarlinDelta, thousandths};
use crate::rrf::{MAX_CONFIG_BYTES, RrfDelta, parse_config};

/// The firmware to write for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Firmware {
    /// RepRapFirmware: `M665`/`M666` lines for `config.g` or
    /// `config-override.g`.
    RepRapFirmware,
    /// Klipper: the `SAVE_CONFIG` block that ends a `printer.cfg`.
    Klipper,
    /// Marlin: `M665`/`M666` lines and `M500`, to send to the printer.
    Marlin {
        /// The radius trims of towers X, Y, Z it was compiled with (mm,
        /// `DELTA_RADIUS_TRIM_TOWER`; zero by default).
        radius_trims: [f64; 3],
    },
}

impl Firmware {
    /// The firmware's name.
    pub fn name(self) -> &'static str {
        match self {
            Self::RepRapFirmware => "RepRapFirmware",
            Self::Klipper => "Klipper",
            Self::Marlin { .. } => "Marlin",
        }
    }

    /// The firmware's comment prefix.
    fn comment(self) -> &'static str {
        match self {
            Self::RepRapFirmware | Self::Marlin { .. } => ";",
            Self::Klipper => "#",
        }
    }
}

/// The probe's trigger height, the nozzle's height above the bed when the
/// probe triggers (mm), as a calibration leaves it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TriggerHeight {
    /// An unknown the data determined: written (`G31 Z`, the probe's
    /// `z_offset`).
    Determined(f64),
    /// An unknown the data left at its prior (`ratio`: its sigma over the
    /// prior's): left as configured.
    AtPrior {
        /// The posterior sigma over the prior sigma.
        ratio: f64,
        /// The configured trigger height, the prior's mean (mm).
        configured: f64,
    },
    /// Not an unknown (no probe heights): left as configured.
    Absent,
}

impl TriggerHeight {
    /// The value to write, if any.
    fn written(self) -> Option<f64> {
        match self {
            Self::Determined(value) => Some(value),
            Self::AtPrior { .. } | Self::Absent => None,
        }
    }

    /// What the export does with it, in one sentence that says whether it
    /// is `written:` or `kept:` (none when absent).
    fn sentence(self, firmware: Firmware) -> Option<String> {
        let setting = match firmware {
            Firmware::RepRapFirmware => "G31 Z",
            Firmware::Klipper => "the probe's z_offset",
            Firmware::Marlin { .. } => "M851 Z",
        };
        match self {
            Self::Determined(value) => Some(format!(
                "written: the probe's trigger height, {value:.3} mm, which the data determine ({setting})"
            )),
            Self::AtPrior { ratio, .. } => Some(format!(
                "kept: the probe's trigger height as configured ({setting}): the data determine it no better than its prior (sigma {ratio:.2} of the prior's); heights measured by hand do"
            )),
            Self::Absent => None,
        }
    }
}

/// A calibrated delta written for a firmware.
#[derive(Debug, Clone, PartialEq)]
pub struct Export {
    /// The file's text: comment lines saying what is lost and what it
    /// costs, then the firmware's lines (in a configuration: its text
    /// before them, then these).
    pub text: String,
    /// The parameters the firmware reads from `text`.
    pub written: DeltaParams,
    /// The trigger height the firmware reads from `text`, if written.
    pub trigger_height: Option<f64>,
    /// Whether the trigger height was written or kept, and why, in one
    /// sentence (none without a trigger height among the unknowns).
    pub trigger_sentence: Option<String>,
    /// What the firmware cannot hold, one sentence each.
    pub lost: Vec<String>,
    /// The position errors of the firmware reading `text` on the
    /// calibrated machine.
    pub cost: PositionErrors,
}

/// The calibrated parameters `calibrated` of a delta with printable
/// radius `print_radius`, and its probe's `trigger` height, written for
/// `firmware` (module documentation), alone or into the configuration
/// `into` (Klipper's `printer.cfg`, its `SAVE_CONFIG` block updated as
/// Klipper's `SAVE_CONFIG` would: [`KlipperDelta::saved_into`]); the cost
/// evaluated over `workspace`.
pub fn export(
    calibrated: &DeltaParams,
    trigger: TriggerHeight,
    print_radius: f64,
    firmware: Firmware,
    into: Option<&Path>,
    workspace: &Workspace,
) -> Result<Export, FirmwareError> {
    let canonical = canonical(calibrated, print_radius)?;
    let mut lost = Vec::new();
    if calibrated.tower_radius != [0.0; 3] || calibrated.angle[2] != 0.0 {
        lost.push(format!(
            "the per-tower radius corrections ({}) and tower C's angle correction ({:.4} deg) are a rigid motion of the frame, written as the same machine in the canonical frame",
            millimetres(&calibrated.tower_radius),
            calibrated.angle[2]
        ));
    }
    // The text before the lines (a configuration's), and the lines.
    let (before, lines, precision) = match firmware {
        Firmware::RepRapFirmware => {
            if let Some(path) = into {
                return Err(FirmwareError::Configuration {
                    path: path.to_path_buf(),
                    message: "RepRapFirmware's lines are written alone, for config-override.g"
                        .to_string(),
                });
            }
            let mut lines = RrfDelta::from_params(&canonical, print_radius)?.calibration_lines();
            if let Some(value) = trigger.written() {
                lines.push_str(&format!("G31 Z{value:.3}\n"));
            }
            (
                String::new(),
                lines,
                "lengths and angles to 0.001, the tilt to 0.001 %",
            )
        }
        Firmware::Klipper => {
            let held = without_tilt(&canonical, firmware, &mut lost);
            let klipper = KlipperDelta::from_params(&held, print_radius)?;
            let (before, block) = match into {
                Some(path) => {
                    let text = read_capped(path, MAX_CONFIG_BYTES, "configuration")?;
                    let (main, block) = klipper.saved_into(&text, trigger.written());
                    let main = without_notes(main, firmware.comment());
                    let newline = if main.is_empty() || main.ends_with('\n') {
                        ""
                    } else {
                        "\n"
                    };
                    (format!("{main}{newline}"), block)
                }
                None => (String::new(), klipper.save_config_block(trigger.written())),
            };
            (before, block, "values to 1e-6")
        }
        Firmware::Marlin { radius_trims } => {
            if let Some(path) = into {
                return Err(FirmwareError::Configuration {
                    path: path.to_path_buf(),
                    message: "Marlin's lines are written alone, to send to the printer".to_string(),
                });
            }
            let held = without_tilt(&canonical, firmware, &mut lost);
            // M665 H counts the M851 Z Marlin will have: the one written,
            // as written, else the configured one.
            let written = trigger.written().map(thousandths);
            let probe = match (written, trigger) {
                (Some(value), _) => value,
                (None, TriggerHeight::AtPrior { configured, .. }) => configured,
                (None, _) => {
                    lost.push(
                        "the probe's Z offset: with no trigger height among the unknowns, M665 H is written for none (M851 Z0); with a probe, add its M851 Z to H"
                            .to_string(),
                    );
                    0.0
                }
            };
            let mut lines =
                MarlinDelta::from_params(&held, probe, radius_trims)?.calibration_lines();
            if let Some(value) = written {
                lines.push_str(&format!("M851 Z{:.3}\n", -value + 0.0));
            }
            lines.push_str("M500\n");
            (String::new(), lines, "lengths and angles to 0.001")
        }
    };
    lost.push(format!(
        "rounding as {} writes ({precision})",
        firmware.name()
    ));
    let (written, trigger_height) = read_back(&before, &lines, firmware, into, trigger)?;
    let trigger_height = trigger_height.filter(|_| trigger.written().is_some());
    let cost = position_errors(&canonical, &written, workspace)?;
    let comment = firmware.comment();
    let mut text = format!(
        "{before}{comment} parcal: the calibrated linear delta for {}\n",
        firmware.name()
    );
    for sentence in &lost {
        text.push_str(&format!("{comment} parcal: lost: {sentence}\n"));
    }
    text.push_str(&format!(
        "{comment} parcal: cost: {}\n",
        cost_sentence(&cost, workspace)
    ));
    let trigger_sentence = trigger.sentence(firmware);
    if let Some(sentence) = &trigger_sentence {
        text.push_str(&format!("{comment} parcal: {sentence}\n"));
    }
    text.push_str(&lines);
    Ok(Export {
        text,
        written,
        trigger_height,
        trigger_sentence,
        lost,
        cost,
    })
}

/// One sentence of the position errors over `workspace`, in µm
/// ([`PositionErrors`]).
pub fn cost_sentence(cost: &PositionErrors, workspace: &Workspace) -> String {
    let um = |mm: f64| mm * 1000.0;
    format!(
        "first layer Z error RMS {:.2} um, max {:.2} um over the printable disc of radius {:.1} mm; 3D error RMS {:.2} um, max {:.2} um over the cylinder to {:.1} mm; besides, a first-layer height offset of {:.2} um (set by the first-layer test)",
        um(cost.flatness_rms),
        um(cost.flatness_max),
        workspace.print_radius,
        um(cost.volume_rms),
        um(cost.volume_max),
        workspace.height,
        hundredths(um(cost.z_offset))
    )
}

/// `value` rounded to hundredths, a value that rounds to zero written
/// without a sign.
fn hundredths(value: f64) -> f64 {
    (value * 100.0).round() / 100.0 + 0.0
}

/// `params` without the bed tilt, which `firmware`'s delta cannot hold
/// (said in `lost`, with the tilt, if there is one).
fn without_tilt(params: &DeltaParams, firmware: Firmware, lost: &mut Vec<String>) -> DeltaParams {
    if params.tilt != [0.0; 2] {
        lost.push(format!(
            "the bed tilt (x {:.4} %, y {:.4} %): {}'s delta has none (a bed mesh can correct it)",
            params.tilt[0],
            params.tilt[1],
            firmware.name()
        ));
    }
    DeltaParams {
        tilt: [0.0; 2],
        ..*params
    }
}

/// `params` in the linear delta's canonical frame.
fn canonical(params: &DeltaParams, print_radius: f64) -> Result<DeltaParams, FirmwareError> {
    let limits = Limits::reach_only(print_radius);
    let delta = LinearDelta::new(params, &Tolerances::default(), limits);
    let canonical = delta
        .canonicalize(params.to_vector().as_slice())
        .map_err(|e| FirmwareError::Calibration(e.to_string()))?;
    Ok(DeltaParams::from_slice(canonical.as_slice()))
}

/// The parameters and trigger height `firmware`'s reader takes from
/// `lines` after `before`, the text of the configuration `into` if any
/// (RepRapFirmware's trigger height its default where no `G31` is
/// written; Marlin's the configured one of `trigger` where no `M851` is).
fn read_back(
    before: &str,
    lines: &str,
    firmware: Firmware,
    into: Option<&Path>,
    trigger: TriggerHeight,
) -> Result<(DeltaParams, Option<f64>), FirmwareError> {
    let source = into.unwrap_or(Path::new("the exported lines"));
    Ok(match firmware {
        Firmware::RepRapFirmware => {
            let config = parse_config(lines, source)?;
            (config.delta.to_params(), Some(config.probe.trigger_height))
        }
        // Alone, the block ends a printer.cfg whose [printer] has delta
        // kinematics.
        Firmware::Klipper => {
            let before = if into.is_some() {
                before
            } else {
                "[printer]\nkinematics: delta\n"
            };
            let printer = parse_printer(&format!("{before}{lines}"), source)?;
            (printer.delta.to_params(), printer.z_offset)
        }
        Firmware::Marlin { radius_trims } => {
            let configured = match trigger {
                TriggerHeight::AtPrior { configured, .. } => format!("M851 Z{}\n", -configured),
                TriggerHeight::Determined(_) | TriggerHeight::Absent => String::new(),
            };
            let config = marlin::parse_config(&format!("{configured}{lines}"), source)?
                .with_radius_trims(radius_trims)
                .map_err(FirmwareError::Calibration)?;
            (config.to_params(), Some(config.trigger_height()))
        }
    })
}

/// `main` without the run of this exporter's note lines (`# parcal: ...`)
/// at its end: those an earlier export wrote before the block, which this
/// one writes anew (a user's lines before them are kept).
fn without_notes<'a>(main: &'a str, comment: &str) -> &'a str {
    let prefix = format!("{comment} parcal: ");
    let mut end = main.len();
    while end > 0 {
        let body = main[..end].strip_suffix('\n').unwrap_or(&main[..end]);
        let start = body.rfind('\n').map_or(0, |i| i + 1);
        if !body[start..].starts_with(&prefix) {
            break;
        }
        end = start;
    }
    &main[..end]
}

/// `[a, b, c]` as `a, b, c mm`.
fn millimetres(values: &[f64; 3]) -> String {
    format!("{:.4}, {:.4}, {:.4} mm", values[0], values[1], values[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn calibrated() -> DeltaParams {
        let mut p = DeltaParams::symmetric(270.0, 135.0, 300.0);
        p.endstop = [0.21, -0.13, -0.08];
        p.angle = [0.23, -0.11, 0.05];
        p.tower_radius = [0.1, -0.05, 0.02];
        p.diagonal = [270.12, 269.91, 270.04];
        p.tilt = [0.05, -0.02];
        p
    }

    /// [`calibrated`] exported with `trigger` for `firmware`, alone or
    /// `into` a configuration, its cost over a printer of radius 110 mm.
    fn exported(trigger: TriggerHeight, firmware: Firmware, into: Option<&Path>) -> Export {
        let workspace = Workspace::of_printer(110.0, 300.0);
        export(&calibrated(), trigger, 110.0, firmware, into, &workspace).unwrap()
    }

    #[test]
    fn an_offset_that_rounds_to_zero_is_written_without_a_sign() {
        let written = |value: f64| format!("{:.2}", hundredths(value));
        assert_eq!(written(-0.001), "0.00");
        assert_eq!(written(-0.0), "0.00");
        assert_eq!(written(-0.274), "-0.27");
        assert_eq!(written(0.276), "0.28");
    }

    #[test]
    fn reprapfirmware_holds_the_machine_to_its_rounding() {
        let export = exported(TriggerHeight::Absent, Firmware::RepRapFirmware, None);
        // Rounding to 0.001 mm moves the nozzle by a few µm at most.
        assert!(export.cost.volume_max < 0.01, "{:?}", export.cost);
        assert!(export.text.contains("; parcal: lost: the per-tower radius"));
        assert!(export.text.contains("; parcal: cost: first layer"));
        assert!(export.text.contains("\nM665 L"), "{}", export.text);
    }

    #[test]
    fn klipper_loses_the_tilt_and_says_what_it_costs() {
        let export = exported(TriggerHeight::Absent, Firmware::Klipper, None);
        assert_eq!(export.written.tilt, [0.0; 2]);
        assert!(export.lost.iter().any(|s| s.contains("bed tilt")));
        // A tilt of 0.05 % across a radius of 110 mm: 55 µm at the edge.
        let edge = 0.05e-2 * 110.0;
        assert!(
            export.cost.flatness_max > 0.8 * edge
                && export.cost.flatness_max < 1.2 * edge.hypot(0.02e-2 * 110.0),
            "{:?}",
            export.cost
        );
        assert!(
            export
                .text
                .starts_with("# parcal: the calibrated linear delta for Klipper\n")
        );
    }

    #[test]
    fn into_a_printer_cfg_the_block_is_updated_and_the_rest_kept() {
        let workspace = Workspace::of_printer(110.0, 300.0);
        let main = "[printer]\nkinematics: delta\ndelta_radius: 134\n\n[stepper_a]\n\
                    arm_length: 269\nposition_endstop: 299\nrotation_distance: 40\n\
                    microsteps: 16\n[stepper_b]\nrotation_distance: 40\nmicrosteps: 16\n\
                    [stepper_c]\nrotation_distance: 40\nmicrosteps: 16\n";
        let saved = "#*# [probe]\n#*# z_offset = 0.650\n#*#\n#*# [delta_calibrate]\n\
                     #*# height0 = 0.65\n#*# height0_pos = 19000.000,19000.000,19000.000\n";
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("printer.cfg");
        let old = KlipperDelta::from_params(&DeltaParams::symmetric(269.0, 134.0, 299.0), 110.0)
            .unwrap()
            .save_config_block(None);
        std::fs::write(&path, format!("{main}{old}{saved}")).unwrap();
        let into = exported(TriggerHeight::Absent, Firmware::Klipper, Some(&path));
        let alone = exported(TriggerHeight::Absent, Firmware::Klipper, None);
        assert_eq!(into.written, alone.written);
        assert_eq!(into.cost, alone.cost);
        assert!(
            into.text
                .starts_with(&format!("{main}# parcal: the calibrated")),
            "{}",
            into.text
        );
        assert!(into.text.ends_with(saved), "{}", into.text);
        // Exported again into what it wrote: its notes replaced, not
        // stacked.
        std::fs::write(&path, &into.text).unwrap();
        let again = exported(TriggerHeight::Absent, Firmware::Klipper, Some(&path));
        assert_eq!(again.text, into.text);
        let back = parse_printer(&into.text, &path).unwrap();
        assert_eq!(back.delta.to_params(), into.written);
        assert_eq!(back.saved.probes.len(), 1);
        let refused = export(
            &calibrated(),
            TriggerHeight::Absent,
            110.0,
            Firmware::RepRapFirmware,
            Some(&path),
            &workspace,
        )
        .unwrap_err()
        .to_string();
        assert!(
            refused.contains("written alone, for config-override.g"),
            "{refused}"
        );
    }

    /// A determined trigger height is written as each firmware writes it
    /// and read back to its rounding; one at its prior is left as
    /// configured, and the file says why.
    #[test]
    fn a_determined_trigger_height_is_written_and_read_back() {
        let determined = TriggerHeight::Determined(0.89687);
        let rrf = exported(determined, Firmware::RepRapFirmware, None);
        assert!(rrf.text.ends_with("G31 Z0.897\n"), "{}", rrf.text);
        assert_eq!(rrf.trigger_height, Some(0.897));
        assert!(rrf.text.contains(
            "; parcal: written: the probe's trigger height, 0.897 mm, which the data determine (G31 Z)\n"
        ));
        let klipper = exported(determined, Firmware::Klipper, None);
        assert!(
            klipper.text.contains("#*# [probe]\n#*# z_offset = 0.897\n"),
            "{}",
            klipper.text
        );
        assert_eq!(klipper.trigger_height, Some(0.897));
        // Neither the parameters nor the cost change with it.
        let absent = exported(TriggerHeight::Absent, Firmware::Klipper, None);
        assert_eq!(
            (klipper.written, klipper.cost),
            (absent.written, absent.cost)
        );
        assert!(!absent.text.contains("z_offset") && !absent.text.contains("trigger height"));
        // At its prior: nothing written, the reason said.
        for firmware in [Firmware::RepRapFirmware, Firmware::Klipper] {
            let at_prior = TriggerHeight::AtPrior {
                ratio: 0.998,
                configured: 0.7,
            };
            let kept = exported(at_prior, firmware, None);
            assert_eq!(kept.trigger_height, None);
            assert!(
                !kept.text.contains("\nG31") && !kept.text.contains("z_offset = "),
                "{}",
                kept.text
            );
            assert!(
                kept.text
                    .contains("parcal: kept: the probe's trigger height as configured")
                    && kept.text.contains("sigma 1.00 of the prior's"),
                "{}",
                kept.text
            );
        }
        // Into a printer.cfg with a BLTouch: its section holds the offset,
        // the saved one replaced.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("printer.cfg");
        let main = "[printer]\nkinematics: delta\ndelta_radius: 134\n\n[stepper_a]\n\
                    arm_length: 269\nposition_endstop: 299\n[bltouch]\nsensor_pin: ^PA1\n\
                    z_offset: 0.5\n";
        let saved = "#*# <---------------------- SAVE_CONFIG ---------------------->\n\
                     #*# DO NOT EDIT THIS BLOCK OR BELOW. The contents are auto-generated.\n\
                     #*#\n#*# [bltouch]\n#*# z_offset = 0.650\n";
        std::fs::write(&path, format!("{main}{saved}")).unwrap();
        let into = exported(determined, Firmware::Klipper, Some(&path));
        assert!(
            into.text.contains("#*# [bltouch]\n#*# z_offset = 0.897\n"),
            "{}",
            into.text
        );
        assert!(
            !into.text.contains("[probe]") && !into.text.contains("0.650"),
            "{}",
            into.text
        );
        assert_eq!(into.trigger_height, Some(0.897));
    }
}
