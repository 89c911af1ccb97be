//! `artefacts.json`: the calibration balls and the calibrated distances
//! between them.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::path::Path;

use rustc_hash::FxHashMap;
use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::check::Check;
use crate::error::Result;
use crate::quote::{has_control, quoted};
use crate::{json, shape};

/// The frame in which the ball centres are given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ArtefactFrame {
    /// The base frame of `machine.json`'s `base_joints` (`"design"`).
    #[default]
    Design,
    /// The canonical base frame (`"canonical"`): the artefact is located
    /// relative to the base joints and `centre_sigma` is used as a prior.
    Canonical,
}

/// One calibration ball.
///
/// Its serde form is an element of `artefacts.json`'s `balls`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Ball {
    /// Identifier, referred to by `measurements.csv` and the distances.
    pub id: String,
    /// Nominal centre, in the frame given by [`Artefacts::frame`].
    #[serde(deserialize_with = "shape::point")]
    pub centre: Point3,
    /// Standard deviation of each coordinate of `centre` (> 0).
    pub centre_sigma: f64,
    /// Calibrated radius (> 0).
    pub radius: f64,
    /// Standard deviation of `radius` (> 0).
    pub radius_sigma: f64,
}

/// A calibrated centre-to-centre distance between two distinct balls, as
/// from a ball plate or a ball bar (one observation each).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Distance {
    /// Index of the first ball in [`Artefacts::balls`].
    pub a: usize,
    /// Index of the second ball in [`Artefacts::balls`].
    pub b: usize,
    /// Calibrated length (> 0).
    pub length: f64,
    /// Its standard deviation (> 0).
    pub sigma: f64,
}

/// The artefacts: balls (ids unique) and optional distances between them.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Artefacts {
    /// Frame of the ball centres.
    pub frame: ArtefactFrame,
    /// The balls, in file order; measurements refer to them by index.
    pub balls: Vec<Ball>,
    /// Calibrated distances, each pair of balls at most once; empty if the
    /// file has none.
    pub distances: Vec<Distance>,
}

/// `artefacts.json` as written: distances refer to balls by id.
#[derive(Serialize, Deserialize)]
struct ArtefactsFile {
    frame: ArtefactFrame,
    balls: Vec<Ball>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    distances: Vec<DistanceFile>,
}

#[derive(Serialize, Deserialize)]
struct DistanceFile {
    a: String,
    b: String,
    length: f64,
    sigma: f64,
}

/// The index of each ball id (its bytes, as a CSV field holds it) in a
/// list of balls.
pub(crate) type BallIndex<'a> = FxHashMap<&'a [u8], usize>;

/// Index of each ball id in `balls`; the error is the first duplicated id, as
/// (index of its first use, index of its second use).
pub(crate) fn ball_index(balls: &[Ball]) -> std::result::Result<BallIndex<'_>, (usize, usize)> {
    let mut index = BallIndex::with_capacity_and_hasher(balls.len(), Default::default());
    for (i, ball) in balls.iter().enumerate() {
        match index.entry(ball.id.as_bytes()) {
            Entry::Vacant(slot) => {
                slot.insert(i);
            }
            Entry::Occupied(first) => return Err((*first.get(), i)),
        }
    }
    Ok(index)
}

impl Artefacts {
    /// Reads and checks `artefacts.json`, resolving the distances' ids.
    pub fn read(path: &Path) -> Result<Self> {
        let file: ArtefactsFile = json::read(path, json::ARTEFACTS)?;
        let check = Check::new(path);
        // The ids must be unique to be resolved; `validate` checks the rest.
        let index = validate_balls(check, &file.balls)?;
        let resolve = |i: usize, end: &str, id: &str| {
            index.get(id.as_bytes()).copied().ok_or_else(|| {
                check.error(
                    format!("distances[{i}].{end}"),
                    format!("unknown ball id {} (not in balls)", quoted(id)),
                )
            })
        };
        let distances = file
            .distances
            .iter()
            .enumerate()
            .map(|(i, d)| {
                Ok(Distance {
                    a: resolve(i, "a", &d.a)?,
                    b: resolve(i, "b", &d.b)?,
                    length: d.length,
                    sigma: d.sigma,
                })
            })
            .collect::<Result<Vec<_>>>()?;
        let artefacts = Self {
            frame: file.frame,
            balls: file.balls,
            distances,
        };
        // The balls were checked above: what is left of `validate`.
        artefacts.validate_distances(check)?;
        Ok(artefacts)
    }

