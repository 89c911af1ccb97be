//! The Hangprinter's RepRapFirmware configuration: the anchors (`M669`)
//! and spool radii (`M666 R`) of a cable robot, written from a calibration
//! and read back as the firmware's `HangprinterKinematics::Configure`
//! reads them.
//!
//! - `M669 K6 A ax:ay:az B bx:by:bz C cx:cy:cz D dx:dy:dz`: kinematics 6
//!   (Hangprinter), each anchor's coordinates (mm) as a `:`-separated
//!   array of three.
//! - `M666 R ra:rb:rc:rd`: the spool radii at the origin (mm), one per
//!   spool. The firmware's other `M666` constants (buildup factor `Q`,
//!   mechanical advantage `U`, lines per spool `O`, gear teeth `L`, `H`)
//!   are constants of the design, not calibrated, and not written.
//!
//! The firmware's origin is where the line lengths are referenced (the
//! encoder zero of [`parcal_kinematics::cable`]): the anchors are written
//! relative to the calibrated encoder zero.

use std::path::Path;

use parcal_kinematics::cable::{CableRobot, cable_name};
use parcal_kinematics::mechanism::Mechanism;

use crate::FirmwareError;
use crate::files::read_capped;
use crate::gcode::{Command, parse_line};
use crate::rrf::MAX_CONFIG_BYTES;

/// The anchor letters of `M669`, in line order.
pub const ANCHOR_LETTERS: [char; 4] = ['A', 'B', 'C', 'D'];

/// A Hangprinter's calibrated geometry as its firmware holds it.
#[derive(Debug, Clone, PartialEq)]
pub struct HangprinterConfig {
    /// The anchors A, B, C, D (mm), the origin at the encoder zero.
    pub anchors: [[f64; 3]; 4],
    /// The spool radii A, B, C, D at the origin (mm).
    pub spool_radii: [f64; 4],
}

impl HangprinterConfig {
    /// The firmware's geometry of the cable robot `robot` with parameters
    /// `params`: each anchor less the encoder zero, each spool's radius;
    /// an error for a robot of other than four lines (the firmware's
    /// `M669` here reads A to D).
    pub fn from_params(robot: &CableRobot, params: &[f64]) -> Result<Self, FirmwareError> {
        if robot.cables() != ANCHOR_LETTERS.len() {
            return Err(FirmwareError::Calibration(format!(
                "the Hangprinter's M669 holds anchors A to D, the calibration has {} lines",
                robot.cables()
            )));
        }
        if params.len() != robot.parameters().len() {
            return Err(FirmwareError::Calibration(format!(
                "a cable robot of {} lines has {} parameters, the calibration {}",
                robot.cables(),
                robot.parameters().len(),
                params.len()
            )));
        }
        let zero = robot.encoder_zero(params);
        Ok(Self {
            anchors: std::array::from_fn(|j| {
                let a = robot.anchor(params, j) - zero;
                [a.x, a.y, a.z]
            }),
            spool_radii: std::array::from_fn(|j| robot.spool_radius(params, j)),
        })
    }

    /// The `M669` and `M666 R` lines: anchors to 0.01 mm and radii to
    /// 0.001 mm, as the author's calibration script prints them (the
    /// firmware reads them back to those digits).
    pub fn lines(&self) -> String {
        let anchors: Vec<String> = ANCHOR_LETTERS
            .iter()
            .zip(&self.anchors)
            .map(|(letter, [x, y, z])| format!("{letter}{x:.2}:{y:.2}:{z:.2}"))
            .collect();
        let radii: Vec<String> = self.spool_radii.iter().map(|r| format!("{r:.3}")).collect();
        format!(
            "; Hangprinter anchors (mm) and spool radii (mm), calibrated by parcal\n\
             M669 K6 {}\n\
             M666 R{}\n",
            anchors.join(" "),
            radii.join(":")
        )
    }
}

/// Reads the anchors and spool radii of a Hangprinter's `config.g`.
pub fn read_config(path: &Path) -> Result<HangprinterConfig, FirmwareError> {
    parse_config(&read_capped(path, MAX_CONFIG_BYTES, "configuration")?, path)
}

