//! Value checks (finite, positive, plausible) that name the file and the
//! field.
//!
//! Used on what was read (after the shapes are known to be right) and on what
//! is about to be written, so that a file this crate writes always reads back.
//!
//! Plausibility bounds: a length or coordinate in mm is at most
//! [`MAX_LENGTH_MM`] in magnitude (a machine larger than 1 km is a unit
//! error), and a standard deviation lies in [[`MIN_SIGMA`],
//! [`MAX_LENGTH_MM`]] of its unit (its weight `1/sigma^2` is used in the
//! fit; below 1e-12 it is no measurement, and at 1e-154 it overflows).

use std::fmt::Display;
use std::path::Path;

use crate::Point3;
use crate::error::{DatasetError, Result};
use crate::quote::{has_control, quoted};

/// The largest magnitude of a length or coordinate, mm (1 km).
pub const MAX_LENGTH_MM: f64 = 1e6;
/// The smallest standard deviation, in its unit.
pub const MIN_SIGMA: f64 = 1e-12;
/// The smallest actuator scale, mm per unit (a nanometre per count; below
/// it a reading would have to exceed 10^15 units to move a leg by 1 m).
pub const MIN_SCALE: f64 = 1e-9;

/// Checks values destined for (or read from) one file.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Check<'a> {
    path: &'a Path,
    /// The largest magnitude of a length: [`MAX_LENGTH_MM`] for a dataset,
    /// none for a result (whatever a calibration found is written).
    max_length: f64,
}

impl<'a> Check<'a> {
    /// Checks of a dataset's file: lengths within [`MAX_LENGTH_MM`].
    pub(crate) fn new(path: &'a Path) -> Self {
        Self {
            path,
            max_length: MAX_LENGTH_MM,
        }
    }

    /// Checks of a result's file (calibration, validation): lengths only
    /// finite.
    pub(crate) fn result(path: &'a Path) -> Self {
        Self {
            path,
            max_length: f64::INFINITY,
        }
    }

    pub(crate) fn path(&self) -> &'a Path {
        self.path
    }

    /// An error about `field` of this file.
    pub(crate) fn error(
        &self,
        field: impl Into<String>,
        message: impl Into<String>,
    ) -> DatasetError {
        DatasetError::field(self.path, field, message)
    }

    /// Finite. The field's name (`field`, e.g. `format_args!`) is only
    /// formatted for an error: the 142857 balls of a 10^6-contact campaign
    /// have 714k checked fields.
    pub(crate) fn finite(&self, field: impl Display, value: f64) -> Result<()> {
        if value.is_finite() {
            Ok(())
        } else {
            Err(self.error(field.to_string(), not_finite(value)))
        }
    }

    /// Finite and strictly positive (sigmas, radii, lengths of distances).
    pub(crate) fn positive(&self, field: impl Display, value: f64) -> Result<()> {
        self.finite(&field, value)?;
        if value > 0.0 {
            Ok(())
        } else {
            Err(self.error(
                field.to_string(),
                format!("must be positive, found {}", shown(value)),
            ))
        }
    }

    /// Finite and not negative (a posterior sigma, 0 when none was
    /// computed).
    pub(crate) fn non_negative(&self, field: impl Display, value: f64) -> Result<()> {
        self.finite(&field, value)?;
        if value >= 0.0 {
            Ok(())
        } else {
            Err(self.error(
                field.to_string(),
                format!("must not be negative, found {}", shown(value)),
            ))
        }
    }

    /// An actuator scale (mm per unit): within [[`MIN_SCALE`],
    /// [`MAX_LENGTH_MM`]].
    pub(crate) fn scale(&self, field: impl Display, value: f64) -> Result<()> {
        self.positive(&field, value)?;
        if (MIN_SCALE..=MAX_LENGTH_MM).contains(&value) {
            Ok(())
        } else {
            Err(self.error(
                field.to_string(),
                format!(
                    "a scale of {} mm per unit is implausible: it must lie in \
                     [{MIN_SCALE:e}, {MAX_LENGTH_MM:e}] (a unit error?)",
                    shown(value)
                ),
            ))
        }
    }

    /// A text without control characters (which would act on the terminal
    /// or the page that shows it).
    pub(crate) fn text(&self, field: impl Display, text: &str) -> Result<()> {
        if has_control(text) {
            Err(self.error(
                field.to_string(),
                format!("{} has a control character", quoted(text)),
            ))
        } else {
            Ok(())
        }
    }

    /// A length or coordinate (mm): finite and within the bound.
    pub(crate) fn length(&self, field: impl Display, value: f64) -> Result<()> {
        self.finite(&field, value)?;
        if value.abs() <= self.max_length {
            Ok(())
        } else {
            Err(self.error(field.to_string(), too_long(value)))
        }
    }

    /// A length that is positive (a radius, a distance).
    pub(crate) fn positive_length(&self, field: impl Display, value: f64) -> Result<()> {
        self.positive(&field, value)?;
        self.length(field, value)
    }

    /// A standard deviation: within [[`MIN_SIGMA`], [`MAX_LENGTH_MM`]].
    pub(crate) fn sigma(&self, field: impl Display, value: f64) -> Result<()> {
        self.positive(&field, value)?;
        if value < MIN_SIGMA {
            return Err(self.error(
                field.to_string(),
                format!(
                    "a standard deviation of {} is too small: it must be at least \
                     {MIN_SIGMA:e} (its weight 1/sigma^2 is used in the fit)",
                    shown(value)
                ),
            ));
        }
        if value > MAX_LENGTH_MM {
            return Err(self.error(
                field.to_string(),
                format!(
                    "a standard deviation of {} is too large: it must be at most \
                     {MAX_LENGTH_MM:e} (a unit error?)",
                    shown(value)
                ),
            ));
        }
        Ok(())
    }

    /// Every value of a row of a table of `columns` finite; an error names
    /// `row(), column name` (`row()`: `line 5`, `row 3`, named only then).
    pub(crate) fn row_values(
        &self,
        row: impl Fn() -> String,
        columns: &[&str],
        values: &[f64],
    ) -> Result<()> {
        match values.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(i) => Err(self.error(cell(&row(), columns, i), not_finite(values[i]))),
        }
    }

    /// Every value of a row of a table of `columns` a length
    /// ([`Check::length`]); an error names `row(), column name`.
    pub(crate) fn row_lengths(
        &self,
        row: impl Fn() -> String,
        columns: &[&str],
        values: &[f64],
    ) -> Result<()> {
        match values
            .iter()
            .position(|v| !v.is_finite() || v.abs() > self.max_length)
        {
            None => Ok(()),
            Some(i) => self.length(cell(&row(), columns, i), values[i]),
        }
    }

    /// Every element finite; an error names `field[i]`.
    pub(crate) fn values(&self, field: impl Display, values: &[f64]) -> Result<()> {
        match values.iter().position(|v| !v.is_finite()) {
            None => Ok(()),
            Some(i) => Err(self.error(format!("{field}[{i}]"), not_finite(values[i]))),
        }
    }

    /// Every element a length ([`Check::length`]); an error names `field[i]`.
    pub(crate) fn lengths(&self, field: impl Display, values: &[f64]) -> Result<()> {
        match values
            .iter()
            .position(|v| !v.is_finite() || v.abs() > self.max_length)
        {
            None => Ok(()),
            Some(i) => self.length(format_args!("{field}[{i}]"), values[i]),
        }
    }

    /// Every coordinate a length; an error names `field[j]`.
    pub(crate) fn point(&self, field: impl Display, p: &Point3) -> Result<()> {
        self.lengths(field, p)
    }

    /// Every coordinate of every point a length; an error names `field[i][j]`.
    pub(crate) fn points(&self, field: impl Display, points: &[Point3]) -> Result<()> {
        match points.iter().position(|p| {
            p.iter()
                .any(|v| !v.is_finite() || v.abs() > self.max_length)
        }) {
            None => Ok(()),
            Some(i) => self.point(format_args!("{field}[{i}]"), &points[i]),
        }
    }
}

