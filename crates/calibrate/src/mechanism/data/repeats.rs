//! Observations given twice: a point sample, a tracker point or a tracker
//! pose equal to an earlier one of its kind in every number it holds.
//!
//! Their readings and measured coordinates are recorded to many digits,
//! so that two equal ones are almost surely one row copied. A copy counts
//! its measurement twice: the parameters it determines seem up to `√2`
//! surer than they are, and each of the pair's w-tests sees half its
//! blunder. Probe heights, distances, heights and quantities are written
//! to a few decimals and may repeat by chance, and ball touches are the
//! hexapod's millions; those are not compared.

use std::collections::HashMap;

use parcal_observe::mechanism::Actuation;

use super::super::observation::{ObservationKind, ObservationRef};
use super::observations::Observations;

/// An observation equal to an earlier one of its kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Repeat {
    /// The later of the two.
    pub copy: ObservationRef,
    /// The earlier one it repeats (the first of its equals).
    pub of: ObservationRef,
}

impl Observations {
    /// The point samples, tracker points and tracker poses equal to an
    /// earlier one of their kind (module doc), by kind, then index.
    pub fn repeats(&self) -> Vec<Repeat> {
        let samples = self.samples.iter().map(|s| {
            let pose = s
                .known_pose
                .iter()
                .flat_map(|(x, sigma)| x.iter().chain(sigma));
            let loads = s.loads.iter().flatten();
            key(s.readings.iter().chain(pose).chain(loads), [1, 0])
        });
        let points = self.tracker_points.iter().map(|p| {
            let at = match &p.at {
                Actuation::Commanded(x) => x.as_slice(),
                Actuation::Readings(q) => q.as_slice(),
            };
            let kind = u64::from(matches!(p.at, Actuation::Readings(_)));
            key(at.iter().chain(&p.measured), [p.tracker as u64, kind])
        });
        let poses = self.tracker_poses.iter().map(|p| {
            let m = p.measured.to_homogeneous();
            key(p.readings.iter().chain(m.iter()), [p.tracker as u64, 0])
        });
        let mut repeats = repeats_of(ObservationKind::Sample, samples);
        repeats.extend(repeats_of(ObservationKind::TrackerPoint, points));
        repeats.extend(repeats_of(ObservationKind::TrackerPose, poses));
        repeats
    }
}

/// The bits of `values` after `tags` (what besides numbers tells two
/// observations apart): equal keys are equal numbers, `0.0` and `-0.0`
/// apart.
fn key<'a>(values: impl Iterator<Item = &'a f64>, tags: [u64; 2]) -> Vec<u64> {
    tags.into_iter()
        .chain(values.map(|v| v.to_bits()))
        .collect()
}

/// The repeats among the observations of `kind` whose keys are `keys`, in
/// order.
fn repeats_of(kind: ObservationKind, keys: impl Iterator<Item = Vec<u64>>) -> Vec<Repeat> {
    let mut first = HashMap::new();
    let at = |index| ObservationRef { kind, index };
    keys.enumerate()
        .filter_map(|(index, key)| {
            let earlier = *first.entry(key).or_insert(index);
            (earlier != index).then(|| Repeat {
                copy: at(index),
                of: at(earlier),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use parcal_observe::mechanism::PointSample;

    use super::*;

    fn sample(readings: [f64; 4], pose: Option<[f64; 3]>) -> PointSample {
        PointSample {
            readings: readings.to_vec(),
            sigma: 0.1,
            known_pose: pose.map(|x| (x, [0.1; 3])),
            loads: None,
        }
    }

    /// A sample given twice is named, after the first of its equals; one
    /// number apart (a reading, the pose, whether the pose was measured,
    /// the sign of a zero) is another sample.
    #[test]
    fn a_sample_equal_in_every_number_to_an_earlier_one_is_a_repeat() {
        let q = [1.0, -2.5, 0.0, 7.25];
        let x = Some([10.0, 20.0, 0.0]);
        let observations = Observations {
            samples: vec![
                sample(q, x),
                sample([1.0, -2.5, -0.0, 7.25], x),
                sample(q, None),
                sample(q, Some([10.0, 20.0, 1e-12])),
                sample(q, x),
                sample(q, x),
            ],
            ..Observations::default()
        };
        let at = |index| ObservationRef {
            kind: ObservationKind::Sample,
            index,
        };
        let repeat = |copy, of| Repeat {
            copy: at(copy),
            of: at(of),
        };
        assert_eq!(observations.repeats(), [repeat(4, 0), repeat(5, 0)]);
        let tagged = Observations {
            samples: vec![sample(q, None); 2],
            ..Observations::default()
        };
        assert_eq!(tagged.repeats(), [repeat(1, 0)]);
        assert!(Observations::default().repeats().is_empty());
    }
}
