//! Reading an MCAP file record by record, from the start, as far as it can be read.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};

use mcap::McapError;
use mcap::read::ChunkReader;
use mcap::records::{Channel, Header, Metadata, Record, Statistics};
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

/// A schema record's contents.
#[derive(Debug, Clone)]
pub(super) struct SchemaRecord {
    pub name: String,
    pub encoding: String,
    pub data: Vec<u8>,
}

/// A message kept to be decoded and shown.
#[derive(Debug, Clone)]
pub(super) struct RawMessage {
    pub channel_id: u16,
    pub sequence: u32,
    pub log_time_ns: u64,
    pub publish_time_ns: u64,
    pub data: Vec<u8>,
}

/// What a scan found.
#[derive(Debug, Default)]
pub(super) struct Scan {
    pub header: Option<Header>,
    pub schemas: BTreeMap<u16, SchemaRecord>,
    pub channels: BTreeMap<u16, Channel>,
    pub message_counts: BTreeMap<u16, u64>,
    pub message_count: u64,
    pub start_ns: Option<u64>,
    pub end_ns: Option<u64>,
    pub chunk_count: u64,
    pub compressions: BTreeMap<String, u64>,
    pub metadata: Vec<Metadata>,
    pub attachment_count: u64,
    pub statistics: Option<Statistics>,
    /// The footer record and the end magic were read: the file is complete.
    pub complete: bool,
    /// Why reading stopped before the end, if it did.
    pub failure: Option<McapError>,
    /// The first messages, in file order.
    pub messages: Vec<RawMessage>,
}

/// What to do besides counting.
#[derive(Debug, Clone, Copy)]
pub(super) struct ScanGoal {
    /// Keep this many messages.
    pub keep_messages: usize,
    /// Stop as soon as the messages are kept (the counts are then partial).
    pub stop_when_kept: bool,
}

/// Reads `file` from its start. I/O errors are returned; format errors end the scan and are
/// kept in [`Scan::failure`] with everything read before them.
pub(super) fn scan(file: &mut File, file_size: u64, goal: ScanGoal) -> io::Result<Scan> {
    file.seek(SeekFrom::Start(0))?;
    let limit = usize::try_from(file_size).unwrap_or(usize::MAX);
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_emit_chunks(true)
            .with_record_length_limit(limit),
    );
    let mut found = Scan::default();
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(wanted)) => {
                let read = read_some(file, reader.insert(wanted))?;
                reader.notify_read(read);
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                let outcome =
                    mcap::parse_record(opcode, data).and_then(|record| found.record(record, goal));
                match outcome {
                    Ok(Flow::Continue) => {}
                    Ok(Flow::Stop) => return Ok(found),
                    Err(error) => {
                        found.failure = Some(error);
                        return Ok(found);
                    }
                }
            }
            Err(error) => {
                found.failure = Some(error);
                return Ok(found);
            }
        }
    }
    Ok(found)
}

fn read_some(file: &mut File, buffer: &mut [u8]) -> io::Result<usize> {
    loop {
        match file.read(buffer) {
            Err(error) if error.kind() == io::ErrorKind::Interrupted => {}
            other => return other,
        }
    }
}

enum Flow {
    Continue,
    Stop,
}

impl Scan {
    fn record(&mut self, record: Record<'_>, goal: ScanGoal) -> Result<Flow, McapError> {
        match record {
            Record::Header(header) => self.header = Some(header),
            Record::Footer(_) => self.complete = true,
            Record::Schema { header, data } => {
                let schema = SchemaRecord {
                    name: header.name,
                    encoding: header.encoding,
                    data: data.into_owned(),
                };
                self.schemas.insert(header.id, schema);
            }
            Record::Channel(channel) => {
                self.channels.insert(channel.id, channel);
            }
            Record::Message { header, data } => {
                self.message_count += 1;
                *self.message_counts.entry(header.channel_id).or_default() += 1;
                let time = header.log_time;
                self.start_ns = Some(self.start_ns.map_or(time, |start| start.min(time)));
                self.end_ns = Some(self.end_ns.map_or(time, |end| end.max(time)));
                if self.messages.len() < goal.keep_messages {
                    self.messages.push(RawMessage {
                        channel_id: header.channel_id,
                        sequence: header.sequence,
                        log_time_ns: header.log_time,
                        publish_time_ns: header.publish_time,
                        data: data.into_owned(),
                    });
                    if goal.stop_when_kept && self.messages.len() == goal.keep_messages {
                        return Ok(Flow::Stop);
                    }
                }
            }
            Record::Chunk { header, data } => {
                self.chunk_count += 1;
                *self
                    .compressions
                    .entry(header.compression.clone())
                    .or_default() += 1;
                for inner in ChunkReader::new(header, &data)? {
                    if let Flow::Stop = self.record(inner?, goal)? {
                        return Ok(Flow::Stop);
                    }
                }
            }
            Record::Attachment { .. } => self.attachment_count += 1,
            Record::Metadata(metadata) => self.metadata.push(metadata),
            Record::Statistics(statistics) => self.statistics = Some(statistics),
            Record::MessageIndex(_)
            | Record::ChunkIndex(_)
            | Record::AttachmentIndex(_)
            | Record::MetadataIndex(_)
            | Record::SummaryOffset(_)
            | Record::DataEnd(_)
            | Record::Unknown { .. } => {}
        }
        Ok(Flow::Continue)
    }
}
