//! Accuracy maps on disk: one CSV with every map and one SVG heat map per
//! map (um), like the paper's figs. 3, 7 and 10.

use std::path::{Path, PathBuf};

use parcal_accuracy::{AccuracyMap, write_csv};
use parcal_calibrate::evaluate::BeforeAfter;

use crate::ReportError;
use crate::plots::{HeatMap, heat_map};

/// The maps of one run: when (before, after calibration), what (predicted,
/// true) and the map.
fn named_maps(maps: &BeforeAfter) -> Vec<(&'static str, &'static str, &AccuracyMap)> {
    let mut out = Vec::new();
    for (when, accuracy) in [("before", &maps.before), ("after", &maps.after)] {
        if let Some(a) = accuracy {
            out.push((when, "predicted", &a.predicted));
            if let Some(t) = &a.true_error {
                out.push((when, "true", t));
            }
        }
    }
    out
}

/// Writes `{prefix}accuracy.csv` and an SVG per map and per metric (absolute,
/// registered) into `dir`; returns the SVG paths.
pub fn write_maps(
    dir: &Path,
    prefix: &str,
    title: &str,
    maps: &BeforeAfter,
) -> Result<Vec<PathBuf>, ReportError> {
    let named = named_maps(maps);
    let names: Vec<String> = named
        .iter()
        .map(|(when, what, _)| format!("{when}_{what}"))
        .collect();
    let columns: Vec<(&str, &AccuracyMap)> = names
        .iter()
        .zip(&named)
        .map(|(name, (_, _, map))| (name.as_str(), *map))
        .collect();
    write_csv(&dir.join(format!("{prefix}accuracy.csv")), &columns)?;
    let mut written = Vec::new();
    for (name, (when, what, map)) in names.iter().zip(&named) {
        for (metric, values) in [("absolute", &map.absolute), ("registered", &map.registered)] {
            let path = dir.join(format!("{prefix}{name}_{metric}.svg"));
            let um: Vec<f64> = values.iter().map(|v| v * 1e3).collect();
            let title = format!("{title}, {when} calibration");
            let subtitle = format!("{what} {metric} error on the plane z = {} mm", map.grid.z);
            heat_map(
                &path,
                &HeatMap {
                    title: &title,
                    subtitle: &subtitle,
                    xs: &map.grid.xs,
                    ys: &map.grid.ys,
                    values: &um,
                    value_label: "error / µm",
                    x_label: "x / mm (design frame)",
                    y_label: "y / mm (design frame)",
                },
            )?;
            written.push(path);
        }
    }
    Ok(written)
}
