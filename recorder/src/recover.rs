//! Repair of a recording whose writer died (SIGKILL, power cut, full disk): every complete
//! record up to the first damaged one is copied into a new file, which gets fresh message
//! and chunk indexes, statistics, a summary and a footer.
//!
//! Chunks are copied one for one (decompressed, checked against their CRC, written again
//! with the same compression and the same boundaries); a chunk cut short, or whose CRC
//! fails, and everything after it, are what is lost. The report says how much.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{BufWriter, Read};
use std::path::{Path, PathBuf};

use mcap::read::ChunkReader;
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader, LinearReaderOptions};
use mcap::{Attachment, McapError, Writer};
use thiserror::Error;

use crate::part::write_options;

/// Bytes read from the broken file at a time.
const READ_BYTES: usize = 1024 * 1024;
/// Magic bytes at the start of an MCAP file.
const MAGIC_BYTES: u64 = 8;
/// Opcode and length before every record's body.
const RECORD_PREFIX_BYTES: u64 = 9;

/// What a repair kept and lost.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct RecoverReport {
    /// Whether the input's data section was complete (it had a Data End record): then
    /// nothing was lost, only the summary was rebuilt.
    pub input_complete: bool,
    /// Chunks copied.
    pub chunks: u64,
    /// Messages copied.
    pub messages: u64,
    /// Messages copied, per topic.
    pub messages_per_topic: BTreeMap<String, u64>,
    /// Metadata records copied.
    pub metadata: u64,
    /// Attachments copied.
    pub attachments: u64,
    /// Bytes of the input that were read as complete records.
    pub valid_bytes: u64,
    /// Bytes of the input after that (the cut-off chunk and anything after it).
    pub discarded_bytes: u64,
    /// Why reading stopped before the end of the data section, with the byte offset.
    pub damage: Option<String>,
}

/// Why a file could not be repaired.
#[derive(Debug, Error)]
pub enum RecoverError {
    /// The output would overwrite the input.
    #[error("{}: the repaired file must be a different file from the broken one", path.display())]
    SamePath {
        /// The path given twice.
        path: PathBuf,
    },
    /// The input cannot be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The input.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// The input is not an MCAP file (or is damaged before its first record).
    #[error("{} is not an MCAP file: {reason}", path.display())]
    NotMcap {
        /// The input.
        path: PathBuf,
        /// What was found.
        reason: String,
    },
    /// The output cannot be created (exists already, missing or read-only folder).
    #[error("cannot create {}: {source}; choose another output path", path.display())]
    Create {
        /// The output.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// Writing the output failed.
    #[error("cannot write {}: {source}", path.display())]
    Write {
        /// The output.
        path: PathBuf,
        /// What the MCAP writer said.
        source: McapError,
    },
}

/// Repairs `broken` into `fixed` (which must not exist). See the module docs.
///
/// # Errors
/// [`RecoverError`]: the input cannot be read or is not MCAP, or the output cannot be
/// written.
pub fn recover(broken: &Path, fixed: &Path) -> Result<RecoverReport, RecoverError> {
    if same_file(broken, fixed) {
        return Err(RecoverError::SamePath {
            path: fixed.to_path_buf(),
        });
    }
    let read_error = |source| RecoverError::Read {
        path: broken.to_path_buf(),
        source,
    };
    let mut input = File::open(broken).map_err(read_error)?;
    let input_size = input.metadata().map_err(read_error)?.len();
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_emit_chunks(true)
            .with_validate_chunk_crcs(false)
            .with_validate_data_section_crc(false)
            .with_validate_summary_section_crc(false)
            // No record is longer than the file: a chunk whose header still has the
            // writer's placeholder length (all ones) is then an error, not an overflow.
            .with_record_length_limit(usize::try_from(input_size).unwrap_or(usize::MAX)),
    );
    let mut copier = Copier::new(broken, fixed);
    let mut offset = 0_u64;
    let mut started = false;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(need)) => {
                let buffer = reader.insert(need.clamp(1, READ_BYTES));
                let n = input.read(buffer).map_err(read_error)?;
                reader.notify_read(n);
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                if !started {
                    started = true;
                    offset = MAGIC_BYTES;
                }
                let record_bytes = RECORD_PREFIX_BYTES + data.len() as u64;
                let record = match mcap::parse_record(opcode, data) {
                    Ok(record) => record,
                    Err(error) => {
                        copier.damage(offset, &format!("a record that does not parse ({error})"));
                        break;
                    }
                };
                match copier.copy(record, offset)? {
                    Flow::Continue => offset += record_bytes,
                    Flow::DataEnd => {
                        offset += record_bytes;
                        copier.report.input_complete = true;
                        break;
                    }
                    Flow::Damaged => break,
                }
            }
            Err(error) => {
                if !started {
                    return Err(RecoverError::NotMcap {
                        path: broken.to_path_buf(),
                        reason: error.to_string(),
                    });
                }
                let what = match error {
                    McapError::UnexpectedEof => {
                        "a record cut short by the end of the file".to_owned()
                    }
                    McapError::RecordTooLarge { .. } => {
                        "an unfinished record (its length runs past the end of the file)".to_owned()
                    }
                    other => format!("an unreadable record ({other})"),
                };
                copier.damage(offset, &what);
                break;
            }
        }
    }
    if !started {
        return Err(RecoverError::NotMcap {
            path: broken.to_path_buf(),
            reason: "the file is empty or has no MCAP header".to_owned(),
        });
    }
    let mut report = copier.finish()?;
    report.valid_bytes = offset.min(input_size);
    report.discarded_bytes = if report.input_complete {
        0
    } else {
        input_size.saturating_sub(report.valid_bytes)
    };
    Ok(report)
}

