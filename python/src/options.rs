//! `parcal.calibrate`'s keyword options: the long flags of `parcal
//! calibrate` with `_` for `-` (`prior="propagated"`, `snoop=True`,
//! `time_limit=60`), parsed as the command parses them.

use std::time::Duration;

use clap::ValueEnum;
use parcal::calibration::bounds::MAX_ITERATIONS;
use parcal::command::CalibrateFlags;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::error::to_py;

/// The options `parcal.calibrate` takes.
pub const OPTIONS: [&str; 10] = [
    "sim",
    "observation",
    "prior",
    "weights",
    "radius",
    "lm",
    "max_iterations",
    "time_limit",
    "snoop",
    "loss",
];

/// The flags `options` ask for; an unknown option, or a value the command
/// would refuse, is a `parcal.Error` naming it.
pub fn flags(options: Option<&Bound<'_, PyDict>>) -> PyResult<CalibrateFlags> {
    let mut flags = CalibrateFlags::default();
    let Some(options) = options else {
        return Ok(flags);
    };
    for (key, value) in options.iter() {
        let name: String = key.extract()?;
        match name.as_str() {
            "sim" => flags.sim = Some(choice(&name, &value)?),
            "observation" => flags.observation = Some(choice(&name, &value)?),
            "prior" => flags.prior = Some(choice(&name, &value)?),
            "weights" => flags.weights = choice(&name, &value)?,
            "radius" => flags.radius = Some(choice(&name, &value)?),
            "lm" => flags.lm = typed(&name, &value, "True or False")?,
            "snoop" => flags.snoop = typed(&name, &value, "True or False")?,
            "max_iterations" => {
                let n: usize = typed(&name, &value, "a count")?;
                flags.max_iterations = Some(MAX_ITERATIONS.check(&name, n).map_err(to_py)?);
            }
            "time_limit" => {
                flags.time_limit = Some(seconds(typed(&name, &value, "a number of seconds")?)?);
            }
            "loss" => {
                let text: String = typed(&name, &value, "a string")?;
                flags.loss = text.parse().map_err(|e| to_py(format!("loss: {e}")))?;
            }
            _ => {
                return Err(to_py(format!(
                    "unknown option {name:?} (the options are {})",
                    OPTIONS.join(", ")
                )));
            }
        }
    }
    Ok(flags)
}

/// `value` as a `T`, or an error naming option `name` and what it expects.
fn typed<'a, 'py, T: FromPyObject<'a, 'py>>(
    name: &str,
    value: &'a Bound<'py, PyAny>,
    expected: &str,
) -> PyResult<T> {
    value
        .extract()
        .map_err(|_| to_py(format!("{name}: expected {expected}, got {value}")))
}

/// `value` as one of the values of a `T`, named as the command names them
/// (case ignored).
pub fn choice<T: ValueEnum>(name: &str, value: &Bound<'_, PyAny>) -> PyResult<T> {
    let text: String = typed(name, value, "a string")?;
    T::from_str(&text, true).map_err(|_| {
        let names: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value().map(|p| p.get_name().to_string()))
            .collect();
        to_py(format!(
            "{name}: {text:?} is not one of {}",
            names.join(", ")
        ))
    })
}

/// The time limit of `seconds` seconds (`time_limit`), refused unless
/// finite and not negative.
pub(crate) fn seconds(seconds: f64) -> PyResult<Duration> {
    Duration::try_from_secs_f64(seconds).map_err(|_| {
        to_py(format!(
            "time_limit: {seconds} is not a finite, non-negative number of seconds"
        ))
    })
}
