//! Writes real PNGs into a temporary directory and checks their headers, and
//! checks that every kind of invalid input is an error.

use std::path::{Path, PathBuf};

use parcal_plot::{
    HEAT_MAP_SIZE, HeatMap, LINE_CHART_SIZE, LineChart, PlotError, Series, heat_map, line_chart,
};

/// Width and height from the PNG signature and IHDR chunk.
fn png_size(path: &Path) -> (u32, u32) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("reading {}: {e}", path.display()));
    assert!(
        bytes.len() > 1000,
        "{} is only {} bytes",
        path.display(),
        bytes.len()
    );
    assert_eq!(
        bytes[..8],
        [0x89, b'P', b'N', b'G', b'\r', b'\n', 0x1a, b'\n'],
        "PNG signature"
    );
    assert_eq!(&bytes[12..16], b"IHDR", "first chunk is IHDR");
    let be = |at: usize| u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap());
    assert_eq!(be(8), 13, "IHDR length");
    (be(16), be(20))
}

fn grid(nx: usize, ny: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let xs: Vec<f64> = (0..nx)
        .map(|i| -100.0 + 200.0 * i as f64 / (nx.max(2) - 1) as f64)
        .collect();
    let ys: Vec<f64> = (0..ny)
        .map(|i| -50.0 + 100.0 * i as f64 / (ny.max(2) - 1) as f64)
        .collect();
    let values = ys
        .iter()
        .flat_map(|&y| {
            xs.iter()
                .map(move |&x| 2.0 + 1e-4 * (x * x + y * y) + (x / 20.0).sin())
        })
        .collect();
    (xs, ys, values)
}

fn heat<'a>(xs: &'a [f64], ys: &'a [f64], values: &'a [f64]) -> HeatMap<'a> {
    HeatMap {
        title: "Tool-tip error",
        xs,
        ys,
        values,
        value_label: "error / µm",
        x_label: "x / mm",
        y_label: "y / mm",
        range: None,
    }
}

fn residual_runs() -> Vec<Vec<(f64, f64)>> {
    (0..3)
        .map(|run| {
            (0..15)
                .map(|k| (f64::from(k), 10.0 * 0.2f64.powi(k * (run + 1)) + 1e-12))
                .collect()
        })
        .collect()
}

#[test]
fn heat_map_writes_a_png() {
    let dir = tempfile::tempdir().unwrap();
    let (xs, ys, values) = grid(41, 31);
    let path = dir.path().join("heat.png");
    heat_map(&path, &heat(&xs, &ys, &values)).unwrap();
    assert_eq!(png_size(&path), HEAT_MAP_SIZE);
}

