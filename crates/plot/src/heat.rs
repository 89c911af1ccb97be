//! Heat maps.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::axis::{Axis, Scale, padded};
use crate::canvas::Canvas;
use crate::{DESC_SIZE, DrawResult, HeatMap, LABEL_SIZE, text, viridis, y_label_area};

/// Validated geometry of a heat map.
pub(crate) struct Prepared {
    x_edges: Vec<f64>,
    y_edges: Vec<f64>,
    x_axis: Axis,
    y_axis: Axis,
    /// Values at the ends of the colour scale.
    lo: f64,
    hi: f64,
    bar_axis: Axis,
}

/// Checks `map` and computes cell edges, axes and the colour range.
pub(crate) fn prepare(map: &HeatMap) -> Result<Prepared, String> {
    let x_edges = edges("x", map.xs)?;
    let y_edges = edges("y", map.ys)?;
    let (nx, ny) = (map.xs.len(), map.ys.len());
    let expected = nx
        .checked_mul(ny)
        .ok_or_else(|| format!("a grid of {nx} by {ny} cells is too large"))?;
    if map.values.len() != expected {
        return Err(format!(
            "{} values do not fill the grid of {nx} x values by {ny} y values, which needs {expected}",
            map.values.len()
        ));
    }
    if let Some(i) = map.values.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "value {} at x index {}, y index {} is not finite",
            map.values[i],
            i % nx,
            i / nx
        ));
    }
    let (lo, hi) = match map.range {
        Some((lo, hi)) => {
            if !(lo.is_finite() && hi.is_finite() && lo < hi && (hi - lo).is_finite()) {
                return Err(format!(
                    "the colour range {lo}..{hi} is not a finite range with its lower end below its upper end"
                ));
            }
            (lo, hi)
        }
        None => {
            let (min, max) = map
                .values
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            if min < max && (max - min).is_finite() {
                (min, max)
            } else {
                padded(min, max, 0.0, Scale::Linear)
                    .ok_or_else(|| format!("the values span {min}..{max}, too wide to plot"))?
            }
        }
    };
    let axis = |e: &[f64]| Axis::linear(e[0], e[e.len() - 1], 8);
    Ok(Prepared {
        x_axis: axis(&x_edges),
        y_axis: axis(&y_edges),
        x_edges,
        y_edges,
        lo,
        hi,
        bar_axis: Axis::linear(lo, hi, 8),
    })
}

/// Cell edges for strictly increasing cell centres: halfway between
/// neighbours, the outer ones half a spacing out.
fn edges(name: &str, centres: &[f64]) -> Result<Vec<f64>, String> {
    let n = centres.len();
    if n == 0 {
        return Err(format!("there are no {name} values"));
    }
    if let Some(i) = centres.iter().position(|c| !c.is_finite()) {
        return Err(format!(
            "{name} value {} at index {i} is not finite",
            centres[i]
        ));
    }
    if let Some(i) = (1..n).find(|&i| centres[i] <= centres[i - 1]) {
        return Err(format!(
            "{name} values are not strictly increasing: {} at index {i} follows {}",
            centres[i],
            centres[i - 1]
        ));
    }
    let mut out = Vec::with_capacity(n + 1);
    if n == 1 {
        let c = centres[0];
        let half = if c == 0.0 { 0.5 } else { c.abs() * 0.1 };
        out.extend([c - half, c + half]);
    } else {
        out.push(centres[0] - (centres[1] - centres[0]) / 2.0);
        out.extend(centres.windows(2).map(|w| w[0] + (w[1] - w[0]) / 2.0));
        out.push(centres[n - 1] + (centres[n - 1] - centres[n - 2]) / 2.0);
    }
    let (first, last) = (out[0], out[n]);
    if !(first.is_finite() && last.is_finite() && first < last && (last - first).is_finite()) {
        return Err(format!("the {name} values span too wide a range to plot"));
    }
    Ok(out)
}

/// Width of the colour bar.
const BAR_WIDTH: u32 = 25;
/// Height of the x label area (tick labels and axis label).
const X_LABEL_AREA: u32 = 60;
const MARGIN: u32 = 15;

pub(crate) fn draw(root: &DrawingArea<Canvas, Shift>, map: &HeatMap, p: &Prepared) -> DrawResult {
    let area = if map.title.is_empty() {
        root.clone()
    } else {
        root.titled(map.title, text(24))?
    };
    let bar_labels = y_label_area(&p.bar_axis, map.value_label);
    let (width, _) = area.dim_in_pixel();
    let (main, bar) =
        area.split_horizontally(width.saturating_sub(5 + BAR_WIDTH + bar_labels + MARGIN));

    let mut chart = ChartBuilder::on(&main)
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(y_label_area(&p.y_axis, map.y_label))
        .build_cartesian_2d(p.x_axis.clone(), p.y_axis.clone())?;
    chart
        .configure_mesh()
        .disable_mesh()
        .set_all_tick_mark_size(5)
        .x_desc(map.x_label)
        .y_desc(map.y_label)
        .label_style(text(LABEL_SIZE))
        .axis_desc_style(text(DESC_SIZE))
        .draw()?;
    let nx = map.xs.len();
    let span = p.hi - p.lo;
    chart.draw_series(map.values.iter().enumerate().map(|(i, &v)| {
        let (ix, iy) = (i % nx, i / nx);
        let (r, g, b) = viridis((v - p.lo) / span);
        Rectangle::new(
            [
                (p.x_edges[ix], p.y_edges[iy]),
                (p.x_edges[ix + 1], p.y_edges[iy + 1]),
            ],
            RGBColor(r, g, b).filled(),
        )
    }))?;

    let mut bar_chart = ChartBuilder::on(&bar)
        .margin_top(MARGIN)
        .margin_bottom(MARGIN + X_LABEL_AREA)
        .margin_left(5)
        .margin_right(MARGIN)
        .right_y_label_area_size(bar_labels)
        .build_cartesian_2d(0.0..1.0, p.bar_axis.clone())?;
    bar_chart
        .configure_mesh()
        .disable_mesh()
        .set_all_tick_mark_size(5)
        .disable_x_axis()
        .y_desc(map.value_label)
        .label_style(text(LABEL_SIZE))
        .axis_desc_style(text(DESC_SIZE))
        .draw()?;
    const STEPS: usize = 256;
    bar_chart.draw_series((0..STEPS).map(|k| {
        let at = |k: usize| p.lo + span * k as f64 / STEPS as f64;
        let (r, g, b) = viridis((k as f64 + 0.5) / STEPS as f64);
        Rectangle::new([(0.0, at(k)), (1.0, at(k + 1))], RGBColor(r, g, b).filled())
    }))?;
    bar_chart.draw_series(std::iter::once(Rectangle::new(
        [(0.0, p.lo), (1.0, p.hi)],
        BLACK.stroke_width(1),
    )))?;
    Ok(())
}
