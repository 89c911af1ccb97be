//! Accuracy maps and their summaries.

use std::fmt;

use crate::MapGrid;

/// One accuracy map: a length per grid point (mm), absolute (in the
/// canonical base frame) and registered (after the best rigid motion of the
/// whole grid). Values are in map order: `values[iy * grid.xs.len() + ix]`.
#[derive(Debug, Clone, PartialEq)]
pub struct AccuracyMap {
    /// The grid the map is on.
    pub grid: MapGrid,
    /// Absolute error per point (mm): `sqrt(trace)` of the tip covariance
    /// (predicted) or `|true tip - target|` (true).
    pub absolute: Vec<f64>,
    /// Error per point after registration (mm).
    pub registered: Vec<f64>,
}

impl AccuracyMap {
    /// Index of grid point `(ix, iy)` in the value vectors.
    pub fn index(&self, ix: usize, iy: usize) -> usize {
        iy * self.grid.xs.len() + ix
    }

    /// RMS and maximum of the absolute map.
    pub fn absolute_summary(&self) -> MapSummary {
        MapSummary::of(&self.absolute)
    }

    /// RMS and maximum of the registered map.
    pub fn registered_summary(&self) -> MapSummary {
        MapSummary::of(&self.registered)
    }
}

impl fmt::Display for AccuracyMap {
    /// One line: `absolute RMS .. um, max .. um; registered RMS .. um, max .. um`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "absolute {}; registered {}",
            self.absolute_summary(),
            self.registered_summary()
        )
    }
}

/// RMS and maximum of a map (mm).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MapSummary {
    /// Root mean square over the grid points (mm).
    pub rms: f64,
    /// Largest value (mm).
    pub max: f64,
}

impl MapSummary {
    /// Summary of a map's values (mm); zeros for an empty map.
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Self { rms: 0.0, max: 0.0 };
        }
        let mean_square = values.iter().map(|v| v * v).sum::<f64>() / values.len() as f64;
        Self {
            rms: mean_square.sqrt(),
            max: values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
}

impl fmt::Display for MapSummary {
    /// In micrometres: `RMS 97.3 um, max 210.4 um`.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "RMS {:.1} um, max {:.1} um",
            1e3 * self.rms,
            1e3 * self.max
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn summary_is_rms_and_max_shown_in_micrometres() {
        let summary = MapSummary::of(&[0.003, 0.004]);
        assert!((summary.rms - (12.5e-6f64).sqrt()).abs() < 1e-15);
        assert_eq!(summary.max, 0.004);
        assert_eq!(summary.to_string(), "RMS 3.5 um, max 4.0 um");
        let grid = MapGrid::square(10.0, 10.0, 400.0);
        let map = AccuracyMap {
            absolute: (0..9).map(|k| k as f64 * 1e-3).collect(),
            registered: vec![1e-3; 9],
            grid,
        };
        assert_eq!(map.absolute[map.index(2, 1)], 5e-3);
        assert_eq!(
            map.to_string(),
            "absolute RMS 4.8 um, max 8.0 um; registered RMS 1.0 um, max 1.0 um"
        );
    }
}
