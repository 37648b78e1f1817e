//! Reading the sequencer's records back from an MCAP recording: the messages of the
//! `/lewis/sequencer` channel, CDR of the `Sequencer` interface, in file order.
//!
//! The file is read once from its start, chunk by chunk (`lewis_mcap`'s scan), so a
//! recording of any size needs little memory. A file cut short (its writer died) gives the records before the cut,
//! with the cut said ([`McapRecords::cut`]): a mission recorded until a crash can still be
//! replayed up to it.

use std::collections::BTreeSet;
use std::io;
use std::path::{Path, PathBuf};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::Sequencer as SequencerMessage;
use lewis_mcap::records::Record as McapRecord;
use lewis_mcap::{At, Flow, McapFile, OpenError, ScanError, Visitor};
use lewis_runtime::names::SEQUENCER_CHANNEL;

use lewis_sequencer::message::{MessageError, from_message};
use lewis_sequencer::record::Record;

/// The first bytes of every MCAP file.
pub const MCAP_MAGIC: &[u8] = lewis_mcap::MAGIC;

/// The sequencer's records could not be read from a recording.
#[derive(Debug, thiserror::Error)]
pub enum McapReadError {
    /// The file cannot be opened or read.
    #[error("cannot read {path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        error: io::Error,
    },
    /// The file is not MCAP, or broken before any sequencer record.
    #[error("{path} is not a readable MCAP file: {error}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What the MCAP reader said.
        error: lewis_mcap::McapError,
    },
    /// A message on the channel is not a `Sequencer` publication.
    #[error("{path}: message {index} of {channel} (log time {log_time_ns} ns): {error}")]
    Decode {
        /// The file.
        path: PathBuf,
        /// The channel.
        channel: &'static str,
        /// The message's position on the channel, from 1.
        index: usize,
        /// Its log time.
        log_time_ns: u64,
        /// Why.
        error: String,
    },
    /// A message decodes but is no record.
    #[error("{path}: message {index} of {channel}: {error}")]
    Record {
        /// The file.
        path: PathBuf,
        /// The channel.
        channel: &'static str,
        /// The message's position on the channel, from 1.
        index: usize,
        /// Why.
        error: MessageError,
    },
    /// The recording has no `/lewis/sequencer` channel at all.
    #[error(
        "{path} holds no {channel} channel: was a mission running (`lewis up --script`, `lewis seq run`) while it was recorded?"
    )]
    NoChannel {
        /// The file.
        path: PathBuf,
        /// The channel looked for.
        channel: &'static str,
    },
}

/// The records found in a recording.
#[derive(Debug)]
pub struct McapRecords {
    /// Every record of the channel, in file order.
    pub records: Vec<Record>,
    /// Why reading stopped before the end of the file, if it did.
    pub cut: Option<String>,
}

/// Whether the file at `path` starts like an MCAP file.
///
/// # Errors
/// When it cannot be opened or read.
pub fn is_mcap(path: &Path) -> io::Result<bool> {
    lewis_mcap::starts_like_mcap(path)
}

/// Reads every record published on `/lewis/sequencer` from the MCAP file at `path`.
///
/// # Errors
/// When the file cannot be read, is not MCAP, has no such channel, or holds a message that
/// is not a record.
pub fn read_mcap(path: &Path) -> Result<McapRecords, McapReadError> {
    let mut file = McapFile::open(path).map_err(|error| match error {
        OpenError::Io(error) => McapReadError::Io {
            path: path.to_owned(),
            error,
        },
        OpenError::NotMcap { error, .. } => McapReadError::Format {
            path: path.to_owned(),
            error,
        },
    })?;
    let mut found = Found {
        path,
        channels: BTreeSet::new(),
        records: Vec::new(),
    };
    let end = file.scan(&mut found).map_err(|error| match error {
        ScanError::Io(error) => McapReadError::Io {
            path: path.to_owned(),
            error,
        },
        ScanError::Visitor(error) => error,
    })?;
    let cut = match end.damage {
        Some(damage) if found.channels.is_empty() => {
            return Err(McapReadError::Format {
                path: path.to_owned(),
                error: damage.error,
            });
        }
        Some(damage) => Some(damage.to_string()),
        None => None,
    };
    if found.channels.is_empty() {
        return Err(McapReadError::NoChannel {
            path: path.to_owned(),
            channel: SEQUENCER_CHANNEL,
        });
    }
    Ok(McapRecords {
        records: found.records,
        cut,
    })
}

/// The scan's visitor: the channels on `/lewis/sequencer` and their records.
struct Found<'p> {
    path: &'p Path,
    channels: BTreeSet<u16>,
    records: Vec<Record>,
}

impl Visitor for Found<'_> {
    type Error = McapReadError;

    fn record(&mut self, _at: At, record: McapRecord<'_>) -> Result<Flow, McapReadError> {
        match record {
            McapRecord::Channel(channel) if channel.topic == SEQUENCER_CHANNEL => {
                self.channels.insert(channel.id);
            }
            McapRecord::Message { header, data } if self.channels.contains(&header.channel_id) => {
                self.add(header.log_time, &data)?;
            }
            _ => {}
        }
        Ok(Flow::Continue)
    }
}

impl Found<'_> {
    fn add(&mut self, log_time_ns: u64, data: &[u8]) -> Result<(), McapReadError> {
        let index = self.records.len() + 1;
        let message: SequencerMessage =
            cdr::from_bytes(data).map_err(|error| McapReadError::Decode {
                path: self.path.to_owned(),
                channel: SEQUENCER_CHANNEL,
                index,
                log_time_ns,
                error: error.to_string(),
            })?;
        let record = from_message(&message).map_err(|error| McapReadError::Record {
            path: self.path.to_owned(),
            channel: SEQUENCER_CHANNEL,
            index,
            error,
        })?;
        self.records.push(record);
        Ok(())
    }
}