/// [`read_config`] of a text already read (`path` names it in errors):
/// `M669` and `M666` lines executed in order, each anchor or radius array
/// given replacing the one before; every anchor and the radii must be
/// given somewhere.
pub fn parse_config(text: &str, path: &Path) -> Result<HangprinterConfig, FirmwareError> {
    let mut anchors: [Option<[f64; 3]>; 4] = [None; 4];
    let mut radii: Option<[f64; 4]> = None;
    for (index, line) in text.lines().enumerate() {
        let at_line = |message: String| FirmwareError::Line {
            path: path.to_path_buf(),
            line: index as u64 + 1,
            message,
        };
        let Some(command) = parse_line(line).map_err(at_line)? else {
            continue;
        };
        match (command.letter, command.number) {
            ('M', 669) => {
                for (slot, letter) in anchors.iter_mut().zip(ANCHOR_LETTERS) {
                    if let Some(values) = array::<3>(&command, letter).map_err(at_line)? {
                        *slot = Some(values);
                    }
                }
            }
            ('M', 666) => {
                if let Some(values) = array::<4>(&command, 'R').map_err(at_line)? {
                    if let Some(j) = values.iter().position(|r| *r <= 0.0) {
                        return Err(at_line(format!(
                            "M666 R: the radius of spool {} is {} mm; it must be positive",
                            cable_name(j).to_ascii_uppercase(),
                            values[j]
                        )));
                    }
                    radii = Some(values);
                }
            }
            _ => {}
        }
    }
    let missing = |message: String| FirmwareError::Configuration {
        path: path.to_path_buf(),
        message,
    };
    let mut found = [[0.0; 3]; 4];
    for (j, anchor) in anchors.iter().enumerate() {
        found[j] = anchor.ok_or_else(|| {
            missing(format!(
                "no M669 {}: anchor {} is not given",
                ANCHOR_LETTERS[j], ANCHOR_LETTERS[j]
            ))
        })?;
    }
    Ok(HangprinterConfig {
        anchors: found,
        spool_radii: radii
            .ok_or_else(|| missing("no M666 R: the spool radii are not given".into()))?,
    })
}

/// The `N` numbers of parameter `letter`, if given; an error naming the
/// command and parameter for another count.
fn array<const N: usize>(command: &Command, letter: char) -> Result<Option<[f64; N]>, String> {
    let Some(values) = command.floats(letter)? else {
        return Ok(None);
    };
    <[f64; N]>::try_from(values.as_slice())
        .map(Some)
        .map_err(|_| {
            format!(
                "{}{} {letter} gives {} values: it takes {N} (`:`-separated)",
                command.letter,
                command.number,
                values.len()
            )
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use parcal_kinematics::mechanism::design;

    #[test]
    fn the_lines_read_back_to_the_digits_written() {
        let robot = CableRobot::typical();
        let mut p = design(&robot);
        for (k, value) in p.iter_mut().enumerate() {
            *value += 0.123456 * (k as f64 + 1.0).sqrt();
        }
        let config = HangprinterConfig::from_params(&robot, p.as_slice()).unwrap();
        // The encoder zero moved to the origin.
        let zero = robot.encoder_zero(p.as_slice());
        assert!((config.anchors[3][2] - (p[11] - zero.z)).abs() < 1e-12);
        let text = config.lines();
        assert!(text.contains("M669 K6 A"), "{text}");
        let back = parse_config(&text, Path::new("config.g")).unwrap();
        for j in 0..4 {
            for axis in 0..3 {
                assert!((back.anchors[j][axis] - config.anchors[j][axis]).abs() <= 0.005 + 1e-9);
            }
            assert!((back.spool_radii[j] - config.spool_radii[j]).abs() <= 0.0005 + 1e-12);
        }
    }

    #[test]
    fn the_published_calibration_is_read_as_printed() {
        let text = "M669 A16.83:-1584.86:-113.17 B1290.18:1229.19:-157.45 C-1409.88:742.61:-151.80 D21.85:-0.16:2343.67\n\
                    M666 R76.017:76.017:76.017:75.657\n\
                    M666 Q0.068750 W2.00 S20000.00 U2:2:2:4 O1:1:1:1 L20:20:20:20 H255:255:255:255\n";
        let config = parse_config(text, Path::new("config.g")).unwrap();
        assert_eq!(config.anchors[1], [1290.18, 1229.19, -157.45]);
        assert_eq!(config.spool_radii, [76.017, 76.017, 76.017, 75.657]);
    }

    #[test]
    fn incomplete_or_malformed_lines_are_named() {
        let path = Path::new("config.g");
        let err =
            parse_config("M669 A0:-1:0 B1:1:0 C-1:1:0\nM666 R75:75:75:75\n", path).unwrap_err();
        assert!(err.to_string().contains("anchor D is not given"), "{err}");
        let err = parse_config("; anchors\nM669 A0:-1\n", path).unwrap_err();
        assert!(
            err.to_string().contains("line 2: M669 A gives 2 values"),
            "{err}"
        );
        let err = parse_config("M666 R75:0:75:75\n", path).unwrap_err();
        assert!(err.to_string().contains("spool B"), "{err}");
        let err = parse_config("M669 A0:-1:0 B1:1:0 C-1:1:0 D0:0:2\n", path).unwrap_err();
        assert!(err.to_string().contains("no M666 R"), "{err}");
    }
}
