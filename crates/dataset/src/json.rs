//! Reading and writing the JSON files of the format: the `format` field,
//! serde errors mapped to file + field, pretty deterministic output.

use std::fmt;
use std::io::{self, Write};
use std::marker::PhantomData;
use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;
use serde::de::{
    self, DeserializeOwned, DeserializeSeed, Deserializer, IgnoredAny, MapAccess, Visitor,
};
use serde::ser::{SerializeMap, SerializeSeq, Serializer};
use serde_json::error::Category;
use serde_json::value::{RawValue, to_raw_value};

use crate::atomic::{write_atomic, write_error};
use crate::error::{DatasetError, Result};
use crate::fields::TakeFields;
use crate::input;
use crate::quote::sanitized;

/// The kind of a JSON file, as named by its `format` field.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Kind {
    /// E.g. `parcal-machine`.
    name: &'static str,
    /// What this crate writes, e.g. `parcal-machine/1` (major version
    /// [`MAJOR`], with a minor version where the format has changed within
    /// it).
    current: &'static str,
    /// The nesting depth (the document is depth 1) from which arrays and
    /// objects are written on one line ([`Layout`]); `usize::MAX`: none.
    one_line_from: usize,
}

pub(crate) const MACHINE: Kind = Kind {
    name: "parcal-machine",
    current: "parcal-machine/1",
    one_line_from: usize::MAX,
};
pub(crate) const ARTEFACTS: Kind = Kind {
    name: "parcal-artefacts",
    current: "parcal-artefacts/1",
    one_line_from: usize::MAX,
};
pub(crate) const TRUTH: Kind = Kind {
    name: "parcal-truth",
    current: "parcal-truth/1",
    one_line_from: usize::MAX,
};
pub(crate) const CALIBRATION: Kind = Kind {
    name: "parcal-calibration",
    current: "parcal-calibration/1",
    one_line_from: usize::MAX,
};
pub(crate) const MECHANISM_TRUTH: Kind = Kind {
    name: "parcal-mechanism-truth",
    current: "parcal-mechanism-truth/1",
    one_line_from: usize::MAX,
};
pub(crate) const MECHANISM_CALIBRATION: Kind = Kind {
    name: "parcal-mechanism-calibration",
    current: "parcal-mechanism-calibration/1.6",
    one_line_from: 4,
};
pub(crate) const MECHANISM_VALIDATION: Kind = Kind {
    name: "parcal-mechanism-validation",
    current: "parcal-mechanism-validation/1",
    one_line_from: usize::MAX,
};
pub(crate) const VALIDATION: Kind = Kind {
    name: "parcal-validation",
    current: "parcal-validation/1",
    one_line_from: usize::MAX,
};

/// The major version this crate reads.
const MAJOR: u64 = 1;

impl Kind {
    /// Accepts `NAME/1` and `NAME/1.N`; says what is wrong otherwise.
    fn check(self, path: &Path, format: &str) -> Result<()> {
        let error = |message: String| DatasetError::Format {
            path: path.to_path_buf(),
            format: format.to_owned(),
            message,
        };
        let malformed = || {
            let name = self.name;
            error(format!(
                "is not a {name} format (expected \"{name}/{MAJOR}\" or \"{name}/{MAJOR}.N\")"
            ))
        };
        let (name, version) = format.split_once('/').ok_or_else(malformed)?;
        if name != self.name {
            return Err(if name.starts_with("parcal-") {
                error(format!("is a {name} file, not a {} file", self.name))
            } else {
                malformed()
            });
        }
        let (major, minor) = version.split_once('.').unwrap_or((version, "0"));
        let is_number = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
        if !is_number(major) || !is_number(minor) {
            return Err(malformed());
        }
        match major.parse::<u64>() {
            Ok(MAJOR) => Ok(()),
            _ => Err(error(format!(
                "has unknown major version {major}; this parcal reads version {MAJOR}"
            ))),
        }
    }
}

