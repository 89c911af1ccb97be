//! An object's fields with some taken out on the way: the top-level
//! `format` of every file ([`crate::json`]) and the geometry's fields at the
//! top level of `machine.json` and `truth.json` ([`crate::geometry`]).

use serde::de::value::StringDeserializer;
use serde::de::{DeserializeSeed, Deserializer, MapAccess, Visitor};

/// The fields of `map` that `take` leaves: `take(key, map)` reads the value
/// of a key it wants from `map` and answers `true`; the other keys are
/// handed on, as a map to visit or as a deserializer of one.
pub(crate) struct TakeFields<A, F> {
    /// The object being read.
    pub map: A,
    /// Reads the value of a key it wants; `false` for the others.
    pub take: F,
}

impl<'de, A, F> MapAccess<'de> for TakeFields<A, F>
where
    A: MapAccess<'de>,
    F: FnMut(&str, &mut A) -> Result<bool, A::Error>,
{
    type Error = A::Error;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, A::Error> {
        while let Some(key) = self.map.next_key::<String>()? {
            if !(self.take)(&key, &mut self.map)? {
                return seed.deserialize(StringDeserializer::new(key)).map(Some);
            }
        }
        Ok(None)
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, A::Error> {
        self.map.next_value_seed(seed)
    }
}

impl<'de, A, F> Deserializer<'de> for &mut TakeFields<A, F>
where
    A: MapAccess<'de>,
    F: FnMut(&str, &mut A) -> Result<bool, A::Error>,
{
    type Error = A::Error;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, A::Error> {
        visitor.visit_map(self)
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map struct enum identifier ignored_any
    }
}
