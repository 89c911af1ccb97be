//! The report of a mechanism calibration (a linear delta's; any
//! mechanism's calibration.json, [`MechanismCalibrationRecord`]): the
//! verdict and its tests first, then the observations tested, the
//! parameters with their sigmas beside their prior sigmas, and what the
//! data determine; a printer's residuals over the bed, and the histogram
//! of every checked row's normalised residual. Rendered as the calibration report is
//! ([`crate::calibration_report`]'s HTML and Markdown). Every number is
//! the record's or computed from it.

use parcal_calibrate::mechanism::{ObservationKind, ObservationRef};
use parcal_calibrate::reliability::{NORMALISED_BINS, UNCONTROLLED};
use parcal_dataset::mechanism::{BallRecord, MechanismCalibrationRecord, RowCheck, TrackerRecord};
use parcal_dataset::{FrameRecord, Histogram};
use plotters::prelude::*;

use crate::calibration_report::Format;
use crate::calibration_report::document::{Block, Cell, Tone};
use crate::calibration_report::figures::normalised_histogram;
use crate::calibration_report::{html, markdown};
use crate::checks::re_seeded_sentences;
use crate::mechanism_validation::observation_row_place;

/// What a mechanism's dataset adds to the report of its calibration.
#[derive(Debug, Clone, Copy, Default)]
pub struct FromDataset<'a> {
    /// Its probe heights (probes.csv's rows: commanded `x, y` and the
    /// trigger's `z`): circles in the figure of the residuals over the bed.
    pub probes: Option<&'a [[f64; 3]]>,
    /// Its heights measured by hand (heights.csv's rows: a commanded
    /// position `x, y, z` and the height measured there): squares in the
    /// figure of the residuals over the bed.
    pub heights: Option<&'a [[f64; 4]]>,
    /// The true values of a simulated machine, one per parameter of the
    /// calibration, in its order and frame: the parameter table's "true"
    /// and "error / sigma" columns.
    pub truth: Option<&'a [f64]>,
    /// The true frames of its trackers, one per tracker of the
    /// calibration in its order (`None`: not known), from its canonical
    /// frame: the trackers' table's "error / sigma" column.
    pub true_frames: Option<&'a [Option<FrameRecord>]>,
}

/// The report of `calibration`, read from `file`, as `format`, with what
/// its dataset adds (`dataset`).
pub fn render(
    calibration: &MechanismCalibrationRecord,
    file: &str,
    dataset: FromDataset<'_>,
    format: Format,
) -> Result<String, String> {
    let title = format!("Calibration of a {} ({file})", calibration.mechanism);
    let mut blocks = blocks(calibration, &dataset, &title);
    if let Some(figure) = bed_residual_figure(calibration, &dataset)? {
        blocks.push(Block::Heading(2, "Residuals over the bed".into()));
        blocks.push(Block::Figure {
            svg: figure.svg,
            caption: figure.caption,
        });
    }
    if let Some(figure) = normalised_residuals(calibration)? {
        blocks.push(Block::Heading(2, "Normalised residuals".into()));
        blocks.push(figure);
    }
    Ok(match format {
        Format::Html => html::render(&title, &blocks),
        Format::Markdown => markdown::render(&blocks),
    })
}

/// The figure of the residuals over the bed: its SVG and its caption.
#[derive(Debug, Clone, PartialEq)]
pub struct BedFigure {
    /// The SVG, titled with the kinds drawn and each one's largest
    /// `|e / sigma|`.
    pub svg: String,
    /// The caption: the kinds drawn, their markers, each one's largest
    /// `|e / sigma|`.
    pub caption: String,
}

/// How an observation is marked over the bed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Marker {
    /// A circle of radius `size` pixels.
    Circle,
    /// A square of half side `size` pixels.
    Square,
}

impl Marker {
    /// Its name in the caption.
    fn name(self) -> &'static str {
        match self {
            Self::Circle => "circle",
            Self::Square => "square",
        }
    }
}

/// A kind of observation drawn over the bed.
struct BedKind {
    /// The kind.
    kind: ObservationKind,
    /// Its name in the plural.
    plural: &'static str,
    /// Its marker.
    marker: Marker,
    /// The commanded `(x, y)` of each of the dataset's observations of the
    /// kind, by index (none: the dataset gives none).
    commanded: fn(&FromDataset<'_>) -> Vec<(f64, f64)>,
}

/// The kinds drawn over the bed, each with its marker.
const BED_KINDS: [BedKind; 2] = [
    BedKind {
        kind: ObservationKind::Probe,
        plural: "probe heights",
        marker: Marker::Circle,
        commanded: |dataset| commanded_xy(dataset.probes),
    },
    BedKind {
        kind: ObservationKind::ManualHeight,
        plural: "manual heights",
        marker: Marker::Square,
        commanded: |dataset| commanded_xy(dataset.heights),
    },
];

/// The commanded `(x, y)` of each row of `rows` (its first two columns).
fn commanded_xy<const N: usize>(rows: Option<&[[f64; N]]>) -> Vec<(f64, f64)> {
    rows.unwrap_or_default()
        .iter()
        .map(|row| (row[0], row[1]))
        .collect()
}

/// The observations of one kind drawn over the bed.
struct Drawn<'k> {
    /// Their kind.
    kind: &'k BedKind,
    /// Each tested one's commanded `(x, y)` and whitened residual
    /// `e / sigma`.
    tested: Vec<((f64, f64), f64)>,
    /// The commanded `(x, y)` of each one removed by data snooping.
    removed: Vec<(f64, f64)>,
}

impl Drawn<'_> {
    /// The largest `|e / sigma|` of the tested ones, as the figure states
    /// it ("none tested" when every one was removed).
    fn largest(&self) -> String {
        (self.tested.iter())
            .map(|(_, e)| e.abs())
            .reduce(f64::max)
            .map_or_else(|| "none tested".to_string(), |e| format!("{e:.2}"))
    }
}

