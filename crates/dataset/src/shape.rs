//! Serde helpers for the shapes of the format: fixed-size arrays that say what
//! they expected ("expected 6 joints, found 5").
//!
//! The fixed-size helpers go through `deserialize_tuple`, exactly as serde's
//! own `[T; N]` does, so the same types also read back from postcard
//! snapshots.

use std::collections::BTreeMap;
use std::fmt;
use std::marker::PhantomData;

use serde::de::{self, Deserializer, IgnoredAny, MapAccess, SeqAccess, Visitor};
use serde::{Deserialize, Serialize};

use crate::Point3;
use crate::quote::quoted;

/// A point that deserializes with "expected 3 coordinates, found N".
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
#[serde(transparent)]
pub(crate) struct P3(pub Point3);

impl<'de> Deserialize<'de> for P3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        fixed::<D, f64, 3>(d, "coordinates").map(P3)
    }
}

/// Reads exactly `N` elements, or fails with "expected N {noun}, found M".
fn fixed<'de, D, T, const N: usize>(d: D, noun: &'static str) -> Result<[T; N], D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de> + Copy + Default,
{
    d.deserialize_tuple(
        N,
        FixedVisitor {
            noun,
            element: PhantomData,
        },
    )
}

struct FixedVisitor<T, const N: usize> {
    noun: &'static str,
    element: PhantomData<T>,
}

impl<'de, T, const N: usize> Visitor<'de> for FixedVisitor<T, N>
where
    T: Deserialize<'de> + Copy + Default,
{
    type Value = [T; N];

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        write!(f, "an array of {N} {}", self.noun)
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
        let mut out = [T::default(); N];
        for (found, slot) in out.iter_mut().enumerate() {
            *slot = seq
                .next_element()?
                .ok_or_else(|| de::Error::custom(self.miscount(found)))?;
        }
        let mut found = N;
        while seq.next_element::<IgnoredAny>()?.is_some() {
            found += 1;
        }
        if found == N {
            Ok(out)
        } else {
            Err(de::Error::custom(self.miscount(found)))
        }
    }
}

impl<T, const N: usize> FixedVisitor<T, N> {
    fn miscount(&self, found: usize) -> String {
        format!("expected {N} {}, found {found}", self.noun)
    }
}

/// `deserialize_with` for a point: 3 coordinates.
pub(crate) fn point<'de, D: Deserializer<'de>>(d: D) -> Result<Point3, D::Error> {
    P3::deserialize(d).map(|p| p.0)
}

/// The 6 joints of a base or platform: "expected 6 joints, found N".
pub(crate) struct Joints(pub [Point3; 6]);

impl<'de> Deserialize<'de> for Joints {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        fixed::<D, P3, 6>(d, "joints").map(|j| Joints(j.map(|p| p.0)))
    }
}

/// The 6 leg lengths: "expected 6 leg lengths, found N".
pub(crate) struct Legs(pub [f64; 6]);

impl<'de> Deserialize<'de> for Legs {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        fixed::<D, f64, 6>(d, "leg lengths").map(Legs)
    }
}

/// `deserialize_with` for the 6 joints of a base or platform.
pub(crate) fn joints<'de, D: Deserializer<'de>>(d: D) -> Result<[Point3; 6], D::Error> {
    Joints::deserialize(d).map(|j| j.0)
}

/// `deserialize_with` for the 6 leg lengths.
pub(crate) fn legs<'de, D: Deserializer<'de>>(d: D) -> Result<[f64; 6], D::Error> {
    Legs::deserialize(d).map(|l| l.0)
}

/// `deserialize_with` for a list of points of any length.
pub(crate) fn points<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<Point3>, D::Error> {
    struct PointsVisitor;
    impl<'de> Visitor<'de> for PointsVisitor {
        type Value = Vec<Point3>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("an array of points")
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
            let mut out = Vec::with_capacity(seq.size_hint().unwrap_or(0).min(1 << 16));
            while let Some(P3(p)) = seq.next_element()? {
                out.push(p);
            }
            Ok(out)
        }
    }
    d.deserialize_seq(PointsVisitor)
}

/// A list of at most `MAX` elements: reading stops at element `MAX + 1`
/// with "expected at most MAX elements", so a list a file inflates costs
/// no more than `MAX` elements of memory and work.
pub(crate) struct Bounded<T, const MAX: usize>(pub Vec<T>);

