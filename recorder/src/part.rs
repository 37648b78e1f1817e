//! One MCAP file being written: the mcap crate's writer over a [`PartFile`], with chunks
//! closed by the recorder (by size and by time) so that it knows which messages are on
//! the disk.

use std::collections::BTreeMap;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};

use mcap::records::{MessageHeader, Metadata};
use mcap::{WriteOptions, Writer};

use crate::channel::{ChannelSpec, MESSAGE_ENCODING, SCHEMA_ENCODING};
use crate::error::{NoRoom, RecordError};
use crate::options::RecorderOptions;
use crate::sink::{PartFile, RoomFlag};
use crate::syncer::Syncer;

/// The MCAP profile: ROS 2 conventions (cdr messages, ros2msg schemas).
pub const PROFILE: &str = "ros2";

/// Bytes a message record takes besides its data: opcode, length, channel, sequence,
/// log time, publish time.
const MESSAGE_RECORD_OVERHEAD: u64 = 1 + 8 + 2 + 4 + 8 + 8;

/// Buffer between the MCAP writer and the file.
const FILE_BUFFER_BYTES: usize = 256 * 1024;

/// One file of a recording, open for writing.
pub(crate) struct Part {
    path: PathBuf,
    writer: Writer<BufWriter<PartFile>>,
    sync: Option<Syncer>,
    room: RoomFlag,
    size: Arc<AtomicU64>,
    /// The MCAP channel id of each registered channel, by [`crate::ChannelId`].
    channel_ids: Vec<u16>,
    /// Uncompressed bytes in the open chunk.
    pending_bytes: u64,
    /// Messages written, and of those, in closed chunks handed to the system.
    pub(crate) messages: u64,
    pub(crate) durable_messages: u64,
    pub(crate) first_log_time_ns: Option<i64>,
    pub(crate) last_log_time_ns: Option<i64>,
}

impl Part {
    /// Creates the file and writes its header and file metadata.
    pub(crate) fn create(
        path: &Path,
        options: &RecorderOptions,
        metadata: &[Metadata],
    ) -> Result<Self, RecordError> {
        let file = PartFile::create(path, options.disk_reserve_bytes)?;
        let room = file.room_flag();
        let size = file.size_handle();
        let sync = if options.sync_on_flush {
            Some(
                file.sync_handle()
                    .and_then(Syncer::start)
                    .map_err(|e| RecordError::opening(path, e))?,
            )
        } else {
            None
        };
        let writer = write_options(options.compression.to_mcap())
            .create(BufWriter::with_capacity(FILE_BUFFER_BYTES, file))
            .map_err(|e| RecordError::writing(path, e))?;
        let mut part = Self {
            path: path.to_path_buf(),
            writer,
            sync,
            room,
            size,
            channel_ids: Vec::new(),
            pending_bytes: 0,
            messages: 0,
            durable_messages: 0,
            first_log_time_ns: None,
            last_log_time_ns: None,
        };
        for record in metadata {
            part.writer
                .write_metadata(record)
                .map_err(|e| RecordError::writing(path, e))?;
        }
        Ok(part)
    }

    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    /// Bytes handed to the system so far.
    pub(crate) fn size_bytes(&self) -> u64 {
        self.size.load(Ordering::Relaxed)
    }

    /// Why the file has no more room, once it has none (the reserve or the headroom
    /// below the file size limit is then all that is left: close now).
    pub(crate) fn no_room(&self) -> Option<NoRoom> {
        self.room.get()
    }

    /// Adds the channel that comes next in registration order.
    pub(crate) fn add_channel(&mut self, spec: &ChannelSpec) -> Result<(), RecordError> {
        let schema_id = self
            .writer
            .add_schema(
                &spec.schema_name,
                SCHEMA_ENCODING,
                spec.schema_text.as_bytes(),
            )
            .map_err(|e| RecordError::writing(&self.path, e))?;
        let id = self
            .writer
            .add_channel(schema_id, &spec.topic, MESSAGE_ENCODING, &spec.metadata())
            .map_err(|e| RecordError::writing(&self.path, e))?;
        self.channel_ids.push(id);
        Ok(())
    }