/// The residuals over the bed (the figure of [`render`]): each probe
/// height's and manual height's whitened residual `e / sigma` at its
/// commanded `(x, y)`, of the kinds `dataset` gives (`None` when it gives
/// neither). An error names an observation of the record that the
/// dataset's rows of its kind do not hold.
pub fn bed_residual_figure(
    calibration: &MechanismCalibrationRecord,
    dataset: &FromDataset<'_>,
) -> Result<Option<BedFigure>, String> {
    let tests = &calibration.tests;
    let mut drawn = Vec::new();
    let mut reach = 1.0;
    for kind in &BED_KINDS {
        let commanded = (kind.commanded)(dataset);
        if commanded.is_empty() {
            continue;
        }
        let name = kind.kind.name();
        let at = |index: usize| {
            commanded.get(index).copied().ok_or_else(|| {
                format!(
                    "{name} {index} is not among the {} {}",
                    commanded.len(),
                    kind.plural
                )
            })
        };
        let tested = (tests.observations.iter())
            .filter(|o| o.kind == name)
            .map(|o| {
                let residual = o.rows.first().map_or(0.0, |r| f64::from(r.residual));
                Ok((at(o.index)?, residual))
            })
            .collect::<Result<Vec<_>, String>>()?;
        let removed = (tests.removed.iter())
            .filter(|r| r.kind == name)
            .map(|r| at(r.index))
            .collect::<Result<Vec<_>, String>>()?;
        reach = (commanded.iter())
            .map(|(x, y)| x.abs().max(y.abs()))
            .fold(reach, f64::max);
        drawn.push(Drawn {
            kind,
            tested,
            removed,
        });
    }
    if drawn.is_empty() {
        return Ok(None);
    }
    let reach = 1.1 * reach;
    // One size rule for every kind: the largest |e / sigma| drawn (at
    // least 1) is the largest marker.
    let largest = (drawn.iter())
        .flat_map(|d| d.tested.iter().map(|(_, e)| e.abs()))
        .fold(1.0, f64::max);
    let title = (drawn.iter())
        .map(|d| format!("{} (largest {})", d.kind.plural, d.largest()))
        .collect::<Vec<_>>()
        .join(", ");
    let title = format!("e / sigma: {title}");
    let markers = (drawn.iter())
        .map(|d| format!("{} ({})", d.kind.kind.name(), d.kind.marker.name()))
        .collect::<Vec<_>>()
        .join(" and each ");
    let largests = (drawn.iter())
        .map(|d| format!("{} {}", d.kind.plural, d.largest()))
        .collect::<Vec<_>>()
        .join(", ");
    let caption = format!(
        "Each {markers} at its commanded XY: filled where the bed is higher than the calibrated machine predicts (positive residual), open where lower; the size grows with |e / sigma| (largest: {largests}); a cross marks one removed by data snooping."
    );
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (640, 600)).into_drawing_area();
        let draw = || -> Result<(), Box<dyn std::error::Error + '_>> {
            root.fill(&WHITE)?;
            let mut chart = ChartBuilder::on(&root)
                .caption(&title, ("sans-serif", 16))
                .margin(15)
                .x_label_area_size(40)
                .y_label_area_size(50)
                .build_cartesian_2d(-reach..reach, -reach..reach)?;
            chart
                .configure_mesh()
                .x_desc("x (mm)")
                .y_desc("y (mm)")
                .draw()?;
            let blue = RGBColor(31, 119, 180);
            let red = RGBColor(214, 39, 40);
            // The last kind first, every filled marker translucent: a probe
            // and a height at one place (the bed's centre) both show.
            for kind in drawn.iter().rev() {
                let markers = kind.tested.iter().map(|&(xy, e)| {
                    let size = (3.0 + 12.0 * e.abs() / largest).round() as i32;
                    let style = if e >= 0.0 {
                        red.mix(0.6).filled()
                    } else {
                        blue.stroke_width(2)
                    };
                    (xy, size, style)
                });
                match kind.kind.marker {
                    Marker::Circle => chart.draw_series(
                        markers.map(|(xy, size, style)| Circle::new(xy, size, style)),
                    )?,
                    Marker::Square => chart.draw_series(markers.map(|(xy, size, style)| {
                        EmptyElement::at(xy) + Rectangle::new([(-size, -size), (size, size)], style)
                    }))?,
                };
            }
            chart.draw_series(
                (drawn.iter())
                    .flat_map(|kind| kind.removed.iter())
                    .map(|&xy| Cross::new(xy, 8, BLACK.stroke_width(2))),
            )?;
            root.present()?;
            Ok(())
        };
        draw().map_err(|e| e.to_string())?;
    }
    Ok(Some(BedFigure { svg, caption }))
}

/// The histogram of every checked row's normalised residual `w_j = e_j /
/// √r_j` ([`RowCheck::normalised`], as calibration.json keeps the row) in
/// the bins of the hexapod's ([`NORMALISED_BINS`]), against the counts a
/// standard normal expects, with the critical value of the w-tests;
/// `None` when no row is checked by another.
fn normalised_residuals(calibration: &MechanismCalibrationRecord) -> Result<Option<Block>, String> {
    let tests = &calibration.tests;
    let w =
        (tests.observations.iter()).flat_map(|o| o.rows.iter().filter_map(RowCheck::normalised));
    let (lower, width, bins) = NORMALISED_BINS;
    let histogram = Histogram::of(w, lower, width, bins);
    if histogram.total() == 0 {
        return Ok(None);
    }
    normalised_histogram(&histogram, tests.critical_value).map(Some)
}

/// The verdict in one sentence: accepted or rejected, and why.
pub fn verdict_sentence(calibration: &MechanismCalibrationRecord) -> String {
    let word = if calibration.accepted {
        "accepted"
    } else {
        "rejected"
    };
    if calibration.reasons.is_empty() {
        format!("Verdict: {word}.")
    } else {
        format!("Verdict: {word}: {}.", calibration.reasons.join("; "))
    }
}

/// The global test in one sentence, or why there is none.
pub fn global_test_sentence(calibration: &MechanismCalibrationRecord) -> String {
    let Some(test) = &calibration.global_test else {
        return "No global test: the run did not converge to a least-squares minimum with redundancy."
            .to_string();
    };
    format!(
        "Global test: the a-posteriori variance factor {:.3} over {} degrees of freedom is {} (interval {:.3} to {:.3} at level {}).",
        test.variance_factor,
        test.redundancy,
        test.outcome,
        test.interval[0],
        test.interval[1],
        test.level
    )
}

/// The w-tests in one sentence: the critical value and the largest
/// normalised residual.
pub fn w_test_sentence(calibration: &MechanismCalibrationRecord) -> String {
    let tests = &calibration.tests;
    let family = match tests.tests {
        Some(family) => format!("{family} tests of {} data rows", tests.data_rows),
        None => format!("{} data rows", tests.data_rows),
    };
    let limit = format!(
        "w-tests: critical value {:.2} (family-wise level {} over {family})",
        tests.critical_value, tests.alpha
    );
    let worst = tests
        .observations
        .iter()
        .filter_map(|o| o.worst().map(|(row, w)| (o, row, w)))
        .max_by(|a, b| a.2.abs().total_cmp(&b.2.abs()));
    match worst {
        Some((observation, row, w)) => format!(
            "{limit}; the largest normalised residual is {w:.2} ({} {}, row {row}), {} the critical value.",
            observation.kind,
            observation.index,
            if w.abs() > tests.critical_value {
                "beyond"
            } else {
                "within"
            }
        ),
        None => format!("{limit}; no row is checked by another."),
    }
}

/// The printable radius the calibration carries from its dataset, and
/// what uses it; `None` when it states none.
pub fn print_radius_sentence(calibration: &MechanismCalibrationRecord) -> Option<String> {
    calibration.print_radius.map(|radius| {
        format!(
            "Printable radius: {radius} mm, the dataset's; compensate keeps targets within it and export writes it back to the firmware."
        )
    })
}

/// The observations tested, one line per kind present; the ball touches'
/// with their observation equation when the record names it.
pub fn observation_counts(calibration: &MechanismCalibrationRecord) -> Vec<String> {
    let mut counts: Vec<(&str, usize)> = Vec::new();
    for observation in calibration.tests.observations.iter() {
        match counts
            .iter_mut()
            .find(|(kind, _)| *kind == observation.kind)
        {
            Some((_, n)) => *n += 1,
            None => counts.push((observation.kind, 1)),
        }
    }
    let equation = calibration
        .observation
        .as_deref()
        .map_or("", touch_equation);
    counted(&counts)
        .into_iter()
        .zip(&counts)
        .map(|(line, &(kind, _))| match kind {
            "ball touch" => format!("{line}{equation}"),
            _ => line,
        })
        .collect()
}

/// How ball touches are observed, from the observation equation's name
/// (`radius`, `coordinates`): " by their radius (eq. 9)", " by their
/// coordinates (eq. 10)"; empty for another name.
pub fn touch_equation(observation: &str) -> &'static str {
    match observation {
        "radius" => " by their radius (eq. 9)",
        "coordinates" => " by their coordinates (eq. 10)",
        _ => "",
    }
}

/// Each `(kind, n)` as "n kinds" ("1 probe height", "3 measured
/// quantities", "2 ball touches").
pub fn counted(counts: &[(&str, usize)]) -> Vec<String> {
    counts
        .iter()
        .map(|&(kind, n)| match (n, kind.strip_suffix('y')) {
            (1, _) => format!("1 {kind}"),
            (_, Some(stem)) => format!("{n} {stem}ies"),
            (_, None) if kind.ends_with("ch") => format!("{n} {kind}es"),
            (_, None) => format!("{n} {kind}s"),
        })
        .collect()
}

