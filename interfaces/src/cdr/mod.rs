//! ROS 2 CDR: plain CDR, little-endian, after the 4-byte encapsulation header
//! `00 01 00 00`, every primitive aligned to its size relative to the end of that header;
//! strings are a `u32` length that counts the terminating NUL, the bytes, then the NUL;
//! sequences are a `u32` count, then the elements.
//!
//! Written once, generic over where the bytes go ([`Sink`]): a counter (to size a
//! shared-memory loan), a caller's slice (to encode straight into shared memory), or a
//! reusable `Vec`. Decoding never trusts a count: it is checked against the bytes left
//! before anything is allocated.

mod decode;
mod encode;
mod header;
mod in_place;
mod view;

pub use decode::{Decode, DecodeError, DecodeErrorKind, Reader, decode_le_vec};
pub use encode::{Encode, EncodeError, Sink, SizeSink, SliceSink, VecSink, encode_le_slice};
pub use header::{ReplaceHeaderError, peek_header, replace_header};
pub use in_place::{BulkParts, LeSliceMut, bulk_len, reserve_bulk};
pub use view::{DecodeView, LeItem, LeSlice, SeqIter, SeqView, ViewToOwned};

/// The encapsulation header of little-endian plain CDR.
pub const ENCAPSULATION_LE: [u8; 4] = [0x00, 0x01, 0x00, 0x00];

/// The number of bytes `value` takes encoded, header included.
pub fn encoded_len<T: Encode + ?Sized>(value: &T) -> usize {
    let mut sink = SizeSink::default();
    value.encode(&mut sink);
    ENCAPSULATION_LE.len() + sink.position()
}

/// Encodes `value` into `buffer` (header included), returning the bytes written.
///
/// # Errors
/// [`EncodeError::BufferTooSmall`] when `buffer` is shorter than [`encoded_len`]; the
/// buffer's contents are then unspecified.
pub fn encode_into<T: Encode + ?Sized>(value: &T, buffer: &mut [u8]) -> Result<usize, EncodeError> {
    let (_, (), written) = encode_framed(buffer, || encoded_len(value), |sink| value.encode(sink))?;
    Ok(written)
}

/// The number of bytes `value` takes encoded with arrays of the lengths `lens` written in
/// place ([`crate::InPlace`]), header included.
pub fn in_place_len<T: crate::InPlace>(value: &T, lens: &T::Lens) -> usize {
    let mut sink = SizeSink::default();
    value.encode_shape(lens, &mut sink);
    ENCAPSULATION_LE.len() + sink.position()
}

/// Encodes `value` into `buffer` (header included) but for its arrays written in place,
/// which get the lengths `lens` and whose room is left as it is; returns their writer.
/// Once every element is written, `buffer[..in_place_len(value, lens)]` is the message.
///
/// # Errors
/// [`EncodeError::BufferTooSmall`] when `buffer` is shorter than [`in_place_len`].
pub fn encode_in_place<'a, T: crate::InPlace>(
    value: &T,
    lens: &T::Lens,
    buffer: &'a mut [u8],
) -> Result<T::Bulk<'a>, EncodeError> {
    let (payload, starts, _) = encode_framed(
        buffer,
        || in_place_len(value, lens),
        |sink| value.encode_shape(lens, sink),
    )?;
    Ok(T::bulk(payload, lens, &starts))
}

/// Writes the encapsulation header into `buffer` and runs `encode` on a sink over the rest;
/// returns that rest (the payload), what `encode` returned and the bytes written, header
/// included. One pass when the buffer is big enough (the usual case: it was sized first);
/// `needed` is computed only to explain a failure.
fn encode_framed<R>(
    buffer: &mut [u8],
    needed: impl FnOnce() -> usize,
    encode: impl FnOnce(&mut SliceSink<'_>) -> R,
) -> Result<(&mut [u8], R, usize), EncodeError> {
    let available = buffer.len();
    let too_small = |needed: usize| EncodeError::BufferTooSmall { needed, available };
    let Some((header, payload)) = buffer.split_at_mut_checked(ENCAPSULATION_LE.len()) else {
        return Err(too_small(needed()));
    };
    header.copy_from_slice(&ENCAPSULATION_LE);
    let mut sink = SliceSink::new(payload);
    let out = encode(&mut sink);
    match sink.finish() {
        Some(written) => Ok((payload, out, written + ENCAPSULATION_LE.len())),
        None => Err(too_small(needed())),
    }
}

/// Encodes `value` into `buffer`, replacing its contents (its allocation is reused).
pub fn encode_to_vec<T: Encode + ?Sized>(value: &T, buffer: &mut Vec<u8>) {
    buffer.clear();
    buffer.extend_from_slice(&ENCAPSULATION_LE);
    let mut sink = VecSink::new(buffer, ENCAPSULATION_LE.len());
    value.encode(&mut sink);
}

/// Encodes `value` into a new `Vec`.
pub fn to_vec<T: Encode + ?Sized>(value: &T) -> Vec<u8> {
    let mut buffer = Vec::with_capacity(encoded_len(value));
    encode_to_vec(value, &mut buffer);
    buffer
}

/// Decodes a `T` from `bytes` (header included). Up to 3 trailing padding bytes are
/// accepted, as some writers pad messages to a multiple of 4.
///
/// # Errors
/// A [`DecodeError`] naming the field and offset when the bytes are not a valid `T`.
#[inline]
pub fn from_bytes<T: Decode>(bytes: &[u8]) -> Result<T, DecodeError> {
    read_whole(bytes, T::decode)
}

/// A `V` read in place from `bytes` (header included), checked as [`from_bytes`] checks:
/// the view of a message, copying nothing (see [`DecodeView`]). For a generated struct
/// `T`, `V` is `T::View<'a>`: [`crate::Struct::view`] names it.
///
/// # Errors
/// As [`from_bytes`].
#[inline]
pub fn view<'a, V: DecodeView<'a>>(bytes: &'a [u8]) -> Result<V, DecodeError> {
    read_whole(bytes, V::decode_view)
}

/// Checks the encapsulation header, reads one value with `read`, and allows at most 3
/// bytes of padding after it.
#[inline]
fn read_whole<'a, T>(
    bytes: &'a [u8],
    read: impl FnOnce(&mut Reader<'a>) -> Result<T, DecodeError>,
) -> Result<T, DecodeError> {
    let payload = match bytes.split_first_chunk::<4>() {
        Some((header, payload)) if *header == ENCAPSULATION_LE => payload,
        Some((header, _)) => {
            return Err(DecodeError::at(0, DecodeErrorKind::Encapsulation(*header)));
        }
        None => {
            return Err(DecodeError::at(
                0,
                DecodeErrorKind::Truncated {
                    needed: 4,
                    left: bytes.len(),
                },
            ));
        }
    };
    let mut reader = Reader::new(payload);
    let value = read(&mut reader)?;
    let trailing = reader.remaining();
    if trailing > 3 {
        return Err(DecodeError::at(
            reader.position() + ENCAPSULATION_LE.len(),
            DecodeErrorKind::TrailingBytes(trailing),
        ));
    }
    Ok(value)
}
