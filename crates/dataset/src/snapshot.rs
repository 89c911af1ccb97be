//! Binary snapshots of a whole [`Dataset`]: postcard, behind a header.
//!
//! Layout (integers little-endian):
//!
//! | bytes | content |
//! |---|---|
//! | 8 | magic `PARCALDS` |
//! | 4 | snapshot version (u32), currently 5 |
//! | 8 | payload length in bytes (u64) |
//! | 4 | CRC-32 (IEEE) of the payload (u32) |
//! | n | payload: the `Dataset` in postcard |
//!
//! The payload is the serde form of the crate's public types, so any change
//! to them must bump [`VERSION`].

use std::io::{Read, Write};
use std::path::Path;

use crate::Dataset;
use crate::atomic::{write_atomic, write_error};
use crate::error::{DatasetError, Result};
use crate::input::{self, Input};

const MAGIC: [u8; 8] = *b"PARCALDS";
/// Version of the snapshot layout and payload.
pub(crate) const VERSION: u32 = 5;
const HEADER_LEN: usize = 8 + 4 + 8 + 4;

/// Writes `dataset` (already validated) to `path` atomically.
pub(crate) fn write(dataset: &Dataset, path: &Path) -> Result<()> {
    let payload = postcard::to_stdvec(dataset)
        .map_err(|e| DatasetError::snapshot(path, format!("cannot encode the dataset: {e}")))?;
    write_atomic(path, |w| {
        let mut header = Vec::with_capacity(HEADER_LEN);
        header.extend_from_slice(&MAGIC);
        header.extend_from_slice(&VERSION.to_le_bytes());
        header.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        header.extend_from_slice(&crc32fast::hash(&payload).to_le_bytes());
        w.write_all(&header)
            .and_then(|()| w.write_all(&payload))
            .map_err(write_error(path))
    })
}

/// Reads a snapshot, refusing anything but an intact one of this version.
/// The payload length in the header is checked against the file's size
/// before the payload is read. The caller validates the dataset.
pub(crate) fn read(path: &Path) -> Result<Dataset> {
    let Input { file, len } = input::open_required(path)?;
    let error = |message: String| DatasetError::snapshot(path, message);
    let read_error = |e| DatasetError::io(path, "read", e);

    let mut header = Vec::with_capacity(HEADER_LEN);
    (&file)
        .take(HEADER_LEN as u64)
        .read_to_end(&mut header)
        .map_err(read_error)?;
    let magic_len = header.len().min(MAGIC.len());
    if header[..magic_len] != MAGIC[..magic_len] {
        return Err(error(
            "is not a parcal dataset snapshot (wrong magic header)".into(),
        ));
    }
    if header.len() < HEADER_LEN {
        return Err(error(format!(
            "is truncated: {} bytes, shorter than the {HEADER_LEN}-byte header",
            header.len()
        )));
    }
    let version = u32::from_le_bytes(header[8..12].try_into().expect("4 bytes"));
    let declared = u64::from_le_bytes(header[12..20].try_into().expect("8 bytes"));
    let crc = u32::from_le_bytes(header[20..24].try_into().expect("4 bytes"));
    if version != VERSION {
        return Err(error(format!(
            "has snapshot version {version}; this parcal reads version {VERSION} \
             (write the snapshot again from the dataset's files)"
        )));
    }
    let check_length = |actual: u64| {
        if actual < declared {
            return Err(error(format!(
                "is truncated: {actual} payload bytes, {declared} expected"
            )));
        }
        if actual > declared {
            return Err(error(format!(
                "is corrupt: {} bytes past the {declared}-byte payload",
                actual - declared
            )));
        }
        Ok(())
    };
    check_length(len.saturating_sub(HEADER_LEN as u64))?;
    // `declared` is the file's real size less the header: nothing larger
    // than the file is allocated, and a file grown since is stopped.
    let mut payload = Vec::with_capacity(usize::try_from(declared).unwrap_or(0));
    (&file)
        .take(declared.saturating_add(1))
        .read_to_end(&mut payload)
        .map_err(read_error)?;
    check_length(payload.len() as u64)?;
    let payload = payload.as_slice();
    if crc32fast::hash(payload) != crc {
        return Err(error("is corrupt: checksum mismatch".into()));
    }
    match postcard::take_from_bytes::<Dataset>(payload) {
        Ok((dataset, [])) => Ok(dataset),
        Ok((_, rest)) => Err(error(format!(
            "is corrupt: {} bytes left after the dataset",
            rest.len()
        ))),
        Err(e) => Err(error(format!("is corrupt: {e}"))),
    }
}

#[cfg(test)]
mod tests {
    use crate::Dataset;

    /// A snapshot with an intact header and checksum but invalid content (it
    /// cannot be made through `Dataset::write_snapshot`) is still refused.
    #[test]
    fn reading_validates_the_content() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.parcal");
        let mut dataset = Dataset::read(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../fixtures/reference-paper-seed1"),
        )
        .unwrap();
        let valid = dataset.clone();
        dataset.measurements.ball[10] = 99;
        super::write(&dataset, &path).unwrap();
        assert_eq!(
            Dataset::read_snapshot(&path).unwrap_err().to_string(),
            format!(
                "{}: line 12, column ball: ball index 99 is out of range (27 balls)",
                path.display()
            )
        );
        // As the text reader does: a ball with fewer than 4 contacts, a
        // zero approach direction.
        let mut dataset = valid.clone();
        let first: Vec<usize> = (0..dataset.measurements.len())
            .filter(|&r| dataset.measurements.ball[r] == 0)
            .skip(3)
            .collect();
        for &r in first.iter().rev() {
            dataset.measurements.ball.remove(r);
            dataset.measurements.q.remove(r);
            if let Some(truth) = &mut dataset.truth {
                truth.contacts.remove(r);
            }
        }
        super::write(&dataset, &path).unwrap();
        let id = &dataset.artefacts.balls[0].id;
        assert_eq!(
            Dataset::read_snapshot(&path).unwrap_err().to_string(),
            format!(
                "{}: ball \"{id}\" has 3 contacts, fewer than the minimum of 4",
                path.display()
            )
        );
        let mut dataset = valid;
        dataset.measurements.direction = Some(vec![[0.0, 0.0, -1.0]; dataset.measurements.len()]);
        dataset.measurements.direction.as_mut().unwrap()[4] = [0.0; 3];
        super::write(&dataset, &path).unwrap();
        assert_eq!(
            Dataset::read_snapshot(&path).unwrap_err().to_string(),
            format!(
                "{}: line 6: the approach direction (0, 0, 0) is zero, not a direction",
                path.display()
            )
        );
    }
}