#[test]
fn heat_map_edge_cases_write_pngs() {
    let dir = tempfile::tempdir().unwrap();
    let (xs, ys, values) = grid(12, 9);
    // Fixed colour range narrower than the values: clamped, not an error.
    let path = dir.path().join("range.png");
    heat_map(
        &path,
        &HeatMap {
            range: Some((2.0, 3.0)),
            ..heat(&xs, &ys, &values)
        },
    )
    .unwrap();
    assert_eq!(png_size(&path), HEAT_MAP_SIZE);
    // One cell; all values equal; no title or labels; upper-case extension.
    let path = dir.path().join("single.PNG");
    heat_map(
        &path,
        &HeatMap {
            xs: &[3.0],
            ys: &[0.0],
            values: &[7.5],
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(png_size(&path), HEAT_MAP_SIZE);
    let path = dir.path().join("flat.png");
    heat_map(&path, &heat(&[1.0, 2.0, 4.0], &[1e-6, 2e-6], &[0.0; 6])).unwrap();
    assert_eq!(png_size(&path), HEAT_MAP_SIZE);
    // Tiny coordinates and values.
    let path = dir.path().join("tiny.png");
    heat_map(
        &path,
        &heat(&[1e-9, 2e-9], &[-3e-9, 3e-9], &[1e-7, 2e-7, 3e-7, 4e-7]),
    )
    .unwrap();
    assert_eq!(png_size(&path), HEAT_MAP_SIZE);
}

#[test]
fn line_charts_write_pngs() {
    let dir = tempfile::tempdir().unwrap();
    let runs = residual_runs();
    let series: Vec<Series> = runs
        .iter()
        .enumerate()
        .map(|(i, points)| Series {
            name: ["Gauss-Newton", "Levenberg-Marquardt", "LM, 200 poses"][i],
            points,
        })
        .collect();
    let path = dir.path().join("residuals.png");
    let chart = LineChart {
        title: "Residual norm per iteration",
        x_label: "iteration",
        y_label: "residual norm / mm",
        series: &series,
        log_x: false,
        log_y: true,
    };
    line_chart(&path, &chart).unwrap();
    assert_eq!(png_size(&path), LINE_CHART_SIZE);

    let timing: Vec<(f64, f64)> = [10.0, 100.0, 1000.0, 10000.0]
        .iter()
        .map(|&n| (n, 1e-6 * n))
        .collect();
    let path = dir.path().join("timing.png");
    let series = [Series {
        name: "dense",
        points: &timing,
    }];
    line_chart(
        &path,
        &LineChart {
            series: &series,
            log_x: true,
            log_y: true,
            ..chart
        },
    )
    .unwrap();
    assert_eq!(png_size(&path), LINE_CHART_SIZE);

    // Linear axes, negative values, one point, unnamed series, more series
    // than colours.
    let wiggles: Vec<Vec<(f64, f64)>> = (0..13)
        .map(|s| {
            (0..20)
                .map(|i| {
                    (
                        f64::from(i) - 5.0,
                        f64::from(s) - (f64::from(i) * 0.4).sin(),
                    )
                })
                .collect()
        })
        .collect();
    let mut series: Vec<Series> = wiggles
        .iter()
        .map(|points| Series { name: "", points })
        .collect();
    series[0].name = "first";
    let one = [(2.0, -1.0)];
    series.push(Series {
        name: "one point",
        points: &one,
    });
    let path = dir.path().join("linear.png");
    line_chart(
        &path,
        &LineChart {
            series: &series,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(png_size(&path), LINE_CHART_SIZE);

    // A range far narrower than its distance from zero.
    let far = [(1e16, 1.0), (1e16 + 2.0, 1.0 + 1e-12)];
    let path = dir.path().join("far.png");
    let series = [Series {
        name: "far",
        points: &far,
    }];
    line_chart(
        &path,
        &LineChart {
            series: &series,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(png_size(&path), LINE_CHART_SIZE);

    // Everything at one point, on log axes.
    let same = [(5.0, 5.0), (5.0, 5.0)];
    let path = dir.path().join("same.png");
    let series = [Series {
        name: "same",
        points: &same,
    }];
    line_chart(
        &path,
        &LineChart {
            series: &series,
            log_x: true,
            log_y: true,
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(png_size(&path), LINE_CHART_SIZE);
}

/// Asserts an `InvalidInput` naming `path` whose reason contains `needle`,
/// and that nothing was written.
fn assert_invalid(result: Result<(), PlotError>, path: &Path, needle: &str) {
    match result {
        Err(
            ref e @ PlotError::InvalidInput {
                path: ref p,
                ref reason,
            },
        ) => {
            assert_eq!(p, path);
            assert_eq!(e.path(), path);
            assert!(
                reason.contains(needle),
                "reason {reason:?} lacks {needle:?}"
            );
            let message = e.to_string();
            assert!(message.contains(&path.display().to_string()), "{message}");
            assert!(!message.contains('\n'), "{message}");
        }
        other => panic!("expected InvalidInput about {needle:?}, got {other:?}"),
    }
    assert!(!path.exists(), "{} was written", path.display());
}

#[test]
fn invalid_heat_maps_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.png");
    let (xs, ys, values) = grid(4, 3);
    let ok = heat(&xs, &ys, &values);
    let with_value = |i: usize, v: f64| {
        let mut values = values.clone();
        values[i] = v;
        values
    };
    let nan = with_value(5, f64::NAN);
    let inf = with_value(0, f64::INFINITY);
    let cases: Vec<(HeatMap, &str)> = vec![
        (
            HeatMap {
                xs: &[],
                values: &[],
                ..ok
            },
            "no x values",
        ),
        (
            HeatMap {
                ys: &[],
                values: &[],
                ..ok
            },
            "no y values",
        ),
        (
            HeatMap {
                values: &values[1..],
                ..ok
            },
            "11 values",
        ),
        (HeatMap { values: &[], ..ok }, "0 values"),
        (HeatMap { values: &nan, ..ok }, "x index 1, y index 1"),
        (HeatMap { values: &inf, ..ok }, "not finite"),
        (
            HeatMap {
                xs: &[0.0, f64::NAN, 2.0, 3.0],
                ..ok
            },
            "x value NaN",
        ),
        (
            HeatMap {
                ys: &[0.0, 1.0, f64::NEG_INFINITY],
                ..ok
            },
            "not finite",
        ),
        (
            HeatMap {
                xs: &[0.0, 2.0, 1.0, 3.0],
                ..ok
            },
            "not strictly increasing",
        ),
        (
            HeatMap {
                ys: &[0.0, 1.0, 1.0],
                ..ok
            },
            "not strictly increasing",
        ),
        (
            HeatMap {
                xs: &[-f64::MAX, -1.0, 1.0, f64::MAX],
                ..ok
            },
            "too wide",
        ),
        (
            HeatMap {
                ys: &[-f64::MAX, 0.0, f64::MAX],
                ..ok
            },
            "too wide",
        ),
        (
            HeatMap {
                range: Some((3.0, 3.0)),
                ..ok
            },
            "colour range",
        ),
        (
            HeatMap {
                range: Some((3.0, 1.0)),
                ..ok
            },
            "colour range",
        ),
        (
            HeatMap {
                range: Some((f64::NAN, 1.0)),
                ..ok
            },
            "colour range",
        ),
        (
            HeatMap {
                range: Some((0.0, f64::INFINITY)),
                ..ok
            },
            "colour range",
        ),
    ];
    for (map, needle) in cases {
        assert_invalid(heat_map(&path, &map), &path, needle);
    }
    let wide = [-f64::MAX, f64::MAX];
    assert_invalid(
        heat_map(&path, &heat(&[0.0, 1.0], &[0.0], &wide)),
        &path,
        "too wide",
    );
    let jpg = dir.path().join("bad.jpg");
    assert_invalid(heat_map(&jpg, &ok), &jpg, ".png");
}

#[test]
fn invalid_line_charts_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bad.png");
    let good = [(1.0, 1.0), (2.0, 0.5)];
    let chart = |series: &[Series], log_x: bool, log_y: bool| {
        line_chart(
            &path,
            &LineChart {
                series,
                log_x,
                log_y,
                ..Default::default()
            },
        )
    };
    let one = |name, points| {
        [
            Series {
                name: "ok",
                points: &good,
            },
            Series { name, points },
        ]
    };
    assert_invalid(chart(&[], false, false), &path, "no series");
    assert_invalid(
        chart(&one("empty", &[]), false, false),
        &path,
        "series 1 (\"empty\") has no points",
    );
    assert_invalid(
        chart(&one("", &[]), false, false),
        &path,
        "series 1 has no points",
    );
    assert_invalid(
        chart(&one("n", &[(0.0, 1.0), (f64::NAN, 1.0)]), false, false),
        &path,
        "x = NaN at point 1",
    );
    assert_invalid(
        chart(&one("i", &[(0.0, f64::INFINITY)]), false, false),
        &path,
        "y = inf at point 0",
    );
    assert_invalid(
        chart(&one("z", &[(1.0, 0.0)]), false, true),
        &path,
        "logarithmic y axis",
    );
    assert_invalid(
        chart(&one("neg", &[(-1.0, 1.0)]), true, false),
        &path,
        "logarithmic x axis",
    );
    assert_invalid(
        chart(
            &one("wide", &[(0.0, -f64::MAX), (1.0, f64::MAX)]),
            false,
            false,
        ),
        &path,
        "too wide",
    );
    // Negative values are fine on a linear axis.
    chart(&one("neg", &[(-1.0, -1.0)]), false, false).unwrap();
    std::fs::remove_file(&path).unwrap();
    let txt = dir.path().join("chart");
    let series = one("ok", &good);
    assert_invalid(
        line_chart(
            &txt,
            &LineChart {
                series: &series,
                ..Default::default()
            },
        ),
        &txt,
        ".png",
    );
}

#[test]
fn unwritable_path_is_a_write_error() {
    let dir = tempfile::tempdir().unwrap();
    let path: PathBuf = dir.path().join("missing").join("chart.png");
    let points = [(1.0, 2.0), (2.0, 3.0)];
    let series = [Series {
        name: "a",
        points: &points,
    }];
    match line_chart(
        &path,
        &LineChart {
            series: &series,
            ..Default::default()
        },
    ) {
        Err(e @ PlotError::Write { .. }) => {
            assert_eq!(e.path(), path);
            let message = e.to_string();
            assert!(
                message.starts_with(&format!("cannot write plot {}: ", path.display())),
                "{message}"
            );
        }
        other => panic!("expected a write error, got {other:?}"),
    }
    let (xs, ys, values) = grid(2, 2);
    assert!(matches!(
        heat_map(&path, &heat(&xs, &ys, &values)),
        Err(PlotError::Write { .. })
    ));
}
