//! Reading the sequencer's records back from an MCAP recording: the messages of the
//! `/lewis/sequencer` channel, CDR of the `Sequencer` interface, in file order.
//!
//! The file is read once from its start, chunk by chunk, so a recording of any size needs
//! little memory. A file cut short (its writer died) gives the records before the cut,
//! with the cut said ([`McapRecords::cut`]): a mission recorded until a crash can still be
//! replayed up to it.

use std::collections::BTreeSet;
use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::Sequencer as SequencerMessage;
use lewis_runtime::names::SEQUENCER_CHANNEL;
use mcap::records::Record as McapRecord;
use mcap::sans_io::{LinearReadEvent, LinearReader, LinearReaderOptions};

use lewis_sequencer::message::{MessageError, from_message};
use lewis_sequencer::record::Record;

/// The first bytes of every MCAP file.
pub const MCAP_MAGIC: &[u8] = b"\x89MCAP0\r\n";

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
        error: mcap::McapError,
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
    let mut start = [0u8; MCAP_MAGIC.len()];
    let mut file = File::open(path)?;
    let mut filled = 0;
    while filled < start.len() {
        match file.read(&mut start[filled..]) {
            Ok(0) => return Ok(false),
            Ok(n) => filled += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(start == MCAP_MAGIC)
}

/// Reads every record published on `/lewis/sequencer` from the MCAP file at `path`.
///
/// # Errors
/// When the file cannot be read, is not MCAP, has no such channel, or holds a message that
/// is not a record.
pub fn read_mcap(path: &Path) -> Result<McapRecords, McapReadError> {
    let io_error = |error| McapReadError::Io {
        path: path.to_owned(),
        error,
    };
    let mut file = File::open(path).map_err(io_error)?;
    let size = file.metadata().map_err(io_error)?.len();
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default()
            .with_record_length_limit(usize::try_from(size).unwrap_or(usize::MAX)),
    );
    let mut channels = BTreeSet::new();
    let mut found = Found {
        path,
        records: Vec::new(),
    };
    let mut cut = None;
    while let Some(event) = reader.next_event() {
        let record = match event {
            Ok(LinearReadEvent::ReadRequest(wanted)) => {
                let read = read_some(&mut file, reader.insert(wanted)).map_err(io_error)?;
                reader.notify_read(read);
                continue;
            }
            Ok(LinearReadEvent::Record { opcode, data }) => mcap::parse_record(opcode, data),
            Err(error) => Err(error),
        };
        match record {
            Ok(McapRecord::Channel(channel)) if channel.topic == SEQUENCER_CHANNEL => {
                channels.insert(channel.id);
            }
            Ok(McapRecord::Message { header, data }) if channels.contains(&header.channel_id) => {
                found.add(header.log_time, &data)?;
            }
            Ok(_) => {}
            Err(error) if channels.is_empty() => {
                return Err(McapReadError::Format {
                    path: path.to_owned(),
                    error,
                });
            }
            Err(error) => {
                cut = Some(error.to_string());
                break;
            }
        }
    }
    if channels.is_empty() {
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

struct Found<'p> {
    path: &'p Path,
    records: Vec<Record>,
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

fn read_some(file: &mut File, buffer: &mut [u8]) -> io::Result<usize> {
    loop {
        match file.read(buffer) {
            Err(error) if error.kind() == io::ErrorKind::Interrupted => {}
            other => return other,
        }
    }
}
