//! The merged message stream of a recording's files, in total order.

use std::collections::{BTreeMap, VecDeque};
use std::path::PathBuf;
use std::sync::Arc;

use lewis_interfaces::cdr::peek_header;
use lewis_mcap::{McapFile, Summary, TimeOrdered};

use super::RecordingError;

/// One recorded message.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordedMessage {
    /// Its topic.
    pub topic: Arc<str>,
    /// When the recorder received it (MCAP `log_time`): the replay's virtual time.
    pub log_time_ns: i64,
    /// The header's publish time (MCAP `publish_time`).
    pub publish_time_ns: i64,
    /// The header's sequence number (0 when the bytes have no valid header).
    pub seq: u64,
    /// The CDR bytes (shared with the comparator and the output).
    pub data: Arc<[u8]>,
}

/// The order key of a message: log time, topic, sequence number, then file and position.
type Key = (i64, Arc<str>, u64, usize, u64);

struct FileStream {
    path: PathBuf,
    messages: TimeOrdered,
    topics: BTreeMap<u16, Arc<str>>,
    head: Option<RecordedMessage>,
    position: u64,
}

impl FileStream {
    fn pull(&mut self) -> Result<Option<RecordedMessage>, RecordingError> {
        for message in self.messages.by_ref() {
            let message = message.map_err(|error| super::read_error(&self.path, error))?;
            let Some(topic) = self.topics.get(&message.header.channel_id) else {
                continue;
            };
            return Ok(Some(RecordedMessage {
                topic: topic.clone(),
                log_time_ns: i64::try_from(message.header.log_time).unwrap_or(i64::MAX),
                publish_time_ns: i64::try_from(message.header.publish_time).unwrap_or(i64::MAX),
                seq: peek_header(&message.data).map_or(0, |header| header.seq),
                data: message.data,
            }));
        }
        Ok(None)
    }

    fn fill(&mut self) -> Result<(), RecordingError> {
        if self.head.is_none() {
            self.head = self.pull()?;
        }
        Ok(())
    }
}

/// The messages of a recording in total order; an iterator of results.
pub struct Messages {
    streams: Vec<FileStream>,
    ready: VecDeque<RecordedMessage>,
    failed: bool,
}

impl std::fmt::Debug for Messages {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Messages")
            .field("files", &self.streams.len())
            .field("ready", &self.ready.len())
            .finish_non_exhaustive()
    }
}

impl Messages {
    pub(super) fn open(
        files: &[(McapFile, Summary)],
        topics: Option<&[&str]>,
    ) -> Result<Self, RecordingError> {
        let mut streams = Vec::new();
        for (file, summary) in files {
            let path = file.path();
            let messages = TimeOrdered::open(path, summary, topics)
                .map_err(|error| super::read_error(path, error))?;
            let topics = summary
                .channels
                .iter()
                .map(|(id, c)| (*id, Arc::from(c.topic.as_str())))
                .collect();
            streams.push(FileStream {
                path: path.to_path_buf(),
                messages,
                topics,
                head: None,
                position: 0,
            });
        }
        Ok(Self {
            streams,
            ready: VecDeque::new(),
            failed: false,
        })
    }

    /// Gathers every message at the earliest pending log time, from every file, sorted.
    fn refill(&mut self) -> Result<(), RecordingError> {
        for stream in &mut self.streams {
            stream.fill()?;
        }
        let Some(time) = self
            .streams
            .iter()
            .filter_map(|s| s.head.as_ref().map(|m| m.log_time_ns))
            .min()
        else {
            return Ok(());
        };
        let mut batch: BTreeMap<Key, RecordedMessage> = BTreeMap::new();
        for (file, stream) in self.streams.iter_mut().enumerate() {
            while stream.head.as_ref().is_some_and(|m| m.log_time_ns == time) {
                if let Some(message) = stream.head.take() {
                    stream.position += 1;
                    let key = (
                        time,
                        message.topic.clone(),
                        message.seq,
                        file,
                        stream.position,
                    );
                    batch.insert(key, message);
                }
                stream.fill()?;
            }
        }
        self.ready.extend(batch.into_values());
        Ok(())
    }
}

impl Iterator for Messages {
    type Item = Result<RecordedMessage, RecordingError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        if self.ready.is_empty()
            && let Err(e) = self.refill()
        {
            self.failed = true;
            return Some(Err(e));
        }
        self.ready.pop_front().map(Ok)
    }
}
