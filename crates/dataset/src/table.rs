//! The machinery shared by the CSV files of a dataset: records parsed from
//! bytes without a per-row allocation, columns found by header name, and
//! errors that name the file, the line (the header is line 1) and the column.

use std::fmt::Write as _;
use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom, Write as _};
use std::path::Path;

use csv::{ByteRecord, ReaderBuilder};
use rayon::prelude::*;

use crate::atomic::{FileWriter, write_atomic, write_error};
use crate::check::not_finite;
use crate::error::DatasetError;
use crate::input;
use crate::quote::{quoted_bytes, sanitized};

/// An error found while parsing, before its line number is known.
pub(crate) enum Failure {
    /// From the CSV reader itself (I/O).
    Csv(csv::Error),
    /// About the record at `place`.
    At {
        place: RowPlace,
        column: Option<&'static str>,
        message: String,
        /// An earlier record the message refers to, whose line is named
        /// after it (`, first on line N`).
        earlier: Option<RowPlace>,
    },
}

impl From<csv::Error> for Failure {
    fn from(e: csv::Error) -> Self {
        Self::Csv(e)
    }
}

/// Where a record is in its input, for naming its line once an error
/// rescans the input ([`line_of`]).
#[derive(Debug, Clone, Copy)]
pub(crate) struct RowPlace {
    /// Input offset just past the record.
    end: u64,
    /// Newlines inside the record's (quoted) fields.
    inner_newlines: u64,
    /// The reader's line number, used if the input cannot be rescanned.
    estimate: u64,
}

impl RowPlace {
    /// The 1-based line of the record in `input` (`skipped` bytes of byte
    /// order mark before the offsets).
    fn line<R: Read + Seek>(&self, input: R, skipped: u64) -> u64 {
        line_of(input, self.end + skipped, self.inner_newlines).unwrap_or(self.estimate)
    }
}

/// One record (the header or a data row) being parsed.
pub(crate) struct Row<'a> {
    pub(crate) record: &'a ByteRecord,
    /// Input offset just past the record.
    pub(crate) end: u64,
}

impl Row<'_> {
    /// Field `column` without surrounding ASCII whitespace (trimmed here
    /// rather than by the CSV reader, whose trimming copies every record).
    pub(crate) fn field(&self, column: usize) -> &[u8] {
        self.record[column].trim_ascii()
    }

    /// Where this record is, to name its line in an error about a later
    /// one ([`Self::error_after`]).
    pub(crate) fn place(&self) -> RowPlace {
        RowPlace {
            end: self.end,
            inner_newlines: self
                .record
                .as_slice()
                .iter()
                .filter(|&&b| b == b'\n')
                .count() as u64,
            estimate: self.record.position().map_or(1, csv::Position::line),
        }
    }

    pub(crate) fn error(&self, column: Option<&'static str>, message: String) -> Failure {
        Failure::At {
            place: self.place(),
            column,
            message,
            earlier: None,
        }
    }

    /// An error about this record, a repeat of the `earlier` one, that
    /// names both lines: `message`, then `, first on line N`.
    pub(crate) fn error_after(&self, earlier: RowPlace, message: String) -> Failure {
        Failure::At {
            place: self.place(),
            column: None,
            message,
            earlier: Some(earlier),
        }
    }

    /// The finite numbers in `columns` (named `names`), each parsed from
    /// its field's bytes as `str::parse::<f64>` parses its text.
    pub(crate) fn numbers<const N: usize>(
        &self,
        columns: &[usize; N],
        names: &[&'static str; N],
    ) -> Result<[f64; N], Failure> {
        let mut out = [0.0; N];
        for ((slot, &column), &name) in out.iter_mut().zip(columns).zip(names) {
            let bytes = self.field(column);
            let value = fast_float2::parse::<f64, _>(bytes).map_err(|_| {
                let message = if bytes.is_empty() {
                    "empty field, expected a number".to_owned()
                } else {
                    format!("expected a number, found {}", quoted_bytes(bytes))
                };
                self.error(Some(name), message)
            })?;
            if !value.is_finite() {
                return Err(self.error(Some(name), not_finite(value)));
            }
            *slot = value;
        }
        Ok(out)
    }
}