/// The parameter table: value, sigma, prior mean and sigma, and their
/// ratio (how much the data narrowed the prior).
///
/// With the `truth` of a simulated machine (one value per parameter, the
/// estimate's frame), two more: the true value and the error of the
/// estimate in its sigmas, `(value - true) / sigma` (`-` for a value the
/// canonical frame fixes, and for a parameter the truth does not hold).
pub fn parameter_rows(
    calibration: &MechanismCalibrationRecord,
    truth: Option<&[f64]>,
) -> Vec<Vec<String>> {
    calibration
        .parameters
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let or_dash = |v: Option<f64>, digits: usize| {
                v.map_or_else(|| "-".to_string(), |v| format!("{v:.digits$}"))
            };
            let mut row = vec![
                p.name.clone(),
                p.unit.clone(),
                format!("{:.4}", p.value),
                or_dash(p.sigma, 4),
                format!("{:.4}", p.prior_mean),
                or_dash(p.prior_sigma, 4),
                or_dash(p.sigma_ratio, 3),
            ];
            if let Some(truth) = truth {
                let value = truth.get(k).copied();
                row.push(or_dash(value, 4));
                // None for a value the canonical frame fixes (sigma 0).
                let sigma = p.sigma.filter(|&sigma| sigma > 0.0);
                let error = value
                    .zip(sigma)
                    .map(|(value, sigma)| (p.value - value) / sigma);
                row.push(or_dash(error, 2));
            }
            row
        })
        .collect()
}

/// The header of [`parameter_rows`], with the truth's columns if `truth`.
pub fn parameter_header(truth: bool) -> Vec<&'static str> {
    let mut header = vec![
        "parameter",
        "unit",
        "value",
        "sigma",
        "prior mean",
        "prior sigma",
        "sigma / prior sigma",
    ];
    if truth {
        header.extend(["true", "error / sigma"]);
    }
    header
}

/// How many calibrated balls a page lists when it does not list them all
/// ([`listed_balls`]).
const LISTED_BALLS: usize = 20;

/// A ball's centre sigma `|σ_c| = √(σ_x² + σ_y² + σ_z²)` (mm), if it has
/// sigmas.
fn centre_sigma(ball: &BallRecord) -> Option<f64> {
    ball.centre_sigma
        .map(|[x, y, z]| (x * x + y * y + z * z).sqrt())
}

/// The balls a page lists, by index: every ball when there are at most 20
/// (`LISTED_BALLS`), else the 20 least determined, of largest centre sigma
/// `|σ_c| = √(σ_x² + σ_y² + σ_z²)` first (a ball without sigmas after every
/// other, ties by index).
pub fn listed_balls(calibration: &MechanismCalibrationRecord) -> Vec<usize> {
    let n = calibration.balls.len();
    if n <= LISTED_BALLS {
        return (0..n).collect();
    }
    let mut keyed: Vec<(f64, usize)> = (calibration.balls.iter().enumerate())
        .map(|(b, ball)| (centre_sigma(ball).unwrap_or(f64::NEG_INFINITY), b))
        .collect();
    keyed.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    keyed
        .into_iter()
        .take(LISTED_BALLS)
        .map(|(_, b)| b)
        .collect()
}

/// What a page that lists some of the balls ([`listed_balls`]) says of
/// them all: how many, the range and median of their centre sigmas
/// `|σ_c|`, and which are listed; none when it lists every ball.
pub fn balls_sentence(calibration: &MechanismCalibrationRecord) -> Option<String> {
    let n = calibration.balls.len();
    if n <= LISTED_BALLS {
        return None;
    }
    let mut sigmas: Vec<f64> = calibration.balls.iter().filter_map(centre_sigma).collect();
    if sigmas.is_empty() {
        return Some(format!(
            "{n} balls calibrated, none with sigmas; listed: the first {LISTED_BALLS}; calibration.json holds every ball."
        ));
    }
    sigmas.sort_by(f64::total_cmp);
    let m = sigmas.len();
    let median = match m % 2 {
        1 => sigmas[m / 2],
        _ => 0.5 * (sigmas[m / 2 - 1] + sigmas[m / 2]),
    };
    let without = match n - m {
        0 => String::new(),
        k => format!(" ({k} without sigmas)"),
    };
    Some(format!(
        "{n} balls calibrated{without}: their centre sigmas |σ_c| (the root sum of squares of the three) run from {:.4} to {:.4} mm, median {median:.4} mm. Listed: the {LISTED_BALLS} of largest |σ_c|, the least determined, largest first; calibration.json holds every ball.",
        sigmas[0],
        sigmas[m - 1],
    ))
}

/// The calibrated balls' table, a row for each ball of `listed` (by
/// index, [`listed_balls`]): centre and its sigmas (the frame of the
/// commanded positions), radius and its sigma (`exact` without one).
pub fn ball_rows(calibration: &MechanismCalibrationRecord, listed: &[usize]) -> Vec<Vec<String>> {
    (listed.iter())
        .map(|&b| {
            let ball = &calibration.balls[b];
            let [x, y, z] = ball.centre;
            let sigmas = ball.centre_sigma.map_or_else(
                || "-".to_string(),
                |[sx, sy, sz]| format!("{sx:.4}, {sy:.4}, {sz:.4}"),
            );
            vec![
                b.to_string(),
                format!("{x:.4}, {y:.4}, {z:.4}"),
                sigmas,
                format!("{:.4}", ball.radius),
                ball.radius_sigma
                    .map_or_else(|| "exact".to_string(), |s| format!("{s:.4}")),
            ]
        })
        .collect()
}

/// The header of [`ball_rows`].
pub const BALL_HEADER: [&str; 5] = [
    "ball",
    "centre (mm)",
    "centre sigmas (mm)",
    "radius (mm)",
    "radius sigma (mm)",
];

/// The trackers' table: each frame's translation and rotation (as a
/// rotation vector, degrees) from the mechanism's canonical frame, and
/// their sigmas; then the body frame the tracker poses saw, if any, from
/// the body's frame to the platform's, as each tracker after which the body
/// was re-mounted saw it and as the others did. With the trackers' true
/// frames (`true_frames`, one per tracker), a last column: each
/// tracker's error in its sigmas ([`frame_error_in_sigmas`]).
pub fn tracker_rows(
    calibration: &MechanismCalibrationRecord,
    true_frames: Option<&[Option<FrameRecord>]>,
) -> Vec<Vec<String>> {
    let error = |k: usize, tracker: &TrackerRecord| {
        let truth = true_frames?;
        let errors = truth
            .get(k)
            .copied()
            .flatten()
            .zip(tracker.sigma)
            .map(|(truth, sigma)| frame_error_in_sigmas(&truth, &tracker.frame, &sigma));
        Some(errors.map_or_else(
            || "-".to_string(),
            |e| {
                format!(
                    "{:.2}, {:.2}, {:.2}; {:.2}, {:.2}, {:.2}",
                    e[0], e[1], e[2], e[3], e[4], e[5]
                )
            },
        ))
    };
    let none = || true_frames.map(|_| "-".to_string());
    let row = |label: &str, frame: &FrameRecord, sigma, error: Option<String>| {
        let mut row = frame_row(label, frame, sigma);
        row.extend(error);
        row
    };
    (calibration.trackers.iter().enumerate())
        .map(|(k, tracker)| {
            row(
                &tracker.label,
                &tracker.frame,
                tracker.sigma,
                error(k, tracker),
            )
        })
        .chain(calibration.trackers.iter().filter_map(|tracker| {
            let body = tracker.body.as_ref()?;
            let label = format!("body seen by {}", tracker.label);
            Some(row(&label, &body.frame, body.sigma, none()))
        }))
        .chain(
            (calibration.body.iter()).map(|body| row(BODY_LABEL, &body.frame, body.sigma, none())),
        )
        .collect()
}

/// A frame's error against its truth in its sigmas: `E = F_true⁻¹ ∘ F`,
/// a rigid motion of the mechanism's canonical frame, its rotation
/// vector's components (rad) and its translation's (mm) each over the
/// sigma of the same correction (`sigma`: rotations about the axes, then
/// translations).
pub fn frame_error_in_sigmas(
    truth: &FrameRecord,
    estimate: &FrameRecord,
    sigma: &[f64; 6],
) -> [f64; 6] {
    let error = truth.isometry().inverse() * estimate.isometry();
    let (rotation, translation) = (error.rotation.scaled_axis(), error.translation.vector);
    std::array::from_fn(|k| {
        let e = if k < 3 {
            rotation[k]
        } else {
            translation[k - 3]
        };
        e / sigma[k]
    })
}

/// The label of the body frame's row in [`tracker_rows`].
pub const BODY_LABEL: &str = "body (on the platform)";