/// Reads a required JSON file of the given kind.
pub(crate) fn read<T: DeserializeOwned>(path: &Path, kind: Kind) -> Result<T> {
    match read_if_present(path, kind)? {
        Some(value) => Ok(value),
        None => Err(DatasetError::MissingFile {
            path: path.to_path_buf(),
        }),
    }
}

/// Reads an optional JSON file of the given kind: `None` if it does not exist.
pub(crate) fn read_if_present<T: DeserializeOwned>(path: &Path, kind: Kind) -> Result<Option<T>> {
    read_if_present_with(path, kind, PhantomData::<T>)
}

/// [`read_if_present`] of the value `seed` reads (what it needs beside the
/// file, such as the balls' index).
pub(crate) fn read_if_present_with<S, V>(path: &Path, kind: Kind, seed: S) -> Result<Option<V>>
where
    S: for<'de> DeserializeSeed<'de, Value = V> + Clone,
{
    match input::read_json(path)? {
        Some(bytes) => parse(path, kind, &bytes, seed).map(Some),
        None => Ok(None),
    }
}

/// Parses the bytes of a JSON file of the given kind into the value `seed`
/// reads: the `format` first (so that a file of another version is refused
/// as such), then the body. A leading UTF-8 byte order mark is skipped.
fn parse<S, V>(path: &Path, kind: Kind, bytes: &[u8], seed: S) -> Result<V>
where
    S: for<'de> DeserializeSeed<'de, Value = V> + Clone,
{
    let bytes = bytes.strip_prefix(input::BOM).unwrap_or(bytes);
    let format = format_field(path, bytes)?;
    kind.check(path, &format)?;
    deserialize(path, bytes, seed)
}

/// The `format` field of a JSON document that must be an object, read only
/// as far as that field: the files this crate writes open with it, so the
/// rest of a large file is scanned once, by the body's parse (truth.json of
/// a 10^6-contact campaign holds 90 MB of contact points). Whatever follows
/// the field, syntax errors and a second `format` included, is the body's
/// parse to report ([`WithoutFormat`]).
fn format_field(path: &Path, bytes: &[u8]) -> Result<String> {
    /// How far the scan got.
    enum Format {
        NotSeen,
        /// The key, not yet its value.
        Key,
        Value(String),
    }
    struct FormatVisitor<'f>(&'f mut Format);
    impl<'de> Visitor<'de> for FormatVisitor<'_> {
        type Value = ();
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("a JSON object with a \"format\" field")
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
            while let Some(key) = map.next_key::<String>()? {
                if key == "format" {
                    // Stop here: serde_json then reports the unread rest
                    // as an error, which the format found makes moot.
                    *self.0 = Format::Key;
                    *self.0 = Format::Value(map.next_value()?);
                    return Ok(());
                }
                map.next_value::<IgnoredAny>()?;
            }
            Ok(())
        }
    }
    let mut format = Format::NotSeen;
    let scanned =
        serde_json::Deserializer::from_slice(bytes).deserialize_map(FormatVisitor(&mut format));
    match (format, scanned) {
        (Format::Value(format), _) => Ok(format),
        (Format::Key, Err(e)) => Err(map_error(path, Some("format".to_owned()), e)),
        (Format::NotSeen, Err(e)) => Err(map_error(path, None, e)),
        (_, Ok(())) => Err(DatasetError::field(
            path,
            "format",
            "required field is missing",
        )),
    }
}

/// The body of a JSON document. Parsed first without tracking the field
/// path, which costs on every element of a large file (a tenth of reading
/// a 10^6-contact campaign's JSON); a document that fails is parsed again
/// with it, so that the error names the field.
fn deserialize<S, V>(path: &Path, bytes: &[u8], seed: S) -> Result<V>
where
    S: for<'de> DeserializeSeed<'de, Value = V> + Clone,
{
    let mut de = serde_json::Deserializer::from_slice(bytes);
    if let Ok(value) = seed.clone().deserialize(WithoutFormat(&mut de))
        && de.end().is_ok()
    {
        return Ok(value);
    }
    let mut de = serde_json::Deserializer::from_slice(bytes);
    let mut track = serde_path_to_error::Track::new();
    let tracked = serde_path_to_error::Deserializer::new(&mut de, &mut track);
    let value = seed.deserialize(WithoutFormat(tracked)).map_err(|e| {
        let at = track.path();
        let field = at.iter().next().map(|_| at.to_string());
        map_error(path, field, e)
    })?;
    de.end().map_err(|e| map_error(path, None, e))?;
    Ok(value)
}

