//! A streaming reader of CARMEN logs, plain or gzip (told apart by the gzip magic bytes,
//! not by the file name): one record at a time, malformed lines reported, counted and
//! skipped, memory bounded by the longest line it accepts.

use std::collections::BTreeMap;
use std::fmt;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

use flate2::read::MultiGzDecoder;

use super::parse::{LaserId, Line, LineErrorKind, Record, parse_line};

/// Lines longer than this are malformed (a 361-beam FLASER line is about 3 KB).
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// The reader keeps the first this many malformed lines (it counts them all).
pub const MAX_KEPT_ERRORS: usize = 100;

/// The reader counts at most this many distinct unknown line types by name; the others
/// are counted together under [`OTHER_UNKNOWN`].
pub const MAX_UNKNOWN_TYPES: usize = 64;

/// The name under which unknown line types beyond [`MAX_UNKNOWN_TYPES`] are counted.
pub const OTHER_UNKNOWN: &str = "(other)";

const GZIP_MAGIC: [u8; 2] = [0x1f, 0x8b];

/// A malformed line: where it is and what is wrong.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineError {
    /// The log.
    pub path: PathBuf,
    /// The line number, from 1.
    pub line: u64,
    /// What is wrong.
    pub kind: LineErrorKind,
}

impl fmt::Display for LineError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}: {}", self.path.display(), self.line, self.kind)
    }
}

impl std::error::Error for LineError {}

/// Why a log cannot be read at all.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The file cannot be opened.
    // Not a `source`: the message says it, and a chain would say it twice.
    #[error("cannot open {}: {error}", path.display())]
    Open {
        /// The log.
        path: PathBuf,
        /// Why.
        error: io::Error,
    },
    /// Reading failed part-way (a damaged gzip stream, an I/O error).
    #[error("{}: reading failed after line {line}: {error}{}", path.display(), if *gzip { " (is the gzip file damaged or cut short?)" } else { "" })]
    Read {
        /// The log.
        path: PathBuf,
        /// The last line read completely.
        line: u64,
        /// Whether the file is gzip-compressed.
        gzip: bool,
        /// Why.
        error: io::Error,
    },
}

/// What the reader has seen so far, line by line.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ParseCounts {
    /// Lines read.
    pub lines: u64,
    /// Empty lines.
    pub blank: u64,
    /// Comment lines (`#`).
    pub comments: u64,
    /// `PARAM` lines.
    pub params: u64,
    /// `ODOM` lines.
    pub odometry: u64,
    /// Laser scan lines, per laser.
    pub scans: BTreeMap<LaserId, u64>,
    /// Known line types that carry nothing to import (`NEFF`), per type.
    pub ignored: BTreeMap<&'static str, u64>,
    /// Unknown line types, per type (see [`MAX_UNKNOWN_TYPES`]).
    pub unknown: BTreeMap<String, u64>,
    /// Malformed lines, skipped.
    pub malformed: u64,
}

impl ParseCounts {
    /// Scan lines of one laser.
    #[must_use]
    pub fn scans_of(&self, laser: LaserId) -> u64 {
        self.scans.get(&laser).copied().unwrap_or(0)
    }

    fn count_unknown(&mut self, kind: &str) {
        let name: String = kind.chars().take(32).collect();
        let key = if self.unknown.contains_key(&name) || self.unknown.len() < MAX_UNKNOWN_TYPES {
            name
        } else {
            OTHER_UNKNOWN.to_owned()
        };
        *self.unknown.entry(key).or_default() += 1;
    }
}

/// A record and the line it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Located<T> {
    /// The line number, from 1.
    pub line: u64,
    /// The record.
    pub value: T,
}

/// Reads a CARMEN log record by record.
pub struct LogReader {
    path: PathBuf,
    input: Box<dyn BufRead + Send>,
    gzip: bool,
    line: u64,
    buf: Vec<u8>,
    counts: ParseCounts,
    errors: Vec<LineError>,
    failed: bool,
}

impl fmt::Debug for LogReader {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LogReader")
            .field("path", &self.path)
            .field("gzip", &self.gzip)
            .field("line", &self.line)
            .finish_non_exhaustive()
    }
}

impl LogReader {
    /// Opens a log, plain or gzip.
    ///
    /// # Errors
    /// The file cannot be opened or its first bytes cannot be read.
    pub fn open(path: &Path) -> Result<Self, ReadError> {
        let file = File::open(path).map_err(|error| ReadError::Open {
            path: path.to_owned(),
            error,
        })?;
        Self::from_reader(path.to_owned(), Box::new(file))
    }

