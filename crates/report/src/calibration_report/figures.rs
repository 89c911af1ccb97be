//! The report's figures as inline SVG ([`crate::plots`]): the normalised
//! residuals against the standard normal density, the redundancy
//! numbers, the accuracy map.

use parcal_accuracy::AccuracyMap;
use parcal_dataset::{Histogram, ObservationTests};

use super::document::Block;
use crate::maps::error_heat_map;
use crate::plots::{BarChart, HeatMap, Series, bar_chart_svg, heat_map_svg};

/// Points of the density curve per bin.
const CURVE_STEPS: usize = 8;

/// The histogram `h` of every residual row's normalised residual with the
/// counts a standard normal expects, `N h φ(w)` (`N` rows, `h` the bin
/// width), and the critical values `±c` (`critical_value`): a hexapod's
/// ([`ObservationTests::normalised_histogram`]) or any mechanism's.
pub(crate) fn normalised_histogram(h: &Histogram, critical_value: f64) -> Result<Block, String> {
    let rows = h.total() as f64;
    let bins = h.counts.len();
    let curve: Vec<(f64, f64)> = (0..=bins * CURVE_STEPS)
        .map(|k| {
            let w = h.lower + h.width * k as f64 / CURVE_STEPS as f64;
            let density = (-0.5 * w * w).exp() / (2.0 * std::f64::consts::PI).sqrt();
            (w, rows * h.width * density)
        })
        .collect();
    let marks = [-critical_value, critical_value];
    let svg = bar_chart_svg(&BarChart {
        title: "Normalised residuals",
        x_label: "normalised residual w",
        y_label: "residual rows",
        lower: h.lower,
        width: h.width,
        counts: &h.counts,
        curve: Some(Series {
            name: "standard normal (expected counts)",
            points: &curve,
        }),
        marks: Some(("critical value", &marks)),
    })?;
    let outside = h.below + h.above;
    Ok(Block::Figure {
        svg,
        caption: format!(
            "Normalised residuals of the {} checked residual rows (bins of {}), against the counts a standard normal expects; dashed: the critical value ±{:.2}. {} row{} outside [{}, {}] not drawn.",
            h.total(),
            h.width,
            critical_value,
            outside,
            if outside == 1 { "" } else { "s" },
            h.lower,
            h.lower + h.width * bins as f64
        ),
    })
}

/// The histogram of the observations' redundancy numbers, with the
/// threshold under which an observation is uncontrolled.
pub fn redundancy_histogram(t: &ObservationTests) -> Result<Block, String> {
    let h = &t.redundancy_histogram;
    let marks = [t.uncontrolled_below];
    let svg = bar_chart_svg(&BarChart {
        title: "Redundancy numbers",
        x_label: "redundancy number r of an observation",
        y_label: "observations",
        lower: h.lower,
        width: h.width,
        counts: &h.counts,
        curve: None,
        marks: Some(("uncontrolled below", &marks)),
    })?;
    Ok(Block::Figure {
        svg,
        caption: format!(
            "Redundancy numbers of the {} observations (the share of an error in an observation that shows in its residual; a contact's is the sum over its rows): sum {:.2}, {} under {} (uncontrolled).",
            t.tested, t.redundancy, t.uncontrolled, t.uncontrolled_below
        ),
    })
}

/// The predicted registered accuracy map (µm).
pub fn accuracy_map(map: &AccuracyMap) -> Result<Block, String> {
    let um: Vec<f64> = map.registered.iter().map(|v| v * 1e3).collect();
    let subtitle = format!("registered error on the plane z = {} mm", map.grid.z);
    let svg = heat_map_svg(&error_heat_map(
        "Predicted accuracy after calibration",
        &subtitle,
        map,
        &um,
    ))?;
    let s = map.registered_summary();
    Ok(Block::Figure {
        svg,
        caption: format!(
            "Predicted tool-tip error after registration (1-sigma, from the posterior covariance): RMS {:.2} µm, max {:.2} µm.",
            s.rms * 1e3,
            s.max * 1e3
        ),
    })
}

/// The correlation matrix of the parameters, `ρ_ij = Σ_ij / √(Σ_ii Σ_jj)`,
/// as an image: `None` without a covariance or with a parameter of zero
/// variance.
pub fn correlation(names: &[String], covariance: &[Vec<f64>]) -> Result<Option<Block>, String> {
    let n = covariance.len();
    if n == 0 || (0..n).any(|i| covariance[i][i] <= 0.0) {
        return Ok(None);
    }
    let values: Vec<f64> = (0..n * n)
        .map(|k| {
            let (i, j) = (k / n, k % n);
            covariance[i][j] / (covariance[i][i] * covariance[j][j]).sqrt()
        })
        .collect();
    let index: Vec<f64> = (1..=n).map(|k| k as f64).collect();
    let svg = heat_map_svg(&HeatMap {
        title: "Correlation of the parameters",
        subtitle: "from the posterior covariance",
        xs: &index,
        ys: &index,
        values: &values,
        value_label: "correlation",
        x_label: "parameter index",
        y_label: "parameter index",
    })?;
    let legend: Vec<String> = names
        .iter()
        .enumerate()
        .map(|(k, name)| format!("{} {name}", k + 1))
        .collect();
    Ok(Some(Block::Figure {
        svg,
        caption: format!(
            "Correlation matrix of the {n} parameters (index 1 at the lower left): {}.",
            legend.join(", ")
        ),
    }))
}
