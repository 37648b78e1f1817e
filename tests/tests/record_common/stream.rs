//! A recording read in one pass with bounded memory (the mcap crate's sans-io linear
//! reader over the file, chunk by chunk): per topic, the sequence numbers as runs and a
//! count; the last `RecorderStats` message; the file metadata. For recordings too large
//! to hold in memory (the 30 s stress mix is close to 1 GB of messages).

use std::collections::BTreeMap;
use std::io::Read;
use std::path::Path;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::RecorderStats;
use mcap::records::Record;
use mcap::sans_io::linear_reader::{LinearReadEvent, LinearReader};

use super::header_of;

/// What one topic holds.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct TopicSeqs {
    /// Messages.
    pub count: u64,
    /// Header sequence numbers as runs of consecutive numbers, `[first, last]`.
    pub runs: Vec<[u64; 2]>,
    /// Messages whose MCAP publish time differs from the header's publish time.
    pub publish_time_mismatches: u64,
}

impl TopicSeqs {
    fn add(&mut self, seq: u64) {
        self.count += 1;
        match self.runs.last_mut() {
            Some(run) if run[1] + 1 == seq => run[1] = seq,
            _ => self.runs.push([seq, seq]),
        }
    }

    /// Numbers missing between the first and the last (gaps).
    pub fn gaps(&self) -> u64 {
        match (self.runs.first(), self.runs.last()) {
            (Some(first), Some(last)) => last[1] - first[0] + 1 - self.count,
            _ => 0,
        }
    }
}

/// A recording read in one pass.
#[derive(Debug, Default)]
pub struct Streamed {
    /// Per topic (the recorder's stats excluded).
    pub topics: BTreeMap<String, TopicSeqs>,
    /// The last stats message.
    pub last_stats: Option<RecorderStats>,
    /// File metadata by name.
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
}

impl Streamed {
    /// Reads `file` to its end (panics on any error: the test's failure).
    pub fn read(file: &Path) -> Self {
        let mut input = std::fs::File::open(file)
            .unwrap_or_else(|e| panic!("cannot open {}: {e}", file.display()));
        let mut reader = LinearReader::new();
        let mut topics_by_id: BTreeMap<u16, String> = BTreeMap::new();
        let mut streamed = Self::default();
        while let Some(event) = reader.next_event() {
            match event.unwrap_or_else(|e| panic!("{}: {e}", file.display())) {
                LinearReadEvent::ReadRequest(n) => {
                    let read = input.read(reader.insert(n)).unwrap();
                    reader.notify_read(read);
                }
                LinearReadEvent::Record { data, opcode } => {
                    match mcap::parse_record(opcode, data).unwrap() {
                        Record::Channel(channel) => {
                            topics_by_id.insert(channel.id, channel.topic);
                        }
                        Record::Message { header, data } => {
                            let topic = &topics_by_id[&header.channel_id];
                            if topic == lewis_recorder::STATS_TOPIC {
                                streamed.last_stats = Some(cdr::from_bytes(&data).unwrap());
                                continue;
                            }
                            let message_header = header_of(&data);
                            let seqs = streamed.topics.entry(topic.clone()).or_default();
                            seqs.add(message_header.seq);
                            if u64::try_from(message_header.publish_time_ns).ok()
                                != Some(header.publish_time)
                            {
                                seqs.publish_time_mismatches += 1;
                            }
                        }
                        Record::Metadata(metadata) => {
                            streamed
                                .metadata
                                .entry(metadata.name)
                                .or_default()
                                .extend(metadata.metadata);
                        }
                        _ => {}
                    }
                }
            }
        }
        streamed
    }

    /// The stats message's counts of `topic`: (written, lost, dropped).
    pub fn stats_of(&self, topic: &str) -> (i64, i64, i64) {
        let stats = self.last_stats.as_ref().expect("a stats message");
        let i = stats
            .topics
            .iter()
            .position(|t| t == topic)
            .unwrap_or_else(|| panic!("{topic} is not in the stats message"));
        (stats.written[i], stats.lost[i], stats.dropped[i])
    }

    /// `lewis.loss` of `topic`.
    pub fn loss_of(&self, topic: &str) -> u64 {
        self.metadata[lewis_recorder::LOSS_METADATA][topic]
            .parse()
            .unwrap()
    }
}
