//! SVG charts drawn with plotters, one function per kind: [`heat_map`]
//! (accuracy maps, paper figs. 3, 7, 10) and [`line_chart`] (residual
//! histories, figs. 5 and 8; time per iteration). The viewer lays out the
//! text; plotters only estimates its extent to place labels, so no font is
//! bundled.
//!
//! Invalid data (nothing to draw, mismatched lengths, values that are not
//! finite, values that are not positive on a logarithmic axis) is reported
//! as [`ReportError::Plot`] before anything is written.
//!
//! ```
//! use parcal_report::plots::{HeatMap, LineChart, Series, heat_map, line_chart};
//!
//! let dir = std::env::temp_dir();
//! // Error over a 3 x 2 grid: values[iy * xs.len() + ix].
//! heat_map(
//!     &dir.join("error.svg"),
//!     &HeatMap {
//!         title: "Tool-tip error",
//!         subtitle: "z = 250 mm",
//!         xs: &[-50.0, 0.0, 50.0],
//!         ys: &[-20.0, 20.0],
//!         values: &[1.2, 0.8, 1.9, 2.4, 0.3, 1.1],
//!         value_label: "error / um",
//!         x_label: "x / mm",
//!         y_label: "y / mm",
//!     },
//! )?;
//! let run: Vec<(f64, f64)> = (0..8).map(|i| (i as f64, 10f64.powi(-i))).collect();
//! line_chart(
//!     &dir.join("residuals.svg"),
//!     &LineChart {
//!         title: "Residual norm per iteration",
//!         x_label: "iteration",
//!         y_label: "residual norm / mm",
//!         series: &[Series { name: "run 1", points: &run }],
//!         log_x: false,
//!         log_y: true,
//!     },
//! )?;
//! # Ok::<(), parcal_report::ReportError>(())
//! ```

use std::ops::Range;
use std::path::Path;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use crate::{ReportError, write_text};

/// A heat map: one cell per grid point, coloured by value (viridis, least
/// value dark blue, greatest yellow), with a colour bar.
///
/// `xs` and `ys` are the cell centres, each strictly increasing; cells reach
/// halfway to their neighbours. `values` is row-major,
/// `values[iy * xs.len() + ix]`, and row `iy = 0` is drawn at the bottom.
#[derive(Debug, Clone, Copy)]
pub struct HeatMap<'a> {
    /// The chart's title.
    pub title: &'a str,
    /// A second, smaller title line (e.g. what is mapped); empty for none.
    pub subtitle: &'a str,
    /// The cells' x centres.
    pub xs: &'a [f64],
    /// The cells' y centres.
    pub ys: &'a [f64],
    /// The cells' values, row-major.
    pub values: &'a [f64],
    /// Label of the colour bar, with the unit (e.g. `"error / um"`).
    pub value_label: &'a str,
    /// Label of the x axis, with the unit.
    pub x_label: &'a str,
    /// Label of the y axis, with the unit.
    pub y_label: &'a str,
}

/// One named line of a [`LineChart`].
#[derive(Debug, Clone, Copy)]
pub struct Series<'a> {
    /// Legend entry.
    pub name: &'a str,
    /// `(x, y)` points, joined in the given order.
    pub points: &'a [(f64, f64)],
}

/// Lines with point markers and a legend, each axis linear or logarithmic.
#[derive(Debug, Clone, Copy)]
pub struct LineChart<'a> {
    /// The chart's title.
    pub title: &'a str,
    /// Label of the x axis, with the unit.
    pub x_label: &'a str,
    /// Label of the y axis, with the unit.
    pub y_label: &'a str,
    /// The lines.
    pub series: &'a [Series<'a>],
    /// Logarithmic x axis (every x must be positive).
    pub log_x: bool,
    /// Logarithmic y axis (every y must be positive).
    pub log_y: bool,
}

/// A histogram of counts in equal bins, with an optional curve over it
/// (e.g. the counts a distribution expects) and marked x values.
#[derive(Debug, Clone, Copy)]
pub struct BarChart<'a> {
    /// The chart's title.
    pub title: &'a str,
    /// Label of the x axis, with the unit.
    pub x_label: &'a str,
    /// Label of the y axis.
    pub y_label: &'a str,
    /// The lower edge of the first bin.
    pub lower: f64,
    /// The width of every bin.
    pub width: f64,
    /// The count of each bin.
    pub counts: &'a [u64],
    /// A curve drawn over the bars (its name in the legend).
    pub curve: Option<Series<'a>>,
    /// Vertical dashed lines at these x values (their name in the legend).
    pub marks: Option<(&'a str, &'a [f64])>,
}

/// Writes `map` to the SVG file `path`.
pub fn heat_map(path: &Path, map: &HeatMap) -> Result<(), ReportError> {
    let svg = heat_map_svg(map).map_err(|reason| plot_error(path, reason))?;
    write_text(path, &svg)
}

/// Writes `chart` to the SVG file `path`.
pub fn line_chart(path: &Path, chart: &LineChart) -> Result<(), ReportError> {
    let svg = line_chart_svg(chart).map_err(|reason| plot_error(path, reason))?;
    write_text(path, &svg)
}

