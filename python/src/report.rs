//! `parcal.report`: a calibration's report as `parcal report` renders it
//! (`parcal::report_pages`, which both call): the self-contained HTML
//! page or its Markdown twin, as text.

use std::path::PathBuf;

use parcal::command::{Recorded, read_either};
use parcal::report_pages::{
    Format, ReportDataset, ReportPageError, hexapod_report, mechanism_report,
};
use pyo3::prelude::*;

use crate::dataset::Dataset;
use crate::error::to_py;
use crate::mechanism::calibration::MechanismCalibration;
use crate::mechanism::dataset::MechanismDataset;
use crate::run::Calibration;

/// The report of `calibration` (a `parcal.Calibration`, a
/// `parcal.MechanismCalibration`, or a calibration.json's path; a
/// rejected one too) as `parcal report` writes it: `format` `"html"`
/// (report.html, a self-contained page: `IPython.display.HTML(text)`
/// shows it in a notebook) or `"markdown"` (report.md). With `dataset`
/// (the `parcal.Dataset` or `parcal.MechanismDataset` calibrated; another
/// hexapod dataset only with `other_data`): a hexapod's machine places
/// the accuracy map, a printer's probe residuals are drawn over the bed,
/// and a simulation's truth stands beside the estimates.
#[pyfunction]
#[pyo3(signature = (calibration, *, dataset=None, format="html", other_data=false))]
pub fn report(
    py: Python<'_>,
    calibration: &Bound<'_, PyAny>,
    dataset: Option<&Bound<'_, PyAny>>,
    format: &str,
    other_data: bool,
) -> PyResult<String> {
    let format = match format {
        "html" => Format::Html,
        "markdown" => Format::Markdown,
        _ => {
            return Err(to_py(format!(
                "format: expected html or markdown, got {format:?}"
            )));
        }
    };
    let (recorded, file) = recorded(calibration)?;
    let hexapod = dataset.and_then(|d| d.cast::<Dataset>().ok());
    let mechanism = dataset.and_then(|d| d.cast::<MechanismDataset>().ok());
    if let (Some(given), None, None) = (dataset, &hexapod, &mechanism) {
        return Err(to_py(format!(
            "dataset: expected a parcal.Dataset or a parcal.MechanismDataset, got {given}"
        )));
    }
    let text = match &recorded {
        Recorded::Own(calibration) => {
            if mechanism.is_some() {
                return Err(to_py(format!(
                    "{file}: a hexapod's own calibration; the dataset is a {}'s",
                    mechanism
                        .as_ref()
                        .map_or("", |m| m.get().data.mechanism.name())
                )));
            }
            let dataset = hexapod.as_ref().map(|d| &d.get().inner);
            py.detach(|| hexapod_report(calibration, &file, dataset, other_data, format))
        }
        Recorded::Mechanism(record) => {
            let dataset = match (&hexapod, &mechanism) {
                (Some(d), _) => Some(ReportDataset::Hexapod(&d.get().inner)),
                (_, Some(d)) => Some(ReportDataset::Mechanism(&d.get().inner, &d.get().data)),
                _ => None,
            };
            py.detach(|| mechanism_report(record, &file, dataset, format))
        }
    };
    text.map_err(|error| match error {
        ReportPageError::OtherData { .. } => to_py(format!(
            "{file}: {error}; give other_data=True to report with it anyway"
        )),
        error => to_py(format!("{file}: {error}")),
    })
}

/// The calibration given, of either kind, and its name in the page and in
/// messages: its file's path, or "in memory".
fn recorded(calibration: &Bound<'_, PyAny>) -> PyResult<(Recorded, String)> {
    const IN_MEMORY: &str = "in memory";
    if let Ok(run) = calibration.cast::<Calibration>() {
        let record = Box::new(run.get().record().clone());
        return Ok((Recorded::Own(record), IN_MEMORY.to_string()));
    }
    if let Ok(run) = calibration.cast::<MechanismCalibration>() {
        let record = Box::new(run.get().record.clone());
        return Ok((Recorded::Mechanism(record), IN_MEMORY.to_string()));
    }
    let path: PathBuf = calibration.extract().map_err(|_| {
        to_py(format!(
            "calibration: expected a parcal.Calibration, a parcal.MechanismCalibration or a calibration.json's path, got {calibration}"
        ))
    })?;
    let recorded = read_either(&path).map_err(to_py)?;
    Ok((recorded, path.display().to_string()))
}
