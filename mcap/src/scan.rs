//! Reading a file from its start, record by record, as far as it can be read.

use std::fmt;
use std::io::{self, Read, Seek, SeekFrom};

use mcap::McapError;
use mcap::records::{ChunkHeader, Record};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

use crate::READ_BYTES;
use crate::file::{MAX_CHUNK_BYTES, McapFile, RECORD_PREFIX_BYTES, length_limit, read_retrying};

/// What a [`Visitor`] wants next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flow {
    /// Go on with the next record.
    Continue,
    /// End the scan here (the visitor has what it needs).
    Stop,
}

/// Where a record lies in the file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct At {
    /// The byte offset of the record; of its chunk, for a record inside a chunk.
    pub offset: u64,
    /// Whether the record was inside a chunk.
    pub in_chunk: bool,
}

/// What a scan hands the records to.
pub trait Visitor {
    /// What the visitor may fail with (it ends the scan).
    type Error;

    /// One record. A chunk comes as a [`Record::Chunk`] (its header and compressed bytes),
    /// then each of its records, then [`Visitor::chunk_end`]; the chunk was decompressed and
    /// checked whole before.
    ///
    /// # Errors
    /// The visitor's own; the scan ends with it.
    fn record(&mut self, at: At, record: Record<'_>) -> Result<Flow, Self::Error>;

    /// The last record of the chunk at `offset` was handed out.
    ///
    /// # Errors
    /// The visitor's own; the scan ends with it.
    fn chunk_end(&mut self, offset: u64) -> Result<Flow, Self::Error> {
        let _ = offset;
        Ok(Flow::Continue)
    }

    /// `bytes_read` bytes of the file have been read so far.
    fn progress(&mut self, bytes_read: u64) {
        let _ = bytes_read;
    }
}

/// What ended a scan that did not fail.
#[derive(Debug)]
pub struct ScanEnd {
    /// Bytes from the start of the file to the end of the last record handed out (the
    /// start magic included, the end magic not).
    pub read_bytes: u64,
    /// The visitor asked to stop.
    pub stopped: bool,
    /// The damage that ended the scan, if it did.
    pub damage: Option<Damage>,
}

/// Why a scan failed (damage in the file is not a failure, see [`ScanEnd::damage`]).
#[derive(Debug, thiserror::Error)]
pub enum ScanError<E> {
    /// The system refused a read.
    #[error("{0}")]
    Io(#[from] io::Error),
    /// The visitor failed.
    #[error("{0}")]
    Visitor(E),
}

/// The kinds of [`Damage`], as a repair or a report words them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DamageKind {
    /// The file ends inside a record, or where a record or the end magic should be.
    CutShort,
    /// A record's length runs past the end of the file (its writer never finished it).
    Unfinished,
    /// A record's body does not parse.
    BadRecord,
    /// A chunk does not decompress, fails its CRC, or holds a record that does not parse.
    BadChunk,
    /// Anything else the reader cannot read past (a bad chunk header, a bad CRC of the data
    /// section, the end magic wrong).
    Unreadable,
}

/// Where and how a file stops being readable. Everything from [`Damage::offset`] on is
/// lost to the scan: records after damage cannot be found without their framing.
#[derive(Debug)]
pub struct Damage {
    /// The byte offset of the first record that cannot be read.
    pub offset: u64,
    /// The bytes from there to the end of the file.
    pub lost_bytes: u64,
    /// What kind of damage.
    pub kind: DamageKind,
    /// What the `mcap` reader said.
    pub error: McapError,
}

impl Damage {
    fn new(kind: DamageKind, offset: u64, file_size: u64, error: McapError) -> Self {
        Self {
            offset,
            lost_bytes: file_size.saturating_sub(offset),
            kind,
            error,
        }
    }

    /// Damage met by the linear reader itself (framing, not contents).
    fn framing(offset: u64, file_size: u64, error: McapError) -> Self {
        let kind = match error {
            McapError::UnexpectedEof => DamageKind::CutShort,
            // Records are limited to the file's size, so one "too large" runs past its end.
            McapError::RecordTooLarge { .. } => DamageKind::Unfinished,
            _ => DamageKind::Unreadable,
        };
        Self::new(kind, offset, file_size, error)
    }

    /// What was met, in words (`a record cut short by the end of the file`).
    #[must_use]
    pub fn what(&self) -> String {
        let error = &self.error;
        match self.kind {
            DamageKind::CutShort => "a record cut short by the end of the file".to_owned(),
            DamageKind::Unfinished => {
                "an unfinished record (its length runs past the end of the file)".to_owned()
            }
            DamageKind::BadRecord => format!("a record that does not parse ({error})"),
            DamageKind::BadChunk => format!("a chunk that does not decode ({error})"),
            DamageKind::Unreadable => format!("an unreadable record ({error})"),
        }
    }
}

impl fmt::Display for Damage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} at byte {}; the {} bytes from there to the end are lost",
            self.what(),
            self.offset,
            self.lost_bytes
        )
    }
}

/// How handing one top-level record out went.
enum Visited {
    Flow(Flow),
    Damaged(DamageKind, McapError),
}

