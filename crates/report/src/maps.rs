//! Accuracy maps on disk: one CSV with every map and one SVG heat map per
//! map (um), like the paper's figs. 3, 7 and 10.

use std::path::{Path, PathBuf};

use parcal_accuracy::{AccuracyMap, to_csv};
use parcal_workflows::evaluate::BeforeAfter;

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

/// When (before, after calibration) and what (predicted, true) a map can be.
const MAP_KINDS: [(&str, &str); 4] = [
    ("before", "predicted"),
    ("before", "true"),
    ("after", "predicted"),
    ("after", "true"),
];
/// The metrics of each map.
const METRICS: [&str; 2] = ["absolute", "registered"];

/// The SVG of one map and metric in `dir`.
fn svg_path(dir: &Path, prefix: &str, when: &str, what: &str, metric: &str) -> PathBuf {
    dir.join(format!("{prefix}{when}_{what}_{metric}.svg"))
}

/// The CSV of the maps in `dir`.
fn csv_path(dir: &Path, prefix: &str) -> PathBuf {
    dir.join(format!("{prefix}accuracy.csv"))
}

/// Every file [`write_maps`] may write into `dir` with `prefix`, whichever
/// maps it is given: to check them before the maps are computed.
pub fn map_files(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let svgs = MAP_KINDS.iter().flat_map(|(when, what)| {
        METRICS
            .iter()
            .map(move |metric| svg_path(dir, prefix, when, what, metric))
    });
    std::iter::once(csv_path(dir, prefix)).chain(svgs).collect()
}

/// Writes `{prefix}accuracy.csv` and an SVG per map and per metric (absolute,
/// registered) into `dir`, each atomically; returns the SVG paths.
pub fn write_maps(
    dir: &Path,
    prefix: &str,
    title: &str,
    maps: &BeforeAfter,
) -> Result<Vec<PathBuf>, ReportError> {
    let named = named_maps(maps);
    let columns: Vec<(String, &AccuracyMap)> = named
        .iter()
        .map(|(when, what, map)| (format!("{when}_{what}"), *map))
        .collect();
    let columns: Vec<(&str, &AccuracyMap)> = columns
        .iter()
        .map(|(name, map)| (name.as_str(), *map))
        .collect();
    let csv = csv_path(dir, prefix);
    parcal_dataset::atomic::write_file(&csv, &to_csv(&csv, &columns)?)?;
    let mut written = Vec::new();
    for (when, what, map) in &named {
        for (metric, values) in METRICS.into_iter().zip([&map.absolute, &map.registered]) {
            let path = svg_path(dir, prefix, when, what, metric);
            let um: Vec<f64> = values.iter().map(|v| v * 1e3).collect();
            let title = format!("{title}, {when} calibration");
            let subtitle = format!("{what} {metric} error on the plane z = {} mm", map.grid.z);
            heat_map(&path, &error_heat_map(&title, &subtitle, map, &um))?;
            written.push(path);
        }
    }
    Ok(written)
}

/// The heat map of `um`, errors (µm) on `map`'s grid, titled `title` and
/// `subtitle`.
pub fn error_heat_map<'a>(
    title: &'a str,
    subtitle: &'a str,
    map: &'a AccuracyMap,
    um: &'a [f64],
) -> HeatMap<'a> {
    HeatMap {
        title,
        subtitle,
        xs: &map.grid.xs,
        ys: &map.grid.ys,
        values: um,
        value_label: "error / µm",
        x_label: "x / mm (design frame)",
        y_label: "y / mm (design frame)",
    }
}