fn plot_error(path: &Path, reason: String) -> ReportError {
    ReportError::Plot {
        path: path.to_path_buf(),
        reason,
    }
}

const HEAT_MAP_SIZE: (u32, u32) = (760, 640);
const LINE_CHART_SIZE: (u32, u32) = (800, 600);
const FONT: &str = "sans-serif";
const TITLE_SIZE: u32 = 22;
const LABEL_SIZE: u32 = 16;
const DESC_SIZE: u32 = 18;
const MARGIN: u32 = 15;
const X_LABEL_AREA: u32 = 55;
const Y_LABEL_AREA: u32 = 80;
/// Width of the colour bar and of its labels.
const BAR_WIDTH: u32 = 25;
const BAR_LABEL_AREA: u32 = 75;
/// Steps of the colour bar's gradient.
const BAR_STEPS: usize = 100;

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

type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;
type DrawResult = Result<(), DrawingAreaErrorKind<std::io::Error>>;

/// Renders with `draw` on a white canvas of `size` into an SVG string.
fn render(size: (u32, u32), draw: impl FnOnce(&Area) -> DrawResult) -> Result<String, String> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        draw(&root).map_err(|e| e.to_string())?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(svg)
}

fn text(size: u32) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

/// The histogram as SVG text (to write, or to put in a web page).
pub fn bar_chart_svg(chart: &BarChart) -> Result<String, String> {
    if chart.counts.is_empty() {
        return Err("there are no bins".to_string());
    }
    if !(chart.width > 0.0 && chart.width.is_finite() && chart.lower.is_finite()) {
        return Err(format!(
            "bins from {} of width {} cannot be drawn",
            chart.lower, chart.width
        ));
    }
    let curve = chart.curve.map_or(&[][..], |c| c.points);
    if let Some((x, y)) = curve
        .iter()
        .find(|(x, y)| !(x.is_finite() && y.is_finite()))
    {
        return Err(format!("the curve has the point ({x}, {y})"));
    }
    let end = chart.lower + chart.width * chart.counts.len() as f64;
    let top = chart
        .counts
        .iter()
        .map(|&c| c as f64)
        .chain(curve.iter().map(|p| p.1))
        .fold(1.0, f64::max)
        * 1.1;
    render(LINE_CHART_SIZE, |root| {
        let mut ctx = ChartBuilder::on(root)
            .caption(chart.title, text(TITLE_SIZE))
            .margin(MARGIN)
            .x_label_area_size(X_LABEL_AREA)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(chart.lower..end, 0.0..top)?;
        ctx.configure_mesh()
            .x_desc(chart.x_label)
            .y_desc(chart.y_label)
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(text(LABEL_SIZE))
            .axis_desc_style(text(DESC_SIZE))
            .bold_line_style(BLACK.mix(0.15))
            .light_line_style(BLACK.mix(0.05))
            .max_light_lines(1)
            .draw()?;
        let bar = PALETTE[0];
        ctx.draw_series(
            chart
                .counts
                .iter()
                .enumerate()
                .filter(|(_, c)| **c > 0)
                .map(|(k, &c)| {
                    let x0 = chart.lower + chart.width * k as f64;
                    Rectangle::new(
                        [(x0, 0.0), (x0 + chart.width, c as f64)],
                        bar.mix(0.7).filled(),
                    )
                }),
        )?;
        if let Some(c) = chart.curve {
            let colour = PALETTE[3];
            ctx.draw_series(LineSeries::new(
                c.points.iter().copied(),
                colour.stroke_width(2),
            ))?
            .label(c.name)
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
            });
        }
        if let Some((name, xs)) = chart.marks {
            let colour = PALETTE[7];
            let inside: Vec<f64> = xs
                .iter()
                .copied()
                .filter(|x| (chart.lower..=end).contains(x))
                .collect();
            for &x in &inside {
                ctx.draw_series(DashedLineSeries::new(
                    [(x, 0.0), (x, top)],
                    6,
                    4,
                    colour.stroke_width(2),
                ))?;
            }
            if !inside.is_empty() {
                // The legend entry, once (a zero-length line).
                ctx.draw_series(std::iter::once(PathElement::new(
                    vec![(inside[0], 0.0), (inside[0], 0.0)],
                    colour.stroke_width(2),
                )))?
                .label(name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], colour.stroke_width(2))
                });
            }
        }
        if chart.curve.is_some() || chart.marks.is_some() {
            ctx.configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .margin(10)
                .label_font(text(LABEL_SIZE))
                .background_style(WHITE.mix(0.9))
                .border_style(BLACK.mix(0.4))
                .draw()?;
        }
        Ok(())
    })
}