impl McapFile {
    /// Hands every record to `visitor`, from the start of the file, in file order, until
    /// the end, damage, or the visitor stops. One chunk is held in memory at a time.
    ///
    /// # Errors
    /// [`ScanError::Io`] when the system refuses a read; [`ScanError::Visitor`] when the
    /// visitor fails. Damage is not an error: it is in [`ScanEnd::damage`].
    pub fn scan<V: Visitor>(&mut self, visitor: &mut V) -> Result<ScanEnd, ScanError<V::Error>> {
        let size = self.size_bytes();
        self.file.seek(SeekFrom::Start(0))?;
        let mut reader = LinearReader::new_with_options(
            LinearReaderOptions::default()
                .with_emit_chunks(true)
                .with_record_length_limit(length_limit(size)),
        );
        let mut offset = mcap::MAGIC.len() as u64;
        let mut bytes_read = 0_u64;
        let mut stopped = false;
        let damage = loop {
            let Some(event) = reader.next_event() else {
                break None;
            };
            match event {
                Ok(LinearReadEvent::ReadRequest(wanted)) => {
                    let buffer = reader.insert(wanted.clamp(1, READ_BYTES));
                    let read = read_retrying(&mut self.file, buffer)?;
                    bytes_read += read as u64;
                    visitor.progress(bytes_read);
                    reader.notify_read(read);
                }
                Ok(LinearReadEvent::Record { opcode, data }) => {
                    let at = offset;
                    let next = at + RECORD_PREFIX_BYTES + data.len() as u64;
                    let visited = match mcap::parse_record(opcode, data) {
                        Ok(record) => {
                            visit(visitor, at, record, data).map_err(ScanError::Visitor)?
                        }
                        Err(error) => Visited::Damaged(DamageKind::BadRecord, error),
                    };
                    match visited {
                        Visited::Flow(flow) => {
                            offset = next;
                            if flow == Flow::Stop {
                                stopped = true;
                                break None;
                            }
                        }
                        Visited::Damaged(kind, error) => {
                            break Some(Damage::new(kind, at, size, error));
                        }
                    }
                }
                Err(error) => break Some(Damage::framing(offset, size, error)),
            }
        };
        Ok(ScanEnd {
            read_bytes: offset.min(size),
            stopped,
            damage,
        })
    }
}

/// Hands one top-level record out (`body` is its bytes after opcode and length): a chunk
/// is decoded whole first, so that a chunk that turns out damaged gives nothing.
fn visit<V: Visitor>(
    visitor: &mut V,
    offset: u64,
    record: Record<'_>,
    body: &[u8],
) -> Result<Visited, V::Error> {
    let Record::Chunk { header, data } = record else {
        let at = At {
            offset,
            in_chunk: false,
        };
        return visitor.record(at, record).map(Visited::Flow);
    };
    let records = match chunk_records(&header, body) {
        Ok(records) => records,
        Err(error) => return Ok(Visited::Damaged(DamageKind::BadChunk, error)),
    };
    let chunk = Record::Chunk { header, data };
    let outside = At {
        offset,
        in_chunk: false,
    };
    if visitor.record(outside, chunk)? == Flow::Stop {
        return Ok(Visited::Flow(Flow::Stop));
    }
    let inside = At {
        offset,
        in_chunk: true,
    };
    for record in records {
        if visitor.record(inside, record)? == Flow::Stop {
            return Ok(Visited::Flow(Flow::Stop));
        }
    }
    visitor.chunk_end(offset).map(Visited::Flow)
}

/// The records of the chunk whose record body is `body`, decompressed whole and checked against its CRC before any is
/// parsed. Nothing in a damaged chunk may size an allocation: its uncompressed size must
/// be at most [`MAX_CHUNK_BYTES`], and no record in it may be longer than that size
/// (`mcap`'s own chunk reader trusts both, and one changed byte then asks for exabytes).
fn chunk_records(header: &ChunkHeader, body: &[u8]) -> Result<Vec<Record<'static>>, McapError> {
    if header.uncompressed_size > MAX_CHUNK_BYTES {
        return Err(McapError::ChunkTooLarge(header.uncompressed_size));
    }
    let length = u64::try_from(body.len()).unwrap_or(u64::MAX);
    let limit = usize::try_from(header.uncompressed_size.max(length)).unwrap_or(usize::MAX);
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_skip_start_magic(true)
            .with_skip_end_magic(true)
            .with_prevalidate_chunk_crcs(true)
            .with_record_length_limit(limit),
    );
    // The reader reads a stream of records: this chunk's record, framed again.
    let mut framed = [0_u8; RECORD_PREFIX_BYTES as usize];
    framed[0] = mcap::records::op::CHUNK;
    framed[1..].copy_from_slice(&length.to_le_bytes());
    let mut input = framed.as_slice().chain(body);
    let mut records = Vec::new();
    while let Some(event) = reader.next_event() {
        match event? {
            LinearReadEvent::ReadRequest(wanted) => {
                let read = input.read(reader.insert(wanted))?;
                reader.notify_read(read);
            }
            LinearReadEvent::Record { opcode, data } => {
                records.push(mcap::parse_record(opcode, data)?.into_owned());
            }
        }
    }
    Ok(records)
}
