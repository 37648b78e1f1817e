//! Lewis MCAP reading: the one reader of recordings that every tool uses (`lewis info`,
//! replay, the mission log, `lewis recover`, the viewer). It owns how a file is opened,
//! how its summary and metadata are read, how it is scanned from its start when the
//! summary is missing or not enough, and how damage is found and reported; and, in
//! [`format`](mod@format), what a Lewis recording holds besides messages (its metadata names, the
//! versions that wrote it), shared by the recorder that writes it and the tools that read
//! it. It does not write MCAP (the recorder does), know CDR (`lewis-interfaces` does) or
//! decide what a tool does with the records.
//!
//! - [`McapFile::open`]: the magic and the Header record; a file that lacks them is not
//!   MCAP ([`OpenError::NotMcap`]).
//! - [`McapFile::summary`]: the summary section through the footer, `None` when the file has
//!   none (a writer that died). [`McapFile::metadata_at`] reads a record the summary
//!   indexes.
//! - [`McapFile::scan`]: every record from the start, in file order, the records of each
//!   chunk after the chunk, to a [`Visitor`]. Damage ends the scan and is reported
//!   ([`Damage`]: what, at which byte, how many bytes after it are lost) instead of being
//!   an error: what was read before it stays usable.
//! - [`TimeOrdered`]: the messages of a file with a summary in log-time order, chunk by
//!   chunk through the indexes, so that memory does not grow with the recording.
//!
//! The `mcap` crate does the parsing: its sans-io `LinearReader`, `SummaryReader` and
//! `IndexedReader` over a `File`, never a whole file in memory (its `MessageStream` and
//! `Summary::read` take the file as one slice, which a gigabyte recording is not). What
//! this crate adds is what damage tolerance needs and the `mcap` readers leave to their
//! caller: the byte offset of every record (the linear reader does not count them), a
//! chunk checked whole (decompressed and its CRC verified) before any of its records is
//! handed out, so that a damaged chunk is lost whole rather than half-read, and the
//! classification of what stopped a scan ([`DamageKind`]).

mod file;
pub mod format;
mod scan;
mod time_ordered;

pub use file::{McapFile, OpenError, ReadError, starts_like_mcap};
pub use scan::{At, Damage, DamageKind, Flow, ScanEnd, ScanError, Visitor};
pub use time_ordered::{IndexedMessage, TimeOrdered};

/// The `mcap` crate's record types, as this crate hands them out.
pub use mcap::records;
pub use mcap::{MAGIC, McapError, Summary};

/// Bytes read from a file at a time by a scan.
const READ_BYTES: usize = 1024 * 1024;
