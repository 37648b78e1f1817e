//! What the viewer takes from an MCAP file: its channels with their schemas, its messages
//! in file order, its metadata. The reading is `lewis_mcap`'s scan (from the start, one
//! chunk in memory at a time); a file cut short (a writer that died) is read up to the
//! damage, which is reported rather than fatal.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use lewis_mcap::records::Record;
use lewis_mcap::{At, Flow, MAGIC, McapFile, OpenError, ScanError, Visitor};

use crate::ViewError;

/// A channel with its schema, as the file declares them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ChannelInfo {
    /// The channel id, unique within one file.
    pub id: u16,
    /// The topic (`/laser/RangeFinder`).
    pub topic: String,
    /// The message encoding (`cdr`).
    pub message_encoding: String,
    /// The schema name (`lewis_interfaces/msg/RangeFinder`); empty when there is none.
    pub schema_name: String,
    /// The schema encoding (`ros2msg`); empty when there is none.
    pub schema_encoding: String,
    /// The schema text.
    pub schema_data: Vec<u8>,
    /// The channel's metadata (`provider`, `interface`).
    pub metadata: BTreeMap<String, String>,
}

/// One message, borrowed from the chunk being read.
#[derive(Debug)]
pub(crate) struct MessageRef<'a> {
    /// Its channel.
    pub channel: &'a Arc<ChannelInfo>,
    /// When the recorder received it, ns since the epoch.
    pub log_time_ns: u64,
    /// When it was published, ns since the epoch.
    pub publish_time_ns: u64,
    /// The encoded message.
    pub data: &'a [u8],
}

/// What reading a file found besides its messages.
#[derive(Debug, Default)]
pub(crate) struct ReadOutcome {
    /// Why reading stopped before the end, when it did.
    pub damage: Option<String>,
    /// The file's metadata records, by name (the last one of a name wins).
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
}

/// Calls `on_message` for every message of the file at `path`, in file order, and
/// `on_progress` with the bytes read so far.
pub(crate) fn read_file(
    path: &Path,
    on_message: &mut dyn FnMut(MessageRef<'_>) -> Result<(), ViewError>,
    on_progress: &mut dyn FnMut(u64),
) -> Result<ReadOutcome, ViewError> {
    let read_error = |source| ViewError::Read {
        path: path.to_owned(),
        source,
    };
    let mut file = McapFile::open(path).map_err(|error| match error {
        OpenError::Io(source) => read_error(source),
        OpenError::NotMcap { start, error } => ViewError::NotMcap {
            path: path.to_owned(),
            detail: if start == MAGIC {
                error.to_string()
            } else {
                format!("it starts with {start:02x?}")
            },
        },
    })?;
    let mut state = State {
        schemas: BTreeMap::new(),
        channels: BTreeMap::new(),
        outcome: ReadOutcome::default(),
        on_message,
        on_progress,
    };
    let end = file.scan(&mut state).map_err(|error| match error {
        ScanError::Io(source) => read_error(source),
        ScanError::Visitor(error) => error,
    })?;
    let mut outcome = state.outcome;
    if outcome.damage.is_none() {
        outcome.damage = end.damage.map(|damage| damage.to_string());
    }
    Ok(outcome)
}

/// The scan's visitor: channels with their schemas, each message handed on.
struct State<'a> {
    schemas: BTreeMap<u16, (String, String, Vec<u8>)>,
    channels: BTreeMap<u16, Arc<ChannelInfo>>,
    outcome: ReadOutcome,
    on_message: &'a mut dyn FnMut(MessageRef<'_>) -> Result<(), ViewError>,
    on_progress: &'a mut dyn FnMut(u64),
}

impl Visitor for State<'_> {
    type Error = ViewError;

    fn record(&mut self, _at: At, record: Record<'_>) -> Result<Flow, ViewError> {
        match record {
            Record::Schema { header, data } => {
                self.schemas
                    .insert(header.id, (header.name, header.encoding, data.into_owned()));
            }
            Record::Channel(channel) => {
                let (schema_name, schema_encoding, schema_data) = self
                    .schemas
                    .get(&channel.schema_id)
                    .cloned()
                    .unwrap_or_default();
                let info = ChannelInfo {
                    id: channel.id,
                    topic: channel.topic,
                    message_encoding: channel.message_encoding,
                    schema_name,
                    schema_encoding,
                    schema_data,
                    metadata: channel.metadata,
                };
                self.channels.insert(channel.id, Arc::new(info));
            }
            Record::Message { header, data } => {
                // A message on an undeclared channel cannot be interpreted; MCAP requires the
                // channel first, so this is damage.
                let Some(channel) = self.channels.get(&header.channel_id) else {
                    self.outcome.damage = Some(format!(
                        "a message on channel {} comes before that channel's record",
                        header.channel_id
                    ));
                    return Ok(Flow::Stop);
                };
                (self.on_message)(MessageRef {
                    channel,
                    log_time_ns: header.log_time,
                    publish_time_ns: header.publish_time,
                    data: &data,
                })?;
            }
            Record::Metadata(metadata) => {
                self.outcome
                    .metadata
                    .insert(metadata.name, metadata.metadata);
            }
            _ => {}
        }
        Ok(Flow::Continue)
    }

    fn progress(&mut self, bytes_read: u64) {
        (self.on_progress)(bytes_read);
    }
}
