//! Write-behind: a large file's data handed to the device while the rest
//! of it is still being written, so that the sync that makes the file
//! durable before it is renamed into place ([`crate::atomic`]) waits only
//! for what was written last.
//!
//! Once [`SYNC_BEHIND`] bytes have been written since the last sync began,
//! and no sync is running, the data written so far is synced
//! (`File::sync_data`) on a thread of its own, through a handle of the same
//! open file, while the writer goes on; the writer never waits for it.
//! [`WriteBehind::finish`] waits for that sync, returns its error if it
//! failed, and then syncs the whole file. The error must come from the
//! thread that met it: the handles share one open file, to which the
//! kernel reports a failed write-back once. A file shorter than
//! [`SYNC_BEHIND`] is synced once, at the end, as without write-behind.

use std::fs::File;
use std::io::{self, Write};
use std::thread::{self, JoinHandle};

/// The bytes written between two syncs begun behind the writer.
pub const SYNC_BEHIND: u64 = 16 << 20;

/// A file written with its data synced behind the writer (module doc).
#[derive(Debug)]
pub struct WriteBehind<'f> {
    file: &'f File,
    /// Bytes written since the last sync began.
    unsynced: u64,
    /// How many bytes start a sync.
    every: u64,
    /// The sync running on its own thread, if any.
    syncing: Option<JoinHandle<io::Result<()>>>,
}

impl<'f> WriteBehind<'f> {
    /// Writes `file`, a sync begun behind the writer every
    /// [`SYNC_BEHIND`] bytes.
    pub(crate) fn new(file: &'f File) -> Self {
        Self::every(file, SYNC_BEHIND)
    }

    /// Writes `file`, a sync begun behind the writer every `every` bytes.
    fn every(file: &'f File, every: u64) -> Self {
        Self {
            file,
            unsynced: 0,
            every,
            syncing: None,
        }
    }

    /// Waits for the sync behind the writer, returns its error if it
    /// failed, then syncs the whole file (its data and metadata).
    pub(crate) fn finish(mut self) -> io::Result<()> {
        if let Some(syncing) = self.syncing.take() {
            joined(syncing)?;
        }
        self.file.sync_all()
    }

    /// Begins a sync of what is written so far on a thread of its own,
    /// unless one is running (the next write tries again); the error of a
    /// sync that ended is returned here. A handle or thread that cannot be
    /// had leaves the data to [`WriteBehind::finish`]'s sync.
    fn sync_behind(&mut self) -> io::Result<()> {
        if let Some(ended) = self.syncing.take_if(|s| s.is_finished()) {
            joined(ended)?;
        }
        if self.syncing.is_some() {
            return Ok(());
        }
        let Ok(handle) = self.file.try_clone() else {
            return Ok(());
        };
        let spawned = thread::Builder::new()
            .name("parcal-sync".to_string())
            .spawn(move || handle.sync_data());
        if let Ok(syncing) = spawned {
            self.syncing = Some(syncing);
            self.unsynced = 0;
        }
        Ok(())
    }
}

impl Write for WriteBehind<'_> {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let written = self.file.write(buf)?;
        self.unsynced += written as u64;
        if self.unsynced >= self.every {
            self.sync_behind()?;
        }
        Ok(written)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

/// The outcome of the sync `syncing` ran.
fn joined(syncing: JoinHandle<io::Result<()>>) -> io::Result<()> {
    syncing
        .join()
        .unwrap_or_else(|_| Err(io::Error::other("the sync behind the writer panicked")))
}

#[cfg(test)]
mod tests {
    use std::io::{Read, Seek};

    use super::*;

    #[test]
    fn a_file_synced_behind_its_writer_holds_every_byte() {
        let mut file = tempfile::tempfile().unwrap();
        let every = 4096;
        let bytes: Vec<u8> = (0..10 * every + 123).map(|i| (i % 251) as u8).collect();
        let mut writer = WriteBehind::every(&file, every as u64);
        // One write of exactly the threshold begins a sync.
        writer.write_all(&bytes[..every]).unwrap();
        assert!(writer.syncing.is_some());
        assert_eq!(writer.unsynced, 0);
        for piece in bytes[every..].chunks(1000) {
            writer.write_all(piece).unwrap();
        }
        writer.finish().unwrap();
        file.rewind().unwrap();
        let mut read = Vec::new();
        file.read_to_end(&mut read).unwrap();
        assert_eq!(read, bytes);
    }

    #[test]
    fn a_file_shorter_than_the_threshold_begins_no_sync() {
        let file = tempfile::tempfile().unwrap();
        let mut writer = WriteBehind::new(&file);
        writer.write_all(&[7; 1000]).unwrap();
        assert!(writer.syncing.is_none());
        assert_eq!(writer.unsynced, 1000);
        writer.finish().unwrap();
        assert_eq!(file.metadata().unwrap().len(), 1000);
    }
}
