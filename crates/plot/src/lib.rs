//! PNG plots for parcal's reports, drawn with [plotters] and a bundled font
//! (DejaVu Sans, see `assets/LICENSE-DejaVu.txt`), so nothing but Cargo is
//! needed to build: no fontconfig, no system fonts.
//!
//! - [`heat_map`]: a grid of cells coloured by the [`viridis`] map, with a
//!   labelled colour bar, e.g. the tool-tip error over a workspace slice.
//! - [`line_chart`]: lines with point markers and a legend, each axis linear
//!   or logarithmic, e.g. the residual norm per iteration of several runs
//!   (log y) or the time per iteration against the number of contacts
//!   (log-log).
//!
//! Invalid input (nothing to draw, mismatched lengths, NaN or infinite
//! values, values that are not positive on a logarithmic axis) is reported as
//! [`PlotError::InvalidInput`] before anything is written; the image is
//! rendered in memory and written only when complete.
//!
//! ```
//! use parcal_plot::{heat_map, line_chart, HeatMap, LineChart, Series};
//!
//! let dir = tempfile::tempdir()?;
//!
//! // Error over a 3 x 2 grid: values[iy * xs.len() + ix].
//! heat_map(
//!     &dir.path().join("error.png"),
//!     &HeatMap {
//!         title: "Tool-tip error, z = 250 mm",
//!         xs: &[-50.0, 0.0, 50.0],
//!         ys: &[-20.0, 20.0],
//!         values: &[1.2, 0.8, 1.9, 2.4, 0.3, 1.1],
//!         value_label: "error / µm",
//!         x_label: "x / mm",
//!         y_label: "y / mm",
//!         range: None,
//!     },
//! )?;
//!
//! let run: Vec<(f64, f64)> = (0..8).map(|i| (i as f64, 10f64.powi(-i))).collect();
//! line_chart(
//!     &dir.path().join("residuals.png"),
//!     &LineChart {
//!         title: "Residual norm per iteration",
//!         x_label: "iteration",
//!         y_label: "residual norm / mm",
//!         series: &[Series { name: "run 1", points: &run }],
//!         log_y: true,
//!         ..Default::default()
//!     },
//! )?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![warn(missing_docs)]

mod axis;
mod canvas;
mod colormap;
mod heat;
mod line;

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use plotters::coord::Shift;
use plotters::prelude::*;

use canvas::Canvas;

pub use colormap::viridis;

/// A heat map: one cell per grid point, coloured by value.
///
/// `xs` and `ys` are the cell centres, each strictly increasing; cells reach
/// halfway to their neighbours. `values` is row-major,
/// `values[iy * xs.len() + ix]`, and row `iy = 0` is drawn at the bottom.
#[derive(Debug, Clone, Copy, Default)]
pub struct HeatMap<'a> {
    /// Title above the plot; empty for none.
    pub title: &'a str,
    /// Cell centres along x, strictly increasing.
    pub xs: &'a [f64],
    /// Cell centres along y, strictly increasing.
    pub ys: &'a [f64],
    /// `xs.len() * ys.len()` values, row-major: `values[iy * xs.len() + ix]`.
    pub values: &'a [f64],
    /// Label of the colour bar, e.g. `"error / µm"`.
    pub value_label: &'a str,
    /// Label of the x axis.
    pub x_label: &'a str,
    /// Label of the y axis.
    pub y_label: &'a str,
    /// Values mapped to the ends of the colour scale (finite, `lo < hi`);
    /// values outside take the end colours. `None`: the least and greatest
    /// value.
    pub range: Option<(f64, f64)>,
}

/// One named line of a [`LineChart`].
#[derive(Debug, Clone, Copy, Default)]
pub struct Series<'a> {
    /// Legend entry; empty for none.
    pub name: &'a str,
    /// `(x, y)` points, joined in the given order.
    pub points: &'a [(f64, f64)],
}

/// A line chart of one or more series, each axis linear or logarithmic.
#[derive(Debug, Clone, Copy, Default)]
pub struct LineChart<'a> {
    /// Title above the plot; empty for none.
    pub title: &'a str,
    /// Label of the x axis.
    pub x_label: &'a str,
    /// Label of the y axis.
    pub y_label: &'a str,
    /// The lines, drawn in distinct colours and marker shapes.
    pub series: &'a [Series<'a>],
    /// Logarithmic x axis (all x must be positive).
    pub log_x: bool,
    /// Logarithmic y axis (all y must be positive).
    pub log_y: bool,
}

/// Why a plot was not written.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The data cannot be plotted; nothing was written.
    #[error("cannot plot {}: {reason}", path.display())]
    InvalidInput {
        /// The PNG that was to be written.
        path: PathBuf,
        /// What is wrong with the input.
        reason: String,
    },
    /// Drawing or writing the image failed (e.g. its directory is missing).
    #[error("cannot write plot {}: {message}", path.display())]
    Write {
        /// The PNG that was to be written.
        path: PathBuf,
        /// The underlying error.
        message: String,
    },
}

impl PlotError {
    /// The PNG the error is about.
    pub fn path(&self) -> &Path {
        match self {
            PlotError::InvalidInput { path, .. } | PlotError::Write { path, .. } => path,
        }
    }
}

/// Size in pixels of a [`heat_map`] image.
pub const HEAT_MAP_SIZE: (u32, u32) = (800, 640);
/// Size in pixels of a [`line_chart`] image.
pub const LINE_CHART_SIZE: (u32, u32) = (800, 600);

