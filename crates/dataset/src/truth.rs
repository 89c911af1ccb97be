//! `truth.json` (simulated datasets only): the true geometry, balls and
//! contact points.

use std::cell::RefCell;
use std::fmt;
use std::path::Path;

use serde::de::{self, DeserializeSeed, Deserializer, IgnoredAny, MapAccess, Visitor};
use serde::{Deserialize, Serialize, Serializer};

use crate::Point3;
use crate::artefacts::{Ball, BallIndex};
use crate::check::Check;
use crate::error::Result;
use crate::geometry::{GeometryAnd, GeometryRecord, WithGeometry};
use crate::quote::quoted;
use crate::session::SessionRecord;
use crate::shape::{self, P3};
use crate::{MEASUREMENTS_FILE, json};

/// The truth behind a simulated dataset, in the frames of `machine.json`.
///
/// `truth.json` has the geometry's fields at its top level and the balls
/// keyed by id.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// True geometry.
    pub geometry: GeometryRecord,
    /// True ball centres, in [`Artefacts::balls`](crate::Artefacts::balls) order.
    pub ball_centres: Vec<Point3>,
    /// True ball radii, in [`Artefacts::balls`](crate::Artefacts::balls) order.
    pub ball_radii: Vec<f64>,
    /// True contact point of each measurement row, in row order; empty
    /// if the dataset was read without them
    /// ([`ReadOptions::true_contacts`](crate::ReadOptions::true_contacts)).
    pub contacts: Vec<Point3>,
    /// True actuator scales (mm per unit), when the machine has
    /// `actuator`.
    pub actuator_scale: Option<[f64; 6]>,
    /// True nuisance of each session of poses.csv and points.csv, in
    /// session order.
    pub sessions: Vec<SessionRecord>,
}

/// The fields of `truth.json` after the geometry, as written: balls keyed
/// by id ([`BallsSeed`] reads them).
#[derive(Serialize)]
struct Balls<'a> {
    ball_centres: Keyed<'a, Point3>,
    ball_radii: Keyed<'a, f64>,
    contacts: &'a [Point3],
    #[serde(skip_serializing_if = "Option::is_none")]
    actuator_scale: Option<[f64; 6]>,
    #[serde(skip_serializing_if = "<[SessionRecord]>::is_empty")]
    sessions: &'a [SessionRecord],
}

/// `truth.json` parsed, its balls' values in ball order, not yet checked
/// against the measurements ([`Truth::parse_if_present`]).
pub(crate) struct TruthFile {
    geometry: GeometryRecord,
    rest: ReadBalls,
    values: BallValues,
    /// Whether the contact points were parsed.
    contacts: bool,
}

/// The fields of `truth.json` after the geometry, as [`BallsSeed`] reads
/// them, but the balls' values ([`BallValues`]).
struct ReadBalls {
    contacts: Vec<Point3>,
    actuator_scale: Option<[f64; 6]>,
    sessions: Vec<SessionRecord>,
}

/// Values keyed by ball id, put in ball order as they are read.
struct ByBall<T> {
    values: Vec<T>,
    /// Which balls were given.
    given: Vec<bool>,
}

impl<T: Clone + Default> ByBall<T> {
    /// Room for `n` balls' values.
    fn new(n: usize) -> Self {
        Self {
            values: vec![T::default(); n],
            given: vec![false; n],
        }
    }
}

/// Where the parse puts the balls' values, shared by the seeds it copies
/// as it descends.
struct BallValues {
    centres: RefCell<ByBall<P3>>,
    radii: RefCell<ByBall<f64>>,
}

impl BallValues {
    /// Room for `n` balls.
    fn new(n: usize) -> Self {
        Self {
            centres: RefCell::new(ByBall::new(n)),
            radii: RefCell::new(ByBall::new(n)),
        }
    }
}

/// Reads the fields after the geometry (`balls` the artefacts', `index`
/// theirs, their values into `values`; the contact points parsed if
/// `contacts`, skipped unparsed otherwise).
#[derive(Clone, Copy)]
struct BallsSeed<'a> {
    balls: &'a [Ball],
    index: &'a BallIndex<'a>,
    values: &'a BallValues,
    contacts: bool,
}