/// The 1-based line on which the record that ended at byte `end` begins.
///
/// The CSV reader's own line numbers are off after blank lines (which it
/// skips) and in files with CRLF line ends, so on error the input is rescanned:
/// the last byte of the record (its terminator, or its last byte at the end
/// of the input) is on line 1 + (newlines before it).
pub(crate) fn line_of<R: Read + Seek>(mut input: R, end: u64, inner_newlines: u64) -> Option<u64> {
    input.seek(SeekFrom::Start(0)).ok()?;
    let mut before = input.take(end.saturating_sub(1));
    let mut buffer = [0u8; 1 << 14];
    let mut newlines = 0;
    loop {
        let n = before.read(&mut buffer).ok()?;
        if n == 0 {
            break;
        }
        newlines += buffer[..n].iter().filter(|&&b| b == b'\n').count() as u64;
    }
    Some((1 + newlines).saturating_sub(inner_newlines).max(1))
}

pub(crate) fn csv_error(path: &Path, error: csv::Error) -> DatasetError {
    let line = error.position().map_or(0, csv::Position::line);
    let message = sanitized(&error.to_string());
    match error.into_kind() {
        csv::ErrorKind::Io(e) => DatasetError::io(path, "read", e),
        _ => DatasetError::csv(path, line, None, message),
    }
}

/// Opens the CSV file `path` (absent: [`DatasetError::MissingFile`]; not a
/// regular file: [`DatasetError::Refused`]) and parses it with `records`.
pub(crate) fn read_file<T>(
    path: &Path,
    records: impl FnOnce(&mut CsvReader<File>) -> Result<T, Failure>,
) -> Result<T, DatasetError> {
    let file = input::open_required(path)?.file;
    parse(path, file, records)
}

/// The CSV reader of an input: lines at most [`CSV_LINE_CAP`] bytes long.
pub(crate) type CsvReader<R> = csv::Reader<LineLimited<R>>;

/// Parses CSV from `input` with `records`; errors name `path`. `input` is
/// read once, front to back (after a UTF-8 byte order mark, which is
/// skipped); it is rewound only to find the line of an error.
pub(crate) fn parse<R: Read + Seek, T>(
    path: &Path,
    mut input: R,
    records: impl FnOnce(&mut CsvReader<R>) -> Result<T, Failure>,
) -> Result<T, DatasetError> {
    let skipped = skip_bom(&mut input).map_err(|e| DatasetError::io(path, "read", e))?;
    let limited = LineLimited {
        inner: input,
        offset: skipped,
        line_length: 0,
        cap: CSV_LINE_CAP,
    };
    let mut reader = ReaderBuilder::new().flexible(true).from_reader(limited);
    // Offsets of the CSV reader count from after the byte order mark.
    let failure = match records(&mut reader) {
        Ok(value) => return Ok(value),
        Err(failure) => failure,
    };
    Err(located(path, reader.into_inner().inner, skipped, failure))
}

/// The error of `failure` in CSV file `path` (`input`, `skipped` bytes of
/// byte order mark), with its line found by rescanning `input`.
fn located<R: Read + Seek>(
    path: &Path,
    mut input: R,
    skipped: u64,
    failure: Failure,
) -> DatasetError {
    match failure {
        Failure::Csv(e) => match line_too_long(&e) {
            Some(&LineTooLong { offset, cap }) => {
                let line = line_of(input, offset + 1, 0).unwrap_or(0);
                DatasetError::csv(
                    path,
                    line,
                    None,
                    format!("the line is longer than {cap} bytes, the most a CSV line may have"),
                )
            }
            None => csv_error(path, e),
        },
        Failure::At {
            place,
            column,
            message,
            earlier,
        } => {
            let message = match earlier {
                Some(earlier) => {
                    let first = earlier.line(&mut input, skipped);
                    format!("{message}, first on line {first}")
                }
                None => message,
            };
            DatasetError::csv(path, place.line(input, skipped), column, message)
        }
    }
}