/// The heat map as SVG text (to write, or to put in a web page).
pub fn heat_map_svg(map: &HeatMap) -> Result<String, String> {
    let x_edges = cell_edges("x", map.xs)?;
    let y_edges = cell_edges("y", map.ys)?;
    let (nx, ny) = (map.xs.len(), map.ys.len());
    if map.values.len() != nx * ny {
        return Err(format!(
            "{} values do not fill the grid of {nx} x values by {ny} y values",
            map.values.len()
        ));
    }
    if let Some(i) = map.values.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "the value at x index {}, y index {} is {}",
            i % nx,
            i / nx,
            map.values[i]
        ));
    }
    let colours = colour_range(map.values)?;
    let x_range = x_edges[0]..x_edges[nx];
    let y_range = y_edges[0]..y_edges[ny];
    render(HEAT_MAP_SIZE, |root| {
        let mut area = root.titled(map.title, text(TITLE_SIZE))?;
        if !map.subtitle.is_empty() {
            area = area.titled(map.subtitle, text(DESC_SIZE))?;
        }
        let (width, _) = area.dim_in_pixel();
        let (main, bar) =
            area.split_horizontally(width - (BAR_WIDTH + BAR_LABEL_AREA + 2 * MARGIN));

        let mut chart = ChartBuilder::on(&main)
            .margin(MARGIN)
            .x_label_area_size(X_LABEL_AREA)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(x_range, y_range)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(map.x_label)
            .y_desc(map.y_label)
            .x_label_formatter(&|v| tick_label(*v))
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(text(LABEL_SIZE))
            .axis_desc_style(text(DESC_SIZE))
            .draw()?;
        chart.draw_series(map.values.iter().enumerate().map(|(i, &v)| {
            let (ix, iy) = (i % nx, i / nx);
            Rectangle::new(
                [
                    (x_edges[ix], y_edges[iy]),
                    (x_edges[ix + 1], y_edges[iy + 1]),
                ],
                viridis(v, &colours).filled(),
            )
        }))?;

        let mut scale = ChartBuilder::on(&bar)
            .margin_top(MARGIN)
            .margin_bottom(MARGIN + X_LABEL_AREA)
            .margin_right(MARGIN)
            .right_y_label_area_size(BAR_LABEL_AREA)
            .build_cartesian_2d(0.0..1.0, colours.clone())?;
        scale
            .configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_desc(map.value_label)
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(text(LABEL_SIZE))
            .axis_desc_style(text(DESC_SIZE))
            .draw()?;
        let span = colours.end - colours.start;
        let at = |k: usize| colours.start + span * k as f64 / BAR_STEPS as f64;
        scale.draw_series((0..BAR_STEPS).map(|k| {
            Rectangle::new(
                [(0.0, at(k)), (1.0, at(k + 1))],
                viridis((at(k) + at(k + 1)) / 2.0, &colours).filled(),
            )
        }))?;
        scale.draw_series(std::iter::once(Rectangle::new(
            [(0.0, colours.start), (1.0, colours.end)],
            BLACK.stroke_width(1),
        )))?;
        Ok(())
    })
}

/// The values at the ends of the colour scale: the least and the greatest,
/// widened around a constant map.
fn colour_range(values: &[f64]) -> Result<Range<f64>, String> {
    let (lo, hi) = values
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        });
    let (lo, hi) = if lo < hi {
        (lo, hi)
    } else {
        let half = if lo == 0.0 { 1.0 } else { lo.abs() / 10.0 };
        (lo - half, hi + half)
    };
    finite_span("values", lo..hi)
}

/// `range` if its span is finite.
fn finite_span(what: &str, range: Range<f64>) -> Result<Range<f64>, String> {
    if (range.end - range.start).is_finite() {
        Ok(range)
    } else {
        Err(format!(
            "the {what} span {}..{}, too wide to plot",
            range.start, range.end
        ))
    }
}

/// The viridis colour of `v` on the scale `range`.
fn viridis(v: f64, range: &Range<f64>) -> RGBColor {
    ViridisRGB::get_color_normalized(v, range.start, range.end)
}

/// Cell edges for strictly increasing cell centres: halfway between
/// neighbours, the outer ones half a spacing out (a single cell: 1 wide).
fn cell_edges(name: &str, centres: &[f64]) -> Result<Vec<f64>, String> {
    if centres.is_empty() {
        return Err(format!("there are no {name} values"));
    }
    if let Some(i) = centres.iter().position(|c| !c.is_finite()) {
        return Err(format!("{name} value {i} is {}", centres[i]));
    }
    if let Some(i) = (1..centres.len()).find(|&i| centres[i] <= centres[i - 1]) {
        return Err(format!(
            "{name} values are not strictly increasing: {} at index {i} follows {}",
            centres[i],
            centres[i - 1]
        ));
    }
    let n = centres.len();
    let half_first = if n == 1 {
        0.5
    } else {
        (centres[1] - centres[0]) / 2.0
    };
    let half_last = if n == 1 {
        0.5
    } else {
        (centres[n - 1] - centres[n - 2]) / 2.0
    };
    let mut edges = Vec::with_capacity(n + 1);
    edges.push(centres[0] - half_first);
    edges.extend(centres.windows(2).map(|w| w[0] + (w[1] - w[0]) / 2.0));
    edges.push(centres[n - 1] + half_last);
    finite_span(&format!("{name} values"), edges[0]..edges[n])?;
    Ok(edges)
}