impl<'a> BallsSeed<'a> {
    /// Reads an object keyed by ball id into `into`.
    fn by_ball<T>(&self, into: &'a RefCell<ByBall<T>>) -> ByBallSeed<'a, T> {
        ByBallSeed {
            balls: self.balls,
            index: self.index,
            into,
        }
    }
}

/// The fields of [`ReadBalls`], any other ignored.
#[derive(Deserialize)]
#[serde(field_identifier, rename_all = "snake_case")]
enum Field {
    BallCentres,
    BallRadii,
    Contacts,
    ActuatorScale,
    Sessions,
    #[serde(other)]
    Other,
}

impl<'de> DeserializeSeed<'de> for BallsSeed<'_> {
    type Value = ReadBalls;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> std::result::Result<ReadBalls, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for BallsSeed<'_> {
    type Value = ReadBalls;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("the fields of truth.json")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> std::result::Result<ReadBalls, A::Error> {
        let (mut centres, mut radii, mut contacts, mut scale, mut sessions) =
            (None, None, None, None, None);
        while let Some(field) = map.next_key()? {
            match field {
                Field::BallCentres => once(&mut centres, "ball_centres", || {
                    map.next_value_seed(self.by_ball(&self.values.centres))
                })?,
                Field::BallRadii => once(&mut radii, "ball_radii", || {
                    map.next_value_seed(self.by_ball(&self.values.radii))
                })?,
                Field::Contacts => once(&mut contacts, "contacts", || {
                    if self.contacts {
                        map.next_value_seed(PointsSeed)
                    } else {
                        map.next_value::<IgnoredAny>().map(|_| Vec::new())
                    }
                })?,
                Field::ActuatorScale => once(&mut scale, "actuator_scale", || map.next_value())?,
                Field::Sessions => once(&mut sessions, "sessions", || map.next_value())?,
                Field::Other => {
                    map.next_value::<IgnoredAny>()?;
                }
            }
        }
        centres.ok_or_else(|| de::Error::missing_field("ball_centres"))?;
        radii.ok_or_else(|| de::Error::missing_field("ball_radii"))?;
        Ok(ReadBalls {
            contacts: contacts.ok_or_else(|| de::Error::missing_field("contacts"))?,
            actuator_scale: scale.flatten(),
            sessions: sessions.unwrap_or_default(),
        })
    }
}

/// Fills `slot` by `read` (a field given twice is an error, as in serde's
/// derived structs).
fn once<T, E: de::Error>(
    slot: &mut Option<T>,
    field: &'static str,
    read: impl FnOnce() -> std::result::Result<T, E>,
) -> std::result::Result<(), E> {
    if slot.is_some() {
        return Err(E::duplicate_field(field));
    }
    *slot = Some(read()?);
    Ok(())
}

/// `truth.json`'s contact points, parsed.
struct PointsSeed;

impl<'de> DeserializeSeed<'de> for PointsSeed {
    type Value = Vec<Point3>;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> std::result::Result<Vec<Point3>, D::Error> {
        shape::points(d)
    }
}

/// Reads an object keyed by ball id into a [`ByBall`]: an id not among the
/// balls, or given twice, is an error.
struct ByBallSeed<'a, T> {
    balls: &'a [Ball],
    index: &'a BallIndex<'a>,
    into: &'a RefCell<ByBall<T>>,
}

impl<'de, T: Deserialize<'de>> DeserializeSeed<'de> for ByBallSeed<'_, T> {
    type Value = ();

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> std::result::Result<(), D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de, T: Deserialize<'de>> Visitor<'de> for ByBallSeed<'_, T> {
    type Value = ();

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("an object keyed by ball id")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> std::result::Result<(), A::Error> {
        let mut out = self.into.borrow_mut();
        // A parse again (to name the field of an error) starts afresh.
        out.given.fill(false);
        let mut next = 0;
        while let Some(i) = map.next_key_seed(BallId {
            balls: self.balls,
            index: self.index,
            next,
        })? {
            next = i + 1;
            if std::mem::replace(&mut out.given[i], true) {
                return Err(de::Error::custom(format!(
                    "ball id {} appears twice",
                    quoted(&self.balls[i].id)
                )));
            }
            out.values[i] = map.next_value()?;
        }
        Ok(())
    }
}

/// A ball id, read as its index among the balls: the ball after the last
/// key read (`next`) first, since the writer keys the balls in their
/// order, any other through the index.
struct BallId<'a> {
    balls: &'a [Ball],
    index: &'a BallIndex<'a>,
    next: usize,
}

impl<'de> DeserializeSeed<'de> for BallId<'_> {
    type Value = usize;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> std::result::Result<usize, D::Error> {
        d.deserialize_str(self)
    }
}

impl<'de> Visitor<'de> for BallId<'_> {
    type Value = usize;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a ball id")
    }

    fn visit_str<E: de::Error>(self, id: &str) -> std::result::Result<usize, E> {
        if self.balls.get(self.next).is_some_and(|ball| ball.id == id) {
            return Ok(self.next);
        }
        self.index.get(id.as_bytes()).copied().ok_or_else(|| {
            E::custom(format!(
                "unknown ball id {} (not in artefacts.json)",
                quoted(id)
            ))
        })
    }
}

