//! Publishing the records on `/lewis/sequencer` through the runtime's IPC, as CDR of the
//! `Sequencer` interface, so that the recorder keeps them.
//!
//! The publisher runs on a thread of its own: the live driver hands each record to a
//! [`PublishSink`] (a channel send, never blocking the mission) and the thread encodes and
//! publishes it in order. The channel waits up to 100 ms for a slow reader
//! ([`names::sequencer_config`]); that wait is the thread's, not the mission's.

use std::sync::mpsc::{self, Receiver, Sender};
use std::thread::JoinHandle;

use lewis_interfaces::cdr;
use lewis_runtime::ipc::{Ipc, IpcError, Namespace};
use lewis_runtime::names;

use crate::message::{PROVIDER, to_message};
use crate::record::{Record, RecordSink};

/// The publisher could not start.
#[derive(Debug, thiserror::Error)]
pub enum PublishStartError {
    /// The IPC node or the channel could not be opened.
    #[error("cannot publish on {channel}: {0}", channel = names::SEQUENCER_CHANNEL)]
    Ipc(#[from] IpcError),
    /// The thread could not be started.
    #[error("cannot start the thread publishing on {channel}: {0}", channel = names::SEQUENCER_CHANNEL)]
    Thread(#[from] std::io::Error),
    /// The thread ended before saying whether the channel opened.
    #[error("the thread publishing on {channel} ended at its start", channel = names::SEQUENCER_CHANNEL)]
    Ended,
}

/// What the publisher did, once finished.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PublishReport {
    /// Records published.
    pub published: u64,
    /// Records that could not be published (logged one by one).
    pub failed: u64,
    /// Deliveries the channel dropped because a reader's buffer stayed full.
    pub discarded: u64,
}

/// The sink the live driver sends records to; cloning it gives another entry to the same
/// publisher.
#[derive(Debug, Clone)]
pub struct PublishSink(Sender<Record>);

impl RecordSink for PublishSink {
    fn record(&mut self, record: &Record) {
        // The thread outlives every sink (it ends when the last sink is dropped).
        let _ = self.0.send(record.clone());
    }
}

/// The publishing thread; [`Publisher::finish`] waits until it has published every record
/// sent before.
#[derive(Debug)]
pub struct Publisher {
    thread: JoinHandle<PublishReport>,
}

impl Publisher {
    /// Opens `/lewis/sequencer` in `namespace` on a new thread (an IPC node named
    /// [`PROVIDER`]) and returns the sink that feeds it.
    ///
    /// # Errors
    /// When the node or the channel cannot be opened, or the thread cannot start.
    pub fn start(namespace: &Namespace) -> Result<(Self, PublishSink), PublishStartError> {
        let (records, incoming) = mpsc::channel();
        let (opened, started) = mpsc::sync_channel(1);
        let namespace = namespace.clone();
        let thread = std::thread::Builder::new()
            .name("lewis-seq-publish".into())
            .spawn(move || {
                // The IPC node stays on the thread that made it.
                let endpoint = Ipc::open(&namespace, PROVIDER).and_then(|ipc| {
                    let publisher =
                        ipc.publisher(names::SEQUENCER_CHANNEL, &names::sequencer_config())?;
                    Ok((ipc, publisher))
                });
                match endpoint {
                    Ok((_ipc, publisher)) => {
                        let _ = opened.send(Ok(()));
                        publish_all(publisher, &incoming)
                    }
                    Err(error) => {
                        let _ = opened.send(Err(error));
                        PublishReport::default()
                    }
                }
            })?;
        match started.recv() {
            Ok(Ok(())) => Ok((Self { thread }, PublishSink(records))),
            Ok(Err(error)) => {
                let _ = thread.join();
                Err(error.into())
            }
            Err(_) => {
                let _ = thread.join();
                Err(PublishStartError::Ended)
            }
        }
    }

    /// Waits until every record sent before the last [`PublishSink`] was dropped is
    /// published. Drop every sink first, or this waits for ever.
    #[must_use]
    pub fn finish(self) -> PublishReport {
        self.thread.join().unwrap_or_default()
    }
}

fn publish_all(
    mut publisher: lewis_runtime::ipc::Publisher,
    incoming: &Receiver<Record>,
) -> PublishReport {
    let mut report = PublishReport::default();
    for record in incoming {
        let message = to_message(&record);
        let len = cdr::encoded_len(&message);
        let mut encoded = Ok(0);
        let published = publisher.publish_with(len, |buf| {
            encoded = cdr::encode_into(&message, buf);
        });
        match (published, encoded) {
            (Ok(_), Ok(_)) => report.published += 1,
            (Err(error), _) => {
                report.failed += 1;
                tracing::warn!("sequencer record {} not published: {error}", record.seq);
            }
            (Ok(_), Err(error)) => {
                report.failed += 1;
                tracing::warn!("sequencer record {} not encoded: {error}", record.seq);
            }
        }
    }
    report.discarded = publisher.discarded();
    report
}