/// The line chart as SVG text.
fn line_chart_svg(chart: &LineChart) -> Result<String, String> {
    if chart.series.is_empty() {
        return Err("there are no series".to_string());
    }
    for s in chart.series {
        if s.points.is_empty() {
            return Err(format!("series {:?} has no points", s.name));
        }
        for (j, &(x, y)) in s.points.iter().enumerate() {
            for (axis, v, log) in [("x", x, chart.log_x), ("y", y, chart.log_y)] {
                if !v.is_finite() || (log && v <= 0.0) {
                    return Err(format!(
                        "series {:?} has {axis} = {v} at point {j}, which {}",
                        s.name,
                        if log {
                            "a logarithmic axis cannot show"
                        } else {
                            "is not finite"
                        }
                    ));
                }
            }
        }
    }
    let points = || chart.series.iter().flat_map(|s| s.points.iter());
    let x = finite_span("x values", axis_range(points().map(|p| p.0), chart.log_x))?;
    let y = finite_span("y values", axis_range(points().map(|p| p.1), chart.log_y))?;
    let legend = legend_corner(chart, &x, &y);
    // A logarithmic axis with ticks at powers of ten only labels them 10ⁿ.
    let decades = |r: &Range<f64>| log_ticks(r).iter().all(|&v| is_power_of_ten(v));
    let powers = (chart.log_x && decades(&x), chart.log_y && decades(&y));
    let log = |r: Range<f64>| {
        let ticks = log_ticks(&r);
        r.log_scale().with_key_points(ticks)
    };
    render(LINE_CHART_SIZE, |root| match (chart.log_x, chart.log_y) {
        (false, false) => draw_lines(root, chart, x, y, legend, powers),
        (false, true) => draw_lines(root, chart, x, log(y), legend, powers),
        (true, false) => draw_lines(root, chart, log(x), y, legend, powers),
        (true, true) => draw_lines(root, chart, log(x), log(y), legend, powers),
    })
}

/// Ticks of a logarithmic axis over `range`: the powers of ten in it when
/// there are at least three, else the values 1, 2 and 5 times a power of
/// ten, else every integer multiple of a power of ten (at least two ticks).
fn log_ticks(range: &Range<f64>) -> Vec<f64> {
    let first = range.start.log10().floor() as i32;
    let last = range.end.log10().ceil() as i32;
    let within = |multiples: &[f64]| -> Vec<f64> {
        (first..=last)
            .flat_map(|e| multiples.iter().map(move |m| m * 10f64.powi(e)))
            .filter(|&v| range.start <= v && v <= range.end)
            .collect()
    };
    [
        &[1.0][..],
        &[1.0, 2.0, 5.0],
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
    ]
    .iter()
    .zip([3, 2, 2])
    .map(|(multiples, least)| (within(multiples), least))
    .find(|(ticks, least)| ticks.len() >= *least)
    .map(|(ticks, _)| ticks)
    .unwrap_or_else(|| vec![range.start, range.end])
}

/// The data's range padded by 4 % of its span (of its logarithm's on a
/// logarithmic axis); a single value is padded by 1 (a factor 2).
fn axis_range(values: impl Iterator<Item = f64>, log: bool) -> Range<f64> {
    let (lo, hi) = values
        .map(|v| if log { v.log10() } else { v })
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v), b.max(v))
        });
    let pad = if lo < hi {
        (hi - lo) * 0.04
    } else if log {
        2f64.log10()
    } else {
        1.0
    };
    let (lo, hi) = (lo - pad, hi + pad);
    if log {
        10f64.powf(lo)..10f64.powf(hi)
    } else {
        lo..hi
    }
}

/// The plot corner whose legend-sized patch holds the fewest points (and
/// points along the lines), preferring upper right, upper left, lower right,
/// lower left.
fn legend_corner(chart: &LineChart, x: &Range<f64>, y: &Range<f64>) -> SeriesLabelPosition {
    // The patch's share of the plot's width and height: a rough legend size.
    let longest = chart.series.iter().map(|s| s.name.len()).max().unwrap_or(0);
    let width = ((longest as f64 * 0.6 * f64::from(LABEL_SIZE) + 70.0) / 650.0).min(1.0);
    let height =
        ((chart.series.len() as f64 * 1.4 * f64::from(LABEL_SIZE) + 20.0) / 480.0).min(1.0);
    let unit = |v: f64, r: &Range<f64>, log: bool| {
        if log {
            (v / r.start).log10() / (r.end / r.start).log10()
        } else {
            (v - r.start) / (r.end - r.start)
        }
    };
    let corners = [
        (SeriesLabelPosition::UpperRight, true, true),
        (SeriesLabelPosition::UpperLeft, false, true),
        (SeriesLabelPosition::LowerRight, true, false),
        (SeriesLabelPosition::LowerLeft, false, false),
    ];
    let mut counts = [0usize; 4];
    for s in chart.series {
        let plotted: Vec<(f64, f64)> = s
            .points
            .iter()
            .map(|&(px, py)| (unit(px, x, chart.log_x), unit(py, y, chart.log_y)))
            .collect();
        let along = plotted.windows(2).flat_map(|w| {
            (0..8).map(move |k| {
                let t = f64::from(k) / 8.0;
                (
                    w[0].0 + (w[1].0 - w[0].0) * t,
                    w[0].1 + (w[1].1 - w[0].1) * t,
                )
            })
        });
        for (u, v) in plotted.iter().copied().chain(along) {
            for (count, &(_, right, upper)) in counts.iter_mut().zip(&corners) {
                let in_u = if right { u >= 1.0 - width } else { u <= width };
                let in_v = if upper {
                    v >= 1.0 - height
                } else {
                    v <= height
                };
                *count += usize::from(in_u && in_v);
            }
        }
    }
    let best = (0..4).min_by_key(|&k| counts[k]).unwrap_or(0);
    corners[best].0.clone()
}