impl TruthFile {
    /// The truth, checked as [`Truth::validate`] checks it, every ball
    /// given (`balls` those the file was parsed with), against `rows`
    /// measurement rows (`truth.json` at `path`).
    pub(crate) fn checked(self, path: &Path, balls: &[Ball], rows: usize) -> Result<Truth> {
        let values = self.values;
        let check = Check::new(path);
        let ReadBalls {
            contacts,
            actuator_scale,
            sessions,
        } = self.rest;
        let truth = Truth {
            geometry: self.geometry,
            ball_centres: every_ball(check, "ball_centres", values.centres, balls)?
                .into_iter()
                .map(|p| p.0)
                .collect(),
            ball_radii: every_ball(check, "ball_radii", values.radii, balls)?,
            contacts,
            actuator_scale,
            sessions,
        };
        truth.validate(check, balls.len(), self.contacts.then_some(rows))?;
        Ok(truth)
    }
}

impl Truth {
    /// Parses `truth.json` if it exists, its balls' values put in the order
    /// of `balls` (`index` theirs) as they are read; without its contact
    /// points (skipped unparsed, [`Truth::contacts`] left empty) unless
    /// `contacts`. [`TruthFile::checked`] checks it against the
    /// measurements.
    pub(crate) fn parse_if_present(
        path: &Path,
        balls: &[Ball],
        index: &BallIndex,
        contacts: bool,
    ) -> Result<Option<TruthFile>> {
        let values = BallValues::new(balls.len());
        let seed = GeometryAnd(BallsSeed {
            balls,
            index,
            values: &values,
            contacts,
        });
        let file = json::read_if_present_with(path, json::TRUTH, seed)?;
        Ok(file.map(|file| TruthFile {
            geometry: file.geometry,
            rest: file.rest,
            values,
            contacts,
        }))
    }

    /// Writes `truth.json` (the caller has validated).
    pub(crate) fn write(&self, path: &Path, balls: &[Ball]) -> Result<()> {
        let file = WithGeometry {
            geometry: &self.geometry,
            rest: Balls {
                ball_centres: Keyed(balls, &self.ball_centres),
                ball_radii: Keyed(balls, &self.ball_radii),
                contacts: &self.contacts,
                actuator_scale: self.actuator_scale,
                sessions: &self.sessions,
            },
        };
        json::write(path, json::TRUTH, &file)
    }

    /// The geometry a machine's ([`GeometryRecord::validate_machine`]),
    /// lengths within bounds, radii positive, one centre and radius per
    /// ball, one contact per measurement row (`contact_rows` rows; `None`:
    /// the contacts were not read).
    pub(crate) fn validate(
        &self,
        check: Check,
        ball_count: usize,
        contact_rows: Option<usize>,
    ) -> Result<()> {
        self.geometry.validate_machine(check, "")?;
        for (field, len) in [
            ("ball_centres", self.ball_centres.len()),
            ("ball_radii", self.ball_radii.len()),
        ] {
            if len != ball_count {
                return Err(check.error(
                    field,
                    format!("expected {ball_count} balls (as in artefacts.json), found {len}"),
                ));
            }
        }
        check.points("ball_centres", &self.ball_centres)?;
        for (i, &r) in self.ball_radii.iter().enumerate() {
            check.positive_length(format_args!("ball_radii[{i}]"), r)?;
        }
        if let Some(rows) = contact_rows
            && self.contacts.len() != rows
        {
            return Err(check.error(
                "contacts",
                format!(
                    "expected {rows} contact points (one per row of {MEASUREMENTS_FILE}), found {}",
                    self.contacts.len()
                ),
            ));
        }
        check.points("contacts", &self.contacts)?;
        if let Some(scale) = &self.actuator_scale {
            check.values("actuator_scale", scale)?;
        }
        for (k, session) in self.sessions.iter().enumerate() {
            session.validate(check, &format!("sessions[{k}]"))?;
        }
        Ok(())
    }
}

/// Values keyed by the ids of the balls, in order: a JSON object.
struct Keyed<'a, T>(&'a [Ball], &'a [T]);

impl<T: Serialize> Serialize for Keyed<'_, T> {
    fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        s.collect_map(self.0.iter().map(|ball| &ball.id).zip(self.1))
    }
}

/// The values read into `by_ball` (the object `field`), every ball of
/// `balls` given.
fn every_ball<T>(
    check: Check,
    field: &str,
    by_ball: RefCell<ByBall<T>>,
    balls: &[Ball],
) -> Result<Vec<T>> {
    let by_ball = by_ball.into_inner();
    match by_ball.given.iter().position(|&given| !given) {
        Some(i) => Err(check.error(
            field,
            format!("ball {} of artefacts.json is missing", quoted(&balls[i].id)),
        )),
        None => Ok(by_ball.values),
    }
}
