//! A ROS 2 bag read record by record in file order (through `lewis-mcap`'s scan, so a bag
//! without a summary or damaged at its end is read as far as it goes), each message handed
//! out with its topic and its index on that topic.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use lewis_mcap::records::Record;
use lewis_mcap::{At, Damage, Flow, McapFile, ScanError, Visitor};
use lewis_ros2_map::qos::OFFERED_QOS_PROFILES;

use super::ImportError;

/// A topic of the bag (an MCAP channel and its schema).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topic {
    /// The MCAP channel id.
    pub id: u16,
    /// The topic name (`/scan`).
    pub name: String,
    /// The message type, as the schema names it (`sensor_msgs/msg/LaserScan`).
    pub type_name: String,
    /// The schema's encoding (`ros2msg` for ROS 2 bags).
    pub schema_encoding: String,
    /// The schema text (a ROS 2 message definition with its dependencies).
    pub schema_text: String,
    /// The messages' encoding (`cdr` for ROS 2 bags).
    pub message_encoding: String,
    /// The QoS its publishers offered (`offered_qos_profiles`), when the bag says (a
    /// non-empty list): kept on the imported channel as received.
    pub offered_qos: Option<String>,
}

impl Topic {
    /// Whether its messages are ROS 2 CDR under a ros2msg schema (the only kind decoded).
    #[must_use]
    pub fn is_ros2(&self) -> bool {
        self.schema_encoding == "ros2msg" && self.message_encoding == "cdr"
    }

    /// The type without the `msg/` part (`sensor_msgs/LaserScan`), so that ROS 1-style
    /// names and ROS 2 names compare equal.
    #[must_use]
    pub fn short_type(&self) -> String {
        self.type_name.replacen("/msg/", "/", 1)
    }
}

/// One message of the bag.
#[derive(Debug, Clone, Copy)]
pub struct BagMessage<'a> {
    /// Its topic.
    pub topic: &'a Topic,
    /// Its index among its topic's messages, from 0, in file order.
    pub index: u64,
    /// MCAP log time (rosbag2: when the recorder received it), in ns.
    pub log_time_ns: u64,
    /// MCAP publish time, in ns.
    pub publish_time_ns: u64,
    /// The CDR bytes.
    pub data: &'a [u8],
}

/// How a read ended.
#[derive(Debug, Clone, Default)]
pub struct ReadEnd {
    /// The damage that ended it early, if any: what and at which byte.
    pub damage: Option<String>,
    /// Bytes read.
    pub bytes: u64,
}

struct Reader<'f, F> {
    schemas: BTreeMap<u16, (String, String, String)>,
    topics: BTreeMap<u16, Arc<Topic>>,
    counts: BTreeMap<u16, u64>,
    on_message: &'f mut F,
}

impl<F, E> Visitor for Reader<'_, F>
where
    F: FnMut(BagMessage<'_>) -> Result<(), E>,
{
    type Error = E;

    fn record(&mut self, _at: At, record: Record<'_>) -> Result<Flow, E> {
        match record {
            Record::Schema { header, data } => {
                let text = String::from_utf8_lossy(&data).into_owned();
                self.schemas
                    .insert(header.id, (header.name, header.encoding, text));
            }
            Record::Channel(channel) => {
                let (type_name, schema_encoding, schema_text) = self
                    .schemas
                    .get(&channel.schema_id)
                    .cloned()
                    .unwrap_or_default();
                self.topics.insert(
                    channel.id,
                    Arc::new(Topic {
                        id: channel.id,
                        name: channel.topic,
                        type_name,
                        schema_encoding,
                        schema_text,
                        message_encoding: channel.message_encoding,
                        offered_qos: channel
                            .metadata
                            .get(OFFERED_QOS_PROFILES)
                            .filter(|text| !matches!(text.trim(), "" | "[]"))
                            .cloned(),
                    }),
                );
            }
            Record::Message { header, data } => {
                // A message of a channel the file never declared is not readable: skipped.
                if let Some(topic) = self.topics.get(&header.channel_id).cloned() {
                    let count = self.counts.entry(header.channel_id).or_default();
                    let index = *count;
                    *count += 1;
                    (self.on_message)(BagMessage {
                        topic: &topic,
                        index,
                        log_time_ns: header.log_time,
                        publish_time_ns: header.publish_time,
                        data: &data,
                    })?;
                }
            }
            _ => {}
        }
        Ok(Flow::Continue)
    }
}

/// Reads the bag at `path` from its start, handing every message to `on_message` in file
/// order; stops at the first error `on_message` returns.
///
/// # Errors
/// The file is not an MCAP file or cannot be read, or `on_message` failed.
pub fn read<F, E>(path: &Path, mut on_message: F) -> Result<ReadEnd, E>
where
    F: FnMut(BagMessage<'_>) -> Result<(), E>,
    E: From<ImportError>,
{
    let cannot = |reason: String| ImportError::Unreadable {
        path: path.to_owned(),
        reason,
    };
    let mut file = McapFile::open(path).map_err(|e| E::from(cannot(e.to_string())))?;
    let mut reader = Reader {
        schemas: BTreeMap::new(),
        topics: BTreeMap::new(),
        counts: BTreeMap::new(),
        on_message: &mut on_message,
    };
    match file.scan(&mut reader) {
        Ok(end) => Ok(ReadEnd {
            damage: end
                .damage
                .map(|d: Damage| format!("{} at byte {}", d.what(), d.offset)),
            bytes: end.read_bytes,
        }),
        Err(ScanError::Io(e)) => Err(E::from(cannot(e.to_string()))),
        Err(ScanError::Visitor(e)) => Err(e),
    }
}
