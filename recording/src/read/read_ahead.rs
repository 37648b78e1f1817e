//! A recording's messages read on a thread of their own, ahead of the replay that takes
//! them: decompressing the chunks (most of it camera frames) and copying the messages out
//! was a fifth of a closed-loop replay's time, spent while the services waited.
//!
//! The order and the messages are exactly those of the iterator read; only where the work
//! is done changes. The thread hands messages over in batches (a channel operation per
//! message costs more than a small message's reading), at most [`BATCH_BYTES`] or
//! [`BATCH_MESSAGES`] each, and keeps at most [`BATCHES_AHEAD`] batches ahead of the
//! reader: the memory it adds is bounded whatever the recording.

use std::sync::mpsc::{Receiver, SyncSender, sync_channel};
use std::thread::JoinHandle;

use super::{RecordedMessage, RecordingError};

/// A batch is handed over once it holds this many bytes of messages.
pub const BATCH_BYTES: usize = 4 << 20;

/// Or this many messages.
pub const BATCH_MESSAGES: usize = 256;

/// Batches read and not yet taken, at most (besides the one being filled).
pub const BATCHES_AHEAD: usize = 2;

type Item = Result<RecordedMessage, RecordingError>;

/// The messages of `source`, read on a thread of their own; an iterator of results that
/// ends after the first error, like its source.
pub struct ReadAhead {
    batches: Option<Receiver<Vec<Item>>>,
    batch: std::vec::IntoIter<Item>,
    thread: Option<JoinHandle<()>>,
}

impl std::fmt::Debug for ReadAhead {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ReadAhead")
            .field("batch", &self.batch.len())
            .finish_non_exhaustive()
    }
}

impl ReadAhead {
    /// Starts reading `source` on a new thread.
    ///
    /// # Errors
    /// When the thread cannot be started.
    pub fn new<I>(source: I) -> std::io::Result<Self>
    where
        I: Iterator<Item = Item> + Send + 'static,
    {
        let (sender, batches) = sync_channel(BATCHES_AHEAD);
        let thread = std::thread::Builder::new()
            .name("replay-read".to_owned())
            .spawn(move || read(source, &sender))?;
        Ok(Self {
            batches: Some(batches),
            batch: Vec::new().into_iter(),
            thread: Some(thread),
        })
    }
}

/// Reads `source` into batches until it ends, fails, or the reader is gone.
fn read(source: impl Iterator<Item = Item>, sender: &SyncSender<Vec<Item>>) {
    let mut batch = Vec::new();
    let mut bytes = 0;
    for item in source {
        let failed = item.is_err();
        bytes += item.as_ref().map_or(0, |m| m.data.len());
        batch.push(item);
        if failed || bytes >= BATCH_BYTES || batch.len() >= BATCH_MESSAGES {
            if sender.send(std::mem::take(&mut batch)).is_err() || failed {
                return;
            }
            bytes = 0;
        }
    }
    if !batch.is_empty() {
        // The reader may be gone already: nothing is lost that it wanted.
        let _ = sender.send(batch);
    }
}

impl Iterator for ReadAhead {
    type Item = Item;

    fn next(&mut self) -> Option<Item> {
        loop {
            if let Some(item) = self.batch.next() {
                return Some(item);
            }
            // A closed channel: the thread has handed over everything.
            self.batch = self.batches.as_ref()?.recv().ok()?.into_iter();
        }
    }
}

impl Drop for ReadAhead {
    fn drop(&mut self) {
        // Closing the channel first ends a thread blocked on a full one.
        self.batches = None;
        if let Some(thread) = self.thread.take() {
            // A panic on the thread has already been reported by its hook.
            let _ = thread.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;

    fn message(n: u64, len: usize) -> RecordedMessage {
        RecordedMessage {
            topic: Arc::from("/t"),
            log_time_ns: i64::try_from(n).unwrap(),
            publish_time_ns: 0,
            seq: n,
            data: vec![0; len].into(),
        }
    }

    #[test]
    fn hands_over_every_message_in_order_small_and_large() {
        let messages: Vec<_> = (0..2000)
            .map(|n| message(n, if n % 97 == 0 { 1 << 20 } else { 16 }))
            .collect();
        let read: Vec<_> = ReadAhead::new(messages.clone().into_iter().map(Ok))
            .unwrap()
            .map(Result::unwrap)
            .collect();
        assert_eq!(read, messages);
    }

    #[test]
    fn ends_after_the_first_error() {
        let source = (0..10).map(|n| {
            if n == 5 {
                Err(RecordingError::NoFiles)
            } else {
                Ok(message(n, 8))
            }
        });
        let read: Vec<_> = ReadAhead::new(source).unwrap().collect();
        assert_eq!(read.len(), 6);
        assert!(read[5].is_err());
    }

    #[test]
    fn a_reader_dropped_early_stops_the_thread() {
        let source = (0..u64::MAX).map(|n| Ok(message(n, 1024)));
        let mut read = ReadAhead::new(source).unwrap();
        assert!(read.next().is_some());
        // Dropping joins the thread: the test would hang if it read on.
        drop(read);
    }
}