    /// Writes `artefacts.json` (the caller has validated).
    pub(crate) fn write(&self, path: &Path) -> Result<()> {
        let id = |i: usize| self.balls[i].id.clone();
        let file = ArtefactsFile {
            frame: self.frame,
            balls: self.balls.clone(),
            distances: self
                .distances
                .iter()
                .map(|d| DistanceFile {
                    a: id(d.a),
                    b: id(d.b),
                    length: d.length,
                    sigma: d.sigma,
                })
                .collect(),
        };
        json::write(path, json::ARTEFACTS, &file)
    }

    /// Balls well-formed and unique, distances between two distinct balls.
    /// Reading and writing (files and snapshots) check with this.
    pub(crate) fn validate(&self, check: Check) -> Result<()> {
        validate_balls(check, &self.balls)?;
        self.validate_distances(check)
    }

    /// Each distance joins two distinct balls in range, no pair twice
    /// (in either order), length and sigma positive.
    fn validate_distances(&self, check: Check) -> Result<()> {
        let n = self.balls.len();
        let mut pairs = HashMap::with_capacity(self.distances.len());
        for (i, d) in self.distances.iter().enumerate() {
            for (end, ball) in [("a", d.a), ("b", d.b)] {
                if ball >= n {
                    return Err(check.error(
                        format!("distances[{i}].{end}"),
                        format!("ball index {ball} is out of range ({n} balls)"),
                    ));
                }
            }
            if d.a == d.b {
                return Err(check.error(
                    format!("distances[{i}]"),
                    format!("joins ball {} to itself", quoted(&self.balls[d.a].id)),
                ));
            }
            if let Some(first) = pairs.insert((d.a.min(d.b), d.a.max(d.b)), i) {
                return Err(check.error(
                    format!("distances[{i}]"),
                    format!(
                        "joins balls {} and {} again (as distances[{first}] does)",
                        quoted(&self.balls[d.a].id),
                        quoted(&self.balls[d.b].id)
                    ),
                ));
            }
            check.positive_length(format_args!("distances[{i}].length"), d.length)?;
            check.sigma(format_args!("distances[{i}].sigma"), d.sigma)?;
        }
        Ok(())
    }
}

/// Checks `balls`: well-formed, their ids unique; their index.
fn validate_balls<'a>(check: Check, balls: &'a [Ball]) -> Result<BallIndex<'a>> {
    if balls.is_empty() {
        return Err(check.error("balls", "lists no ball"));
    }
    for (i, ball) in balls.iter().enumerate() {
        if ball.id.is_empty() || ball.id.trim() != ball.id {
            return Err(check.error(
                format!("balls[{i}].id"),
                format!(
                    "ball id {} is empty or has leading or trailing whitespace",
                    quoted(&ball.id)
                ),
            ));
        }
        if has_control(&ball.id) {
            return Err(check.error(
                format!("balls[{i}].id"),
                format!("ball id {} has a control character", quoted(&ball.id)),
            ));
        }
        check.point(format_args!("balls[{i}].centre"), &ball.centre)?;
        check.sigma(format_args!("balls[{i}].centre_sigma"), ball.centre_sigma)?;
        check.positive_length(format_args!("balls[{i}].radius"), ball.radius)?;
        check.sigma(format_args!("balls[{i}].radius_sigma"), ball.radius_sigma)?;
    }
    ball_index(balls).map_err(|(first, i)| {
        check.error(
            format!("balls[{i}].id"),
            format!(
                "ball id {} is used twice (also by balls[{first}])",
                quoted(&balls[i].id)
            ),
        )
    })
}