/// Parses the CSV file `path` as [`read_file`] would: its header
/// (`expected`) and what `columns` finds in it, then its data rows
/// (`what`), each checked to have the header's width and passed to `each`
/// with the accumulator of its piece. The rows are read in blocks of
/// [`PIECE_LEN`] bytes per thread of rayon's pool, cut at line ends, and
/// each block into [`PIECES_PER_THREAD`] pieces per thread, parsed side by
/// side while the next block is read (two blocks in memory); `gather`
/// empties the accumulators in file order, so that what they held does not
/// depend on the number of threads. A piece is split at its line ends and
/// commas ([`split_piece`]); from a block with a quote character on (whose
/// quoted fields may hold line ends and commas), the rest of the file is
/// one piece, parsed by csv's reader. Of several errors, the one earliest
/// in the file.
pub(crate) fn read_file_in_pieces<C: Sync, A: Default + Send>(
    path: &Path,
    expected: &str,
    what: &str,
    columns: impl FnOnce(&Header) -> Result<C, Failure>,
    each: impl Fn(&C, &Row, &mut A) -> Result<(), Failure> + Sync,
    mut gather: impl FnMut(&mut A),
) -> Result<(), DatasetError> {
    let mut file = input::open_required(path)?.file;
    let (header, columns) = parse(path, &mut file, |reader| {
        let header = Header::read(reader, expected)?;
        let columns = columns(&header)?;
        Ok((header, columns))
    })?;
    let io_error = |e| DatasetError::io(path, "read", e);
    file.rewind().map_err(io_error)?;
    let skipped = skip_bom(&mut file).map_err(io_error)?;
    // The offset in the file of the block's first byte.
    let mut offset = skipped + header.end;
    file.seek(SeekFrom::Start(offset)).map_err(io_error)?;
    let threads = rayon::current_num_threads().max(1);
    let block_len = PIECE_LEN * threads;
    // The block parsed, and the next one, read beside its parsing.
    let mut block = Vec::with_capacity(block_len);
    let mut next = Vec::with_capacity(block_len);
    let mut end_of_file = fill(&mut file, &mut block, block_len).map_err(io_error)?;
    // One accumulator per piece, emptied by `gather` and reused from block
    // to block: the pieces allocate once, not once per block.
    let count = threads * PIECES_PER_THREAD;
    let mut accumulators: Vec<A> = (0..count).map(|_| A::default()).collect();
    let mut rows = 0;
    while !block.is_empty() {
        if block.contains(&b'"') {
            let rest = io::Cursor::new(std::mem::take(&mut block)).chain(&mut file);
            let accumulator = &mut accumulators[0];
            let piece = parse_piece(rest, offset, skipped, &header, |row| {
                each(&columns, row, accumulator)
            });
            rows += piece.map_err(|f| located(path, &mut file, skipped, f))?;
            gather(accumulator);
            break;
        }
        // A block without a line end holds part of a line longer than the
        // cap, which its piece refuses.
        let end = match (end_of_file, block.iter().rposition(|&b| b == b'\n')) {
            (false, Some(last)) => last + 1,
            _ => block.len(),
        };
        // The next block starts with the rest of this one; its bytes are
        // read while this one's pieces are parsed.
        next.clear();
        next.extend_from_slice(&block[end..]);
        let (read, parsed) = rayon::join(
            || fill(&mut file, &mut next, block_len),
            || {
                (pieces(&block[..end], count).par_windows(2))
                    .zip(accumulators.par_iter_mut())
                    .map(|(bounds, accumulator)| {
                        let (start, stop) = (bounds[0], bounds[1]);
                        let bytes = &block[start..stop];
                        split_piece(bytes, offset + start as u64, skipped, &header, |row| {
                            each(&columns, row, accumulator)
                        })
                    })
                    .collect::<Vec<Result<usize, Failure>>>()
            },
        );
        // This block's errors before the next one's: the earliest in the
        // file first.
        for (piece, accumulator) in parsed.into_iter().zip(&mut accumulators) {
            rows += piece.map_err(|f| located(path, &mut file, skipped, f))?;
            gather(accumulator);
        }
        end_of_file = read.map_err(io_error)?;
        offset += end as u64;
        std::mem::swap(&mut block, &mut next);
    }
    if rows == 0 {
        let failure = header.error(format!("the header is followed by no {what} row"));
        return Err(located(path, &mut file, skipped, failure));
    }
    Ok(())
}

