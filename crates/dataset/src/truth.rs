//! `truth.json` (simulated datasets only): the true geometry, balls and
//! contact points.

use std::path::Path;

use serde::de::IgnoredAny;
use serde::{Deserialize, Deserializer, Serialize};

use crate::Point3;
use crate::artefacts::{Ball, BallIndex, ball_index};
use crate::check::Check;
use crate::error::Result;
use crate::geometry::{GeometryRecord, WithGeometry};
use crate::quote::quoted;
use crate::session::SessionRecord;
use crate::shape::{self, IdMap, P3};
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

/// The fields of `truth.json` after the geometry: balls keyed by id; the
/// contact points as `C` (written from a `Vec`, read as [`TrueContacts`],
/// or skipped unparsed as [`IgnoredAny`]).
#[derive(Serialize, Deserialize)]
struct Balls<C> {
    ball_centres: IdMap<P3>,
    ball_radii: IdMap<f64>,
    contacts: C,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    actuator_scale: Option<[f64; 6]>,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    sessions: Vec<SessionRecord>,
}

/// `truth.json`'s contact points, parsed.
struct TrueContacts(Vec<Point3>);

impl<'de> Deserialize<'de> for TrueContacts {
    fn deserialize<D: Deserializer<'de>>(d: D) -> std::result::Result<Self, D::Error> {
        shape::points(d).map(Self)
    }
}

impl Truth {
    /// Reads and checks `truth.json` if it exists, against the balls and the
    /// number of measurement rows; without its contact points (skipped
    /// unparsed, [`Truth::contacts`] left empty) unless `contacts`.
    pub(crate) fn read_if_present(
        path: &Path,
        balls: &[Ball],
        rows: usize,
        contacts: bool,
    ) -> Result<Option<Self>> {
        let contact_rows = contacts.then_some(rows);
        let read = |file: Option<WithGeometry<GeometryRecord, Balls<Vec<Point3>>>>| {
            file.map(|file| Self::checked(path, file, balls, contact_rows))
                .transpose()
        };
        if contacts {
            let file = json::read_if_present::<WithGeometry<GeometryRecord, Balls<TrueContacts>>>(
                path,
                json::TRUTH,
            )?;
            read(file.map(|f| with_contacts(f, |c| c.0)))
        } else {
            let file = json::read_if_present::<WithGeometry<GeometryRecord, Balls<IgnoredAny>>>(
                path,
                json::TRUTH,
            )?;
            read(file.map(|f| with_contacts(f, |_| Vec::new())))
        }
    }

    /// The truth of `file` (`truth.json` at `path`), checked as
    /// [`Truth::validate`] checks it.
    fn checked(
        path: &Path,
        file: WithGeometry<GeometryRecord, Balls<Vec<Point3>>>,
        balls: &[Ball],
        contact_rows: Option<usize>,
    ) -> Result<Self> {
        let check = Check::new(path);
        let index = ball_index(balls).expect("ball ids are unique");
        let truth = Self {
            geometry: file.geometry,
            ball_centres: by_ball(check, "ball_centres", file.rest.ball_centres, balls, &index)?
                .into_iter()
                .map(|p| p.0)
                .collect(),
            ball_radii: by_ball(check, "ball_radii", file.rest.ball_radii, balls, &index)?,
            contacts: file.rest.contacts,
            actuator_scale: file.rest.actuator_scale,
            sessions: file.rest.sessions,
        };
        truth.validate(check, balls.len(), contact_rows)?;
        Ok(truth)
    }

    /// Writes `truth.json` (the caller has validated).
    pub(crate) fn write(&self, path: &Path, balls: &[Ball]) -> Result<()> {
        let file = WithGeometry {
            geometry: &self.geometry,
            rest: Balls {
                ball_centres: keyed(balls, self.ball_centres.iter().copied().map(P3)),
                ball_radii: keyed(balls, self.ball_radii.iter().copied()),
                contacts: self.contacts.clone(),
                actuator_scale: self.actuator_scale,
                sessions: self.sessions.clone(),
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

/// `file` with its contact points mapped by `f`.
fn with_contacts<C, D>(
    file: WithGeometry<GeometryRecord, Balls<C>>,
    f: impl FnOnce(C) -> D,
) -> WithGeometry<GeometryRecord, Balls<D>> {
    let Balls {
        ball_centres,
        ball_radii,
        contacts,
        actuator_scale,
        sessions,
    } = file.rest;
    WithGeometry {
        geometry: file.geometry,
        rest: Balls {
            ball_centres,
            ball_radii,
            contacts: f(contacts),
            actuator_scale,
            sessions,
        },
    }
}

/// `values` keyed by the ids of `balls`, in order.
fn keyed<T>(balls: &[Ball], values: impl IntoIterator<Item = T>) -> IdMap<T> {
    balls.iter().map(|b| b.id.as_str()).zip(values).collect()
}

/// The values of an id-keyed object in `balls` order (`index` theirs):
/// every ball exactly once.
fn by_ball<T>(
    check: Check,
    field: &str,
    map: IdMap<T>,
    balls: &[Ball],
    index: &BallIndex,
) -> Result<Vec<T>> {
    let mut slots: Vec<Option<T>> = balls.iter().map(|_| None).collect();
    map.try_for_each(|id, value| {
        let &i = index.get(id).ok_or_else(|| {
            check.error(
                field,
                format!("unknown ball id {} (not in artefacts.json)", quoted(id)),
            )
        })?;
        if slots[i].replace(value).is_some() {
            return Err(check.error(field, format!("ball id {} appears twice", quoted(id))));
        }
        Ok(())
    })?;
    slots
        .into_iter()
        .zip(balls)
        .map(|(slot, ball)| {
            slot.ok_or_else(|| {
                check.error(
                    field,
                    format!("ball {} of artefacts.json is missing", quoted(&ball.id)),
                )
            })
        })
        .collect()
}