/// A document's top-level object without its `format` field, which the
/// body's types do not have (and would ignore): the field was judged by
/// [`format_field`], and a second one is refused as a duplicate, as any
/// other field given twice is.
struct WithoutFormat<D>(D);

impl<'de, D: Deserializer<'de>> Deserializer<'de> for WithoutFormat<D> {
    type Error = D::Error;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, D::Error> {
        self.0.deserialize_map(SkipFormat(visitor))
    }

    serde::forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map struct enum identifier ignored_any
    }
}

/// The visitor of the body, given the object without its `format`.
struct SkipFormat<V>(V);

impl<'de, V: Visitor<'de>> Visitor<'de> for SkipFormat<V> {
    type Value = V::Value;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        self.0.expecting(f)
    }

    fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<V::Value, A::Error> {
        let mut seen = false;
        let take = |key: &str, map: &mut A| -> Result<bool, A::Error> {
            if key != "format" {
                return Ok(false);
            }
            if std::mem::replace(&mut seen, true) {
                return Err(de::Error::duplicate_field("format"));
            }
            map.next_value::<IgnoredAny>()?;
            Ok(true)
        };
        self.0.visit_map(TakeFields { map, take })
    }
}

/// Turns a serde_json error, and the path of the field where it happened
/// (`None` at the top level), into one sentence naming the file, the field
/// and the line.
fn map_error(path: &Path, field: Option<String>, inner: serde_json::Error) -> DatasetError {
    // serde_json reports column 0 when the error is before a line's first
    // character.
    let (line, column) = (inner.line(), inner.column().max(1));
    let category = inner.classify();
    let message = sanitized(&strip_location(&inner));
    let field = field.map(|f| sanitized(&f));
    let top_level = |message: String| DatasetError::Json {
        path: path.to_path_buf(),
        line,
        column,
        message,
    };
    if let (Category::Data, Some(name)) = (category, missing_field(&message)) {
        let field = match field {
            Some(parent) => format!("{parent}.{name}"),
            None => name.to_owned(),
        };
        return DatasetError::field(path, field, "required field is missing");
    }
    match (category, field) {
        (Category::Io, _) => DatasetError::io(path, "read", inner.into()),
        (Category::Data, None) => top_level(message),
        (Category::Data, Some(field)) => {
            DatasetError::field(path, field, located(&message, line, column))
        }
        // The field path of a syntax error is unreliable (often `?`): the
        // line and column say where it is.
        (Category::Syntax | Category::Eof, _) => top_level(format!("invalid JSON: {message}")),
    }
}

fn located(message: &str, line: usize, column: usize) -> String {
    format!("{message} (line {line}, column {column})")
}

/// serde_json's message without its " at line L column C" suffix.
fn strip_location(error: &serde_json::Error) -> String {
    let full = error.to_string();
    let suffix = format!(" at line {} column {}", error.line(), error.column());
    full.strip_suffix(&suffix).unwrap_or(&full).to_owned()
}

/// The field name in serde's "missing field `name`" message.
fn missing_field(message: &str) -> Option<&str> {
    message.strip_prefix("missing field `")?.strip_suffix('`')
}

/// Writes `body` to `path` atomically as pretty JSON (indent 1, [`Layout`]),
/// preceded by the `format` field of `kind`. Field order is the order of
/// declaration, so the same data always gives the same bytes.
pub(crate) fn write<T: Serialize>(path: &Path, kind: Kind, body: &T) -> Result<()> {
    write_atomic(path, |w| serialize_document(path, w, kind, body))
}

