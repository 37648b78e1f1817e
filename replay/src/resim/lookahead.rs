//! The recording in replay order: a bounded window that reads messages in log-time order
//! (the order they are stored in) and hands them over in the order of their replay time.
//!
//! The replay time of a message is when it was made: its publish time (the header's, which
//! the recorder stores as MCAP `publish_time`) when that lies within [`MAX_LATENCY_NS`] of
//! its log time, else its log time (a message with no publish time, like the broker's
//! decisions, or one whose clock is off). So every message's replay time is within
//! `MAX_LATENCY_NS` of its log time, and once the reader has reached log time `F`, no
//! message still unread can have a replay time before `F - MAX_LATENCY_NS`: messages before
//! that are handed over in a total order (replay time, topic, sequence number, reading
//! order) that the file alone fixes.
//!
//! A message is handed over only once everything up to [`HORIZON_NS`] after it has been
//! read and shown to the caller (`preview`), so the harness knows that far ahead what the
//! followed services did live. The window holds about `MAX_LATENCY_NS + HORIZON_NS` of the
//! recording, whatever its length.

use std::collections::BTreeMap;
use std::sync::Arc;

use lewis_recording::{RecordedMessage, RecordingError};

/// The largest delay between a message's publish time and the recorder's log time that
/// is taken as the recorder's latency (beyond it, the log time is used).
pub const MAX_LATENCY_NS: i64 = 1_000_000_000;

/// How far ahead of the message handed over the reader has read.
pub const HORIZON_NS: i64 = 1_000_000_000;

/// The replay time of a recorded message (see the module documentation).
#[must_use]
pub fn replay_time(message: &RecordedMessage) -> i64 {
    let (publish, log) = (message.publish_time_ns, message.log_time_ns);
    let near = log.saturating_sub(MAX_LATENCY_NS)..=log.saturating_add(MAX_LATENCY_NS);
    if publish > 0 && near.contains(&publish) {
        publish
    } else {
        log
    }
}

type Key = (i64, Arc<str>, u64, u64);

/// Recorded messages, read ahead and handed over in replay order.
#[derive(Debug)]
pub struct Lookahead<I> {
    source: I,
    window: BTreeMap<Key, RecordedMessage>,
    /// The log time of the last message read.
    frontier_ns: i64,
    read: u64,
    exhausted: bool,
}

impl<I: Iterator<Item = Result<RecordedMessage, RecordingError>>> Lookahead<I> {
    /// A window over `source` (messages in log-time order, like
    /// [`Messages`](lewis_recording::Messages)).
    #[must_use]
    pub fn new(source: I) -> Self {
        Self {
            source,
            window: BTreeMap::new(),
            frontier_ns: i64::MIN,
            read: 0,
            exhausted: false,
        }
    }

    /// The next message in replay order and its replay time; `preview` sees every message
    /// as it is read, in reading order, before any is handed over past it.
    ///
    /// # Errors
    /// When a file cannot be read.
    pub fn next(
        &mut self,
        preview: &mut dyn FnMut(&RecordedMessage, i64),
    ) -> Result<Option<(i64, RecordedMessage)>, RecordingError> {
        loop {
            if let Some(entry) = self.window.first_entry() {
                let ready = self.exhausted
                    || entry.key().0
                        < self
                            .frontier_ns
                            .saturating_sub(MAX_LATENCY_NS.saturating_add(HORIZON_NS));
                if ready {
                    let ((time, ..), message) = entry.remove_entry();
                    return Ok(Some((time, message)));
                }
            } else if self.exhausted {
                return Ok(None);
            }
            match self.source.next() {
                None => self.exhausted = true,
                Some(Err(e)) => {
                    self.exhausted = true;
                    return Err(e);
                }
                Some(Ok(message)) => {
                    self.frontier_ns = self.frontier_ns.max(message.log_time_ns);
                    let time = replay_time(&message);
                    preview(&message, time);
                    self.read += 1;
                    self.window.insert(
                        (time, message.topic.clone(), message.seq, self.read),
                        message,
                    );
                }
            }
        }
    }

    /// Whether every message of the source has been read (and previewed).
    #[must_use]
    pub const fn read_whole(&self) -> bool {
        self.exhausted
    }

    /// The replay time of the next message to hand over, reading as far as needed.
    ///
    /// # Errors
    /// When a file cannot be read.
    pub fn peek_time(
        &mut self,
        preview: &mut dyn FnMut(&RecordedMessage, i64),
    ) -> Result<Option<i64>, RecordingError> {
        let Some((time, message)) = self.next(preview)? else {
            return Ok(None);
        };
        // Put it back: it has the smallest key, it will be the next one again.
        self.window
            .insert((time, message.topic.clone(), message.seq, 0), message);
        Ok(Some(time))
    }

    /// Messages in the window now (for tests of the bound).
    #[must_use]
    pub fn len(&self) -> usize {
        self.window.len()
    }

    /// Whether the window is empty now.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.window.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn message(topic: &str, publish: i64, log: i64) -> RecordedMessage {
        RecordedMessage {
            topic: Arc::from(topic),
            log_time_ns: log,
            publish_time_ns: publish,
            seq: 0,
            data: Arc::from([]),
        }
    }

    fn replayed(messages: Vec<RecordedMessage>) -> (Vec<(i64, String)>, usize) {
        let mut window = Lookahead::new(messages.into_iter().map(Ok));
        let mut seen = 0;
        let mut out = Vec::new();
        let mut largest = 0;
        while let Some((time, m)) = window.next(&mut |_, _| seen += 1).unwrap() {
            largest = largest.max(window.len());
            out.push((time, m.topic.to_string()));
        }
        assert_eq!(seen, out.len());
        (out, largest)
    }

    #[test]
    fn messages_come_in_replay_order_from_a_bounded_window() {
        const MS: i64 = 1_000_000;
        // A scan made at 10 ms reached the recorder after the tick of 12 ms that used it.
        let mut messages = vec![
            message("/tick", 12 * MS, 13 * MS),
            message("/scan", 10 * MS, 14 * MS),
            message("/broker", 0, 15 * MS),
        ];
        for i in 0..1000 {
            messages.push(message("/odom", (20 + 10 * i) * MS, (21 + 10 * i) * MS));
        }
        let (out, largest) = replayed(messages);
        assert_eq!(out[0], (10 * MS, "/scan".into()));
        assert_eq!(out[1], (12 * MS, "/tick".into()));
        assert_eq!(out[2], (15 * MS, "/broker".into()));
        assert!(out.windows(2).all(|w| w[0].0 <= w[1].0));
        // 10 s of messages at 100 Hz; the window holds about 2 s of them.
        assert!((190..=210).contains(&largest), "{largest}");
    }

    #[test]
    fn the_replay_time_is_the_publish_time_when_it_is_near_the_log_time() {
        let check = |publish, log, expected| {
            assert_eq!(replay_time(&message("/t", publish, log)), expected);
        };
        check(900, 1_000, 900);
        check(0, 1_000, 1_000);
        check(5 * MAX_LATENCY_NS, 1_000, 1_000);
        check(
            3 * MAX_LATENCY_NS + 5,
            4 * MAX_LATENCY_NS,
            3 * MAX_LATENCY_NS + 5,
        );
        check(
            3 * MAX_LATENCY_NS - 5,
            4 * MAX_LATENCY_NS,
            4 * MAX_LATENCY_NS,
        );
        check(1, 3 * MAX_LATENCY_NS, 3 * MAX_LATENCY_NS);
    }
}
