//! The [`Header`] every message starts with, read and rewritten without the rest of the
//! message: what a recorder, a replay or a tool needs of a message it has no type for
//! (the sequence number, the provider, the publish time).

use thiserror::Error;

use super::{DecodeError, ENCAPSULATION_LE, Encode, Reader, SizeSink, SliceSink};
use crate::cdr::Decode;
use crate::msg::Header;

/// Why a header could not be replaced.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum ReplaceHeaderError {
    /// The bytes do not start with a valid header.
    #[error("{0}")]
    Decode(#[from] DecodeError),
    /// The new header does not encode to the length of the old one: the fields after it
    /// would move, and CDR aligns them relative to the start of the message.
    #[error("the new header takes {new} bytes where the old one took {old}")]
    Length {
        /// The old header's encoded length.
        old: usize,
        /// The new one's.
        new: usize,
    },
}

/// The header at the start of the CDR message `bytes` (encapsulation included), decoded
/// without decoding the rest of the message.
///
/// # Errors
/// When the bytes do not start with the encapsulation and a valid header.
pub fn peek_header(bytes: &[u8]) -> Result<Header, DecodeError> {
    header_and_len(bytes).map(|(header, _)| header)
}

/// Replaces the header at the start of the CDR message `bytes` with `header`, in place;
/// the rest of the message is left as it is. The header must encode to the same length
/// as the one it replaces (another publish time or sequence number always does).
///
/// # Errors
/// [`ReplaceHeaderError`]: no valid header, or a header of another length; `bytes` are
/// then unchanged.
pub fn replace_header(bytes: &mut [u8], header: &Header) -> Result<(), ReplaceHeaderError> {
    let (_, old) = header_and_len(bytes)?;
    let mut size = SizeSink::default();
    header.encode(&mut size);
    let new = super::Sink::position(&size);
    let at = ENCAPSULATION_LE.len()..ENCAPSULATION_LE.len() + old;
    match bytes.get_mut(at) {
        Some(room) if new == old => {
            // The header starts the payload, so alignment relative to `room` is alignment
            // relative to the message.
            let mut sink = SliceSink::new(room);
            header.encode(&mut sink);
            Ok(())
        }
        _ => Err(ReplaceHeaderError::Length { old, new }),
    }
}

/// The header and its encoded length (after the encapsulation).
fn header_and_len(bytes: &[u8]) -> Result<(Header, usize), DecodeError> {
    match bytes.split_first_chunk::<4>() {
        Some((encapsulation, payload)) if *encapsulation == ENCAPSULATION_LE => {
            let mut reader = Reader::new(payload);
            let header = Header::decode(&mut reader)?;
            Ok((header, reader.position()))
        }
        // Not CDR: the full decoder says why.
        _ => super::from_bytes::<Header>(bytes).map(|header| (header, 0)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cdr;
    use crate::msg::{Distance, InputRef};

    fn distance() -> Distance {
        Distance {
            header: Header {
                provider: "laser".into(),
                seq: 7,
                publish_time_ns: 1_000,
                inputs: vec![InputRef {
                    channel: "/base/GroundTruth".into(),
                    seq: 3,
                }],
            },
            min_distance: 1.5,
            ..Distance::default()
        }
    }

    #[test]
    fn the_header_is_read_without_decoding_the_rest() {
        let message = distance();
        let mut bytes = cdr::to_vec(&message);
        assert_eq!(peek_header(&bytes), Ok(message.header.clone()));
        // The rest may be anything.
        bytes.truncate(bytes.len() - 4);
        assert_eq!(peek_header(&bytes), Ok(message.header));
        assert!(peek_header(b"junk").is_err());
        assert!(peek_header(&[]).is_err());
    }

    #[test]
    fn a_replaced_header_leaves_the_rest_of_the_message_as_it_was() {
        let message = distance();
        let mut bytes = cdr::to_vec(&message);
        let mut header = message.header.clone();
        header.publish_time_ns = 1_500;
        header.seq = 8;
        replace_header(&mut bytes, &header).unwrap();
        let mut expected = message;
        expected.header = header;
        assert_eq!(cdr::from_bytes::<Distance>(&bytes), Ok(expected));
    }

    #[test]
    fn a_header_of_another_length_is_refused_and_nothing_changes() {
        let message = distance();
        let mut bytes = cdr::to_vec(&message);
        let before = bytes.clone();
        let mut header = message.header;
        header.provider = "a much longer provider name".into();
        assert!(matches!(
            replace_header(&mut bytes, &header),
            Err(ReplaceHeaderError::Length { .. })
        ));
        assert_eq!(bytes, before);
        let mut junk = b"junk".to_vec();
        assert!(matches!(
            replace_header(&mut junk, &header),
            Err(ReplaceHeaderError::Decode(_))
        ));
        assert_eq!(junk, b"junk");
    }
}
