//! Line charts.

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::axis::{Axis, Scale, padded};
use crate::canvas::Canvas;
use crate::{DESC_SIZE, DrawResult, LABEL_SIZE, LINE_CHART_SIZE, LineChart, text, y_label_area};

/// Matplotlib's "tab10" colours, distinguishable also in print.
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

const MARGIN: u32 = 15;
const X_LABEL_AREA: u32 = 60;
const TITLE_SIZE: u32 = 24;
const LEGEND_GLYPH: u32 = 36;
const LEGEND_MARGIN: u32 = 10;

/// Validated, transformed data of a line chart.
pub(crate) struct Prepared {
    /// Points of each series in plot units (log10 on log axes).
    series: Vec<Vec<(f64, f64)>>,
    x_axis: Axis,
    y_axis: Axis,
    legend: SeriesLabelPosition,
}

/// Checks `chart`, transforms its points to plot units and lays out the axes
/// and legend.
pub(crate) fn prepare(chart: &LineChart) -> Result<Prepared, String> {
    if chart.series.is_empty() {
        return Err("there are no series".to_string());
    }
    let x_scale = if chart.log_x {
        Scale::Log10
    } else {
        Scale::Linear
    };
    let y_scale = if chart.log_y {
        Scale::Log10
    } else {
        Scale::Linear
    };
    let mut series = Vec::with_capacity(chart.series.len());
    for (i, s) in chart.series.iter().enumerate() {
        let which = if s.name.is_empty() {
            format!("series {i}")
        } else {
            format!("series {i} ({:?})", s.name)
        };
        if s.points.is_empty() {
            return Err(format!("{which} has no points"));
        }
        for (j, &(x, y)) in s.points.iter().enumerate() {
            for (axis, v, log) in [("x", x, chart.log_x), ("y", y, chart.log_y)] {
                if !v.is_finite() {
                    return Err(format!(
                        "{which} has {axis} = {v} at point {j}, which is not finite"
                    ));
                }
                if log && v <= 0.0 {
                    return Err(format!(
                        "{which} has {axis} = {v} at point {j}, which cannot be shown on a logarithmic {axis} axis"
                    ));
                }
            }
        }
        series.push(
            s.points
                .iter()
                .map(|&(x, y)| (x_scale.to_plot(x), y_scale.to_plot(y)))
                .collect::<Vec<_>>(),
        );
    }
    let bounds = |pick: fn(&(f64, f64)) -> f64| {
        series
            .iter()
            .flatten()
            .map(pick)
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
                (a.min(v), b.max(v))
            })
    };
    let axis = |name: &str, scale, (min, max): (f64, f64), max_ticks| {
        let (lo, hi) = padded(min, max, 0.04, scale)
            .ok_or_else(|| format!("the {name} values span {min}..{max}, too wide to plot"))?;
        Ok::<_, String>(match scale {
            Scale::Linear => Axis::linear(lo, hi, max_ticks),
            Scale::Log10 => Axis::log10(lo, hi, max_ticks),
        })
    };
    let x_axis = axis("x", x_scale, bounds(|p| p.0), 9)?;
    let y_axis = axis("y", y_scale, bounds(|p| p.1), 8)?;
    let legend = legend_position(chart, &series, &x_axis, &y_axis);
    Ok(Prepared {
        series,
        x_axis,
        y_axis,
        legend,
    })
}

/// The plot corner whose legend-sized patch covers the fewest points and
/// line samples, preferring upper right, upper left, lower right, lower left.
fn legend_position(
    chart: &LineChart,
    series: &[Vec<(f64, f64)>],
    x: &Axis,
    y: &Axis,
) -> SeriesLabelPosition {
    let named: Vec<&str> = chart
        .series
        .iter()
        .map(|s| s.name)
        .filter(|n| !n.is_empty())
        .collect();
    // Rough legend and plot sizes in pixels; the counts only rank corners.
    let longest = named.iter().map(|n| n.chars().count()).max().unwrap_or(0) as f64;
    let legend_w =
        longest * 0.6 * f64::from(LABEL_SIZE) + f64::from(LEGEND_GLYPH + 3 * LEGEND_MARGIN);
    let legend_h = named.len() as f64 * 1.3 * f64::from(LABEL_SIZE) + f64::from(3 * LEGEND_MARGIN);
    let title = if chart.title.is_empty() {
        0
    } else {
        TITLE_SIZE + 10
    };
    let plot_w = f64::from(
        LINE_CHART_SIZE
            .0
            .saturating_sub(2 * MARGIN + y_label_area(y, chart.y_label)),
    )
    .max(100.0);
    let plot_h = f64::from(LINE_CHART_SIZE.1 - 2 * MARGIN - X_LABEL_AREA - title);
    let (fw, fh) = ((legend_w / plot_w).min(1.0), (legend_h / plot_h).min(1.0));

    let corners = [
        (SeriesLabelPosition::UpperRight, true, true),
        (SeriesLabelPosition::UpperLeft, false, true),
        (SeriesLabelPosition::LowerRight, true, false),
        (SeriesLabelPosition::LowerLeft, false, false),
    ];
    let mut counts = [0usize; 4];
    let mut count = |(px, py): (f64, f64)| {
        let u = (px - x.lo) / (x.hi - x.lo);
        let v = (py - y.lo) / (y.hi - y.lo);
        for (c, &(_, right, upper)) in counts.iter_mut().zip(&corners) {
            let in_u = if right { u >= 1.0 - fw } else { u <= fw };
            let in_v = if upper { v >= 1.0 - fh } else { v <= fh };
            *c += usize::from(in_u && in_v);
        }
    };
    for points in series {
        points.iter().copied().for_each(&mut count);
        for w in points.windows(2) {
            const SAMPLES: usize = 16;
            for k in 1..SAMPLES {
                let t = k as f64 / SAMPLES as f64;
                count((
                    w[0].0 + (w[1].0 - w[0].0) * t,
                    w[0].1 + (w[1].1 - w[0].1) * t,
                ));
            }
        }
    }
    let best = (0..4).min_by_key(|&i| counts[i]).unwrap_or(0);
    corners[best].0.clone()
}