impl<'de, T: Deserialize<'de>, const MAX: usize> Deserialize<'de> for Bounded<T, MAX> {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct BoundedVisitor<T, const MAX: usize>(PhantomData<T>);
        impl<'de, T: Deserialize<'de>, const MAX: usize> Visitor<'de> for BoundedVisitor<T, MAX> {
            type Value = Bounded<T, MAX>;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                write!(f, "an array of at most {MAX} elements")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let hint = seq.size_hint().unwrap_or(0).min(MAX).min(1 << 12);
                let mut out = Vec::with_capacity(hint);
                while let Some(element) = seq.next_element()? {
                    if out.len() == MAX {
                        return Err(de::Error::custom(format!(
                            "expected at most {MAX} elements, found more"
                        )));
                    }
                    out.push(element);
                }
                Ok(Bounded(out))
            }
        }
        d.deserialize_seq(BoundedVisitor::<T, MAX>(PhantomData))
    }
}

/// `deserialize_with` for a list of at most `MAX` elements ([`Bounded`]).
pub(crate) fn bounded<'de, D, T, const MAX: usize>(d: D) -> Result<Vec<T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    Bounded::<T, MAX>::deserialize(d).map(|list| list.0)
}

/// `deserialize_with` for a matrix of at most `MAX` rows of at most `MAX`
/// numbers ([`Bounded`]).
pub(crate) fn bounded_matrix<'de, D, const MAX: usize>(d: D) -> Result<Vec<Vec<f64>>, D::Error>
where
    D: Deserializer<'de>,
{
    let rows = Bounded::<Bounded<f64, MAX>, MAX>::deserialize(d)?;
    Ok(rows.0.into_iter().map(|row| row.0).collect())
}

/// `deserialize_with` for an object keyed by name: a key given twice is an
/// error (a map would keep the last value silently).
pub(crate) fn unique_map<'de, D, T>(d: D) -> Result<BTreeMap<String, T>, D::Error>
where
    D: Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct UniqueVisitor<T>(PhantomData<T>);
    impl<'de, T: Deserialize<'de>> Visitor<'de> for UniqueVisitor<T> {
        type Value = BTreeMap<String, T>;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("an object")
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Self::Value, A::Error> {
            let mut out = BTreeMap::new();
            while let Some(key) = map.next_key::<String>()? {
                if out.contains_key(&key) {
                    return Err(de::Error::custom(format!(
                        "key {} is given twice",
                        quoted(&key)
                    )));
                }
                let value = map.next_value()?;
                out.insert(key, value);
            }
            Ok(out)
        }
    }
    d.deserialize_map(UniqueVisitor(PhantomData))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize, Serialize, PartialEq)]
    struct Probe {
        #[serde(deserialize_with = "joints")]
        j: [Point3; 6],
        #[serde(deserialize_with = "legs")]
        l: [f64; 6],
    }

    fn probe(j: usize, coords: usize, l: usize) -> String {
        let point = format!("[{}]", vec!["1.5"; coords].join(","));
        format!(
            r#"{{"j": [{}], "l": [{}]}}"#,
            vec![point; j].join(","),
            vec!["2"; l].join(",")
        )
    }

    fn error(json: &str) -> String {
        serde_json::from_str::<Probe>(json).unwrap_err().to_string()
    }

    #[test]
    fn right_shapes_read() {
        let p: Probe = serde_json::from_str(&probe(6, 3, 6)).unwrap();
        assert_eq!(p.j, [[1.5; 3]; 6]);
        assert_eq!(p.l, [2.0; 6]);
    }

    #[test]
    fn wrong_counts_say_what_they_expected() {
        assert!(error(&probe(5, 3, 6)).starts_with("expected 6 joints, found 5"));
        assert!(error(&probe(7, 3, 6)).starts_with("expected 6 joints, found 7"));
        assert!(error(&probe(6, 2, 6)).starts_with("expected 3 coordinates, found 2"));
        assert!(error(&probe(6, 4, 6)).starts_with("expected 3 coordinates, found 4"));
        assert!(error(&probe(6, 3, 0)).starts_with("expected 6 leg lengths, found 0"));
        assert!(error(r#"{"j": 3, "l": []}"#).contains("expected an array of 6 joints"));
    }

    #[test]
    fn fixed_arrays_round_trip_through_postcard() {
        let p = Probe {
            j: [[1.0, -2.0, 3.5]; 6],
            l: [235.0; 6],
        };
        let bytes = postcard::to_stdvec(&p).unwrap();
        assert_eq!(postcard::from_bytes::<Probe>(&bytes).unwrap(), p);
    }
}