/// The text [`write`] writes of `body` (errors name `path`).
pub(crate) fn text<T: Serialize>(path: &Path, kind: Kind, body: &T) -> Result<String> {
    let mut bytes = Vec::new();
    serialize_document(path, &mut bytes, kind, body)?;
    String::from_utf8(bytes).map_err(|e| {
        DatasetError::io(
            path,
            "write",
            std::io::Error::new(std::io::ErrorKind::InvalidData, e),
        )
    })
}

/// [`write`], with `check` run beside the writing: if it fails, its error
/// is returned (before any error of the writing) and nothing is written.
pub(crate) fn write_checked<T: Serialize>(
    path: &Path,
    kind: Kind,
    body: &T,
    check: impl FnOnce() -> Result<()> + Send,
) -> Result<()> {
    let mut check = Some(check);
    let written = write_atomic(path, |w| {
        let mut checked = Ok(());
        let serialized = rayon::in_place_scope(|scope| {
            if let Some(check) = check.take() {
                scope.spawn(|_| checked = check());
            }
            serialize_document(path, w, kind, body)
        });
        checked.and(serialized)
    });
    // A file that could not be staged was not checked yet.
    match check {
        Some(check) => check().and(written),
        None => written,
    }
}

/// Serializes `body` into `w`: its document as [`write`] describes it.
fn serialize_document<T: Serialize>(
    path: &Path,
    mut w: impl Write,
    kind: Kind,
    body: &T,
) -> Result<()> {
    #[derive(Serialize)]
    struct Versioned<'a, T> {
        format: &'static str,
        #[serde(flatten)]
        body: &'a T,
    }
    let document = Versioned {
        format: kind.current,
        body,
    };
    let formatter = Layout::new(kind.one_line_from);
    let mut serializer = serde_json::Serializer::with_formatter(&mut w, formatter);
    document
        .serialize(&mut serializer)
        .map_err(|e| DatasetError::io(path, "write", e.into()))?;
    w.write_all(b"\n").map_err(write_error(path))
}

/// How many elements of a few hundred bytes (a ball's record) a wave of
/// [`serialize_seq_on_threads`] or [`serialize_map_on_threads`] formats:
/// about a megabyte.
pub(crate) const ELEMENTS_A_WAVE: usize = 4096;

/// Serializes the list `element(0)`, ..., `element(len - 1)` into
/// `serializer`, a JSON one, each element on one line (as compact JSON,
/// under any layout) and formatted on the threads ([`in_waves`]): the same
/// bytes as writing each in turn as compact JSON (a calibration's
/// observation records of 10^6 touches, its 10^5 balls). JSON only:
/// another format would write each element as a [`RawValue`].
pub(crate) fn serialize_seq_on_threads<S, T>(
    serializer: S,
    len: usize,
    wave: usize,
    element: impl Fn(usize) -> T + Sync,
) -> std::result::Result<S::Ok, S::Error>
where
    S: Serializer,
    T: Serialize,
{
    let mut seq = serializer.serialize_seq(Some(len))?;
    in_waves::<S::Error, _>(len, wave, element, |_, raw| seq.serialize_element(raw))?;
    seq.end()
}

/// Serializes the map of the entries `entry(0)`, ..., `entry(len - 1)`
/// (key, value) into `serializer`, as [`serialize_seq_on_threads`] does a
/// list: each value on one line, formatted on the threads, each key
/// written in turn.
pub(crate) fn serialize_map_on_threads<S, K, V>(
    serializer: S,
    len: usize,
    wave: usize,
    entry: impl Fn(usize) -> (K, V) + Sync,
) -> std::result::Result<S::Ok, S::Error>
where
    S: Serializer,
    K: Serialize,
    V: Serialize,
{
    let mut map = serializer.serialize_map(Some(len))?;
    in_waves::<S::Error, _>(
        len,
        wave,
        |k| entry(k).1,
        |k, raw| map.serialize_entry(&entry(k).0, raw),
    )?;
    map.end()
}