/// Parses the rows of `input`, the bytes of the file from offset `start`
/// (the beginning of a line; `skipped` bytes of byte order mark), with
/// `each`; the number of rows.
fn parse_piece(
    input: impl Read,
    start: u64,
    skipped: u64,
    header: &Header,
    each: impl FnMut(&Row) -> Result<(), Failure>,
) -> Result<usize, Failure> {
    let mut reader = ReaderBuilder::new()
        .flexible(true)
        .has_headers(false)
        .from_reader(LineLimited {
            inner: input,
            offset: start,
            line_length: 0,
            cap: CSV_LINE_CAP,
        });
    each_row(&mut reader, header, start - skipped, each)
}

/// Parses the rows of `bytes`, a piece of the file without a quote
/// character from offset `start` (the beginning of a line; `skipped` bytes
/// of byte order mark), with `each`, as [`parse_piece`] would; the number
/// of rows. Without quotes a record is a line and its fields are what its
/// commas separate, so the piece is cut with memchr's search rather than by
/// csv's state machine: at every `\n` and `\r` (csv's line ends: `\n`,
/// `\r\n` and `\r` alone), empty lines skipped, then each line at its
/// commas. A line (from one `\n` to the next) longer than the cap is
/// refused as [`LineLimited`] refuses it.
fn split_piece(
    bytes: &[u8],
    start: u64,
    skipped: u64,
    header: &Header,
    mut each: impl FnMut(&Row) -> Result<(), Failure>,
) -> Result<usize, Failure> {
    let base = start - skipped;
    let mut record = ByteRecord::new();
    let mut rows = 0usize;
    // The current line: where it begins (after a `\n`) and its number in
    // the piece (the estimate of `RowPlace`).
    let (mut line_start, mut line) = (0, 1);
    let mut from = 0;
    while from < bytes.len() {
        let stop =
            memchr::memchr2(b'\n', b'\r', &bytes[from..]).map_or(bytes.len(), |at| from + at);
        if (stop - line_start) as u64 > CSV_LINE_CAP {
            let offset = start + line_start as u64 + CSV_LINE_CAP;
            let too_long = LineTooLong {
                offset,
                cap: CSV_LINE_CAP,
            };
            return Err(Failure::Csv(io::Error::other(too_long).into()));
        }
        let text = &bytes[from..stop];
        let ends_line = bytes.get(stop) == Some(&b'\n');
        // Just past the record's line end (or its last byte, at the end).
        from = (stop + 1).min(bytes.len());
        if !text.is_empty() {
            record.clear();
            let mut field = 0;
            for comma in memchr::memchr_iter(b',', text) {
                record.push_field(&text[field..comma]);
                field = comma + 1;
            }
            record.push_field(&text[field..]);
            let mut position = csv::Position::new();
            position.set_line(line);
            record.set_position(Some(position));
            let row = Row {
                record: &record,
                end: base + from as u64,
            };
            take_row(&row, header, &mut each)?;
            rows += 1;
        }
        if ends_line {
            (line_start, line) = (from, line + 1);
        }
    }
    Ok(rows)
}

