//! Checksums that tie together the files one run writes as a set
//! ([`crate::atomic::write_set`]): one member records the checksum of
//! another (plan.json of plan.csv), so that a reader tells a mismatched
//! pair (a run killed between the renames) from a whole one.

use std::io::{self, Write};
use std::path::Path;

use rayon::prelude::*;
use serde::Serialize;
use serde::ser::SerializeTuple;

use crate::error::{DatasetError, Result};
use crate::input::{open_required, read_json};

/// The checksum of `bytes`: `crc32:` and its CRC-32 in hex, as
/// [`crate::Dataset::checksum`] writes it.
pub fn of_bytes(bytes: &[u8]) -> String {
    let mut crc = Crc32::default();
    crc.0.update(bytes);
    crc.checksum()
}

/// The checksum ([`of_bytes`]) of the regular file `path`, streamed.
pub fn of_file(path: &Path) -> Result<String> {
    let mut file = open_required(path)?.file;
    let mut crc = Crc32::default();
    io::copy(&mut file, &mut crc).map_err(|e| DatasetError::io(path, "read", e))?;
    Ok(crc.checksum())
}

/// How many elements a piece of [`Crc32::of_seq`] encodes.
const PIECE: usize = 1 << 14;

/// A writer that keeps only the CRC-32 of what is written to it: the
/// checksum of a stream of any length in constant memory.
#[derive(Default)]
pub(crate) struct Crc32(crc32fast::Hasher);

impl Crc32 {
    /// The CRC of the sequence `items` in the snapshot's encoding (its
    /// length, then each item in turn, as postcard writes a `Vec`), the
    /// items encoded in pieces on the threads and the pieces' CRCs
    /// combined: the CRC of the same bytes ([`crc32fast::Hasher::combine`]).
    pub(crate) fn of_seq<T: Serialize + Sync>(items: &[T]) -> Self {
        let mut crc = Self::default();
        crc.encode(&items.len());
        let pieces: Vec<Self> = (items.par_chunks(PIECE))
            .map(|piece| {
                let mut crc = Self::default();
                crc.encode_each(piece);
                crc
            })
            .collect();
        for piece in &pieces {
            crc.append(piece);
        }
        crc
    }

    /// `value` in the snapshot's encoding (postcard) written into the CRC
    /// through a buffer, never held whole.
    pub(crate) fn encode<T: Serialize + ?Sized>(&mut self, value: &T) {
        // The buffer, dropped, flushes into the CRC, which takes any bytes.
        let buffer = io::BufWriter::with_capacity(1 << 16, &mut *self);
        let encoded = postcard::to_io(value, buffer);
        drop(encoded.expect("data in memory has a snapshot encoding"));
    }

    /// Each of `values` encoded in turn, as a tuple is: no length first.
    fn encode_each<T: Serialize>(&mut self, values: &[T]) {
        struct EachInTurn<'a, T>(&'a [T]);
        impl<T: Serialize> Serialize for EachInTurn<'_, T> {
            fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
                let mut tuple = serializer.serialize_tuple(self.0.len())?;
                for value in self.0 {
                    tuple.serialize_element(value)?;
                }
                tuple.end()
            }
        }
        self.encode(&EachInTurn(values));
    }

    /// The CRC of what was written here, then of what `other` was given.
    pub(crate) fn append(&mut self, other: &Self) {
        self.0.combine(&other.0);
    }

    /// [`of_bytes`] of everything written.
    pub(crate) fn checksum(self) -> String {
        format!("crc32:{:08x}", self.0.finalize())
    }
}

impl Write for Crc32 {
    fn write(&mut self, bytes: &[u8]) -> io::Result<usize> {
        self.0.update(bytes);
        Ok(bytes.len())
    }

    fn flush(&mut self) -> io::Result<()> {
        Ok(())
    }
}

/// The string `field` of the JSON object in `path` (read within
/// [`crate::JSON_CAP`]): `None` if the file or the field is absent.
pub fn recorded(path: &Path, field: &str) -> Result<Option<String>> {
    let Some(bytes) = read_json(path)? else {
        return Ok(None);
    };
    let value: serde_json::Value = serde_json::from_slice(&bytes)
        .map_err(|e| DatasetError::refused(path, format!("is not JSON: {e}")))?;
    match value.get(field) {
        None => Ok(None),
        Some(serde_json::Value::String(text)) => Ok(Some(text.clone())),
        Some(_) => Err(DatasetError::field(path, field, "is not a string")),
    }
}