/// `value(0)`, ..., `value(len - 1)` formatted as compact JSON and handed
/// in order to `write` with their index: each wave of `wave` values (at
/// least one) formatted on the threads while the wave before is written
/// (and the one before that freed).
fn in_waves<E: serde::ser::Error, T: Serialize>(
    len: usize,
    wave: usize,
    value: impl Fn(usize) -> T + Sync,
    mut write: impl FnMut(usize, &RawValue) -> std::result::Result<(), E>,
) -> std::result::Result<(), E> {
    let wave = wave.max(1);
    let format = |start: usize| -> serde_json::Result<Vec<Box<RawValue>>> {
        (start..len.min(start + wave))
            .into_par_iter()
            .map(|k| to_raw_value(&value(k)))
            .collect()
    };
    let mut write_wave = |start: usize, formatted: &[Box<RawValue>]| {
        (formatted.iter().enumerate()).try_for_each(|(j, raw)| write(start + j, raw))
    };
    // The wave being written (from `at`), and the one written before it.
    let (mut at, mut formatted, mut written) = (0, Vec::new(), Vec::new());
    for start in (0..len).step_by(wave) {
        let mut next = Ok(Vec::new());
        rayon::in_place_scope(|scope| {
            scope.spawn(|_| {
                drop(written);
                next = format(start);
            });
            write_wave(at, &formatted)
        })?;
        written = std::mem::replace(&mut formatted, next.map_err(E::custom)?);
        at = start;
    }
    write_wave(at, &formatted)
}

/// serde_json's pretty layout (indent 1, a value per line) down to the
/// depth `one_line_from`, and from there each array or object on one line,
/// as compact JSON: a calibration's million observation records one per
/// line, at half the bytes of a value per line.
struct Layout {
    /// The depth from which containers go on one line.
    one_line_from: usize,
    /// The containers open.
    depth: usize,
    /// The indentation of the pretty part.
    indent: usize,
    /// Whether the innermost pretty container has a value yet.
    has_value: bool,
}

impl Layout {
    fn new(one_line_from: usize) -> Self {
        Self {
            one_line_from,
            depth: 0,
            indent: 0,
            has_value: false,
        }
    }

    /// Whether the innermost open container is on one line.
    fn one_line(&self) -> bool {
        self.depth >= self.one_line_from
    }

    /// Opens a container with `bracket`.
    fn open<W: ?Sized + io::Write>(&mut self, w: &mut W, bracket: &[u8]) -> io::Result<()> {
        self.depth += 1;
        if !self.one_line() {
            self.indent += 1;
            self.has_value = false;
        }
        w.write_all(bracket)
    }

    /// Closes the innermost container with `bracket`.
    fn close<W: ?Sized + io::Write>(&mut self, w: &mut W, bracket: &[u8]) -> io::Result<()> {
        if !self.one_line() {
            self.indent -= 1;
            if self.has_value {
                w.write_all(b"\n")?;
                self.write_indent(w)?;
            }
        }
        self.depth -= 1;
        w.write_all(bracket)
    }

    /// Starts a value of an array, or a key of an object.
    fn item<W: ?Sized + io::Write>(&mut self, w: &mut W, first: bool) -> io::Result<()> {
        if self.one_line() {
            return if first { Ok(()) } else { w.write_all(b",") };
        }
        w.write_all(if first { b"\n" } else { b",\n" })?;
        self.write_indent(w)
    }

    /// Ends a value of the innermost container.
    fn item_done(&mut self) {
        if !self.one_line() {
            self.has_value = true;
        }
    }

    fn write_indent<W: ?Sized + io::Write>(&self, w: &mut W) -> io::Result<()> {
        for _ in 0..self.indent {
            w.write_all(b" ")?;
        }
        Ok(())
    }
}

