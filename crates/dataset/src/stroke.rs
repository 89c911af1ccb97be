//! Readings outside machine.json's `stroke`.
//!
//! A reading is what an actuator's encoder reported; with the actuator at
//! an end of its stroke it lies beyond that end by its noise only (the
//! repeatability `sigma_a` of `repeatability.actuator`, in the actuators'
//! unit like the stroke and the readings). A reading beyond an end by more
//! than [`STROKE_SIGMAS`] `sigma_a` (a chance of 3e-5 for a reading made at
//! the end) is one the machine cannot have made: the stroke, or the
//! readings' unit or zero, is wrong.

use std::fmt;

use crate::{Dataset, MEASUREMENTS_FILE, POINTS_FILE, POSES_FILE};

/// How many actuator repeatabilities a reading may lie beyond an end of the
/// stroke (module doc).
pub const STROKE_SIGMAS: f64 = 4.0;

/// The first reading outside the stroke (module doc), and how many there
/// are.
#[derive(Debug, Clone, PartialEq)]
pub struct OutsideStroke {
    /// Its file (measurements.csv, poses.csv or points.csv).
    pub file: &'static str,
    /// Its line (the header is line 1).
    pub line: u64,
    /// Its leg (1-based).
    pub leg: usize,
    /// The reading (actuators' unit).
    pub reading: f64,
    /// machine.json's `stroke`.
    pub stroke: [f64; 2],
    /// How far beyond an end a reading may lie ([`STROKE_SIGMAS`]
    /// `sigma_a`).
    pub tolerance: f64,
    /// The actuators' unit.
    pub unit: String,
    /// How many readings of the dataset lie outside.
    pub count: usize,
}

impl fmt::Display for OutsideStroke {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [min, max] = self.stroke;
        write!(
            f,
            "{} line {}: q{} = {} {} is outside machine.json's stroke [{min}, {max}] by more than {STROKE_SIGMAS} actuator repeatabilities ({} {})",
            self.file, self.line, self.leg, self.reading, self.unit, self.tolerance, self.unit
        )?;
        if self.count > 1 {
            write!(f, ", and so are {} more readings", self.count - 1)?;
        }
        write!(
            f,
            ": the machine cannot have made them; check the stroke, and the readings' unit and zero"
        )
    }
}

impl Dataset {
    /// The first reading of measurements.csv, poses.csv then points.csv
    /// outside machine.json's stroke (module doc), or `None` (also without
    /// a stroke).
    pub fn reading_outside_stroke(&self) -> Option<OutsideStroke> {
        let [min, max] = self.machine.stroke?;
        let tolerance = STROKE_SIGMAS * self.machine.repeatability.actuator;
        let outside = |q: &f64| !(min - tolerance..=max + tolerance).contains(q);
        let files = [
            (MEASUREMENTS_FILE, &self.measurements.q),
            (POSES_FILE, &self.tracker.poses.q),
            (POINTS_FILE, &self.tracker.points.q),
        ];
        // Counted over each file's readings as one slice (a loop the
        // compiler vectorises: 6 million readings at 10^6 contacts), and
        // looked for again only when there is one.
        let count: usize = (files.iter())
            .map(|(_, rows)| rows.as_flattened().iter().filter(|q| outside(q)).count())
            .sum();
        if count == 0 {
            return None;
        }
        files.iter().find_map(|(file, rows)| {
            rows.iter().enumerate().find_map(|(row, q)| {
                q.iter().position(outside).map(|i| OutsideStroke {
                    file,
                    line: row as u64 + 2,
                    leg: i + 1,
                    reading: q[i],
                    stroke: [min, max],
                    tolerance,
                    unit: self.machine.actuator.unit.clone(),
                    count,
                })
            })
        })
    }
}
