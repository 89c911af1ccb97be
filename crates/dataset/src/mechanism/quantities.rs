//! `quantities.csv`: quantities of the machine measured directly, each a
//! known function of its parameters (a cable robot's line lengths at the
//! encoder zero, measured with a tape), header `quantity,value,sigma`:
//! the quantity's name among the mechanism's
//! ([`Mechanism::quantities`]), the measured value and its standard
//! deviation, in the quantity's unit.

use std::path::Path;

use parcal_kinematics::mechanism::Mechanism;

use crate::error::Result;
use crate::quote::quoted_bytes;
use crate::table::{self, Header};

use super::observations::{OBSERVATIONS, too_many};

/// The columns of quantities.csv.
pub const QUANTITY_COLUMNS: [&str; 3] = ["quantity", "value", "sigma"];

/// One row of quantities.csv.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct QuantityRow {
    /// The quantity's name (`line_length_a`).
    pub quantity: String,
    /// The measured value.
    pub value: f64,
    /// Its standard deviation (positive).
    pub sigma: f64,
}

/// Reads quantities.csv at `path` for `mechanism`: every name one of its
/// quantities, every value finite, every sigma finite and positive, at
/// most [`OBSERVATIONS`] rows; errors name the line and column.
pub(crate) fn read_quantities(path: &Path, mechanism: &dyn Mechanism) -> Result<Vec<QuantityRow>> {
    let expected = QUANTITY_COLUMNS.join(",");
    let names: Vec<&str> = mechanism
        .quantities()
        .iter()
        .map(|q| q.name.as_str())
        .collect();
    table::read_file(path, |reader| {
        let header = Header::read(reader, &expected)?;
        header.only(&QUANTITY_COLUMNS, &expected)?;
        let [name_at, value_at, sigma_at] = header.require_all(&QUANTITY_COLUMNS, &expected)?;
        let mut rows = Vec::new();
        table::for_each_row(reader, &header, "quantity", |row| {
            if rows.len() == OBSERVATIONS.max {
                return Err(too_many(row, "quantity"));
            }
            let name = row.field(name_at);
            let quantity = std::str::from_utf8(name)
                .ok()
                .filter(|name| names.contains(name))
                .ok_or_else(|| {
                    row.error(
                        Some("quantity"),
                        format!(
                            "{} is not a quantity of the {} (its quantities: {})",
                            quoted_bytes(name),
                            mechanism.name(),
                            if names.is_empty() {
                                "none".to_string()
                            } else {
                                names.join(", ")
                            }
                        ),
                    )
                })?
                .to_string();
            let [value, sigma] = row.numbers(&[value_at, sigma_at], &["value", "sigma"])?;
            if sigma <= 0.0 {
                return Err(row.error(
                    Some("sigma"),
                    format!("{sigma} is not a positive standard deviation"),
                ));
            }
            rows.push(QuantityRow {
                quantity,
                value,
                sigma,
            });
            Ok(())
        })?;
        Ok(rows)
    })
}

/// Writes quantities.csv at `path` atomically.
pub(crate) fn write_quantities(path: &Path, rows: &[QuantityRow]) -> Result<()> {
    table::write_file(path, &QUANTITY_COLUMNS, |w| {
        for row in rows {
            w.text(&row.quantity)?;
            w.numbers(&[row.value, row.sigma])?;
            w.end_row()?;
        }
        Ok(())
    })
}