impl serde_json::ser::Formatter for Layout {
    fn begin_array<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.open(w, b"[")
    }

    fn end_array<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.close(w, b"]")
    }

    fn begin_array_value<W: ?Sized + io::Write>(
        &mut self,
        w: &mut W,
        first: bool,
    ) -> io::Result<()> {
        self.item(w, first)
    }

    fn end_array_value<W: ?Sized + io::Write>(&mut self, _w: &mut W) -> io::Result<()> {
        self.item_done();
        Ok(())
    }

    fn begin_object<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.open(w, b"{")
    }

    fn end_object<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.close(w, b"}")
    }

    fn begin_object_key<W: ?Sized + io::Write>(
        &mut self,
        w: &mut W,
        first: bool,
    ) -> io::Result<()> {
        self.item(w, first)
    }

    fn begin_object_value<W: ?Sized + io::Write>(&mut self, w: &mut W) -> io::Result<()> {
        w.write_all(if self.one_line() { b":" } else { b": " })
    }

    fn end_object_value<W: ?Sized + io::Write>(&mut self, _w: &mut W) -> io::Result<()> {
        self.item_done();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    /// `value` written with `formatter`.
    fn written<F: serde_json::ser::Formatter>(value: &serde_json::Value, formatter: F) -> String {
        let mut bytes = Vec::new();
        let mut serializer = serde_json::Serializer::with_formatter(&mut bytes, formatter);
        value.serialize(&mut serializer).unwrap();
        String::from_utf8(bytes).unwrap()
    }

    #[test]
    fn the_layout_is_serde_jsons_pretty_one_down_to_its_depth_then_one_line() {
        let value = serde_json::json!({
            "a": [1.5, [], {}, {"b": [2, 3], "c": {"d": null}}],
            "e": {"f": [[4, 5], [6]], "g": "h"},
            "i": []
        });
        let pretty = written(&value, serde_json::ser::PrettyFormatter::with_indent(b" "));
        assert_eq!(written(&value, Layout::new(usize::MAX)), pretty);
        let layout = written(&value, Layout::new(3));
        assert_eq!(
            layout,
            "{\n \"a\": [\n  1.5,\n  [],\n  {},\n  {\"b\":[2,3],\"c\":{\"d\":null}}\n ],\n \"e\": {\n  \"f\": [[4,5],[6]],\n  \"g\": \"h\"\n },\n \"i\": []\n}"
        );
        let read: serde_json::Value = serde_json::from_str(&layout).unwrap();
        assert_eq!(read, value);
    }

    /// A list or a map of more than two waves, formatted on the threads,
    /// is its elements written in turn, each on one line: the same bytes
    /// as [`Layout`] writes where its containers go on one line, and as
    /// compact JSON; the same value under a pretty layout; empty, and in
    /// any number of threads.
    #[test]
    fn a_list_or_map_formatted_on_the_threads_is_written_as_in_turn() {
        const WAVE: usize = 64;
        struct List<'a>(&'a [serde_json::Value]);
        impl Serialize for List<'_> {
            fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                serialize_seq_on_threads(s, self.0.len(), WAVE, |k| &self.0[k])
            }
        }
        struct Map<'a>(&'a [serde_json::Value]);
        impl Serialize for Map<'_> {
            fn serialize<S: Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
                serialize_map_on_threads(s, self.0.len(), WAVE, |k| (key(k), &self.0[k]))
            }
        }
        fn key(k: usize) -> String {
            format!("k{k:04}")
        }
        #[derive(Serialize)]
        struct Document<'a> {
            list: List<'a>,
            map: Map<'a>,
        }
        let elements: Vec<serde_json::Value> = (0..2 * WAVE + 5)
            .map(|k| serde_json::json!({"k": k, "x": [k as f64 / 7.0, null], "s": "a\"b"}))
            .collect();
        for threads in [1, 2, 3] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            for list in [&elements[..], &elements[..3], &[]] {
                let map: serde_json::Map<String, serde_json::Value> = (list.iter().enumerate())
                    .map(|(k, v)| (key(k), v.clone()))
                    .collect();
                let in_turn = serde_json::json!({ "list": list, "map": map });
                let laid_out = |one_line_from: usize| {
                    let mut bytes = Vec::new();
                    let layout = Layout::new(one_line_from);
                    let mut serializer = serde_json::Serializer::with_formatter(&mut bytes, layout);
                    let document = Document {
                        list: List(list),
                        map: Map(list),
                    };
                    pool.install(|| document.serialize(&mut serializer).unwrap());
                    String::from_utf8(bytes).unwrap()
                };
                let one_line = laid_out(3);
                assert_eq!(
                    one_line,
                    written(&in_turn, Layout::new(3)),
                    "{threads} threads"
                );
                let pretty = laid_out(usize::MAX);
                let read: serde_json::Value = serde_json::from_str(&pretty).unwrap();
                assert_eq!(read, in_turn);
                // Each element on a line of its own, as compact JSON.
                let lines: Vec<&str> = pretty.lines().map(str::trim).collect();
                for (k, element) in list.iter().enumerate() {
                    let compact = serde_json::to_string(element).unwrap();
                    let comma = if k + 1 < list.len() { "," } else { "" };
                    assert!(lines.contains(&format!("{compact}{comma}").as_str()));
                    let entry = format!("\"{}\": {compact}{comma}", key(k));
                    assert!(lines.contains(&entry.as_str()), "{entry}");
                }
                let compact = pool.install(|| serde_json::to_string(&List(list)).unwrap());
                assert_eq!(compact, serde_json::to_string(list).unwrap());
            }
        }
    }

    fn check(format: &str) -> Result<()> {
        MACHINE.check(Path::new("machine.json"), format)
    }

    #[test]
    fn accepts_version_1_and_its_minor_versions() {
        check("parcal-machine/1").unwrap();
        check("parcal-machine/1.0").unwrap();
        check("parcal-machine/1.17").unwrap();
    }

    #[test]
    fn refuses_an_unknown_major_version() {
        assert_eq!(
            check("parcal-machine/2").unwrap_err().to_string(),
            "machine.json: format \"parcal-machine/2\" has unknown major version 2; \
             this parcal reads version 1"
        );
        assert!(check("parcal-machine/0.9").is_err());
        assert!(check("parcal-machine/2.1").is_err());
    }

    #[test]
    fn refuses_another_kind_or_a_malformed_format() {
        assert_eq!(
            check("parcal-truth/1").unwrap_err().to_string(),
            "machine.json: format \"parcal-truth/1\" is a parcal-truth file, \
             not a parcal-machine file"
        );
        for bad in [
            "",
            "parcal-machine",
            "parcal-machine/",
            "parcal-machine/1.",
            "x/1",
            "parcal-machine/v1",
            "parcal-machine/1.2.3",
        ] {
            let err = check(bad).unwrap_err().to_string();
            assert!(
                err.contains("is not a parcal-machine format"),
                "{bad}: {err}"
            );
        }
    }

    #[derive(Debug, Deserialize, Serialize)]
    struct Body {
        a: f64,
        inner: Inner,
    }
    #[derive(Debug, Deserialize, Serialize)]
    struct Inner {
        b: Vec<f64>,
    }

    fn parse_err(json: &str) -> String {
        parse(
            Path::new("x.json"),
            MACHINE,
            json.as_bytes(),
            PhantomData::<Body>,
        )
        .unwrap_err()
        .to_string()
    }

    #[test]
    fn the_format_is_found_wherever_it_is_and_judged_before_the_body() {
        let body = r#""a": 1, "inner": {"b": [2]}"#;
        let parse_ok = |json: &str| {
            parse(
                Path::new("x.json"),
                MACHINE,
                json.as_bytes(),
                PhantomData::<Body>,
            )
        };
        for json in [
            format!(r#"{{"format": "parcal-machine/1", {body}}}"#),
            format!(r#"{{{body}, "format": "parcal-machine/1.3"}}"#),
        ] {
            let parsed = parse_ok(&json).unwrap();
            assert_eq!((parsed.a, parsed.inner.b), (1.0, vec![2.0]));
        }
        // A file of another version is refused as such, whatever follows
        // its format field; what precedes the field must be valid JSON.
        assert!(
            parse_err(r#"{"format": "parcal-machine/2", "a": [1,, "#)
                .contains("has unknown major version 2")
        );
        assert!(
            parse_err(r#"{"format": "parcal-machine/1", "a": 1, "inner": {"b": [1,, "#)
                .contains("invalid JSON: expected value")
        );
        assert!(parse_err(r#"{"a": [1,, "format": "parcal-machine/2"}"#).contains("invalid JSON"));
        assert!(parse_err(r#"[{"format": "parcal-machine/1"}]"#).contains("a JSON object"));
        assert_eq!(
            parse_err(r#"{"format": 1}"#),
            "x.json: field format: invalid type: integer `1`, expected a string (line 1, column 12)"
        );
    }

    #[test]
    fn a_second_format_field_is_refused_like_any_duplicate() {
        let body = r#""a": 1, "inner": {"b": [2]}"#;
        for json in [
            format!(
                "{{\"format\": \"parcal-machine/1\", {body},\n \"format\": \"parcal-truth/1\"}}"
            ),
            format!(
                "{{\"format\": \"parcal-machine/1\", {body},\n \"format\": \"parcal-machine/1\"}}"
            ),
        ] {
            assert_eq!(
                parse_err(&json),
                "x.json: line 2, column 9: duplicate field `format`"
            );
        }
        assert_eq!(
            parse_err(&format!(
                r#"{{"format": "parcal-machine/1", {body}, "a": 2}}"#
            )),
            "x.json: line 1, column 63: duplicate field `a`"
        );
    }

    #[test]
    fn quoted_input_is_escaped_and_shortened() {
        let f = r#""format": "parcal-machine/1""#;
        let long = r"\u001b[31m".repeat(100_000);
        let err = parse_err(&format!(r#"{{{f}, "a": "{long}", "inner": {{"b": []}}}}"#));
        assert!(err.len() < 400, "{err}");
        assert!(!err.contains('\u{1b}'), "{err}");
        assert!(
            err.starts_with("x.json: field a: invalid type: string \"\\u{1b}[31m"),
            "{err}"
        );
        assert!(
            err.ends_with("\", expected f64 (line 1, column 1000038)"),
            "{err}"
        );
        let err = parse_err(&format!(r#"{{"format": "{long}"}}"#));
        assert!(err.len() < 400 && !err.contains('\u{1b}'), "{err}");
    }

    #[test]
    fn errors_name_the_field() {
        let f = r#""format": "parcal-machine/1""#;
        assert_eq!(
            parse_err(&format!(r#"{{{f}, "inner": {{"b": []}}}}"#)),
            "x.json: field a: required field is missing"
        );
        assert_eq!(
            parse_err(&format!(r#"{{{f}, "a": 1, "inner": {{}}}}"#)),
            "x.json: field inner.b: required field is missing"
        );
        assert_eq!(
            parse_err(&format!(r#"{{{f}, "a": 1, "inner": {{"b": [1, "x"]}}}}"#)),
            "x.json: field inner.b[1]: invalid type: string \"x\", expected f64 (line 1, column 61)"
        );
        assert_eq!(
            parse_err(r#"{"a": 1}"#),
            "x.json: field format: required field is missing"
        );
        assert_eq!(
            parse_err("{"),
            "x.json: line 1, column 1: invalid JSON: EOF while parsing an object"
        );
        assert!(
            parse_err(&format!(r#"{{{f}, "a": 1, "inner": {{"b": []}}}} x"#))
                .contains("invalid JSON: trailing characters")
        );
        assert!(
            parse_err(&format!(r#"{{{f}, "a": NaN}}"#)).contains("invalid JSON"),
            "NaN is not JSON"
        );
        assert!(parse_err(&format!(r#"{{{f}, "a": 1e999}}"#)).contains("number out of range"));
    }
}