enum Flow {
    Continue,
    DataEnd,
    Damaged,
}

/// The output side: an MCAP writer created at the first record (the Header gives the
/// profile) and fed what is read.
struct Copier<'a> {
    broken: &'a Path,
    fixed: &'a Path,
    writer: Option<Writer<BufWriter<File>>>,
    profile: String,
    compression: Option<Option<mcap::Compression>>,
    topics: BTreeMap<u16, String>,
    report: RecoverReport,
}

impl<'a> Copier<'a> {
    fn new(broken: &'a Path, fixed: &'a Path) -> Self {
        Self {
            broken,
            fixed,
            writer: None,
            profile: String::new(),
            compression: None,
            topics: BTreeMap::new(),
            report: RecoverReport::default(),
        }
    }

    fn damage(&mut self, offset: u64, what: &str) {
        self.report.damage = Some(format!(
            "{}: {what} at byte {offset}; everything from there on is lost",
            self.broken.display()
        ));
    }

    /// The writer, created on first use with the compression of the first chunk seen.
    fn writer(&mut self) -> Result<&mut Writer<BufWriter<File>>, RecoverError> {
        let writer = match self.writer.take() {
            Some(writer) => writer,
            None => {
                let file = OpenOptions::new()
                    .write(true)
                    .create_new(true)
                    .open(self.fixed)
                    .map_err(|source| RecoverError::Create {
                        path: self.fixed.to_path_buf(),
                        source,
                    })?;
                let compression = self.compression.unwrap_or(Some(mcap::Compression::Zstd));
                write_options(compression)
                    .profile(self.profile.clone())
                    .create(BufWriter::new(file))
                    .map_err(|e| write_error(self.fixed, e))?
            }
        };
        Ok(self.writer.insert(writer))
    }

