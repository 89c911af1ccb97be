//! A whole dataset: one directory, or one binary snapshot.

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::artefacts::ball_index;
use crate::atomic;
use crate::check::Check;
use crate::checksum::Crc32;
use crate::error::{DatasetError, Result};
use crate::truth::TruthFile;
use crate::{
    ARTEFACTS_FILE, Artefacts, MACHINE_FILE, MEASUREMENTS_FILE, Machine, Measurements, POINTS_FILE,
    POSES_FILE, TRUTH_FILE, Tracker, Truth, snapshot,
};

/// A dataset: the machine, the artefacts and ball touches, the poses and
/// points measured by instruments and, for simulated datasets, the truth.
/// Ball touches (`artefacts.json` with `measurements.csv`), instrument
/// measurements (`poses.csv`, `points.csv`) or both; whatever is absent is
/// empty.
///
/// Every `Dataset` this crate returns is valid: values finite, sigmas and
/// radii positive, ball ids unique, indices in range, one truth contact per
/// measurement row (none if read without them,
/// [`ReadOptions::true_contacts`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Dataset {
    /// `machine.json`.
    pub machine: Machine,
    /// `artefacts.json`.
    pub artefacts: Artefacts,
    /// `measurements.csv`.
    pub measurements: Measurements,
    /// `poses.csv` and `points.csv`, with their sessions.
    #[serde(default)]
    pub tracker: Tracker,
    /// `truth.json`, if present.
    pub truth: Option<Truth>,
}

/// Options of [`Dataset::write_with`].
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct WriteOptions {
    /// Replace an existing, non-empty dataset directory as a whole (its
    /// other files, e.g. a calibration of the old data, go with it).
    /// Without it such a directory is an error.
    pub replace: bool,
    /// Also write a binary snapshot ([`Dataset::write_snapshot`]) under this
    /// file name in the directory, as part of the set.
    pub snapshot: Option<String>,
}

/// Options of [`Dataset::read_with`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadOptions {
    /// A ball with fewer contacts than this is an error (a ball with no
    /// contact too, unless this is 0). Default [`MIN_CONTACTS_PER_BALL`].
    pub min_contacts_per_ball: usize,
    /// Whether `truth.json`'s contact points are read: without them (they
    /// are skipped unparsed and [`Truth::contacts`] is empty) a simulated
    /// dataset's truth holds what judges a calibration, its geometry and
    /// balls, and reads in a fraction of the time; such a dataset cannot
    /// be written or validated with its truth. Default `true`.
    pub true_contacts: bool,
}

/// The least number of contacts per ball of a dataset that is written,
/// read from a snapshot or validated, and of one read by default
/// ([`ReadOptions::default`]): on a sphere of known radius three points
/// leave a mirror ambiguity, and a ball's initial centre is the best fit
/// of at least four.
pub const MIN_CONTACTS_PER_BALL: usize = 4;

impl Default for ReadOptions {
    fn default() -> Self {
        Self {
            min_contacts_per_ball: MIN_CONTACTS_PER_BALL,
            true_contacts: true,
        }
    }
}

impl Dataset {
    /// Reads the dataset in directory `dir` with [`ReadOptions::default`].
    pub fn read(dir: &Path) -> Result<Self> {
        Self::read_with(dir, &ReadOptions::default())
    }

    /// Reads the dataset in directory `dir`: `machine.json`,
    /// `artefacts.json` and, if present, `truth.json`, parsed while
    /// `measurements.csv` is read (in blocks, each parsed in pieces side by
    /// side), checking each and their consistency.
    ///
    /// `artefacts.json` and `measurements.csv` may be absent together when
    /// `poses.csv` or `points.csv` is there.
    pub fn read_with(dir: &Path, options: &ReadOptions) -> Result<Self> {
        let machine = Machine::read(&dir.join(MACHINE_FILE))?;
        let scale = &machine.actuator.scale;
        let tracker = Tracker::read(&dir.join(POSES_FILE), &dir.join(POINTS_FILE), scale)?;
        let (artefacts_path, measurements_path) =
            (dir.join(ARTEFACTS_FILE), dir.join(MEASUREMENTS_FILE));
        let tracker_only =
            !tracker.is_empty() && !artefacts_path.exists() && !measurements_path.exists();
        let truth_path = dir.join(TRUTH_FILE);
        let touches = (!tracker_only).then_some((&*artefacts_path, &*measurements_path));
        let Touches {
            artefacts,
            measurements,
            truth,
        } = read_touches(touches, &truth_path, scale, options.true_contacts)?;
        let dataset = Self {
            truth: truth
                .map(|file| file.checked(&truth_path, &artefacts.balls, measurements.len()))
                .transpose()?,
            machine,
            artefacts,
            measurements,
            tracker,
        };
        // Each file was checked as it was read, by the checks of
        // `validate_as`; what is left is across files.
        dataset.check_across(|name| dir.join(name), options.min_contacts_per_ball)?;
        Ok(dataset)
    }

