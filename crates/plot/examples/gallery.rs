//! Writes sample plots of realistic data for a visual check:
//! `cargo run -p parcal-plot --example gallery [-- DIR]` (default
//! `/tmp/parcal-plot-check`).

use std::error::Error;
use std::path::PathBuf;

use parcal_plot::{HeatMap, LineChart, Series, heat_map, line_chart};

fn main() -> Result<(), Box<dyn Error>> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "/tmp/parcal-plot-check".into()),
    );
    std::fs::create_dir_all(&dir)?;

    // Tool-tip error over a workspace slice: a bowl plus a waviness, in µm.
    let xs: Vec<f64> = (0..41).map(|i| -100.0 + 5.0 * f64::from(i)).collect();
    let ys: Vec<f64> = (0..31).map(|i| -75.0 + 5.0 * f64::from(i)).collect();
    let values: Vec<f64> = ys
        .iter()
        .flat_map(|&y| {
            xs.iter().map(move |&x| {
                1.5 + 2.5e-4 * (x * x + 1.5 * y * y) + 0.8 * (x / 25.0).sin() * (y / 40.0).cos()
            })
        })
        .collect();
    heat_map(
        &dir.join("heat_map.png"),
        &HeatMap {
            title: "Tool-tip error after calibration, z = 250 mm",
            xs: &xs,
            ys: &ys,
            values: &values,
            value_label: "error / µm",
            x_label: "x / mm",
            y_label: "y / mm",
            range: None,
        },
    )?;

    // Residual norm per iteration, several runs (log y).
    // Superlinear convergence down to a noise floor.
    let run = |r0: f64, rate: f64, floor: f64, n: i32| -> Vec<(f64, f64)> {
        let mut r = r0;
        (0..n)
            .map(|k| {
                let p = (
                    f64::from(k),
                    r.max(floor) * (1.0 + 0.3 * (f64::from(k) * 1.7).sin().abs()),
                );
                r *= rate * (r / r0).powf(0.35);
                p
            })
            .collect()
    };
    let runs = [
        run(12.0, 0.3, 3e-11, 12),
        run(12.0, 0.5, 4e-11, 18),
        run(30.0, 0.25, 2e-10, 10),
        run(3.0, 0.6, 1e-9, 22),
    ];
    let series = [
        Series {
            name: "Gauss-Newton, 66 poses",
            points: &runs[0],
        },
        Series {
            name: "Levenberg-Marquardt, 66 poses",
            points: &runs[1],
        },
        Series {
            name: "Gauss-Newton, 200 poses",
            points: &runs[2],
        },
        Series {
            name: "LM, noisy start",
            points: &runs[3],
        },
    ];
    line_chart(
        &dir.join("residuals.png"),
        &LineChart {
            title: "Residual norm per iteration",
            x_label: "iteration",
            y_label: "residual norm / mm",
            series: &series,
            log_x: false,
            log_y: true,
        },
    )?;

    // Time per iteration against the number of contacts (log-log).
    let contacts = [50.0, 100.0, 200.0, 500.0, 1000.0, 2000.0, 5000.0, 10000.0];
    let time = |a: f64, b: f64, p: f64| -> Vec<(f64, f64)> {
        contacts
            .iter()
            .map(|&n| (n, a + b * f64::powf(n, p)))
            .collect()
    };
    let (dense, sparse, parallel) = (
        time(2e-5, 4e-8, 2.0),
        time(5e-5, 6e-7, 1.1),
        time(3e-4, 2.5e-7, 1.05),
    );
    let series = [
        Series {
            name: "dense QR",
            points: &dense,
        },
        Series {
            name: "normal equations",
            points: &sparse,
        },
        Series {
            name: "normal equations, 2 threads",
            points: &parallel,
        },
    ];
    line_chart(
        &dir.join("timing.png"),
        &LineChart {
            title: "Time per iteration",
            x_label: "contacts",
            y_label: "time / s",
            series: &series,
            log_x: true,
            log_y: true,
        },
    )?;

    // A log axis spanning less than a decade, and a single point.
    let narrow: Vec<(f64, f64)> = (0..10)
        .map(|i| (f64::from(i), 3.1e-3 + 0.8e-3 * f64::from(i % 4) / 3.0))
        .collect();
    let single = [(4.5, 3.5e-3)];
    line_chart(
        &dir.join("narrow.png"),
        &LineChart {
            title: "",
            x_label: "run",
            y_label: "time / s",
            series: &[
                Series {
                    name: "repeat",
                    points: &narrow,
                },
                Series {
                    name: "",
                    points: &single,
                },
            ],
            log_x: false,
            log_y: true,
        },
    )?;
    // Small coordinates and values with a fixed colour range.
    heat_map(
        &dir.join("heat_map_small.png"),
        &HeatMap {
            title: "Residual per contact",
            xs: &[1e-4, 2e-4, 3e-4],
            ys: &[-2e-4, 0.0, 2e-4],
            values: &[1e-7, 2e-7, 3e-7, -4e-7, 5e-7, 6e-7, 7e-7, 8e-7, 1.5e-6],
            value_label: "residual / mm",
            x_label: "u / m",
            y_label: "v / m",
            range: Some((-5e-7, 1e-6)),
        },
    )?;

    // More series than colours, negative values, linear axes.
    let wiggles: Vec<Vec<(f64, f64)>> = (0..12)
        .map(|s| {
            (0..30)
                .map(|i| {
                    (
                        f64::from(i) * 0.5 - 5.0,
                        f64::from(s) * 0.4 - (f64::from(i) * 0.3).sin(),
                    )
                })
                .collect()
        })
        .collect();
    let names: Vec<String> = (0..12).map(|s| format!("leg {}", s + 1)).collect();
    let series: Vec<Series> = wiggles
        .iter()
        .zip(&names)
        .map(|(points, name)| Series { name, points })
        .collect();
    line_chart(
        &dir.join("many_series.png"),
        &LineChart {
            title: "Leg length error",
            x_label: "stroke / mm",
            y_label: "error / µm",
            series: &series,
            log_x: false,
            log_y: false,
        },
    )?;
    println!("wrote {}", dir.display());
    Ok(())
}