    /// Writes one message on the part's channel `index` (0 is the recorder's stats, then
    /// the registered channels in order).
    pub(crate) fn write(
        &mut self,
        index: usize,
        sequence: u32,
        publish_time_ns: i64,
        log_time_ns: i64,
        data: &[u8],
    ) -> Result<(), RecordError> {
        let Some(&channel_id) = self.channel_ids.get(index) else {
            return Err(RecordError::UnknownChannel {
                channel: crate::ChannelId(u32::try_from(index).unwrap_or(u32::MAX)),
            });
        };
        let header = MessageHeader {
            channel_id,
            sequence,
            log_time: mcap_time(log_time_ns),
            publish_time: mcap_time(publish_time_ns),
        };
        self.writer
            .write_to_known_channel(&header, data)
            .map_err(|e| RecordError::writing(&self.path, e))?;
        // The recorder's own stats (channel 0) are not counted as recorded messages.
        if index != 0 {
            self.messages += 1;
            self.first_log_time_ns.get_or_insert(log_time_ns);
            self.last_log_time_ns = Some(log_time_ns);
        }
        self.pending_bytes += MESSAGE_RECORD_OVERHEAD + data.len() as u64;
        Ok(())
    }

    /// Whether the open chunk has reached `chunk_size_bytes`.
    pub(crate) fn chunk_full(&self, chunk_size_bytes: u64) -> bool {
        self.pending_bytes >= chunk_size_bytes
    }

    /// Whether anything (the recorder's stats included) is in the open chunk.
    pub(crate) fn chunk_has_data(&self) -> bool {
        self.pending_bytes > 0
    }

    /// Whether messages wait in an open chunk.
    pub(crate) fn has_pending(&self) -> bool {
        self.messages > self.durable_messages
    }

    /// Closes the open chunk and hands everything to the system; with `sync`, also asks
    /// for it to reach the disk (on the syncer's thread: this does not wait for the disk).
    pub(crate) fn flush(&mut self, sync: bool) -> Result<(), RecordError> {
        self.writer
            .flush()
            .map_err(|e| RecordError::writing(&self.path, e))?;
        self.pending_bytes = 0;
        self.durable_messages = self.messages;
        if sync && let Some(syncer) = &self.sync {
            syncer.request().map_err(|source| RecordError::Io {
                path: self.path.clone(),
                source,
            })?;
        }
        Ok(())
    }

    /// Writes a metadata record (it closes the open chunk first).
    pub(crate) fn write_metadata(&mut self, record: &Metadata) -> Result<(), RecordError> {
        self.writer
            .write_metadata(record)
            .map_err(|e| RecordError::writing(&self.path, e))?;
        self.pending_bytes = 0;
        self.durable_messages = self.messages;
        Ok(())
    }

    /// Closes the last chunk, writes the summary (schemas, channels, statistics, chunk
    /// and metadata indexes) and the footer, and syncs the file.
    pub(crate) fn finish(mut self) -> Result<(), RecordError> {
        self.writer
            .finish()
            .map_err(|e| RecordError::writing(&self.path, e))?;
        self.durable_messages = self.messages;
        let syncer = self.sync.take();
        let mut file = self.writer.into_inner();
        file.flush().map_err(|source| RecordError::Io {
            path: self.path.clone(),
            source,
        })?;
        // After the last bytes left the buffer: the file is on the disk when this returns.
        if let Some(syncer) = syncer {
            syncer.finish().map_err(|source| RecordError::Io {
                path: self.path.clone(),
                source,
            })?;
        }
        if let Ok(mut file) = file.into_inner() {
            file.release_reserve();
        }
        Ok(())
    }
}

/// The writer options of every file the recorder writes: profile `ros2`, chunked with
/// message and chunk indexes, statistics, repeated schemas and channels in the summary,
/// summary offsets and CRCs; chunks closed by the recorder only.
pub(crate) fn write_options(compression: Option<mcap::Compression>) -> WriteOptions {
    WriteOptions::new()
        .profile(PROFILE)
        .library(format!(
            "lewis-recorder/{} ({})",
            env!("CARGO_PKG_VERSION"),
            mcap::LIBRARY_IDENTIFIER
        ))
        .compression(compression)
        .use_chunks(true)
        .chunk_size(None)
        .emit_statistics(true)
        .emit_message_indexes(true)
        .emit_chunk_indexes(true)
        .emit_metadata_indexes(true)
        .emit_summary_offsets(true)
        .repeat_channels(true)
        .repeat_schemas(true)
}

/// MCAP times are unsigned: a time before the epoch (a clock not yet set) is written as 0.
pub(crate) fn mcap_time(time_ns: i64) -> u64 {
    u64::try_from(time_ns).unwrap_or(0)
}

/// The metadata map of one record.
pub(crate) fn metadata(name: &str, entries: BTreeMap<String, String>) -> Metadata {
    Metadata {
        name: name.to_owned(),
        metadata: entries,
    }
}