    /// A checksum of what was measured (CRC-32 of the machine, artefacts,
    /// measurements and instrument data in the snapshot's encoding, `crc32:`
    /// and 8 hex digits; a simulation's truth is not part of it): the same
    /// data, the same checksum, whatever the files' formatting. It
    /// recognises a dataset; it is not a cryptographic hash.
    pub fn checksum(&self) -> String {
        // The tuple's encoding, its parts in turn: the contacts' columns
        // in pieces on the threads.
        let mut crc = Crc32::default();
        crc.encode(&(&self.machine, &self.artefacts));
        crc.append(&self.measurements.encoded_crc());
        crc.encode(&self.tracker);
        crc.checksum()
    }

    /// Whether the dataset has ball touches.
    pub fn has_touches(&self) -> bool {
        !self.measurements.is_empty()
    }

    /// Writes the dataset as the new directory `dir` with
    /// [`WriteOptions::default`]: `dir` must not exist or be empty.
    pub fn write(&self, dir: &Path) -> Result<()> {
        self.write_with(dir, &WriteOptions::default())
    }

    /// Writes the dataset as the directory `dir`, as a set: the files are
    /// written into a hidden sibling directory that is then renamed into
    /// place ([`atomic::write_dir`]), so that `dir` holds either what it
    /// held before or the whole new dataset, never a mix. Its parents are
    /// created if needed. The dataset is validated first, so nothing is
    /// written if it is invalid. An existing non-empty `dir` is an error
    /// unless [`WriteOptions::replace`], and then it must be a dataset.
    pub fn write_with(&self, dir: &Path, options: &WriteOptions) -> Result<()> {
        self.validate_as(|name| dir.join(name), MIN_CONTACTS_PER_BALL)?;
        Self::check_target(dir, options.replace)?;
        atomic::write_dir(dir, options.replace, |new| {
            self.machine.write(&new.join(MACHINE_FILE))?;
            if self.has_touches() {
                self.artefacts.write(&new.join(ARTEFACTS_FILE))?;
                self.measurements
                    .write(&new.join(MEASUREMENTS_FILE), &self.artefacts.balls)?;
            }
            self.tracker
                .write(&new.join(POSES_FILE), &new.join(POINTS_FILE))?;
            if let Some(truth) = &self.truth {
                truth.write(&new.join(TRUTH_FILE), &self.artefacts.balls)?;
            }
            match &options.snapshot {
                Some(name) => snapshot::write(self, &new.join(name)),
                None => Ok(()),
            }
        })
    }

    /// Checks, before any work, that [`Dataset::write_with`] can write the
    /// directory `dir`: absent or empty, or (with `replace`) a dataset
    /// (a directory holding `machine.json`), in a place that can be
    /// written.
    pub fn check_target(dir: &Path, replace: bool) -> Result<()> {
        atomic::check_dir_target(dir, replace)?;
        let target = atomic::resolve(dir)?;
        let full = fs::read_dir(&target).is_ok_and(|mut entries| entries.next().is_some());
        if full && !target.join(MACHINE_FILE).is_file() {
            return Err(DatasetError::io(
                dir,
                "replace",
                io::Error::other(format!(
                    "the directory is not a dataset (it has no {MACHINE_FILE}); only a dataset is replaced"
                )),
            ));
        }
        Ok(())
    }

    /// Writes a binary snapshot (postcard behind a versioned, checksummed
    /// header) to `path`, atomically. Loads much faster than the text files.
    pub fn write_snapshot(&self, path: &Path) -> Result<()> {
        self.validate_as(|_| path.to_path_buf(), MIN_CONTACTS_PER_BALL)?;
        snapshot::write(self, path)
    }

    /// Reads a snapshot written by [`Dataset::write_snapshot`]; a file of
    /// another version, truncated or corrupt is an error, and so is a
    /// dataset that [`Dataset::validate`] refuses.
    pub fn read_snapshot(path: &Path) -> Result<Self> {
        let dataset = snapshot::read(path)?;
        dataset.validate_as(|_| path.to_path_buf(), MIN_CONTACTS_PER_BALL)?;
        Ok(dataset)
    }

    /// Number of contacts (measurement rows) of each ball, in
    /// [`Artefacts::balls`] order.
    pub fn contacts_per_ball(&self) -> Vec<usize> {
        self.measurements.count_per_ball(self.artefacts.balls.len())
    }

    /// Checks what [`Dataset::write`] would write: everything that reading
    /// checks, with the default minimum of contacts per ball
    /// ([`MIN_CONTACTS_PER_BALL`]). Errors name the file each value would go
    /// to.
    pub fn validate(&self) -> Result<()> {
        self.validate_as(|name| PathBuf::from(name), MIN_CONTACTS_PER_BALL)
    }