pub(crate) fn draw(
    root: &DrawingArea<Canvas, Shift>,
    chart: &LineChart,
    p: &Prepared,
) -> DrawResult {
    let mut builder = ChartBuilder::on(root);
    builder
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(y_label_area(&p.y_axis, chart.y_label));
    if !chart.title.is_empty() {
        builder.caption(chart.title, text(TITLE_SIZE));
    }
    let mut ctx = builder.build_cartesian_2d(p.x_axis.clone(), p.y_axis.clone())?;
    ctx.configure_mesh()
        .x_desc(chart.x_label)
        .y_desc(chart.y_label)
        .set_all_tick_mark_size(5)
        .label_style(text(LABEL_SIZE))
        .axis_desc_style(text(DESC_SIZE))
        .bold_line_style(BLACK.mix(0.15))
        .light_line_style(BLACK.mix(0.06))
        .draw()?;

    for (i, (s, points)) in chart.series.iter().zip(&p.series).enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let shape = SHAPES[i % SHAPES.len()];
        let size = match points.len() {
            0..=50 => 4,
            51..=150 => 3,
            _ => 2,
        };
        let anno = ctx.draw_series(LineSeries::new(
            points.iter().copied(),
            colour.stroke_width(2),
        ))?;
        if !s.name.is_empty() {
            let half = LEGEND_GLYPH as i32 / 2 - 4;
            anno.label(s.name).legend(move |(x, y)| {
                EmptyElement::at((x + half, y))
                    + PathElement::new(vec![(-half, 0), (half, 0)], colour.stroke_width(2))
                    + Polygon::new(outline(shape, 4), colour.filled())
            });
        }
        let outline = outline(shape, size);
        ctx.draw_series(
            points
                .iter()
                .map(|&at| EmptyElement::at(at) + Polygon::new(outline.clone(), colour.filled())),
        )?;
    }

    if chart.series.iter().any(|s| !s.name.is_empty()) {
        ctx.configure_series_labels()
            .position(p.legend.clone())
            .margin(LEGEND_MARGIN)
            .legend_area_size(LEGEND_GLYPH)
            .label_font(text(LABEL_SIZE))
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK.mix(0.4))
            .draw()?;
    }
    Ok(())
}

#[derive(Debug, Clone, Copy)]
enum Shape {
    Circle,
    Square,
    Triangle,
    Diamond,
}

const SHAPES: [Shape; 4] = [
    Shape::Circle,
    Shape::Square,
    Shape::Triangle,
    Shape::Diamond,
];

/// Outline of a marker of half-width `s` pixels, relative to its centre.
/// All shapes are polygons so that one element type draws them all.
fn outline(shape: Shape, s: i32) -> Vec<(i32, i32)> {
    match shape {
        Shape::Circle => (0..16)
            .map(|k| {
                let a = f64::from(k) * std::f64::consts::TAU / 16.0;
                let r = f64::from(s) + 0.3;
                ((r * a.cos()).round() as i32, (r * a.sin()).round() as i32)
            })
            .collect(),
        Shape::Square => vec![(-s, -s), (s, -s), (s, s), (-s, s)],
        Shape::Triangle => vec![(0, -s - 1), (s + 1, s), (-s - 1, s)],
        Shape::Diamond => vec![(0, -s - 1), (s + 1, 0), (0, s + 1), (-s - 1, 0)],
    }
}