/// The bounds of `count` pieces of `rows` of about equal length, each
/// ending just after a line end (or at the end).
fn pieces(rows: &[u8], count: usize) -> Vec<usize> {
    let mut bounds = vec![0];
    for k in 1..count {
        let from = (rows.len() * k / count).max(*bounds.last().expect("starts with 0"));
        let cut = rows[from..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(rows.len(), |at| from + at + 1);
        bounds.push(cut);
    }
    bounds.push(rows.len());
    bounds
}

/// The bytes of rows a block holds for each thread (4 MiB, more than a
/// line may have, [`CSV_LINE_CAP`]): the memory of reading a file of any
/// length in pieces.
const PIECE_LEN: usize = 4 << 20;

/// The pieces a block is cut into for each thread: more pieces than
/// threads, so that a thread that ends its piece early (or reads the next
/// block first) takes another instead of waiting.
const PIECES_PER_THREAD: usize = 4;

/// Fills `block`, which holds the bytes kept from the block before, up to
/// `len` bytes from `input`; whether the input ended.
fn fill(input: &mut impl Read, block: &mut Vec<u8>, len: usize) -> io::Result<bool> {
    let kept = block.len();
    block.resize(len.max(kept), 0);
    let read = read_full(input, &mut block[kept..]);
    let filled = kept + read.as_ref().map_or(0, |&n| n);
    block.truncate(filled);
    read.map(|_| filled < len)
}

/// Fills `buffer` from `input` as far as it goes; the bytes read (fewer
/// than the buffer's length only at the end of the input).
fn read_full(input: &mut impl Read, buffer: &mut [u8]) -> io::Result<usize> {
    let mut filled = 0;
    while filled < buffer.len() {
        match input.read(&mut buffer[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(filled)
}

/// Positions `input` after its UTF-8 byte order mark, if it has one, and
/// returns the bytes skipped.
fn skip_bom<R: Read + Seek>(input: &mut R) -> io::Result<u64> {
    let mut start = [0u8; 3];
    let mut n = 0;
    while n < start.len() {
        match input.read(&mut start[n..])? {
            0 => break,
            k => n += k,
        }
    }
    let skipped = if start[..n] == *input::BOM { 3 } else { 0 };
    input.seek(SeekFrom::Start(skipped))?;
    Ok(skipped)
}

/// The longest CSV line read, bytes (1 MiB): a row of measurements.csv is
/// a few hundred bytes. A longer line (an endless one) is refused with its
/// line number instead of growing the record without bound.
pub const CSV_LINE_CAP: u64 = 1 << 20;

/// A reader that fails when a line (bytes between two newlines) grows
/// longer than `cap`.
pub(crate) struct LineLimited<R> {
    inner: R,
    /// Offset in the input of the next byte read.
    offset: u64,
    /// Length of the line read so far (bytes since the last newline).
    line_length: u64,
    cap: u64,
}

/// The error of a line longer than the cap: it reached the cap at byte
/// `offset` of the input.
#[derive(Debug)]
struct LineTooLong {
    offset: u64,
    cap: u64,
}

impl std::fmt::Display for LineTooLong {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "a line is longer than {} bytes", self.cap)
    }
}

impl std::error::Error for LineTooLong {}

fn line_too_long(error: &csv::Error) -> Option<&LineTooLong> {
    match error.kind() {
        csv::ErrorKind::Io(e) => e.get_ref()?.downcast_ref(),
        _ => None,
    }
}

impl<R: Read> Read for LineLimited<R> {
    /// Reads at most `cap` bytes at a time, so that only a line that spans
    /// reads can be too long: the check looks at the first and the last
    /// newline of what was read, not at every byte.
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        let most = buf
            .len()
            .min(usize::try_from(self.cap).unwrap_or(usize::MAX));
        let n = self.inner.read(&mut buf[..most])?;
        let chunk = &buf[..n];
        let (first, last) = match chunk.iter().position(|&b| b == b'\n') {
            Some(first) => (first, chunk.iter().rposition(|&b| b == b'\n')),
            None => (n, None),
        };
        if self.line_length + first as u64 > self.cap {
            return Err(io::Error::other(LineTooLong {
                offset: self.offset + (self.cap - self.line_length),
                cap: self.cap,
            }));
        }
        self.line_length = match last {
            Some(last) => (n - last - 1) as u64,
            None => self.line_length + n as u64,
        };
        self.offset += n as u64;
        Ok(n)
    }
}

/// The header of a CSV file, its columns found by name.
pub(crate) struct Header {
    record: ByteRecord,
    end: u64,
}

impl Header {
    /// Reads the header of `reader`; an empty file is an error that names
    /// the `expected` header.
    pub(crate) fn read<R: Read>(
        reader: &mut csv::Reader<R>,
        expected: &str,
    ) -> Result<Self, Failure> {
        let header = Self {
            record: reader.byte_headers()?.clone(),
            end: reader.position().byte(),
        };
        if header.record.is_empty() {
            return Err(header.error(format!(
                "the file is empty (expected the header {expected})"
            )));
        }
        Ok(header)
    }

    /// An error about the header line.
    pub(crate) fn error(&self, message: String) -> Failure {
        self.row().error(None, message)
    }

    fn row(&self) -> Row<'_> {
        Row {
            record: &self.record,
            end: self.end,
        }
    }

    /// Number of fields every row must have.
    pub(crate) fn width(&self) -> usize {
        self.record.len()
    }

    /// The column named `name` (surrounding whitespace ignored), if any; a
    /// name given twice is an error.
    pub(crate) fn find(&self, name: &str) -> Result<Option<usize>, Failure> {
        let mut found = self
            .record
            .iter()
            .enumerate()
            .filter(|(_, f)| f.trim_ascii() == name.as_bytes());
        match (found.next(), found.next()) {
            (Some((i, _)), None) => Ok(Some(i)),
            (None, _) => Ok(None),
            (Some(_), Some(_)) => Err(self.error(format!("the header names column {name} twice"))),
        }
    }

    /// The column named `name`; its absence is an error that names the
    /// `expected` header.
    pub(crate) fn require(&self, name: &str, expected: &str) -> Result<usize, Failure> {
        self.find(name)?.ok_or_else(|| {
            self.error(format!(
                "the header has no column {name} (it must name {expected})"
            ))
        })
    }

    /// Refuses a column that is none of `known` (its name trimmed), naming
    /// it and the `expected` header: a misspelt column would otherwise be
    /// passed over without a word (loads read as none).
    pub(crate) fn only(&self, known: &[&str], expected: &str) -> Result<(), Failure> {
        for field in &self.record {
            let name = String::from_utf8_lossy(field.trim_ascii());
            if !known.contains(&name.as_ref()) {
                return Err(self.error(format!(
                    "the header names column {:?}, which is not one of this file's (the header is {expected})",
                    name
                )));
            }
        }
        Ok(())
    }

    /// The columns named `names`, all required.
    pub(crate) fn require_all<const N: usize>(
        &self,
        names: &[&str; N],
        expected: &str,
    ) -> Result<[usize; N], Failure> {
        let mut out = [0; N];
        for (slot, name) in out.iter_mut().zip(names) {
            *slot = self.require(name, expected)?;
        }
        Ok(out)
    }
}

