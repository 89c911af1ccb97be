//! Accuracy maps on disk: one CSV with every map and one PNG heat map per
//! map (um), like the paper's figs. 3, 7 and 10.

use std::path::{Path, PathBuf};

use parcal_accuracy::{AccuracyMap, write_csv};
use parcal_calibrate::evaluate::BeforeAfter;
use parcal_plot::{HeatMap, heat_map};

use crate::ReportError;

/// The maps of one run, each named `{when}_{kind}` (e.g. `after_true`).
fn named_maps(maps: &BeforeAfter) -> Vec<(String, &AccuracyMap)> {
    let mut out = Vec::new();
    for (when, accuracy) in [("before", &maps.before), ("after", &maps.after)] {
        if let Some(a) = accuracy {
            out.push((format!("{when}_predicted"), &a.predicted));
            if let Some(t) = &a.true_error {
                out.push((format!("{when}_true"), t));
            }
        }
    }
    out
}

/// Writes `{prefix}accuracy.csv` and a PNG per map and per metric (absolute,
/// registered) into `dir`; returns the PNG paths.
pub fn write_maps(
    dir: &Path,
    prefix: &str,
    title: &str,
    maps: &BeforeAfter,
) -> Result<Vec<PathBuf>, ReportError> {
    let named = named_maps(maps);
    let columns: Vec<(&str, &AccuracyMap)> = named.iter().map(|(n, m)| (n.as_str(), *m)).collect();
    write_csv(&dir.join(format!("{prefix}accuracy.csv")), &columns)?;
    let mut written = Vec::new();
    for (name, map) in &named {
        for (metric, values) in [("absolute", &map.absolute), ("registered", &map.registered)] {
            let path = dir.join(format!("{prefix}{name}_{metric}.png"));
            let um: Vec<f64> = values.iter().map(|v| v * 1e3).collect();
            let caption = format!(
                "{title}: {} {metric} error, z = {} mm",
                name.replace('_', " "),
                map.grid.z
            );
            heat_map(
                &path,
                &HeatMap {
                    title: &caption,
                    xs: &map.grid.xs,
                    ys: &map.grid.ys,
                    values: &um,
                    value_label: "error / um",
                    x_label: "x / mm (design frame)",
                    y_label: "y / mm (design frame)",
                    range: None,
                },
            )?;
            written.push(path);
        }
    }
    Ok(written)
}