/// Draws the axes, the series and the legend on coordinates `x`, `y`.
fn draw_lines<X, Y>(
    root: &Area,
    chart: &LineChart,
    x: X,
    y: Y,
    legend: SeriesLabelPosition,
    (x_powers, y_powers): (bool, bool),
) -> DrawResult
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut ctx = ChartBuilder::on(root)
        .caption(chart.title, text(TITLE_SIZE))
        .margin(MARGIN)
        .x_label_area_size(X_LABEL_AREA)
        .y_label_area_size(Y_LABEL_AREA)
        .build_cartesian_2d(x, y)?;
    let label = |powers: bool| {
        move |v: &f64| {
            if powers {
                power_of_ten_label(*v)
            } else {
                tick_label(*v)
            }
        }
    };
    let (x_tick, y_tick) = (label(x_powers), label(y_powers));
    ctx.configure_mesh()
        .x_desc(chart.x_label)
        .y_desc(chart.y_label)
        .x_label_formatter(&x_tick)
        .y_label_formatter(&y_tick)
        .label_style(text(LABEL_SIZE))
        .axis_desc_style(text(DESC_SIZE))
        .bold_line_style(BLACK.mix(0.15))
        .light_line_style(BLACK.mix(0.05))
        .max_light_lines(1)
        .draw()?;
    for (i, s) in chart.series.iter().enumerate() {
        let colour = PALETTE[i % PALETTE.len()];
        let marker = MARKERS[i % MARKERS.len()];
        ctx.draw_series(LineSeries::new(
            s.points.iter().copied(),
            colour.stroke_width(2),
        ))?
        .label(s.name)
        .legend(move |(x, y)| {
            EmptyElement::at((x + 10, y))
                + PathElement::new(vec![(-10, 0), (10, 0)], colour.stroke_width(2))
                + Polygon::new(marker_outline(marker, 4), colour.filled())
        });
        ctx.draw_series(s.points.iter().map(|&at| {
            EmptyElement::at(at) + Polygon::new(marker_outline(marker, 4), colour.filled())
        }))?;
    }
    ctx.configure_series_labels()
        .position(legend)
        .margin(10)
        .legend_area_size(30)
        .label_font(text(LABEL_SIZE))
        .background_style(WHITE.mix(0.9))
        .border_style(BLACK.mix(0.4))
        .draw()?;
    Ok(())
}

#[derive(Debug, Clone, Copy)]
enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
}

const MARKERS: [Marker; 4] = [
    Marker::Circle,
    Marker::Square,
    Marker::Triangle,
    Marker::Diamond,
];

/// Outline of a marker of half-width `s` pixels about its centre; all are
/// polygons so that one element type draws them all.
fn marker_outline(marker: Marker, s: i32) -> Vec<(i32, i32)> {
    match marker {
        Marker::Circle => (0..12)
            .map(|k| {
                let a = f64::from(k) * std::f64::consts::TAU / 12.0;
                let r = f64::from(s);
                ((r * a.cos()).round() as i32, (r * a.sin()).round() as i32)
            })
            .collect(),
        Marker::Square => vec![(-s, -s), (s, -s), (s, s), (-s, s)],
        Marker::Triangle => vec![(0, -s - 1), (s + 1, s), (-s - 1, s)],
        Marker::Diamond => vec![(0, -s - 1), (s + 1, 0), (0, s + 1), (-s - 1, 0)],
    }
}

fn is_power_of_ten(v: f64) -> bool {
    (v / 10f64.powf(v.log10().round()) - 1.0).abs() < 1e-9
}

/// `10ⁿ` for a power of ten `v`.
fn power_of_ten_label(v: f64) -> String {
    const SUPERSCRIPTS: [char; 10] = ['⁰', '¹', '²', '³', '⁴', '⁵', '⁶', '⁷', '⁸', '⁹'];
    let exponent = v.log10().round() as i32;
    let sign = if exponent < 0 { "⁻" } else { "" };
    let digits: String = exponent
        .unsigned_abs()
        .to_string()
        .chars()
        .filter_map(|d| d.to_digit(10).map(|d| SUPERSCRIPTS[d as usize]))
        .collect();
    format!("10{sign}{digits}")
}