    /// Reads a log from any byte source, plain or gzip; `path` names it in messages.
    ///
    /// # Errors
    /// Its first bytes cannot be read.
    pub fn from_reader(path: PathBuf, input: Box<dyn Read + Send>) -> Result<Self, ReadError> {
        let mut raw = BufReader::new(input);
        let head = loop {
            match raw.fill_buf() {
                Ok(head) => break head,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(error) => return Err(ReadError::Open { path, error }),
            }
        };
        let gzip = head.starts_with(&GZIP_MAGIC);
        let input: Box<dyn BufRead + Send> = if gzip {
            Box::new(BufReader::new(MultiGzDecoder::new(raw)))
        } else {
            Box::new(raw)
        };
        Ok(Self {
            path,
            input,
            gzip,
            line: 0,
            buf: Vec::new(),
            counts: ParseCounts::default(),
            errors: Vec::new(),
            failed: false,
        })
    }

    /// The log's name in messages.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Whether the log is gzip-compressed.
    #[must_use]
    pub fn is_gzip(&self) -> bool {
        self.gzip
    }

    /// What has been read so far.
    #[must_use]
    pub fn counts(&self) -> &ParseCounts {
        &self.counts
    }

    /// The first [`MAX_KEPT_ERRORS`] malformed lines.
    #[must_use]
    pub fn errors(&self) -> &[LineError] {
        &self.errors
    }

    /// The next record, skipping (and counting) blank, comment, ignored, unknown and
    /// malformed lines; `None` at the end of the log.
    ///
    /// # Errors
    /// Reading failed (I/O, a damaged gzip stream); after that the log is at its end.
    pub fn next_record(&mut self) -> Result<Option<Located<Record>>, ReadError> {
        loop {
            if self.failed {
                return Ok(None);
            }
            let too_long = match self.read_line() {
                Ok(None) => return Ok(None),
                Ok(Some(too_long)) => too_long,
                Err(error) => {
                    self.failed = true;
                    return Err(ReadError::Read {
                        path: self.path.clone(),
                        line: self.line,
                        gzip: self.gzip,
                        error,
                    });
                }
            };
            self.line += 1;
            self.counts.lines += 1;
            let parsed = if too_long {
                Err(LineErrorKind::TooLong {
                    limit: MAX_LINE_BYTES,
                })
            } else {
                let bytes = self.buf.strip_suffix(b"\r").unwrap_or(&self.buf);
                std::str::from_utf8(bytes)
                    .map_err(|_| LineErrorKind::NotText)
                    .and_then(parse_line)
            };
            match parsed {
                Ok(Line::Blank) => self.counts.blank += 1,
                Ok(Line::Comment) => self.counts.comments += 1,
                Ok(Line::Ignored(kind)) => *self.counts.ignored.entry(kind).or_default() += 1,
                Ok(Line::Unknown(kind)) => self.counts.count_unknown(&kind),
                Ok(Line::Record(record)) => {
                    match &record {
                        Record::Param(_) => self.counts.params += 1,
                        Record::Odometry(_) => self.counts.odometry += 1,
                        Record::Laser(scan) => {
                            *self.counts.scans.entry(scan.laser).or_default() += 1;
                        }
                    }
                    return Ok(Some(Located {
                        line: self.line,
                        value: record,
                    }));
                }
                Err(kind) => {
                    self.counts.malformed += 1;
                    if self.errors.len() < MAX_KEPT_ERRORS {
                        self.errors.push(LineError {
                            path: self.path.clone(),
                            line: self.line,
                            kind,
                        });
                    }
                }
            }
        }
    }

    /// Reads the next line into `buf` (without its `\n`); `Some(true)` when it was longer
    /// than [`MAX_LINE_BYTES`] (then `buf` holds only its start), `None` at the end.
    fn read_line(&mut self) -> io::Result<Option<bool>> {
        self.buf.clear();
        let mut seen_any = false;
        let mut too_long = false;
        loop {
            let chunk = match self.input.fill_buf() {
                Ok(chunk) => chunk,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            };
            if chunk.is_empty() {
                return Ok(seen_any.then_some(too_long));
            }
            seen_any = true;
            let (take, complete) = match chunk.iter().position(|&b| b == b'\n') {
                Some(end) => (end, true),
                None => (chunk.len(), false),
            };
            if take > MAX_LINE_BYTES - self.buf.len() {
                too_long = true;
            }
            if !too_long {
                self.buf.extend_from_slice(&chunk[..take]);
            }
            self.input.consume(take + usize::from(complete));
            if complete {
                return Ok(Some(too_long));
            }
        }
    }
}

impl Iterator for LogReader {
    type Item = Result<Located<Record>, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        self.next_record().transpose()
    }
}
