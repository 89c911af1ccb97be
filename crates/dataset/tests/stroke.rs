//! Readings outside machine.json's stroke: found with their file, line
//! and leg, within the actuator's noise of an end left alone.

use crate::common;

use common::*;
use parcal_dataset::*;

#[test]
fn the_first_reading_outside_the_stroke_is_named_with_its_file_line_and_leg() {
    let mut d = dataset(NONE);
    assert_eq!(
        d.reading_outside_stroke(),
        None,
        "no stroke, nothing outside"
    );
    let readings = || d.measurements.q.iter().flatten().copied();
    let low = readings().fold(f64::INFINITY, f64::min);
    let high = readings().fold(f64::NEG_INFINITY, f64::max);
    let sigma = d.machine.repeatability.actuator;
    // Every reading within the stroke, or beyond it by less than the
    // tolerance of STROKE_SIGMAS actuator repeatabilities.
    let tolerance = STROKE_SIGMAS * sigma;
    d.machine.stroke = Some([low + 0.9 * tolerance, high - 0.9 * tolerance]);
    assert_eq!(d.reading_outside_stroke(), None);
    // Leg 4 of the seventh contact (line 8) pushed past the top.
    d.machine.stroke = Some([low - 1.0, high + 1.0]);
    d.measurements.q[6][3] = high + 1.0 + 1.1 * tolerance;
    d.measurements.q[9][1] = low - 1.0 - 1.1 * tolerance;
    let found = d.reading_outside_stroke().unwrap();
    assert_eq!(
        (found.file, found.line, found.leg, found.count),
        (MEASUREMENTS_FILE, 8, 4, 2)
    );
    let message = found.to_string();
    assert!(
        message.starts_with("measurements.csv line 8: q4 = ")
            && message.contains("is outside machine.json's stroke")
            && message.contains("and so are 1 more readings"),
        "{message}"
    );
}
