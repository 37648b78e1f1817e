//! An opened MCAP file: its Header, its summary, the records its summary indexes.

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use mcap::records::{Header, Metadata, MetadataIndex, Record};
use mcap::sans_io::{
    LinearReadEvent, LinearReader, LinearReaderOptions, SummaryReadEvent, SummaryReader,
    SummaryReaderOptions,
};
use mcap::{McapError, Summary};

/// Opcode and length before every record's body.
pub(crate) const RECORD_PREFIX_BYTES: u64 = 9;

/// Why a file could not be opened as MCAP. The caller names the file.
#[derive(Debug, thiserror::Error)]
pub enum OpenError {
    /// The file cannot be opened or read.
    #[error("{0}")]
    Io(#[from] io::Error),
    /// The file does not start with the MCAP magic and a Header record.
    #[error("{error}")]
    NotMcap {
        /// Its first bytes (up to the length of the magic), to show what it is instead.
        start: Vec<u8>,
        /// What the reader met.
        error: McapError,
    },
}

/// Why a part of an opened file could not be read. The caller names the file.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// The system refused a read or a seek.
    #[error("{0}")]
    Io(#[from] io::Error),
    /// The bytes are not what MCAP says they must be.
    #[error("{0}")]
    Format(#[from] McapError),
}

/// An MCAP file opened for reading: its Header was read.
#[derive(Debug)]
pub struct McapFile {
    path: PathBuf,
    pub(crate) file: File,
    size_bytes: u64,
    header: Header,
}

impl McapFile {
    /// Opens `path` and reads its magic and Header record.
    ///
    /// # Errors
    /// [`OpenError::Io`] when it cannot be read; [`OpenError::NotMcap`] when it does not
    /// start with the magic and a Header.
    pub fn open(path: &Path) -> Result<Self, OpenError> {
        let mut file = File::open(path)?;
        let size_bytes = file.metadata()?.len();
        let mut start = [0_u8; 8];
        let got = read_retrying(&mut file, &mut start)?;
        let start = start.get(..got).unwrap_or_default().to_vec();
        file.seek(SeekFrom::Start(0))?;
        let header = first_record(&mut file, size_bytes)?
            .map_err(|error| OpenError::NotMcap { start, error })?;
        Ok(Self {
            path: path.to_path_buf(),
            file,
            size_bytes,
            header,
        })
    }

    /// The path it was opened from.
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Its size when it was opened.
    #[must_use]
    pub fn size_bytes(&self) -> u64 {
        self.size_bytes
    }

    /// Its Header record (profile, writing library).
    #[must_use]
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The summary section, read through the footer; `None` when the file has none (its
    /// writer did not finish it, or wrote none).
    ///
    /// # Errors
    /// [`ReadError::Format`] when the footer or the summary cannot be read (a file cut short
    /// has no footer: the caller decides whether to scan it instead).
    pub fn summary(&mut self) -> Result<Option<Summary>, ReadError> {
        let mut reader = SummaryReader::new_with_options(
            SummaryReaderOptions::default().with_file_size(self.size_bytes),
        );
        while let Some(event) = reader.next_event() {
            match event? {
                SummaryReadEvent::ReadRequest(wanted) => {
                    let read = read_retrying(&mut self.file, reader.insert(wanted))?;
                    reader.notify_read(read);
                }
                SummaryReadEvent::SeekRequest(to) => {
                    let position = self.file.seek(to)?;
                    reader.notify_seeked(position);
                }
            }
        }
        Ok(reader.finish())
    }

    /// The metadata record a summary's index points at.
    ///
    /// # Errors
    /// [`ReadError::Format`] when the index points outside the file or at another record.
    pub fn metadata_at(&mut self, index: &MetadataIndex) -> Result<Metadata, ReadError> {
        // The index's length counts the whole record: opcode, length, body.
        let length = usize::try_from(index.length).map_err(|_| McapError::BadIndex)?;
        let prefix = usize::try_from(RECORD_PREFIX_BYTES).map_err(|_| McapError::BadIndex)?;
        if index.offset.saturating_add(index.length) > self.size_bytes || length < prefix {
            return Err(McapError::BadIndex.into());
        }
        self.file.seek(SeekFrom::Start(index.offset))?;
        let mut bytes = vec![0; length];
        self.file.read_exact(&mut bytes)?;
        let (opcode, body) = match bytes.split_first() {
            Some((opcode, rest)) => (*opcode, rest.get(prefix - 1..).unwrap_or_default()),
            None => return Err(McapError::BadIndex.into()),
        };
        match mcap::parse_record(opcode, body)? {
            Record::Metadata(metadata) => Ok(metadata),
            _ => Err(McapError::BadIndex.into()),
        }
    }

    /// Every metadata record of a name, in file order, through the summary's indexes.
    ///
    /// # Errors
    /// As [`McapFile::metadata_at`].
    pub fn metadata_named(
        &mut self,
        summary: &Summary,
        name: &str,
    ) -> Result<Vec<Metadata>, ReadError> {
        summary
            .metadata_indexes
            .iter()
            .filter(|index| index.name == name)
            .map(|index| self.metadata_at(index))
            .collect()
    }
}

/// Whether the file at `path` starts with the MCAP magic (without reading further: to
/// tell an MCAP file from another format before choosing a reader).
///
/// # Errors
/// When it cannot be opened or read.
pub fn starts_like_mcap(path: &Path) -> io::Result<bool> {
    let mut start = [0_u8; 8];
    let read = read_retrying(&mut File::open(path)?, &mut start)?;
    Ok(start.get(..read) == Some(mcap::MAGIC))
}

/// The Header record, which follows the magic at the start of every MCAP file.
fn first_record(file: &mut File, file_size: u64) -> io::Result<Result<Header, McapError>> {
    let mut reader = LinearReader::new_with_options(
        LinearReaderOptions::default().with_record_length_limit(length_limit(file_size)),
    );
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(wanted)) => {
                let read = read_retrying(file, reader.insert(wanted))?;
                reader.notify_read(read);
            }
            Ok(LinearReadEvent::Record { opcode, data }) => {
                return Ok(match mcap::parse_record(opcode, data) {
                    Ok(Record::Header(header)) => Ok(header),
                    Ok(_) => Err(McapError::BadIndex),
                    Err(error) => Err(error),
                });
            }
            Err(error) => return Ok(Err(error)),
        }
    }
    Ok(Err(McapError::UnexpectedEof))
}

/// The largest chunk, uncompressed, that Lewis reads: a bound for damaged sizes, far
/// above what any recorder writes (Lewis's own chunks are a few MiB).
pub(crate) const MAX_CHUNK_BYTES: u64 = 1 << 30;

/// No record is longer than the file: a chunk whose header still has the writer's
/// placeholder length (all ones) is then damage, not an allocation of exabytes.
pub(crate) fn length_limit(file_size: u64) -> usize {
    usize::try_from(file_size).unwrap_or(usize::MAX)
}

/// Reads into `buffer` until it is full or the file ends; returns the bytes read.
pub(crate) fn read_retrying(file: &mut File, buffer: &mut [u8]) -> io::Result<usize> {
    let mut filled = 0;
    while let Some(rest) = buffer.get_mut(filled..)
        && !rest.is_empty()
    {
        match file.read(rest) {
            Ok(0) => break,
            Ok(read) => filled += read,
            Err(error) if error.kind() == io::ErrorKind::Interrupted => {}
            Err(error) => return Err(error),
        }
    }
    Ok(filled)
}
