//! Repair of a recording whose writer died (SIGKILL, power cut, full disk): every complete
//! record up to the first damaged one (as `lewis_mcap`'s scan finds them) is copied into a
//! new file, which gets fresh message and chunk indexes, statistics, a summary and a footer.
//!
//! Chunks are copied one for one (decompressed, checked against their CRC, written again
//! with the same compression and the same boundaries); a chunk cut short, or whose CRC
//! fails, and everything after it, are what is lost. The report says how much.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::BufWriter;
use std::path::{Path, PathBuf};

use lewis_mcap::records::Record;
use lewis_mcap::{At, Flow, McapFile, OpenError, ScanError, Visitor};
use mcap::{Attachment, McapError, Writer};
use thiserror::Error;

use crate::part::write_options;

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
    let mut input = McapFile::open(broken).map_err(|error| match error {
        OpenError::Io(source) => read_error(source),
        OpenError::NotMcap { error, .. } => RecoverError::NotMcap {
            path: broken.to_path_buf(),
            reason: error.to_string(),
        },
    })?;
    let mut copier = Copier::new(broken, fixed);
    let end = input.scan(&mut copier).map_err(|error| match error {
        ScanError::Io(source) => read_error(source),
        ScanError::Visitor(error) => error,
    })?;
    if let Some(damage) = &end.damage {
        copier.damage(damage.offset, &damage.what());
    }
    let mut report = copier.finish()?;
    report.valid_bytes = end.read_bytes;
    report.discarded_bytes = if report.input_complete {
        0
    } else {
        input.size_bytes().saturating_sub(report.valid_bytes)
    };
    Ok(report)
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

    fn copy(&mut self, record: Record<'_>) -> Result<Flow, RecoverError> {
        let fixed = self.fixed;
        match record {
            Record::Header(header) => self.profile = header.profile,
            // Its records follow (the scan checked the whole chunk first), then `chunk_end`.
            Record::Chunk { header, .. } => {
                self.compression
                    .get_or_insert(match header.compression.as_str() {
                        "zstd" => Some(mcap::Compression::Zstd),
                        "lz4" => Some(mcap::Compression::Lz4),
                        _ => None,
                    });
            }
            Record::DataEnd(_) | Record::Footer(_) => {
                self.report.input_complete = true;
                return Ok(Flow::Stop);
            }
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

impl Visitor for Copier<'_> {
    type Error = RecoverError;

    fn record(&mut self, at: At, record: Record<'_>) -> Result<Flow, RecoverError> {
        if at.in_chunk {
            self.copy_inner(record)?;
            Ok(Flow::Continue)
        } else {
            self.copy(record)
        }
    }

    /// A chunk of the input is a chunk of the output: same boundaries.
    fn chunk_end(&mut self, _offset: u64) -> Result<Flow, RecoverError> {
        let fixed = self.fixed;
        let writer = self.writer()?;
        writer.flush().map_err(|e| write_error(fixed, e))?;
        self.report.chunks += 1;
        Ok(Flow::Continue)
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