/// A frame's row of [`tracker_rows`].
fn frame_row(label: &str, frame: &FrameRecord, sigma: Option<[f64; 6]>) -> Vec<String> {
    let [x, y, z] = frame.translation;
    let rotation = rotation_vector_degrees(frame.rotation);
    let (rotation_sigmas, translation_sigmas) = sigma.map_or_else(
        || ("-".to_string(), "-".to_string()),
        |s| {
            let degrees = s.map(f64::to_degrees);
            (
                format!("{:.4}, {:.4}, {:.4}", degrees[0], degrees[1], degrees[2]),
                format!("{:.4}, {:.4}, {:.4}", s[3], s[4], s[5]),
            )
        },
    );
    vec![
        label.to_string(),
        format!("{x:.3}, {y:.3}, {z:.3}"),
        translation_sigmas,
        format!("{:.4}, {:.4}, {:.4}", rotation[0], rotation[1], rotation[2]),
        rotation_sigmas,
    ]
}

/// One sentence per re-homed tracker: its actuators' zero offsets.
pub fn tracker_offset_sentences(calibration: &MechanismCalibrationRecord) -> Vec<String> {
    (calibration.trackers.iter())
        .filter(|tracker| !tracker.offsets.is_empty())
        .map(|tracker| {
            let sigmas = tracker.offset_sigmas.as_deref().unwrap_or_default();
            let offsets: Vec<String> = (tracker.offsets.iter().enumerate())
                .map(|(i, offset)| match sigmas.get(i) {
                    Some(sigma) => format!("{offset:.4} ± {sigma:.4}"),
                    None => format!("{offset:.4}"),
                })
                .collect();
            format!(
                "tracker {}: the machine re-homed before it measured; its actuators' zero offsets {}",
                tracker.label,
                offsets.join(", ")
            )
        })
        .collect()
}

/// The header of [`tracker_rows`], with the truth's column if `truth`.
pub fn tracker_header(truth: bool) -> Vec<&'static str> {
    let mut header = vec![
        "tracker",
        "translation (mm)",
        "translation sigmas (mm)",
        "rotation vector (degrees)",
        "rotation sigmas (degrees)",
    ];
    if truth {
        header.push("error / sigma (rotations; translations)");
    }
    header
}

/// The rotation vector of the unit quaternion `[x, y, z, w]`, in degrees.
fn rotation_vector_degrees([x, y, z, w]: [f64; 4]) -> [f64; 3] {
    let sine = (x * x + y * y + z * z).sqrt();
    if sine == 0.0 {
        return [0.0; 3];
    }
    let angle = 2.0 * sine.atan2(w);
    [x, y, z].map(|c| (c / sine * angle).to_degrees())
}

/// The sentence of a Gauss-Newton fit that ran away, when the calibration
/// was made again with Levenberg-Marquardt.
pub fn run_away_sentence(calibration: &MechanismCalibrationRecord) -> Option<String> {
    let cost = |v: Option<f64>| v.map_or_else(|| "not finite".to_string(), |v| format!("{v:.3e}"));
    calibration.gauss_newton.as_ref().map(|run| {
        format!(
            "Gauss-Newton ran away after {} iterations, cost {} -> {} ({}): the calibration was made again with Levenberg-Marquardt",
            run.iterations,
            cost(run.cost[0]),
            cost(run.cost[1]),
            run.status
        )
    })
}

/// One sentence per ball found on the wrong side of its touches and
/// re-seeded, for the first 10, then one counting the others
/// (calibration.json lists every one).
pub fn mirrored_sentences(calibration: &MechanismCalibrationRecord) -> Vec<String> {
    re_seeded_sentences(
        &calibration.mirrored,
        |m| {
            format!(
                "ball {} was on the wrong side of its touches after {} linear solves (chi-square {:.1}; its touches' tool points there fit the mirror image of its centre {:.0} times better): re-seeded there, and the calibration resumed",
                m.ball, m.iteration, m.chi_square, m.gain
            )
        },
        |more| {
            format!(
                "{more} more balls were on the wrong side of their touches and were re-seeded likewise (calibration.json's mirrored lists every one)"
            )
        },
    )
}

/// Row `row` (`None`: all its rows) of observation `index` of the kind
/// the record names `kind`, by its file and line
/// ([`observation_row_place`]), or as the record names it for a kind the
/// report does not know.
fn row_place(
    calibration: &MechanismCalibrationRecord,
    kind: &str,
    index: usize,
    row: Option<usize>,
) -> String {
    let observation = ObservationKind::named(kind).map(|kind| ObservationRef { kind, index });
    match (observation, row) {
        (Some(observation), row) => observation_row_place(&calibration.mechanism, observation, row),
        (None, Some(row)) => format!("{kind} {index} (row {row})"),
        (None, None) => format!("{kind} {index}"),
    }
}

/// How many tests named in one sentence ([`uncontrolled_sentence`]).
const NAMED_TESTS: usize = 10;

/// The tests of redundancy under [`UNCONTROLLED`] (a row's redundancy
/// number; a touch's summed over its rows, which are tested as one,
/// [`ObservationKind::rows_tested_as_one`]), the first ten of
/// them (in the record's order) named: an error there shows in the
/// residuals by less than a tenth of its size, the rest going into the
/// estimates, so its w-test hardly sees it; `None` when every test is
/// controlled.
pub fn uncontrolled_sentence(calibration: &MechanismCalibrationRecord) -> Option<String> {
    let redundancy = |r: &RowCheck| f64::from(r.redundancy);
    let mut tests = 0;
    let mut uncontrolled: Vec<(&str, usize, Option<usize>)> = Vec::new();
    for o in calibration.tests.observations.iter() {
        let as_one =
            ObservationKind::named(o.kind).is_some_and(ObservationKind::rows_tested_as_one);
        if as_one {
            tests += 1;
            if o.rows.iter().map(redundancy).sum::<f64>() < UNCONTROLLED {
                uncontrolled.push((o.kind, o.index, None));
            }
        } else {
            tests += o.rows.len();
            let under = (o.rows.iter().enumerate()).filter(|(_, r)| redundancy(r) < UNCONTROLLED);
            uncontrolled.extend(under.map(|(j, _)| (o.kind, o.index, Some(j))));
        }
    }
    if uncontrolled.is_empty() {
        return None;
    }
    let named: Vec<String> = (uncontrolled.iter().take(NAMED_TESTS))
        .map(|&(kind, index, row)| row_place(calibration, kind, index, row))
        .collect();
    let first = if uncontrolled.len() > NAMED_TESTS {
        format!("the first {NAMED_TESTS}: ")
    } else {
        String::new()
    };
    Some(format!(
        "{} of the {tests} w-tests have a redundancy under {UNCONTROLLED}: an error there shows in the residuals by less than a tenth of its size and goes into the estimates, hardly seen by its test ({first}{}).",
        uncontrolled.len(),
        named.join(", ")
    ))
}

/// One sentence per observation removed by data snooping.
pub fn removal_sentences(calibration: &MechanismCalibrationRecord) -> Vec<String> {
    let factor = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.3}"));
    calibration
        .tests
        .removed
        .iter()
        .map(|r| {
            let place = row_place(calibration, &r.kind, r.index, Some(r.row));
            format!(
                "{place}: normalised residual {:.2}; variance factor {} before, {} after",
                r.normalised,
                factor(r.variance_factor_before),
                factor(r.variance_factor_after)
            )
        })
        .collect()
}

