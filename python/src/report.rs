//! `parcal.report`: a calibration's report as `parcal report` renders it
//! (`parcal::report_pages`, which both call): the self-contained HTML
//! page or its Markdown twin, as text.

use parcal::command::Recorded;
use parcal::report_pages::{
    Format, ReportDataset, ReportPageError, hexapod_report, mechanism_report,
};
use pyo3::prelude::*;

use crate::dataset::Dataset;
use crate::error::to_py;
use crate::mechanism::dataset::MechanismDataset;
use crate::recorded::recorded;

/// The report of `calibration` (a `parcal.Calibration`, a
/// `parcal.MechanismCalibration`, or a calibration.json's path; a
/// rejected one too) as `parcal report` writes it: `format` `"html"`
/// (report.html, a self-contained page: `IPython.display.HTML(text)`
/// shows it in a notebook) or `"markdown"` (report.md). With `dataset`
/// (the `parcal.Dataset` or `parcal.MechanismDataset` calibrated; another
/// hexapod dataset only with `other_data`): a hexapod's machine places
/// the accuracy map, a printer's probe and manual height residuals are
/// drawn over the bed, and a simulation's truth stands beside the
/// estimates.
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
    let (recorded, path) = recorded(calibration)?;
    let file = path.map_or("in memory".to_string(), |path| path.display().to_string());
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
            py.detach(|| mechanism_report(record, &file, dataset, other_data, format))
        }
    };
    text.map_err(|error| match error {
        ReportPageError::OtherData { .. } => to_py(format!(
            "{file}: {error}; give other_data=True to report with it anyway"
        )),
        error => to_py(format!("{file}: {error}")),
    })
}