/// A tick value without trailing zeros (at most four decimals), in
/// scientific notation beyond 10^5 and below 10^-3.
fn tick_label(v: f64) -> String {
    if v == 0.0 {
        return "0".to_string();
    }
    if !(1e-3..1e5).contains(&v.abs()) {
        return format!("{v:e}");
    }
    let fixed = format!("{v:.4}");
    fixed
        .trim_end_matches('0')
        .trim_end_matches('.')
        .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The opening tags `<name ...>` of `svg`, in document order.
    fn tags<'a>(svg: &'a str, name: &str) -> Vec<&'a str> {
        svg.match_indices(&format!("<{name} "))
            .map(|(i, _)| &svg[i..i + svg[i..].find('>').unwrap() + 1])
            .collect()
    }

    fn attr<'a>(tag: &'a str, name: &str) -> &'a str {
        let key = format!(" {name}=\"");
        let start = tag
            .find(&key)
            .unwrap_or_else(|| panic!("{tag} has no {name}"))
            + key.len();
        &tag[start..start + tag[start..].find('"').unwrap()]
    }

    /// `(text-anchor, content)` of every text element.
    fn texts(svg: &str) -> Vec<(String, String)> {
        svg.match_indices("<text ")
            .map(|(i, _)| {
                let element = &svg[i..i + svg[i..].find("</text>").unwrap()];
                let (tag, content) = element.split_at(element.find('>').unwrap() + 1);
                (
                    attr(tag, "text-anchor").to_string(),
                    content.trim().to_string(),
                )
            })
            .collect()
    }

    /// The value of a tick label: a number or `10ⁿ`.
    fn tick_value(label: &str) -> Option<f64> {
        if let Some(exponent) = label
            .strip_prefix("10")
            .filter(|e| !e.is_empty() && !e.starts_with(|c: char| c.is_ascii_digit() || c == '.'))
        {
            let plain: String = exponent
                .chars()
                .map(|c| match c {
                    '⁻' => '-',
                    c => char::from_digit(
                        "⁰¹²³⁴⁵⁶⁷⁸⁹".chars().position(|s| s == c).unwrap() as u32,
                        10,
                    )
                    .unwrap(),
                })
                .collect();
            return Some(10f64.powi(plain.parse().ok()?));
        }
        label.parse().ok()
    }

    /// The numeric labels drawn with `anchor`, ascending.
    fn ticks(svg: &str, anchor: &str) -> Vec<f64> {
        let mut values: Vec<f64> = texts(svg)
            .iter()
            .filter(|(a, _)| a == anchor)
            .filter_map(|(_, t)| tick_value(t))
            .collect();
        values.sort_by(f64::total_cmp);
        values
    }

    fn rgb(hex: &str) -> (u8, u8, u8) {
        let channel = |k: usize| u8::from_str_radix(&hex[1 + 2 * k..3 + 2 * k], 16).unwrap();
        (channel(0), channel(1), channel(2))
    }

    fn points(polyline: &str) -> Vec<(i32, i32)> {
        attr(polyline, "points")
            .split_whitespace()
            .map(|p| {
                let (x, y) = p.split_once(',').unwrap();
                (x.parse().unwrap(), y.parse().unwrap())
            })
            .collect()
    }

    const XS: [f64; 4] = [-30.0, -10.0, 10.0, 30.0];
    const YS: [f64; 3] = [0.0, 50.0, 100.0];

    fn map(values: &[f64]) -> HeatMap<'_> {
        HeatMap {
            title: "Tool-tip error",
            subtitle: "z = 250 mm",
            xs: &XS,
            ys: &YS,
            values,
            value_label: "error / µm",
            x_label: "x / mm",
            y_label: "y / mm",
        }
    }

    #[test]
    fn heat_map_colours_each_cell_by_its_value_from_the_low_end_of_viridis() {
        // Values not in grid order: 7 * k mod 12 visits all of 0..12.
        let values: Vec<f64> = (0..12)
            .map(|k| f64::from((7 * k) % 12) * 1.5 + 2.0)
            .collect();
        let svg = heat_map_svg(&map(&values)).unwrap();
        let rects = tags(&svg, "rect");
        // Background, 12 cells, the bar's steps and its outline.
        assert_eq!(rects.len(), 1 + 12 + BAR_STEPS + 1);
        let cells = &rects[1..13];
        let fills: Vec<(u8, u8, u8)> = cells.iter().map(|c| rgb(attr(c, "fill"))).collect();
        let distinct: std::collections::BTreeSet<_> = fills.iter().collect();
        assert_eq!(distinct.len(), 12);
        // Viridis' green rises monotonically from its low end to its high end.
        let mut order: Vec<usize> = (0..12).collect();
        order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
        assert!(
            order.windows(2).all(|w| fills[w[0]].1 < fills[w[1]].1),
            "{fills:?}"
        );
        assert_eq!(
            fills[order[0]],
            (68, 1, 84),
            "least value: viridis' low end"
        );
        assert_eq!(
            fills[order[11]],
            (254, 232, 37),
            "greatest value: its high end"
        );
        // Cell (ix, iy) = values[iy * 4 + ix]: x grows with ix, y (down) falls with iy.
        let corner = |c: &str| -> (i32, i32) {
            (attr(c, "x").parse().unwrap(), attr(c, "y").parse().unwrap())
        };
        let (x00, y00) = corner(cells[0]);
        let (x30, _) = corner(cells[3]);
        let (_, y02) = corner(cells[8]);
        assert!(x30 > x00 && y02 < y00);
        // The bar's steps run from the low end (bottom) to the high end (top).
        let steps = &rects[13..13 + BAR_STEPS];
        let bottom = steps
            .iter()
            .max_by_key(|s| attr(s, "y").parse::<i32>().unwrap())
            .unwrap();
        let top = steps
            .iter()
            .min_by_key(|s| attr(s, "y").parse::<i32>().unwrap())
            .unwrap();
        assert!(rgb(attr(bottom, "fill")).1 < 20 && rgb(attr(top, "fill")).1 > 220);
    }

    #[test]
    fn heat_map_labels_cover_the_grid_and_the_values() {
        let values: Vec<f64> = (0..12).map(|k| 3.0 + f64::from(k)).collect();
        let svg = heat_map_svg(&map(&values)).unwrap();
        let all: Vec<String> = texts(&svg).into_iter().map(|(_, t)| t).collect();
        for label in [
            "Tool-tip error",
            "z = 250 mm",
            "x / mm",
            "y / mm",
            "error / µm",
        ] {
            assert!(
                all.iter().any(|t| t == label),
                "{label} missing from {all:?}"
            );
        }
        // x ticks (centred below the axis), y ticks (left of it), colour-bar ticks (right of it).
        let x = ticks(&svg, "middle");
        let y = ticks(&svg, "end");
        let bar = ticks(&svg, "start");
        assert!(x[0] <= XS[0] && x[x.len() - 1] >= XS[3], "{x:?}");
        assert!(y[0] <= YS[0] && y[y.len() - 1] >= YS[2], "{y:?}");
        assert!(bar.len() >= 3, "{bar:?}");
        assert!(bar[0] >= 3.0 && bar[0] <= 3.0 + 0.25 * 11.0, "{bar:?}");
        assert!(
            bar[bar.len() - 1] <= 14.0 && bar[bar.len() - 1] >= 14.0 - 0.25 * 11.0,
            "{bar:?}"
        );
    }

    #[test]
    fn a_constant_heat_map_is_drawn_in_one_colour() {
        let svg = heat_map_svg(&map(&[5.0; 12])).unwrap();
        let rects = tags(&svg, "rect");
        let fills: std::collections::BTreeSet<&str> =
            rects[1..13].iter().map(|c| attr(c, "fill")).collect();
        assert_eq!(fills.len(), 1);
    }

    #[test]
    fn heat_map_rejects_data_it_cannot_draw() {
        let short = heat_map_svg(&map(&[1.0; 11])).unwrap_err();
        assert!(
            short.contains("11 values do not fill the grid of 4 x values by 3 y values"),
            "{short}"
        );
        let mut values = vec![1.0; 12];
        values[5] = f64::NAN;
        let nan = heat_map_svg(&map(&values)).unwrap_err();
        assert_eq!(nan, "the value at x index 1, y index 1 is NaN");
        let unordered = heat_map_svg(&HeatMap {
            xs: &[0.0, 2.0, 1.0, 3.0],
            ..map(&[1.0; 12])
        })
        .unwrap_err();
        assert!(
            unordered.contains("x values are not strictly increasing: 1 at index 2 follows 2"),
            "{unordered}"
        );
        let wide = heat_map_svg(&map(&[
            -f64::MAX,
            f64::MAX,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
            0.0,
        ]))
        .unwrap_err();
        assert!(wide.contains("too wide to plot"), "{wide}");
        let empty = heat_map_svg(&HeatMap {
            ys: &[],
            values: &[],
            ..map(&[])
        })
        .unwrap_err();
        assert_eq!(empty, "there are no y values");
    }

    const FAST: [(f64, f64); 6] = [
        (0.0, 100.0),
        (1.0, 30.0),
        (2.0, 9.0),
        (3.0, 2.7),
        (4.0, 0.81),
        (5.0, 0.243),
    ];
    const SLOW: [(f64, f64); 3] = [(0.0, 50.0), (1.0, 40.0), (2.0, 32.0)];

    fn chart<'a>(series: &'a [Series<'a>], log_y: bool) -> LineChart<'a> {
        LineChart {
            title: "Residual norm per iteration",
            x_label: "iteration",
            y_label: "norm / mm",
            series,
            log_x: false,
            log_y,
        }
    }

    #[test]
    fn line_chart_draws_each_series_with_all_its_points_and_names_it() {
        let series = [
            Series {
                name: "fast run",
                points: &FAST,
            },
            Series {
                name: "slow run",
                points: &SLOW,
            },
        ];
        let svg = line_chart_svg(&chart(&series, true)).unwrap();
        let polylines = tags(&svg, "polyline");
        for (i, data) in [&FAST[..], &SLOW[..]].into_iter().enumerate() {
            let colour = PALETTE[i];
            let hex = format!("#{:02X}{:02X}{:02X}", colour.0, colour.1, colour.2);
            let lines: Vec<&&str> = polylines
                .iter()
                .filter(|p| attr(p, "stroke") == hex)
                .collect();
            // The series, then its legend sample.
            assert_eq!(lines.len(), 2, "{hex}");
            let line = points(lines[0]);
            assert_eq!(line.len(), data.len());
            assert_eq!(points(lines[1]).len(), 2);
            // x grows to the right; the falling values rise on screen (y down).
            assert!(
                line.windows(2).all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1),
                "{line:?}"
            );
        }
        // FAST falls by a constant factor: on a log axis, by equal steps.
        let fast = points(
            polylines
                .iter()
                .find(|p| attr(p, "stroke") == "#1F77B4")
                .unwrap(),
        );
        let steps: Vec<i32> = fast.windows(2).map(|w| w[1].1 - w[0].1).collect();
        assert!(steps.iter().all(|s| (s - steps[0]).abs() <= 1), "{steps:?}");
        let all: Vec<String> = texts(&svg).into_iter().map(|(_, t)| t).collect();
        for label in [
            "fast run",
            "slow run",
            "Residual norm per iteration",
            "iteration",
            "norm / mm",
        ] {
            assert!(
                all.iter().any(|t| t == label),
                "{label} missing from {all:?}"
            );
        }
    }

    #[test]
    fn line_chart_ticks_cover_the_data() {
        let series = [Series {
            name: "fast run",
            points: &FAST,
        }];
        // Log y over 0.243..100: ticks at powers of ten, labelled 10ⁿ.
        let svg = line_chart_svg(&chart(&series, true)).unwrap();
        let y = ticks(&svg, "end");
        assert_eq!(
            y,
            [0.1, 1.0, 10.0, 100.0]
                .into_iter()
                .filter(|v| *v >= 0.2)
                .collect::<Vec<_>>()
        );
        assert!(texts(&svg).iter().any(|(_, t)| t == "10²"));
        let x = ticks(&svg, "middle");
        assert!(x[0] <= 0.0 && x[x.len() - 1] >= 5.0, "{x:?}");
        // Linear y: ticks from near the least to near the greatest value.
        let svg = line_chart_svg(&chart(&series, false)).unwrap();
        let y = ticks(&svg, "end");
        assert!(y[0] <= 0.243 + 25.0 && y[y.len() - 1] >= 75.0, "{y:?}");
    }

    #[test]
    fn line_chart_rejects_data_it_cannot_draw() {
        let zero = [(0.0, 1.0), (1.0, 0.0)];
        let series = [Series {
            name: "run",
            points: &zero,
        }];
        let error = line_chart_svg(&chart(&series, true)).unwrap_err();
        assert_eq!(
            error,
            "series \"run\" has y = 0 at point 1, which a logarithmic axis cannot show"
        );
        assert!(line_chart_svg(&chart(&series, false)).is_ok());
        let nan = [(f64::NAN, 1.0)];
        let error = line_chart_svg(&chart(
            &[Series {
                name: "run",
                points: &nan,
            }],
            false,
        ))
        .unwrap_err();
        assert_eq!(
            error,
            "series \"run\" has x = NaN at point 0, which is not finite"
        );
        let error = line_chart_svg(&chart(
            &[Series {
                name: "run",
                points: &[],
            }],
            false,
        ))
        .unwrap_err();
        assert_eq!(error, "series \"run\" has no points");
        assert_eq!(
            line_chart_svg(&chart(&[], false)).unwrap_err(),
            "there are no series"
        );
    }

    #[test]
    fn log_ticks_are_decades_or_one_two_five() {
        assert_eq!(log_ticks(&(5.5..5000.0)), [10.0, 100.0, 1000.0]);
        assert_eq!(log_ticks(&(8.6..160.0)), [10.0, 20.0, 50.0, 100.0]);
        assert_eq!(
            log_ticks(&(25.0..90.0)),
            [30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0]
        );
        assert_eq!(log_ticks(&(12.0..18.0)), [12.0, 18.0]);
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(-100.0), "-100");
        assert_eq!(tick_label(-0.0), "0");
        assert_eq!(tick_label(2e6), "2e6");
        assert_eq!(power_of_ten_label(1e-3), "10⁻³");
        assert_eq!(power_of_ten_label(1e12), "10¹²");
    }

    #[test]
    fn the_legend_goes_where_the_lines_are_not() {
        let rising: Vec<(f64, f64)> = (0..10).map(|k| (f64::from(k), f64::from(k))).collect();
        let falling: Vec<(f64, f64)> = rising.iter().map(|&(x, y)| (x, 9.0 - y)).collect();
        for (data, expected) in [(&rising, "UpperLeft"), (&falling, "UpperRight")] {
            let series = [Series {
                name: "run",
                points: data,
            }];
            let c = chart(&series, false);
            let x = axis_range(data.iter().map(|p| p.0), false);
            let y = axis_range(data.iter().map(|p| p.1), false);
            let corner = match legend_corner(&c, &x, &y) {
                SeriesLabelPosition::UpperLeft => "UpperLeft",
                SeriesLabelPosition::UpperRight => "UpperRight",
                _ => "other",
            };
            assert_eq!(corner, expected);
        }
    }
}
