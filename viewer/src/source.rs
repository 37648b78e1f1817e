//! Reading MCAP files record by record from the start, as far as they can be read, without
//! holding more than one chunk in memory. A file cut short (a writer that died) is read up
//! to the damage, which is reported rather than fatal.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, Read};
use std::path::Path;
use std::sync::Arc;

use mcap::read::ChunkReader;
use mcap::records::Record;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

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
    let mut file = File::open(path).map_err(read_error)?;
    let size = file.metadata().map_err(read_error)?.len();
    let mut magic = [0_u8; 8];
    let got = read_some(&mut file, &mut magic).map_err(read_error)?;
    if got < magic.len() || &magic[..] != mcap::MAGIC {
        return Err(ViewError::NotMcap {
            path: path.to_owned(),
            detail: format!("it starts with {:02x?}", &magic[..got]),
        });
    }
    let mut file = File::open(path).map_err(read_error)?;
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_emit_chunks(true)
            .with_record_length_limit(usize::try_from(size).unwrap_or(usize::MAX)),
    );
    let mut state = State::default();
    let mut bytes_read = 0_u64;
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(wanted)) => {
                let read = read_some(&mut file, reader.insert(wanted)).map_err(read_error)?;
                bytes_read += read as u64;
                on_progress(bytes_read);
                reader.notify_read(read);
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                let record = match mcap::parse_record(opcode, data) {
                    Ok(record) => record,
                    Err(error) => {
                        state.outcome.damage = Some(error.to_string());
                        break;
                    }
                };
                if let Err(damage) = state.record(record, on_message)? {
                    state.outcome.damage = Some(damage);
                    break;
                }
            }
            Err(error) => {
                state.outcome.damage = Some(error.to_string());
                break;
            }
        }
    }
    Ok(state.outcome)
}

fn read_some(file: &mut File, buffer: &mut [u8]) -> io::Result<usize> {
    let mut filled = 0;
    while filled < buffer.len() {
        match file.read(&mut buffer[filled..]) {
            Ok(0) => break,
            Ok(read) => filled += read,
            Err(error) if error.kind() == io::ErrorKind::Interrupted => {}
            Err(error) => return Err(error),
        }
    }
    Ok(filled)
}

#[derive(Default)]
struct State {
    schemas: BTreeMap<u16, (String, String, Vec<u8>)>,
    channels: BTreeMap<u16, Arc<ChannelInfo>>,
    outcome: ReadOutcome,
}

impl State {
    /// `Ok(Err(damage))` when the file's content is broken; `Err` when the callback failed.
    fn record(
        &mut self,
        record: Record<'_>,
        on_message: &mut dyn FnMut(MessageRef<'_>) -> Result<(), ViewError>,
    ) -> Result<Result<(), String>, ViewError> {
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
                    return Ok(Err(format!(
                        "a message on channel {} comes before that channel's record",
                        header.channel_id
                    )));
                };
                on_message(MessageRef {
                    channel,
                    log_time_ns: header.log_time,
                    publish_time_ns: header.publish_time,
                    data: &data,
                })?;
            }
            Record::Chunk { header, data } => {
                let records = match ChunkReader::new(header, &data) {
                    Ok(records) => records,
                    Err(error) => return Ok(Err(error.to_string())),
                };
                for inner in records {
                    let inner = match inner {
                        Ok(inner) => inner,
                        Err(error) => return Ok(Err(error.to_string())),
                    };
                    if let Err(damage) = self.record(inner, on_message)? {
                        return Ok(Err(damage));
                    }
                }
            }
            Record::Metadata(metadata) => {
                self.outcome
                    .metadata
                    .insert(metadata.name, metadata.metadata);
            }
            _ => {}
        }
        Ok(Ok(()))
    }
}
