//! What a scan of a file from its start counts, as far as it can be read (the reading
//! is `lewis_mcap`'s).

use std::collections::BTreeMap;
use std::convert::Infallible;
use std::io;

use lewis_mcap::records::{Channel, Header, Metadata, Record, Statistics};
use lewis_mcap::{At, Flow, McapError, McapFile, ScanError, Visitor};

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

/// Reads `file` from its start. I/O errors are returned; damage ends the scan and is kept
/// in [`Scan::failure`] with everything read before it.
pub(super) fn scan(file: &mut McapFile, goal: ScanGoal) -> io::Result<Scan> {
    let mut counter = Counter {
        found: Scan::default(),
        goal,
    };
    let end = match file.scan(&mut counter) {
        Ok(end) => end,
        Err(ScanError::Io(error)) => return Err(error),
        Err(ScanError::Visitor(never)) => match never {},
    };
    let mut found = counter.found;
    found.failure = end.damage.map(|damage| damage.error);
    Ok(found)
}

/// The scan's visitor: counts, and keeps the first messages.
struct Counter {
    found: Scan,
    goal: ScanGoal,
}

impl Visitor for Counter {
    type Error = Infallible;

    fn record(&mut self, _at: At, record: Record<'_>) -> Result<Flow, Infallible> {
        Ok(self.found.record(record, self.goal))
    }
}

impl Scan {
    fn record(&mut self, record: Record<'_>, goal: ScanGoal) -> Flow {
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
                        return Flow::Stop;
                    }
                }
            }
            // Its records follow, one by one.
            Record::Chunk { header, .. } => {
                self.chunk_count += 1;
                *self.compressions.entry(header.compression).or_default() += 1;
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
        Flow::Continue
    }
}