/// Iterates over the data rows of `reader`, each checked to have `width`
/// fields, calling `each` on it; a file with no data row is an error.
pub(crate) fn for_each_row<R: Read>(
    reader: &mut csv::Reader<R>,
    header: &Header,
    what: &str,
    each: impl FnMut(&Row) -> Result<(), Failure>,
) -> Result<(), Failure> {
    if each_row(reader, header, 0, each)? == 0 {
        return Err(header.error(format!("the header is followed by no {what} row")));
    }
    Ok(())
}

/// Calls `each` on every row of `reader`, checked to have the header's
/// width; the rows' offsets count from `base`. Returns the number of rows.
fn each_row<R: Read>(
    reader: &mut csv::Reader<R>,
    header: &Header,
    base: u64,
    mut each: impl FnMut(&Row) -> Result<(), Failure>,
) -> Result<usize, Failure> {
    let mut record = ByteRecord::new();
    let mut rows = 0usize;
    while reader.read_byte_record(&mut record)? {
        let row = Row {
            record: &record,
            end: base + reader.position().byte(),
        };
        take_row(&row, header, &mut each)?;
        rows += 1;
    }
    Ok(rows)
}

/// Passes `row` to `each` once it is checked to have the header's width.
fn take_row(
    row: &Row,
    header: &Header,
    each: &mut impl FnMut(&Row) -> Result<(), Failure>,
) -> Result<(), Failure> {
    let width = row.record.len();
    if width != header.width() {
        return Err(row.error(
            None,
            format!("expected {} fields, found {width}", header.width()),
        ));
    }
    each(row)
}