/// Which parameters' priors are correlated and the strongest pair, when
/// the record has a prior correlation (matched sets, propagated
/// tolerances); `None` for independent priors.
pub fn prior_correlation_sentence(calibration: &MechanismCalibrationRecord) -> Option<String> {
    let correlation = calibration.prior_correlation.as_ref()?;
    let name = |k: usize| {
        calibration
            .parameters
            .get(k)
            .map_or("?", |p| p.name.as_str())
    };
    let mut correlated = Vec::new();
    let mut strongest: Option<(usize, usize, f64)> = None;
    for (j, row) in correlation.iter().enumerate() {
        for (k, &c) in row.iter().enumerate() {
            if j == k || c == 0.0 {
                continue;
            }
            if !correlated.contains(&j) {
                correlated.push(j);
            }
            if j < k && strongest.is_none_or(|(_, _, s)| c.abs() > s.abs()) {
                strongest = Some((j, k, c));
            }
        }
    }
    let (a, b, c) = strongest?;
    let names: Vec<&str> = correlated.iter().map(|&k| name(k)).collect();
    Some(format!(
        "The priors of {} of the {} parameters are correlated ({}); the strongest, {} and {}, by {c:.4}.",
        names.len(),
        correlation.len(),
        names.join(", "),
        name(a),
        name(b)
    ))
}

/// The identifiability statements, or why there are none; for a linear
/// delta calibrated without part distances whose undetermined directions
/// involve the rods or the radius, what would determine them.
pub fn identifiability_statements(calibration: &MechanismCalibrationRecord) -> Vec<String> {
    let Some(identifiability) = &calibration.identifiability else {
        return vec!["No covariance: what the data determine is not known.".to_string()];
    };
    let mut lines = identifiability.statements.clone();
    let scale = |name: &str| name.starts_with("diagonal") || name == "radius";
    let scale_undetermined = identifiability
        .undetermined
        .iter()
        .any(|u| u.components.iter().any(|(name, _)| scale(name)));
    let lengths = [
        ObservationKind::Distance.name(),
        ObservationKind::Touch.name(),
    ];
    let has_lengths = calibration
        .tests
        .observations
        .iter()
        .any(|o| lengths.contains(&o.kind));
    if calibration.mechanism == "linear delta" && scale_undetermined && !has_lengths {
        lines.push(
            "Probe heights see Z, hardly the XY scale: distances measured on a printed part (distances.csv) or touches of calibrated balls (balls.csv, touches.csv) determine the diagonal rods and the radius.".to_string(),
        );
    }
    lines
}

