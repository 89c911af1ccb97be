//! The geometry block of `machine.json`, `truth.json` and
//! `calibration.json`: base joints, platform joints, tool tip, initial leg
//! lengths.
//!
//! `calibration.json` holds it as an object of its own (`canonical`);
//! `machine.json` and `truth.json` have its fields at the top level, before
//! the file's other fields ([`WithGeometry`]).

use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, DeserializeSeed, Deserializer, MapAccess, Visitor};
use serde::{Deserialize, Serialize};

use parcal_kinematics::{Geometry, KinematicsError};

use crate::Point3;
use crate::check::Check;
use crate::error::Result;
use crate::fields::TakeFields;
use crate::shape::{self, Joints, Legs, P3};

/// A machine geometry, in the frames the file that holds it names.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GeometryRecord {
    /// Base joints B1..B6 in the base frame.
    #[serde(deserialize_with = "shape::joints")]
    pub base_joints: [Point3; 6],
    /// Platform joints E1..E6 in the platform frame.
    #[serde(deserialize_with = "shape::joints")]
    pub platform_joints: [Point3; 6],
    /// Tool tip E_T in the platform frame.
    #[serde(deserialize_with = "shape::point")]
    pub tool: Point3,
    /// Initial leg lengths l1..l6 (leg i is `l_i + q_i` long).
    #[serde(deserialize_with = "shape::legs")]
    pub leg_lengths: [f64; 6],
}

impl GeometryRecord {
    /// Every value a length ([`Check::length`]). Errors name the field after
    /// `parent` (`""` or e.g. `"canonical."`).
    pub(crate) fn validate(&self, check: Check, parent: &str) -> Result<()> {
        check.points(format_args!("{parent}base_joints"), &self.base_joints)?;
        check.points(
            format_args!("{parent}platform_joints"),
            &self.platform_joints,
        )?;
        check.point(format_args!("{parent}tool"), &self.tool)?;
        check.lengths(format_args!("{parent}leg_lengths"), &self.leg_lengths)
    }

    /// The geometry of a machine to calibrate (machine.json, truth.json):
    /// [`GeometryRecord::validate`], and its canonical frames exist (no two
    /// joints of a body coincide, joints 1, 2 and 3 of each body are not
    /// collinear), as the calibration's
    /// [`canonicalize`](parcal_kinematics::Geometry::canonicalize) judges.
    /// Errors name the field after `parent`, as [`GeometryRecord::validate`].
    pub(crate) fn validate_machine(&self, check: Check, parent: &str) -> Result<()> {
        self.validate(check, parent)?;
        let geometry = Geometry::from_arrays(
            &self.base_joints,
            &self.platform_joints,
            &self.tool,
            &self.leg_lengths,
        );
        match geometry.canonicalize() {
            Ok(_) => Ok(()),
            Err(e) => {
                let field = match &e {
                    KinematicsError::CoincidentJoints { body, .. }
                    | KinematicsError::CollinearFrameJoints { body, .. } => {
                        format!("{parent}{body}_joints")
                    }
                    _ => format!("{parent}base_joints"),
                };
                Err(check.error(field, format!("degenerate geometry: {e}")))
            }
        }
    }
}

/// A JSON object with the fields of `geometry` first, then those of `rest`.
///
/// Written through serde's `flatten`. Read by handing every key that is not
/// a geometry field to `rest`'s own `Deserialize`, as the object streams
/// by: serde's `flatten` would buffer the fields, and an error would lose
/// its field path and line.
#[derive(Debug, Serialize)]
pub(crate) struct WithGeometry<G, T> {
    #[serde(flatten)]
    pub geometry: G,
    #[serde(flatten)]
    pub rest: T,
}

impl<'de, T: Deserialize<'de>> Deserialize<'de> for WithGeometry<GeometryRecord, T> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        GeometryAnd(PhantomData::<T>).deserialize(d)
    }
}

/// Reads a [`WithGeometry`] whose `rest` is the value of the seed it holds.
#[derive(Clone)]
pub(crate) struct GeometryAnd<S>(pub S);

impl<'de, S: DeserializeSeed<'de>> DeserializeSeed<'de> for GeometryAnd<S> {
    type Value = WithGeometry<GeometryRecord, S::Value>;

    fn deserialize<D: Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de, S: DeserializeSeed<'de>> Visitor<'de> for GeometryAnd<S> {
    type Value = WithGeometry<GeometryRecord, S::Value>;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a JSON object")
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<Self::Value, A::Error> {
        let mut geometry = PartialGeometry::default();
        let take = |key: &str, map: &mut A| geometry.read(key, map);
        let rest = self.0.deserialize(&mut TakeFields { map, take })?;
        Ok(WithGeometry {
            geometry: geometry.finish()?,
            rest,
        })
    }
}

/// The geometry fields read so far.
#[derive(Default)]
struct PartialGeometry {
    base_joints: Option<[Point3; 6]>,
    platform_joints: Option<[Point3; 6]>,
    tool: Option<Point3>,
    leg_lengths: Option<[f64; 6]>,
}