/// Writes `path` atomically as CSV: the `header`, then the rows `fill`
/// writes through a [`NumberWriter`].
pub(crate) fn write_file(
    path: &Path,
    header: &[&str],
    fill: impl FnOnce(&mut NumberWriter<&mut FileWriter<'_>>) -> Result<(), csv::Error>,
) -> Result<(), DatasetError> {
    write_atomic(path, |w| {
        let to_error = |e: csv::Error| DatasetError::io(path, "write", e.into());
        let mut numbers = NumberWriter {
            writer: csv::Writer::from_writer(w),
            text: String::new(),
        };
        numbers.writer.write_record(header).map_err(to_error)?;
        fill(&mut numbers).map_err(to_error)?;
        numbers.writer.flush().map_err(write_error(path))
    })
}

/// Writes `path` atomically as CSV: the `header`, as [`write_file`] writes
/// it, then the text `fill` writes (whole rows, each ended by a newline).
pub(crate) fn write_text_file(
    path: &Path,
    header: &[&str],
    fill: impl FnOnce(&mut FileWriter<'_>) -> io::Result<()>,
) -> Result<(), DatasetError> {
    write_atomic(path, |w| {
        let mut line = csv::Writer::from_writer(Vec::new());
        let header = (line.write_record(header))
            .and_then(|()| line.into_inner().map_err(|e| e.into_error().into()))
            .map_err(|e| DatasetError::io(path, "write", e.into()))?;
        (w.write_all(&header))
            .and_then(|()| fill(w))
            .and_then(|()| w.flush())
            .map_err(write_error(path))
    })
}

/// Writes CSV fields, numbers in Rust's shortest round-trip form (`{}`),
/// so that they read back bit for bit.
pub(crate) struct NumberWriter<W: io::Write> {
    writer: csv::Writer<W>,
    text: String,
}

impl<W: io::Write> NumberWriter<W> {
    /// A text field.
    pub(crate) fn text(&mut self, field: &str) -> Result<(), csv::Error> {
        self.writer.write_field(field)
    }

    /// Number fields.
    pub(crate) fn numbers(&mut self, values: &[f64]) -> Result<(), csv::Error> {
        for &v in values {
            self.text.clear();
            write!(self.text, "{v}").expect("formatting into a String");
            self.writer.write_field(&self.text)?;
        }
        Ok(())
    }

    /// Ends the row.
    pub(crate) fn end_row(&mut self) -> Result<(), csv::Error> {
        self.writer.write_record(None::<&[u8]>)
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    use super::*;

    /// What a piece's parse gave: each row's fields and end, then the error
    /// that stopped it (its text and place), if any.
    type Parsed = (Vec<(Vec<Vec<u8>>, u64)>, Option<String>);

    /// [`Parsed`], and each row's line number as its record's position
    /// gives it.
    fn parsed(
        parse: impl FnOnce(&mut dyn FnMut(&Row) -> Result<(), Failure>) -> Result<usize, Failure>,
    ) -> (Parsed, Vec<u64>) {
        let (mut rows, mut lines) = (Vec::new(), Vec::new());
        let outcome = parse(&mut |row: &Row| {
            let fields = row.record.iter().map(<[u8]>::to_vec).collect();
            rows.push((fields, row.end));
            lines.push(row.record.position().map_or(0, csv::Position::line));
            // A row whose first field is `x` fails, to compare the stops.
            match row.record.get(0) {
                Some(b"x") => Err(row.error(None, "x".to_owned())),
                _ => Ok(()),
            }
        });
        let error = match outcome {
            Ok(count) => {
                assert_eq!(count, rows.len());
                None
            }
            Err(Failure::Csv(e)) => Some(format!("{e:?}")),
            // The place's line estimate is checked apart (`both`).
            Err(Failure::At { place, message, .. }) => {
                Some(format!("{message} {} {}", place.end, place.inner_newlines))
            }
        };
        ((rows, error), lines)
    }

    fn header(width: usize) -> Header {
        Header {
            record: ByteRecord::from(vec!["h"; width]),
            end: 0,
        }
    }

    /// Both ways of parsing a piece without quotes: csv's reader and the
    /// split at line ends and commas. The split's line numbers are checked
    /// to be each row's line in the piece (csv's miss its blank lines).
    fn both(bytes: &[u8], start: u64, skipped: u64, width: usize) -> (Parsed, Parsed) {
        let header = header(width);
        let (by_csv, _) = parsed(|each| parse_piece(bytes, start, skipped, &header, each));
        let (by_split, lines) = parsed(|each| split_piece(bytes, start, skipped, &header, each));
        for ((_, end), line) in by_split.0.iter().zip(lines) {
            let last = usize::try_from(end - (start - skipped)).unwrap() - 1;
            let newlines = bytes[..last].iter().filter(|&&b| b == b'\n').count();
            assert_eq!(line, 1 + newlines as u64, "{bytes:?}");
        }
        (by_csv, by_split)
    }

    proptest! {
        /// Any piece without quotes (line ends `\n`, `\r\n` and `\r`,
        /// empty and blank lines, rows of the wrong width, a failing row)
        /// gives csv's rows, offsets and errors when it is split.
        #[test]
        fn a_split_piece_is_parsed_as_csv_parses_it(
            bytes in proptest::collection::vec(
                prop::sample::select(b"1x ,,\r\n\n".to_vec()), 0..80),
            width in 1usize..4,
            start in 0u64..50,
            bom in any::<bool>(),
        ) {
            let skipped = if bom { 3 } else { 0 };
            let (by_csv, by_split) = both(&bytes, start + skipped, skipped, width);
            prop_assert_eq!(by_csv, by_split);
        }
    }

    proptest! {
        /// A field's number is `str::parse`'s, to the bit, and a field it
        /// refuses is refused: signs, exponents, `inf` and `nan` in any
        /// case, stray characters, invalid UTF-8.
        #[test]
        fn a_field_is_parsed_as_str_parses_it(
            bytes in proptest::collection::vec(
                prop::sample::select(b"0123456789.eE+-infatyINFATY_x \xc3".to_vec()), 0..24),
        ) {
            let by_str = std::str::from_utf8(&bytes).ok().and_then(|t| t.parse::<f64>().ok());
            let by_bytes = fast_float2::parse::<f64, _>(&bytes).ok();
            let bits = |v: Option<f64>| v.map(|v| if v.is_nan() { f64::NAN.to_bits() } else { v.to_bits() });
            prop_assert_eq!(bits(by_str), bits(by_bytes));
        }

        /// Any double written as parcal writes it (`{}`), in exponent form
        /// or cut to a few digits, is read back as `str::parse` reads it.
        #[test]
        fn a_written_number_is_parsed_as_str_parses_it(value in any::<f64>(), digits in 0usize..20) {
            for text in [format!("{value}"), format!("{value:e}"), format!("{value:.digits$}")] {
                let by_str = text.parse::<f64>().map(f64::to_bits).ok();
                let by_bytes = fast_float2::parse::<f64, _>(text.as_bytes()).map(f64::to_bits).ok();
                prop_assert_eq!(by_str, by_bytes, "{}", text);
            }
        }
    }

    /// A line longer than the cap is refused at the same offset both ways,
    /// after a line end of either kind.
    #[test]
    fn a_split_piece_refuses_a_line_over_the_cap_as_csv_does() {
        for before in ["1,1\n", "1,1\r\n", "1,1\r"] {
            let long = "1".repeat(CSV_LINE_CAP as usize + 1);
            let bytes = format!("{before}{long}\n1,1\n");
            let (by_csv, by_split) = both(bytes.as_bytes(), 10, 0, 2);
            assert!(
                by_csv
                    .1
                    .as_deref()
                    .is_some_and(|e| e.contains("LineTooLong"))
            );
            assert_eq!(by_csv, by_split);
        }
    }
}