/// The report's blocks.
fn blocks(
    calibration: &MechanismCalibrationRecord,
    dataset: &FromDataset<'_>,
    title: &str,
) -> Vec<Block> {
    let truth = dataset.truth;
    let tone = if calibration.accepted {
        Tone::Accepted
    } else {
        Tone::Rejected
    };
    let mut blocks = vec![
        Block::Heading(1, title.to_string()),
        Block::Paragraph(tone, verdict_sentence(calibration)),
        Block::Heading(2, "Tests".into()),
        Block::Paragraph(Tone::Plain, global_test_sentence(calibration)),
        Block::Paragraph(Tone::Plain, w_test_sentence(calibration)),
    ];
    if let Some(sentence) = uncontrolled_sentence(calibration) {
        blocks.push(Block::Paragraph(Tone::Warning, sentence));
    }
    blocks.push(Block::Paragraph(
        Tone::Plain,
        format!(
            "Solver: {} after {} linear solves.",
            calibration.status, calibration.iterations
        ),
    ));
    if let Some(sentence) = print_radius_sentence(calibration) {
        blocks.push(Block::Paragraph(Tone::Plain, sentence));
    }
    if let Some(sentence) = run_away_sentence(calibration) {
        blocks.push(Block::Paragraph(Tone::Warning, sentence));
    }
    if !calibration.mirrored.is_empty() {
        blocks.push(Block::Heading(3, "Balls re-seeded".into()));
        blocks.push(Block::List(Tone::Warning, mirrored_sentences(calibration)));
    }
    if !calibration.tests.removed.is_empty() {
        blocks.push(Block::Heading(3, "Removed by data snooping".into()));
        blocks.push(Block::List(Tone::Warning, removal_sentences(calibration)));
    }
    if let Some(why) = &calibration.tests.snooping_stopped {
        blocks.push(Block::Paragraph(Tone::Warning, why.clone()));
    }
    if !calibration.warnings.is_empty() {
        blocks.push(Block::Heading(3, "Warnings".into()));
        blocks.push(Block::List(Tone::Warning, calibration.warnings.clone()));
    }
    blocks.push(Block::Heading(2, "Observations tested".into()));
    blocks.push(Block::List(Tone::Plain, observation_counts(calibration)));
    blocks.push(Block::Heading(2, "Parameters (canonical frame)".into()));
    let ratios_flag = |row: &[String]| row[6].parse::<f64>().is_ok_and(|r| r >= 0.9);
    blocks.push(Block::Table {
        header: (parameter_header(truth.is_some()).iter())
            .map(|s| s.to_string())
            .collect(),
        rows: parameter_rows(calibration, truth)
            .into_iter()
            .map(|row| {
                let prior_only = ratios_flag(&row);
                row.into_iter()
                    .enumerate()
                    .map(|(k, text)| {
                        if k < 2 {
                            Cell::text(text)
                        } else {
                            Cell::number(text).flagged(k == 6 && prior_only)
                        }
                    })
                    .collect()
            })
            .collect(),
    });
    blocks.push(Block::Paragraph(
        Tone::Note,
        "A ratio sigma / prior sigma near 1 (flagged from 0.9) marks a parameter the data hardly inform: its value is its prior's.".into(),
    ));
    if let Some(sentence) = prior_correlation_sentence(calibration) {
        blocks.push(Block::Paragraph(Tone::Note, sentence));
    }
    if !calibration.balls.is_empty() {
        blocks.push(Block::Heading(2, "Calibrated balls".into()));
        if let Some(sentence) = balls_sentence(calibration) {
            blocks.push(Block::Paragraph(Tone::Plain, sentence));
        }
        blocks.push(Block::Table {
            header: BALL_HEADER.iter().map(|s| s.to_string()).collect(),
            rows: ball_rows(calibration, &listed_balls(calibration))
                .into_iter()
                .map(|row| row.into_iter().map(Cell::text).collect())
                .collect(),
        });
    }
    if !calibration.trackers.is_empty() {
        blocks.push(Block::Heading(2, "Trackers".into()));
        blocks.push(Block::Table {
            header: (tracker_header(dataset.true_frames.is_some()).iter())
                .map(|s| s.to_string())
                .collect(),
            rows: tracker_rows(calibration, dataset.true_frames)
                .into_iter()
                .map(|row| row.into_iter().map(Cell::text).collect())
                .collect(),
        });
        blocks.push(Block::Paragraph(
            Tone::Note,
            "Each tracker's frame maps the mechanism's canonical frame to the tracker's (x_tracker = R x + t); its sigmas are of rotations about the mechanism's axes and of translations along them.".into(),
        ));
        if dataset.true_frames.is_some() {
            blocks.push(Block::Paragraph(
                Tone::Note,
                "A simulated tracker's error is the rotation vector (rad) and translation (mm) of F_true⁻¹ ∘ F, a motion of the canonical frame, each over its sigma.".into(),
            ));
        }
        if calibration.body.is_some() {
            blocks.push(Block::Paragraph(
                Tone::Note,
                format!("The {BODY_LABEL}'s frame, which the tracker poses measured, maps the body's frame to the platform's (x_platform = R x + t)."),
            ));
        }
        let offsets = tracker_offset_sentences(calibration);
        if !offsets.is_empty() {
            blocks.push(Block::List(Tone::Plain, offsets));
        }
    }
    blocks.push(Block::Heading(2, "What the data determine".into()));
    blocks.push(Block::List(
        Tone::Plain,
        identifiability_statements(calibration),
    ));
    blocks
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::checks::NAMED_MIRRORED;
    use parcal_calibrate::mechanism::{MechanismData, MechanismOptions, calibrate_mechanism};
    use parcal_dataset::mechanism::{
        MechanismDataset, MechanismMachine, MechanismTruth, MirroredRecord, Noise,
        ObservationRecords, ValuePrior,
    };
    use parcal_kinematics::delta::{LinearDelta, probe_rings};

    /// A printer exactly as configured, probed on 3 rings of 8 (25
    /// probes), one probe 0.3 mm off, calibrated with snooping.
    fn calibrated() -> (MechanismCalibrationRecord, Vec<[f64; 3]>) {
        let dataset = printer();
        let data = MechanismData::from_dataset(&dataset).unwrap();
        let options = MechanismOptions::default().with_snooping(true);
        (
            calibrate_mechanism(&data, &options, &mut |_| {})
                .unwrap()
                .record(),
            dataset.probes,
        )
    }

    /// The dataset of [`calibrated`].
    fn printer() -> MechanismDataset {
        let delta = LinearDelta::typical();
        let mut machine = MechanismMachine::of(&delta);
        machine.noise = Noise {
            probe: Some(0.01),
            ..Noise::default()
        };
        machine.trigger_height = Some(ValuePrior {
            value: 0.7,
            sigma: Some(0.05),
        });
        let mut probes: Vec<[f64; 3]> = probe_rings(100.0, 3, 8)
            .into_iter()
            .map(|[x, y]| [x, y, 0.7])
            .collect();
        probes[5][2] += 0.3;
        MechanismDataset {
            machine,
            probes,
            ..MechanismDataset::default()
        }
    }

    /// What the dataset of `probes` adds: the probes alone.
    fn with_probes(probes: &[[f64; 3]]) -> FromDataset<'_> {
        FromDataset {
            probes: Some(probes),
            heights: None,
            truth: None,
            true_frames: None,
        }
    }

    /// The report of `record` with the dataset's `probes`, as `format`.
    fn rendered(
        record: &MechanismCalibrationRecord,
        probes: &[[f64; 3]],
        format: Format,
    ) -> String {
        render(record, "calibration.json", with_probes(probes), format).unwrap()
    }

    /// Past [`NAMED_MIRRORED`] re-seeded balls, one sentence counts the
    /// rest; up to it, each has its own.
    #[test]
    fn many_re_seeded_balls_are_named_up_to_a_bound_and_the_rest_counted() {
        let (mut record, _) = calibrated();
        let mirrored = |n: usize| {
            (0..n)
                .map(|ball| MirroredRecord {
                    ball,
                    iteration: 2,
                    chi_square: 40.0,
                    gain: 9.0,
                    centre: [0.0; 3],
                })
                .collect()
        };
        record.mirrored = mirrored(NAMED_MIRRORED);
        let sentences = mirrored_sentences(&record);
        assert_eq!(sentences.len(), NAMED_MIRRORED);
        assert!(sentences.iter().all(|s| s.starts_with("ball ")));
        record.mirrored = mirrored(NAMED_MIRRORED + 2);
        let sentences = mirrored_sentences(&record);
        assert_eq!(sentences.len(), NAMED_MIRRORED + 1);
        assert!(
            sentences[NAMED_MIRRORED - 1].starts_with(&format!("ball {} ", NAMED_MIRRORED - 1))
        );
        assert!(
            sentences[NAMED_MIRRORED].starts_with("2 more balls were on the wrong side"),
            "{}",
            sentences[NAMED_MIRRORED]
        );
    }

    #[test]
    fn a_page_of_many_balls_lists_the_least_determined_and_sums_up_the_rest() {
        // 25 balls of centre sigmas |σ_c| 0.01, 0.02, ..., 0.25 mm and one
        // without sigmas: the page lists the 20 of largest |σ_c| (balls 24
        // down to 5) and states the range and median of all 25.
        let (mut record, probes) = calibrated();
        record.balls = (0..26)
            .map(|b| BallRecord {
                centre: [b as f64, 0.0, 12.7],
                centre_sigma: (b < 25).then(|| [0.01 * (b + 1) as f64, 0.0, 0.0]),
                radius: 12.7,
                radius_sigma: None,
            })
            .collect();
        let markdown = rendered(&record, &probes, Format::Markdown);
        let start = markdown
            .find("## Calibrated balls")
            .expect("the balls' section");
        let balls = &markdown[start..];
        let balls = &balls[..balls.find("\n## ").unwrap_or(balls.len())];
        let sentence = balls_sentence(&record).expect("a sentence on all the balls");
        assert!(
            sentence.starts_with(
                "26 balls calibrated (1 without sigmas): their centre sigmas |σ_c| (the root sum of squares of the three) run from 0.0100 to 0.2500 mm, median 0.1300 mm. Listed: the 20 of largest |σ_c|"
            ),
            "{sentence}"
        );
        assert!(balls.contains("26 balls calibrated"), "{balls}");
        let listed: Vec<&str> = (balls.lines())
            .filter_map(|line| line.strip_prefix("| ")?.split(' ').next())
            .filter(|first| first.parse::<usize>().is_ok())
            .collect();
        let expected: Vec<String> = (5..25).rev().map(|b| b.to_string()).collect();
        assert_eq!(listed, expected, "{balls}");
        // At most LISTED_BALLS balls: every one, in order, and no sentence.
        record.balls.truncate(LISTED_BALLS);
        assert_eq!(listed_balls(&record), (0..LISTED_BALLS).collect::<Vec<_>>());
        assert_eq!(balls_sentence(&record), None);
    }

    #[test]
    fn a_simulated_machines_truth_is_set_beside_each_parameter() {
        // The printer is the configured one, its trigger 0.7 mm: the
        // truth's columns give it and each estimate's error in its sigmas.
        let (record, probes) = calibrated();
        let delta = LinearDelta::typical();
        let truth = MechanismTruth {
            parameters: parcal_kinematics::mechanism::design(&delta)
                .as_slice()
                .to_vec(),
            trigger_height: Some(0.7),
            trackers: std::collections::BTreeMap::new(),
        };
        let data = MechanismData::from_dataset(&printer()).unwrap();
        let truth = data.true_values(&truth).unwrap();
        assert_eq!(truth.len(), record.parameters.len());
        let rows = parameter_rows(&record, Some(&truth));
        let header = parameter_header(true);
        for ((row, parameter), value) in rows.iter().zip(&record.parameters).zip(&truth) {
            assert_eq!(row.len(), header.len());
            assert_eq!(row[7], format!("{value:.4}"));
            match parameter.sigma.unwrap() {
                // Fixed by the canonical frame, at the truth's value there.
                0.0 => {
                    assert_eq!(row[8], "-");
                    assert!((parameter.value - value).abs() < 1e-9, "{}", parameter.name);
                }
                sigma => {
                    let error = (parameter.value - value) / sigma;
                    assert_eq!(row[8], format!("{error:.2}"));
                }
            }
        }
        let dataset = FromDataset {
            probes: Some(&probes),
            heights: None,
            truth: Some(&truth),
            true_frames: None,
        };
        let markdown = render(&record, "calibration.json", dataset, Format::Markdown).unwrap();
        assert!(markdown.contains("| true | error / sigma |"), "{markdown}");
        let without = rendered(&record, &probes, Format::Markdown);
        assert!(!without.contains("error / sigma"));
    }

    #[test]
    fn the_report_states_the_tests_parameters_and_what_determines_them() {
        let (record, probes) = calibrated();
        let markdown = rendered(&record, &probes, Format::Markdown);
        assert!(
            markdown.contains("# Calibration of a linear delta"),
            "{markdown}"
        );
        assert!(markdown.contains("Removed by data snooping"), "{markdown}");
        assert!(
            markdown.contains("probes.csv line 7 (probe height 5, row 0)"),
            "{markdown}"
        );
        assert!(markdown.contains("| diagonal\\_a | mm |"), "{markdown}");
        assert!(markdown.contains("24 probe heights"), "{markdown}");
        assert!(!markdown.contains("Printable radius"), "{markdown}");
        let within = MechanismCalibrationRecord {
            print_radius: Some(85.0),
            ..record.clone()
        };
        let stated = rendered(&within, &probes, Format::Markdown);
        assert!(
            stated.contains("Printable radius: 85 mm, the dataset's"),
            "{stated}"
        );
        // Probe heights alone: the rods' scale is the prior's, and the
        // report says what would determine it.
        assert!(
            markdown.contains("distances measured on a printed part"),
            "{markdown}"
        );
        let html = rendered(&record, &probes, Format::Html);
        // One circle per probe tested, a cross for the one removed.
        assert_eq!(html.matches("<circle").count(), 24, "circles");
        // A record's probe that the probes given do not hold is named.
        let err = bed_residual_figure(&record, &with_probes(&probes[..3])).unwrap_err();
        assert!(err.contains("is not among the 3 probe heights"), "{err}");
        assert!(!markdown.contains("Calibrated balls"), "{markdown}");
        // A record with a ball: its table.
        let mut record = record;
        record.balls.push(parcal_dataset::mechanism::BallRecord {
            centre: [60.0, 0.0, 12.7],
            centre_sigma: Some([0.5, 0.6, 0.05]),
            radius: 12.7,
            radius_sigma: None,
        });
        let markdown = rendered(&record, &probes, Format::Markdown);
        assert!(markdown.contains("## Calibrated balls"), "{markdown}");
        assert!(markdown.contains("60.0000, 0.0000, 12.7000"), "{markdown}");
        assert!(markdown.contains("exact"), "{markdown}");
        assert!(!markdown.contains("## Trackers"), "{markdown}");
        // A record with a tracker turned a quarter turn about z.
        let half = std::f64::consts::FRAC_PI_4;
        record
            .trackers
            .push(parcal_dataset::mechanism::TrackerRecord {
                label: "left".to_string(),
                frame: parcal_dataset::FrameRecord {
                    translation: [1200.0, -300.0, 150.0],
                    rotation: [0.0, 0.0, half.sin(), half.cos()],
                },
                sigma: Some([1e-4, 2e-4, 3e-4, 0.01, 0.02, 0.03]),
                offsets: Vec::new(),
                offset_sigmas: None,
                body: None,
            });
        let markdown = rendered(&record, &probes, Format::Markdown);
        assert!(markdown.contains("## Trackers"), "{markdown}");
        assert!(!markdown.contains("re-homed"), "{markdown}");
        record.trackers[0].offsets = vec![0.25, -0.125, 0.5];
        record.trackers[0].offset_sigmas = Some(vec![0.0625; 3]);
        let markdown = rendered(&record, &probes, Format::Markdown);
        assert!(markdown.contains("tracker left: the machine re-homed before it measured; its actuators' zero offsets 0.2500 ± 0.0625, -0.1250 ± 0.0625, 0.5000 ± 0.0625"), "{markdown}");
        assert!(markdown.contains("| left | 1200.000, -300.000, 150.000 | 0.0100, 0.0200, 0.0300 | 0.0000, 0.0000, 90.0000 | 0.0057, 0.0115, 0.0172 |"), "{markdown}");
        // The body as a tracker saw it after it was moved, without sigmas.
        record.trackers[0].body = Some(parcal_dataset::mechanism::BodyRecord {
            frame: parcal_dataset::FrameRecord {
                translation: [1.0, 2.0, 3.0],
                rotation: [0.0, 0.0, 0.0, 1.0],
            },
            sigma: None,
        });
        let markdown = rendered(&record, &probes, Format::Markdown);
        assert!(
            markdown.contains(
                "| body seen by left | 1.000, 2.000, 3.000 | - | 0.0000, 0.0000, 0.0000 | - |"
            ),
            "{markdown}"
        );
    }

    /// Five heights measured by hand 5 mm above the bed of the printer of
    /// [`printer`]: with its probes and the fourth height measured 0.3 mm
    /// high if `probed`, else alone and exact (no probe on the machine).
    /// Calibrated with snooping.
    fn measured_by_hand(probed: bool) -> (MechanismCalibrationRecord, MechanismDataset) {
        let mut dataset = printer();
        dataset.machine.noise.height = Some(0.01);
        dataset.heights = [
            [0.0, 0.0],
            [60.0, 0.0],
            [0.0, 60.0],
            [-60.0, 0.0],
            [0.0, -60.0],
        ]
        .into_iter()
        .map(|[x, y]| [x, y, 5.0, 5.0])
        .collect();
        if probed {
            dataset.heights[3][3] += 0.3;
        } else {
            dataset.probes.clear();
            dataset.machine.trigger_height = None;
        }
        let data = MechanismData::from_dataset(&dataset).unwrap();
        let options = MechanismOptions::default().with_snooping(true);
        let record = calibrate_mechanism(&data, &options, &mut |_| {})
            .unwrap()
            .record();
        (record, dataset)
    }

    /// What `dataset` adds: its probes and heights.
    fn bed_of(dataset: &MechanismDataset) -> FromDataset<'_> {
        FromDataset {
            probes: Some(&dataset.probes),
            heights: Some(&dataset.heights),
            truth: None,
            true_frames: None,
        }
    }

    /// The markers of `svg` drawn in the residuals' colours: `element`s
    /// (`"<circle"`, `"<rect"`) filled red or stroked blue.
    fn markers(svg: &str, element: &str) -> usize {
        (svg.lines())
            .filter(|line| line.trim_start().starts_with(element))
            .filter(|line| line.contains("#D62728") || line.contains("#1F77B4"))
            .count()
    }

    /// The part of the page `html` from the heading `heading` to the next
    /// heading of its level.
    fn section<'h>(html: &'h str, heading: &str) -> &'h str {
        let start = html
            .find(&format!(">{heading}</h2>"))
            .unwrap_or_else(|| panic!("no section {heading}: {html}"));
        let rest = &html[start..];
        rest.find("<h2").map_or(rest, |end| &rest[..end])
    }

    #[test]
    fn every_checked_row_is_in_the_histogram_of_normalised_residuals() {
        let (mut record, probes) = calibrated();
        let checked = (record.tests.observations.iter())
            .flat_map(|o| o.rows.iter().filter_map(RowCheck::normalised))
            .count();
        assert!(checked > 20, "{checked}");
        let html = rendered(&record, &probes, Format::Html);
        let figure = section(&html, "Normalised residuals");
        assert!(
            figure.contains(&format!(
                "Normalised residuals of the {checked} checked residual rows (bins of 0.25)"
            )) && figure.contains(&format!(
                "dashed: the critical value ±{:.2}",
                record.tests.critical_value
            )),
            "{figure}"
        );
        let markdown = rendered(&record, &probes, Format::Markdown);
        assert_eq!(markdown.matches("## Normalised residuals").count(), 1);
        // No row checked by another: no histogram.
        with_redundancies(&mut record, |_| 0.0);
        let html = rendered(&record, &probes, Format::Html);
        assert!(!html.contains("Normalised residuals"), "{html}");
    }

    /// `record`'s observations as they are, each row's redundancy number
    /// `redundancy(k)` (`k` counting the rows in order), its residual 1.
    fn with_redundancies(
        record: &mut MechanismCalibrationRecord,
        redundancy: impl Fn(usize) -> f32,
    ) {
        let observations: Vec<(String, usize, usize)> = (record.tests.observations.iter())
            .map(|o| (o.kind.to_string(), o.index, o.rows.len()))
            .collect();
        let rows = observations.iter().map(|o| o.2).sum();
        let checks = (0..rows)
            .map(|k| RowCheck {
                residual: 1.0,
                redundancy: redundancy(k),
            })
            .collect();
        let mut records = ObservationRecords::of_rows(checks);
        for (kind, index, rows) in observations {
            assert!(records.push(kind.into(), index, rows));
        }
        record.tests.observations = records;
    }

    #[test]
    fn tests_of_redundancy_under_a_tenth_are_counted_and_the_first_named() {
        let (mut record, probes) = calibrated();
        // The run's own: as many as the record holds under 0.1 (a probe
        // height is one row, tested alone).
        let rows: Vec<f32> = (record.tests.observations.iter())
            .flat_map(|o| o.rows.iter().map(|r| r.redundancy))
            .collect();
        let under = rows.iter().filter(|&&r| f64::from(r) < 0.1).count();
        let stated = uncontrolled_sentence(&record);
        match under {
            0 => assert_eq!(stated, None),
            n => assert!(
                stated
                    .unwrap()
                    .starts_with(&format!("{n} of the {} w-tests", rows.len()))
            ),
        }
        // Twelve under it: ten named, in order, from the first probe's
        // line on.
        with_redundancies(&mut record, |k| if k < 12 { 0.05 } else { 0.5 });
        // (Probe height 5 was removed by snooping: not among the rows.)
        let sentence = uncontrolled_sentence(&record).unwrap();
        let named: Vec<String> = [0, 1, 2, 3, 4, 6, 7, 8, 9, 10]
            .iter()
            .map(|k| format!("probes.csv line {} (probe height {k}, row 0)", k + 2))
            .collect();
        assert_eq!(
            sentence,
            format!(
                "12 of the {} w-tests have a redundancy under 0.1: an error there shows in the residuals by less than a tenth of its size and goes into the estimates, hardly seen by its test (the first 10: {}).",
                rows.len(),
                named.join(", ")
            )
        );
        let html = rendered(&record, &probes, Format::Html);
        assert!(html.contains(&sentence), "{html}");
        // None under it: no sentence.
        with_redundancies(&mut record, |_| 0.1);
        assert_eq!(uncontrolled_sentence(&record), None);
        // A touch's rows are one test, of their summed redundancy: 0.09
        // is under 0.1, 0.12 is not, though each of its rows is.
        let redundancies = [0.02, 0.03, 0.04, 0.02, 0.05, 0.05, 0.05];
        let checks = (redundancies.iter())
            .map(|&redundancy| RowCheck {
                residual: 1.0,
                redundancy,
            })
            .collect();
        let mut touched = ObservationRecords::of_rows(checks);
        assert!(touched.push("ball touch".into(), 0, 3));
        assert!(touched.push("ball touch".into(), 1, 3));
        assert!(touched.push("probe height".into(), 0, 1));
        record.tests.observations = touched;
        let touch = ObservationRef {
            kind: ObservationKind::Touch,
            index: 0,
        };
        assert_eq!(
            uncontrolled_sentence(&record).unwrap(),
            format!(
                "2 of the 3 w-tests have a redundancy under 0.1: an error there shows in the residuals by less than a tenth of its size and goes into the estimates, hardly seen by its test ({}, probes.csv line 2 (probe height 0, row 0)).",
                observation_row_place(&record.mechanism, touch, None)
            )
        );
    }

    /// The crosses of `svg`: black lines 2 wide, two per cross.
    fn crosses(svg: &str) -> usize {
        (svg.lines())
            .filter(|line| {
                line.trim_start().starts_with("<line") || line.trim_start().starts_with("<polyline")
            })
            .filter(|line| {
                line.contains("stroke=\"#000000\"") && line.contains("stroke-width=\"2\"")
            })
            .count()
            / 2
    }

    #[test]
    fn the_bed_figure_draws_manual_heights_beside_the_probes() {
        let (record, dataset) = measured_by_hand(true);
        let removed: Vec<(&str, usize)> = (record.tests.removed.iter())
            .map(|r| (r.kind.as_str(), r.index))
            .collect();
        assert_eq!(removed, [("probe height", 5), ("manual height", 3)]);
        let figure = bed_residual_figure(&record, &bed_of(&dataset))
            .unwrap()
            .unwrap();
        // One circle per probe and one square per height tested, a cross
        // for each one removed.
        assert_eq!(markers(&figure.svg, "<circle"), 24, "{}", figure.svg);
        assert_eq!(markers(&figure.svg, "<rect"), 4, "{}", figure.svg);
        assert_eq!(crosses(&figure.svg), 2, "{}", figure.svg);
        // Title and caption name both kinds, with each one's largest.
        let largest = |kind: &str| {
            (record.tests.observations.iter())
                .filter(|o| o.kind == kind)
                .map(|o| f64::from(o.rows[0].residual).abs())
                .fold(0.0, f64::max)
        };
        let (probe, manual) = (largest("probe height"), largest("manual height"));
        assert!(
            figure.svg.contains(&format!(
                "e / sigma: probe heights (largest {probe:.2}), manual heights (largest {manual:.2})"
            )),
            "{}",
            figure.svg
        );
        let markdown = render(
            &record,
            "calibration.json",
            bed_of(&dataset),
            Format::Markdown,
        )
        .unwrap();
        assert!(
            markdown.contains(
                "Each probe height (circle) and each manual height (square) at its commanded XY"
            ) && markdown.contains(&format!(
                "(largest: probe heights {probe:.2}, manual heights {manual:.2})"
            )),
            "{markdown}"
        );
        assert_eq!(markdown.matches("## Residuals over the bed").count(), 1);
        // The probes alone: no square, their caption alone.
        let probes = bed_residual_figure(&record, &with_probes(&dataset.probes))
            .unwrap()
            .unwrap();
        assert_eq!(markers(&probes.svg, "<rect"), 0);
        assert_eq!(crosses(&probes.svg), 1);
        assert!(
            probes
                .caption
                .starts_with("Each probe height (circle) at its")
                && !probes.caption.contains("manual"),
            "{}",
            probes.caption
        );
        // A record's height that the heights given do not hold is named.
        let two = FromDataset {
            heights: Some(&dataset.heights[..2]),
            ..bed_of(&dataset)
        };
        let err = render(&record, "calibration.json", two, Format::Html).unwrap_err();
        assert_eq!(err, "manual height 2 is not among the 2 manual heights");
    }

    #[test]
    fn a_dataset_of_heights_alone_gets_the_bed_figure() {
        let (record, dataset) = measured_by_hand(false);
        let html = render(&record, "calibration.json", bed_of(&dataset), Format::Html).unwrap();
        let bed = section(&html, "Residuals over the bed");
        assert_eq!(markers(bed, "<rect"), 5, "{html}");
        assert_eq!(markers(bed, "<circle"), 0, "{html}");
        assert_eq!(crosses(bed), 0, "{html}");
        assert!(
            html.contains("e / sigma: manual heights (largest ")
                && html.contains("Each manual height (square) at its commanded XY")
                && !html.contains("probe heights ("),
            "{html}"
        );
        // Without the dataset's heights, no figure.
        let bare = render(
            &record,
            "calibration.json",
            FromDataset::default(),
            Format::Html,
        )
        .unwrap();
        assert!(!bare.contains("Residuals over the bed"), "{bare}");
    }

    #[test]
    fn a_simulated_trackers_error_is_given_in_its_sigmas() {
        // Tracker "left" estimated at F_true ∘ E, E turning the canonical
        // frame by 2 sigmas about z and moving it by 3 sigmas along x and
        // -1.5 along z; "right" without a truth: its error unknown, as the
        // body's rows always are.
        use nalgebra::{Isometry3, Vector3};
        let truth = Isometry3::new(
            Vector3::new(1200.0, -300.0, 150.0),
            Vector3::new(0.1, -0.2, 2.5),
        );
        let sigma = [1e-4, 1e-4, 1e-4, 0.01, 0.01, 0.02];
        let error = Isometry3::new(Vector3::new(0.03, 0.0, -0.03), Vector3::new(0.0, 0.0, 2e-4));
        let tracker = |label: &str, frame: &Isometry3<f64>| TrackerRecord {
            label: label.to_string(),
            frame: FrameRecord::of(frame),
            sigma: Some(sigma),
            offsets: Vec::new(),
            offset_sigmas: None,
            body: None,
        };
        let (mut record, probes) = calibrated();
        record.trackers = vec![tracker("left", &(truth * error)), tracker("right", &truth)];
        record.body = Some(parcal_dataset::mechanism::BodyRecord {
            frame: FrameRecord::IDENTITY,
            sigma: None,
        });
        let true_frames = [Some(FrameRecord::of(&truth)), None];
        let rows = tracker_rows(&record, Some(&true_frames));
        assert_eq!(rows.len(), 3);
        assert_eq!(rows[0][5], "0.00, 0.00, 2.00; 3.00, 0.00, -1.50");
        assert_eq!((rows[1][5].as_str(), rows[2][5].as_str()), ("-", "-"));
        assert!(tracker_rows(&record, None).iter().all(|row| row.len() == 5));
        let dataset = FromDataset {
            probes: Some(&probes),
            heights: None,
            truth: None,
            true_frames: Some(&true_frames),
        };
        let markdown = render(&record, "calibration.json", dataset, Format::Markdown).unwrap();
        assert!(
            markdown.contains("| error / sigma (rotations; translations) |")
                && markdown.contains("A simulated tracker's error is"),
            "{markdown}"
        );
    }
}