/// A number as a message shows it: in scientific notation when very large
/// or very small (`1e300`, not 301 digits).
pub fn shown(value: f64) -> String {
    let magnitude = value.abs();
    if magnitude != 0.0 && !(1e-4..1e6).contains(&magnitude) {
        format!("{value:e}")
    } else {
        format!("{value}")
    }
}

/// The field of the row named `row`, column `i` of a table of `columns`:
/// `row, column name`.
fn cell(row: &str, columns: &[&str], i: usize) -> String {
    format!("{row}, column {}", columns[i])
}

/// The message for a value that is NaN or infinite.
pub(crate) fn not_finite(value: f64) -> String {
    format!("value {value} is not a finite number")
}

/// The first of the actuator readings `q` (with their `scale`, mm per
/// unit) that is not finite or extends its leg by more than
/// [`MAX_LENGTH_MM`], with why.
pub(crate) fn readings(q: &[f64; 6], scale: &[f64; 6]) -> Option<(usize, String)> {
    q.iter().zip(scale).enumerate().find_map(|(k, (&q, &s))| {
        if !q.is_finite() {
            Some((k, not_finite(q)))
        } else if (s * q).abs() > MAX_LENGTH_MM {
            Some((
                k,
                format!(
                    "the reading {} extends its leg by {} mm, {}",
                    shown(q),
                    shown(s * q),
                    beyond()
                ),
            ))
        } else {
            None
        }
    })
}

/// The message for a length beyond [`MAX_LENGTH_MM`].
pub(crate) fn too_long(value: f64) -> String {
    format!("{} mm is {}", shown(value), beyond())
}

fn beyond() -> String {
    format!("beyond the {MAX_LENGTH_MM:e} mm (1 km) a length may have (a unit error?)")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_file_field_and_value() {
        let check = Check::new(Path::new("dir/machine.json"));
        let err = check.points("base_joints", &[[0.0; 3], [0.0, f64::NAN, 0.0]]);
        assert_eq!(
            err.unwrap_err().to_string(),
            "dir/machine.json: field base_joints[1][1]: value NaN is not a finite number"
        );
        let err = check.positive("prior_sigma.leg", -0.5).unwrap_err();
        assert_eq!(
            err.to_string(),
            "dir/machine.json: field prior_sigma.leg: must be positive, found -0.5"
        );
        assert!(check.positive("x", 0.0).is_err());
        assert!(check.positive("x", f64::INFINITY).is_err());
        assert!(check.positive("x", 1e-300).is_ok());
    }
}