    /// The one validation of a dataset, of its files read, of a snapshot
    /// read and of what is written: each part by the checks its reader
    /// makes, then [`Dataset::check_across`]. Names the file of each part
    /// by `file(file_name)`.
    fn validate_as(&self, file: impl Fn(&str) -> PathBuf, min_contacts: usize) -> Result<()> {
        let balls = self.artefacts.balls.len();
        let rows = self.measurements.len();
        let scale = &self.machine.actuator.scale;
        self.machine.validate(Check::new(&file(MACHINE_FILE)))?;
        if self.has_touches() || self.tracker.is_empty() {
            self.artefacts.validate(Check::new(&file(ARTEFACTS_FILE)))?;
            self.measurements
                .validate(Check::new(&file(MEASUREMENTS_FILE)), balls, scale)?;
        }
        self.tracker.validate(
            Check::new(&file(POSES_FILE)),
            Check::new(&file(POINTS_FILE)),
            scale,
        )?;
        if let Some(truth) = &self.truth {
            truth.validate(Check::new(&file(TRUTH_FILE)), balls, Some(rows))?;
        }
        self.check_across(file, min_contacts)
    }

    /// The checks across files: the truth's sessions, the instruments'
    /// repeatability, at least `min_contacts` contacts per ball.
    fn check_across(&self, file: impl Fn(&str) -> PathBuf, min_contacts: usize) -> Result<()> {
        self.check_sessions(&file(TRUTH_FILE))?;
        self.check_instruments(&file(MACHINE_FILE))?;
        self.check_contacts(&file(MEASUREMENTS_FILE), min_contacts)
    }

    /// A truth of instrument measurements has one record per session.
    fn check_sessions(&self, truth_path: &Path) -> Result<()> {
        let Some(truth) = &self.truth else {
            return Ok(());
        };
        let (found, expected) = (truth.sessions.len(), self.tracker.sessions.len());
        if found != expected {
            return Err(Check::new(truth_path).error(
                "sessions",
                format!(
                    "expected {expected} sessions (as in poses.csv and points.csv), found {found}"
                ),
            ));
        }
        Ok(())
    }

    /// Instrument measurements come with the instrument's repeatability.
    fn check_instruments(&self, machine_path: &Path) -> Result<()> {
        let r = &self.machine.repeatability;
        let check = Check::new(machine_path);
        if !self.tracker.is_empty() && r.position.is_none() {
            return Err(check.error(
                "repeatability.position",
                "required when the dataset has poses.csv or points.csv (mm, per axis)",
            ));
        }
        if !self.tracker.poses.is_empty() && r.orientation.is_none() {
            return Err(check.error(
                "repeatability.orientation",
                "required when the dataset has poses.csv (rad, per axis)",
            ));
        }
        Ok(())
    }

    /// Every ball has at least `min` contacts.
    fn check_contacts(&self, path: &Path, min: usize) -> Result<()> {
        let counts = self.contacts_per_ball();
        let mut short = counts.iter().enumerate().filter(|&(_, &count)| count < min);
        match short.next() {
            None => Ok(()),
            Some((i, &count)) => Err(DatasetError::TooFewContacts {
                path: path.to_path_buf(),
                ball: self.artefacts.balls[i].id.clone(),
                count,
                min,
                others: short.count(),
            }),
        }
    }
}

/// What [`read_touches`] reads: the artefacts, the touches, and the truth.
struct Touches {
    artefacts: Artefacts,
    measurements: Measurements,
    truth: Option<TruthFile>,
}

/// `artefacts.json` and `measurements.csv` (`touches`' paths; none for a
/// dataset of instrument data alone) and, if present, `truth.json`
/// (`contacts`: its true contacts read), the JSON parsed while the CSV is
/// read on a thread of its own, its ball ids kept as written and resolved
/// once both are read. What the dataset keeps of the JSON is allocated on
/// this thread: another thread's allocator arena would keep the copies its
/// growth left, resident. An error in the CSV, or an id that does not
/// resolve, has the CSV read again with the ids resolved row by row, which
/// names the earliest; the artefacts' errors come first, the truth's last.
fn read_touches(
    touches: Option<(&Path, &Path)>,
    truth_path: &Path,
    scale: &[f64; 6],
    contacts: bool,
) -> Result<Touches> {
    std::thread::scope(|scope| {
        let csv = touches.map(|(_, csv)| {
            let read = scope.spawn(move || Measurements::read_unresolved(csv, scale));
            (csv, read)
        });
        let artefacts = match touches {
            Some((json, _)) => Artefacts::read(json)?,
            None => Artefacts::default(),
        };
        let index = ball_index(&artefacts.balls).expect("ball ids are unique");
        let truth = Truth::parse_if_present(truth_path, &artefacts.balls, &index, contacts);
        let measurements = match csv {
            None => Measurements::default(),
            Some((path, read)) => {
                let read = (read.join()).unwrap_or_else(|panic| std::panic::resume_unwind(panic));
                match read.ok().and_then(|unresolved| unresolved.resolve(&index)) {
                    Some(measurements) => measurements,
                    None => Measurements::read(path, &index, scale)?,
                }
            }
        };
        let truth = truth?;
        Ok(Touches {
            artefacts,
            measurements,
            truth,
        })
    })
}