impl PartialGeometry {
    /// Reads the value of `key` from `map` if `key` is a geometry field;
    /// `false` if it is not.
    fn read<'de, A: MapAccess<'de>>(&mut self, key: &str, map: &mut A) -> Result<bool, A::Error> {
        match key {
            "base_joints" => fill(&mut self.base_joints, "base_joints", map, |j: Joints| j.0),
            "platform_joints" => fill(
                &mut self.platform_joints,
                "platform_joints",
                map,
                |j: Joints| j.0,
            ),
            "tool" => fill(&mut self.tool, "tool", map, |p: P3| p.0),
            "leg_lengths" => fill(&mut self.leg_lengths, "leg_lengths", map, |l: Legs| l.0),
            _ => return Ok(false),
        }?;
        Ok(true)
    }

    /// The geometry, or the first missing field.
    fn finish<E: de::Error>(self) -> Result<GeometryRecord, E> {
        Ok(GeometryRecord {
            base_joints: self
                .base_joints
                .ok_or_else(|| E::missing_field("base_joints"))?,
            platform_joints: self
                .platform_joints
                .ok_or_else(|| E::missing_field("platform_joints"))?,
            tool: self.tool.ok_or_else(|| E::missing_field("tool"))?,
            leg_lengths: self
                .leg_lengths
                .ok_or_else(|| E::missing_field("leg_lengths"))?,
        })
    }
}

/// Reads the next value of `map` into `slot` (which must be empty: a field
/// given twice is an error, as in serde's derived structs).
fn fill<'de, A, V, T>(
    slot: &mut Option<T>,
    field: &'static str,
    map: &mut A,
    into: impl FnOnce(V) -> T,
) -> Result<(), A::Error>
where
    A: MapAccess<'de>,
    V: Deserialize<'de>,
{
    if slot.is_some() {
        return Err(de::Error::duplicate_field(field));
    }
    *slot = Some(into(map.next_value()?));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Rest {
        a: f64,
        #[serde(default)]
        b: Vec<u32>,
    }

    const GEOMETRY: &str = r#""base_joints": [[1,2,3],[4,5,6],[7,8,9],[1,2,3],[4,5,6],[7,8,9]],
        "platform_joints": [[1,0,0],[0,1,0],[0,0,1],[1,0,0],[0,1,0],[0,0,1]],
        "tool": [0, 0, 60],
        "leg_lengths": [235, 235, 235, 235, 235, 235]"#;

    fn parse(json: &str) -> Result<WithGeometry<GeometryRecord, Rest>, String> {
        let mut de = serde_json::Deserializer::from_str(json);
        serde_path_to_error::deserialize(&mut de)
            .map_err(|e| format!("{}: {}", e.path(), e.inner()))
    }

    #[test]
    fn fields_of_both_parts_in_any_order_round_trip() {
        let read = parse(&format!(
            r#"{{"a": 1.5, {GEOMETRY}, "extra": [1, {{}}], "b": [7]}}"#
        ))
        .unwrap();
        assert_eq!(read.geometry.tool, [0.0, 0.0, 60.0]);
        assert_eq!(read.geometry.base_joints[2], [7.0, 8.0, 9.0]);
        assert_eq!(read.rest, Rest { a: 1.5, b: vec![7] });
        let text = serde_json::to_string(&read).unwrap();
        assert!(text.starts_with(r#"{"base_joints":"#), "{text}");
        assert!(
            text.ends_with(
                r#""leg_lengths":[235.0,235.0,235.0,235.0,235.0,235.0],"a":1.5,"b":[7]}"#
            ),
            "{text}"
        );
        let again: WithGeometry<GeometryRecord, Rest> = serde_json::from_str(&text).unwrap();
        assert_eq!((again.geometry, again.rest), (read.geometry, read.rest));
    }

    #[test]
    fn errors_keep_the_field_path_and_the_line() {
        let bad_joints = GEOMETRY.replace("[7,8,9]]", "[7,8]]");
        let err = parse(&format!("{{\"a\": 1,\n{bad_joints}}}")).unwrap_err();
        assert!(
            err.starts_with("base_joints[5]: expected 3 coordinates, found 2 at line 2 column"),
            "{err}"
        );
        let err = parse(&format!(r#"{{{GEOMETRY}, "a": 1, "b": [1, "x"]}}"#)).unwrap_err();
        assert!(err.starts_with("b[1]: invalid type: string \"x\""), "{err}");
    }

    #[test]
    fn missing_and_repeated_fields_are_named() {
        let without_tool = GEOMETRY.replace(r#""tool": [0, 0, 60],"#, "");
        let err = parse(&format!(r#"{{{without_tool}, "a": 1}}"#)).unwrap_err();
        assert!(err.contains("missing field `tool`"), "{err}");
        let err = parse(&format!(r#"{{{GEOMETRY}}}"#)).unwrap_err();
        assert!(err.contains("missing field `a`"), "{err}");
        let err = parse(&format!(r#"{{{GEOMETRY}, "a": 1, "tool": [0, 0, 1]}}"#)).unwrap_err();
        assert!(err.contains("duplicate field `tool`"), "{err}");
    }
}