/// Draws `map` into the PNG file `path` ([`HEAT_MAP_SIZE`]): cells coloured
/// by [`viridis`], axes with ticks, and a colour bar labelled with
/// `map.value_label`.
///
/// # Errors
/// [`PlotError::InvalidInput`] if `path` does not end in `.png`; `xs` or `ys`
/// is empty, not finite or not strictly increasing; `values` does not have
/// `xs.len() * ys.len()` elements or one is NaN or infinite; `range` is not
/// finite with `lo < hi`; or coordinates or values span more than an `f64`
/// holds. [`PlotError::Write`] if the file cannot be written.
pub fn heat_map(path: &Path, map: &HeatMap) -> Result<(), PlotError> {
    let invalid = |reason| PlotError::InvalidInput {
        path: path.to_path_buf(),
        reason,
    };
    check_png_path(path).map_err(invalid)?;
    let prepared = heat::prepare(map).map_err(invalid)?;
    render(path, HEAT_MAP_SIZE, |root| heat::draw(root, map, &prepared))
}

/// Draws `chart` into the PNG file `path` ([`LINE_CHART_SIZE`]): each series
/// as a line with point markers in its own colour and marker shape, a legend
/// of the named series in the emptiest corner, and linear or logarithmic
/// axes with ticks.
///
/// # Errors
/// [`PlotError::InvalidInput`] if `path` does not end in `.png`, there are no
/// series, a series has no points, a coordinate is NaN or infinite, one is
/// not positive on a logarithmic axis, or the values span more than an `f64`
/// holds. [`PlotError::Write`] if the file cannot be written.
pub fn line_chart(path: &Path, chart: &LineChart) -> Result<(), PlotError> {
    let invalid = |reason| PlotError::InvalidInput {
        path: path.to_path_buf(),
        reason,
    };
    check_png_path(path).map_err(invalid)?;
    let prepared = line::prepare(chart).map_err(invalid)?;
    render(path, LINE_CHART_SIZE, |root| {
        line::draw(root, chart, &prepared)
    })
}

/// The bitmap encoder picks the format from the extension.
fn check_png_path(path: &Path) -> Result<(), String> {
    match path.extension().and_then(|e| e.to_str()) {
        Some(ext) if ext.eq_ignore_ascii_case("png") => Ok(()),
        _ => Err("the file name must end in .png".to_string()),
    }
}

/// The font family used for all text.
const FONT: &str = "sans-serif";

/// Registers the bundled font with plotters once, under every generic family
/// name it might fall back to: plotters measures legend text itself (all
/// text is drawn by [`Canvas`]). Returns whether it is usable.
fn register_font() -> bool {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    *REGISTERED.get_or_init(|| {
        ["sans-serif", "serif", "monospace"]
            .into_iter()
            .all(|family| {
                plotters::style::register_font(family, FontStyle::Normal, canvas::DEJAVU_SANS)
                    .is_ok()
            })
    })
}

type DrawResult = Result<(), DrawingAreaErrorKind<<Canvas<'static> as DrawingBackend>::ErrorType>>;

/// Renders into memory with `draw` on a white background, then writes the PNG.
fn render(
    path: &Path,
    (width, height): (u32, u32),
    draw: impl FnOnce(&DrawingArea<Canvas, Shift>) -> DrawResult,
) -> Result<(), PlotError> {
    let failed = |message: String| PlotError::Write {
        path: path.to_path_buf(),
        message,
    };
    let font = match canvas::font() {
        Some(font) if register_font() => font,
        _ => return Err(failed("the bundled font could not be loaded".to_string())),
    };
    let mut pixels = vec![0u8; width as usize * height as usize * 3];
    {
        let bitmap = BitMapBackend::with_buffer(&mut pixels, (width, height));
        let root = Canvas::new(bitmap, font).into_drawing_area();
        root.fill(&WHITE).map_err(|e| failed(e.to_string()))?;
        draw(&root).map_err(|e| failed(e.to_string()))?;
        root.present().map_err(|e| failed(e.to_string()))?;
    }
    let mut file = BitMapBackend::new(path, (width, height));
    file.blit_bitmap((0, 0), (width, height), &pixels)
        .map_err(|e| failed(e.to_string()))?;
    file.present().map_err(|e| failed(e.to_string()))
}

/// Size of tick labels.
const LABEL_SIZE: u32 = 15;
/// Size of axis labels.
const DESC_SIZE: u32 = 17;

/// Width of a vertical axis' label area: tick mark, gap, the widest tick
/// label, gap and the rotated axis label (if any).
fn y_label_area(axis: &axis::Axis, desc: &str) -> u32 {
    let widest = axis
        .major
        .iter()
        .map(|(_, label)| canvas::text_width(label, f64::from(LABEL_SIZE)))
        .fold(0.0f32, f32::max);
    let desc = if desc.is_empty() { 0 } else { DESC_SIZE + 12 };
    5 + 10 + widest.ceil() as u32 + 8 + desc
}

/// Text style of the given size in the bundled font.
fn text(size: u32) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn png_extension_is_required() {
        assert!(check_png_path(Path::new("a/b.png")).is_ok());
        assert!(check_png_path(Path::new("B.PNG")).is_ok());
        assert!(check_png_path(Path::new("b.jpg")).is_err());
        assert!(check_png_path(Path::new("b")).is_err());
    }

    #[test]
    fn font_registers() {
        assert!(register_font());
        assert!(register_font());
    }
}