    fn copy(&mut self, record: Record<'_>, offset: u64) -> Result<Flow, RecoverError> {
        let fixed = self.fixed;
        match record {
            Record::Header(header) => self.profile = header.profile,
            Record::Chunk { header, data } => {
                if self.compression.is_none() {
                    self.compression = Some(match header.compression.as_str() {
                        "zstd" => Some(mcap::Compression::Zstd),
                        "lz4" => Some(mcap::Compression::Lz4),
                        _ => None,
                    });
                }
                let staged: Result<Vec<Record<'static>>, McapError> =
                    ChunkReader::new(header, &data)
                        .and_then(|records| records.map(|r| r.map(Record::into_owned)).collect());
                let staged = match staged {
                    Ok(staged) => staged,
                    Err(error) => {
                        self.damage(offset, &format!("a chunk that does not decode ({error})"));
                        return Ok(Flow::Damaged);
                    }
                };
                for record in staged {
                    self.copy_inner(record)?;
                }
                let writer = self.writer()?;
                writer.flush().map_err(|e| write_error(fixed, e))?;
                self.report.chunks += 1;
            }
            Record::DataEnd(_) | Record::Footer(_) => return Ok(Flow::DataEnd),
            Record::Metadata(metadata) => {
                let writer = self.writer()?;
                writer
                    .write_metadata(&metadata)
                    .map_err(|e| write_error(fixed, e))?;
                self.report.metadata += 1;
            }
            Record::Attachment { header, data, .. } => {
                let attachment = Attachment {
                    log_time: header.log_time,
                    create_time: header.create_time,
                    name: header.name,
                    media_type: header.media_type,
                    data,
                };
                let writer = self.writer()?;
                writer
                    .attach(&attachment)
                    .map_err(|e| write_error(fixed, e))?;
                self.report.attachments += 1;
            }
            record @ (Record::Schema { .. } | Record::Channel(_) | Record::Message { .. }) => {
                self.copy_inner(record)?;
            }
            // Indexes and summary records are rebuilt; private records are not ours.
            _ => {}
        }
        Ok(Flow::Continue)
    }

    /// Copies a schema, channel or message (from a chunk or not).
    fn copy_inner(&mut self, record: Record<'_>) -> Result<(), RecoverError> {
        let fixed = self.fixed;
        match record {
            Record::Schema { header, data } => {
                let writer = self.writer()?;
                writer
                    .add_schema_with_id(header.id, &header.name, &header.encoding, &data)
                    .map_err(|e| write_error(fixed, e))?;
            }
            Record::Channel(channel) => {
                let writer = self.writer()?;
                writer
                    .add_channel_with_id(
                        channel.id,
                        channel.schema_id,
                        &channel.topic,
                        &channel.message_encoding,
                        &channel.metadata,
                    )
                    .map_err(|e| write_error(fixed, e))?;
                self.topics.insert(channel.id, channel.topic);
            }
            Record::Message { header, data } => {
                let writer = self.writer()?;
                writer
                    .write_to_known_channel(&header, &data)
                    .map_err(|e| write_error(fixed, e))?;
                self.report.messages += 1;
                let topic = self
                    .topics
                    .get(&header.channel_id)
                    .cloned()
                    .unwrap_or_default();
                *self.report.messages_per_topic.entry(topic).or_default() += 1;
            }
            _ => {}
        }
        Ok(())
    }

    fn finish(mut self) -> Result<RecoverReport, RecoverError> {
        let fixed = self.fixed;
        let writer = self.writer()?;
        writer.finish().map_err(|e| write_error(fixed, e))?;
        if let Some(writer) = self.writer.take() {
            let file = writer.into_inner();
            let file = file.into_inner().map_err(|e| RecoverError::Write {
                path: self.fixed.to_path_buf(),
                source: McapError::Io(e.into_error()),
            })?;
            file.sync_all().map_err(|source| RecoverError::Write {
                path: self.fixed.to_path_buf(),
                source: McapError::Io(source),
            })?;
        }
        Ok(self.report)
    }
}

fn write_error(path: &Path, source: McapError) -> RecoverError {
    RecoverError::Write {
        path: path.to_path_buf(),
        source,
    }
}

fn same_file(a: &Path, b: &Path) -> bool {
    match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}
