//! Reading the summary section (through the footer) and the records it indexes, without
//! reading the data section.

use std::fs::File;
use std::io::{self, Read, Seek, SeekFrom};

use mcap::records::{Header, Metadata, MetadataIndex, Record};
use mcap::sans_io::{
    LinearReadEvent, LinearReader, SummaryReadEvent, SummaryReader, SummaryReaderOptions,
};
use mcap::{McapError, Summary};

/// Why the summary could not be used.
pub(crate) enum SummaryFailure {
    Io(io::Error),
    Format(McapError),
}

impl From<io::Error> for SummaryFailure {
    fn from(error: io::Error) -> Self {
        Self::Io(error)
    }
}

/// The summary, `None` when the file has none.
pub(crate) fn read_summary(
    file: &mut File,
    file_size: u64,
) -> Result<Option<Summary>, SummaryFailure> {
    let mut reader =
        SummaryReader::new_with_options(SummaryReaderOptions::default().with_file_size(file_size));
    while let Some(event) = reader.next_event() {
        match event.map_err(SummaryFailure::Format)? {
            SummaryReadEvent::ReadRequest(wanted) => {
                let read = file.read(reader.insert(wanted))?;
                reader.notify_read(read);
            }
            SummaryReadEvent::SeekRequest(to) => {
                let position = file.seek(to)?;
                reader.notify_seeked(position);
            }
        }
    }
    Ok(reader.finish())
}

/// The Header record, which follows the magic at the start of every MCAP file.
pub(crate) fn read_header(
    file: &mut File,
    file_size: u64,
) -> io::Result<Result<Header, McapError>> {
    file.seek(SeekFrom::Start(0))?;
    let mut reader = LinearReader::new_with_options(
        mcap::sans_io::LinearReaderOptions::default()
            .with_record_length_limit(usize::try_from(file_size).unwrap_or(usize::MAX)),
    );
    while let Some(event) = reader.next_event() {
        match event {
            Ok(LinearReadEvent::ReadRequest(wanted)) => {
                let read = file.read(reader.insert(wanted))?;
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

/// Reads the metadata record an index points at.
pub(crate) fn read_metadata(
    file: &mut File,
    index: &MetadataIndex,
) -> Result<Metadata, SummaryFailure> {
    // A record is its opcode, a u64 length, then the body the index length includes.
    let length =
        usize::try_from(index.length).map_err(|_| SummaryFailure::Format(McapError::BadIndex))?;
    let file_size = file.metadata()?.len();
    if index.offset.saturating_add(index.length) > file_size || length < 9 {
        return Err(SummaryFailure::Format(McapError::BadIndex));
    }
    file.seek(SeekFrom::Start(index.offset))?;
    let mut bytes = vec![0; length];
    file.read_exact(&mut bytes)?;
    let (opcode, body) = (bytes[0], &bytes[9..]);
    match mcap::parse_record(opcode, body).map_err(SummaryFailure::Format)? {
        Record::Metadata(metadata) => Ok(metadata),
        _ => Err(SummaryFailure::Format(McapError::BadIndex)),
    }
}
