//! The messages of a file with a summary, in log-time order, through its indexes.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::Path;
use std::sync::Arc;

use mcap::Summary;
use mcap::records::MessageHeader;
use mcap::sans_io::indexed_reader::{IndexedReadEvent, IndexedReader, IndexedReaderOptions};

use crate::file::{MAX_CHUNK_BYTES, ReadError};

/// One message, copied out of its chunk.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct IndexedMessage {
    /// Its channel, sequence number, log and publish times.
    pub header: MessageHeader,
    /// The encoded message, shared: a replay hands one message to several readers.
    pub data: Arc<[u8]>,
}

/// The messages of one file in log-time order, read chunk by chunk through the summary's
/// indexes (only the chunks that overlap in time are held at once); an iterator of results
/// that ends after the first error.
pub struct TimeOrdered {
    file: File,
    reader: IndexedReader,
    chunk: Vec<u8>,
    failed: bool,
}

impl std::fmt::Debug for TimeOrdered {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TimeOrdered").finish_non_exhaustive()
    }
}

impl TimeOrdered {
    /// The messages of the file at `path`, whose summary is `summary`: of every channel, or
    /// of the channels on `topics` only.
    ///
    /// # Errors
    /// When the file cannot be opened or the summary's chunk indexes are not usable.
    pub fn open(
        path: &Path,
        summary: &Summary,
        topics: Option<&[&str]>,
    ) -> Result<Self, ReadError> {
        // A damaged chunk index must not size an allocation of exabytes.
        let limit = usize::try_from(MAX_CHUNK_BYTES).unwrap_or(usize::MAX);
        let mut options = IndexedReaderOptions::new().with_record_length_limit(limit);
        if let Some(topics) = topics {
            options = options.include_topics(topics.iter().map(|t| (*t).to_owned()));
        }
        let reader = IndexedReader::new_with_options(summary, options)?;
        let file = File::open(path)?;
        Ok(Self {
            file,
            reader,
            chunk: Vec::new(),
            failed: false,
        })
    }

    fn pull(&mut self) -> Result<Option<IndexedMessage>, ReadError> {
        loop {
            let (offset, length) = match self.reader.next_event() {
                None => return Ok(None),
                Some(Err(error)) => return Err(error.into()),
                Some(Ok(IndexedReadEvent::ReadChunkRequest { offset, length })) => (offset, length),
                Some(Ok(IndexedReadEvent::Message { header, data })) => {
                    return Ok(Some(IndexedMessage {
                        header,
                        data: Arc::from(data),
                    }));
                }
            };
            self.chunk.resize(length, 0);
            self.file.seek(SeekFrom::Start(offset))?;
            self.file.read_exact(&mut self.chunk)?;
            self.reader.insert_chunk_record_data(offset, &self.chunk)?;
        }
    }
}

impl Iterator for TimeOrdered {
    type Item = Result<IndexedMessage, ReadError>;

    fn next(&mut self) -> Option<Self::Item> {
        if self.failed {
            return None;
        }
        match self.pull() {
            Ok(message) => message.map(Ok),
            Err(error) => {
                self.failed = true;
                Some(Err(error))
            }
        }
    }
}
