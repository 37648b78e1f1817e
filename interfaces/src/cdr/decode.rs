//! Decoding: the [`Decode`] trait and a bounds-checked reader.

use std::fmt;

use super::view::LeItem;

/// What went wrong decoding.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum DecodeErrorKind {
    /// Fewer bytes were left than the value needs.
    Truncated {
        /// Bytes needed.
        needed: usize,
        /// Bytes left.
        left: usize,
    },
    /// A sequence claims more elements than the bytes left could hold.
    CountTooLarge {
        /// The count read.
        count: usize,
        /// Bytes left.
        left: usize,
    },
    /// A string is not NUL-terminated.
    MissingNul,
    /// A string is not UTF-8.
    InvalidUtf8,
    /// The encapsulation header is not little-endian plain CDR.
    Encapsulation([u8; 4]),
    /// Bytes remain after the message.
    TrailingBytes(usize),
    /// A command name that the interface does not have.
    UnknownCommand(String),
}

/// A decoding failure: what, where (byte offset from the start of the message), and in
/// which field (outermost first).
///
/// Boxed, so that a `Result` of a decoded number is two words and comes back in
/// registers: decoding and views run one such `Result` per field.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DecodeError(Box<Failure>);

#[derive(Debug, Clone, PartialEq, Eq)]
struct Failure {
    kind: DecodeErrorKind,
    offset: usize,
    path: Vec<&'static str>,
}

impl DecodeError {
    /// An error at a byte offset, outside any field.
    #[must_use]
    #[cold]
    pub fn at(offset: usize, kind: DecodeErrorKind) -> Self {
        Self(Box::new(Failure {
            kind,
            offset,
            path: Vec::new(),
        }))
    }

    /// What went wrong.
    #[must_use]
    pub fn kind(&self) -> &DecodeErrorKind {
        &self.0.kind
    }

    /// Byte offset in the message, encapsulation header included.
    #[must_use]
    pub fn offset(&self) -> usize {
        self.0.offset
    }

    /// The field path, outermost first (`header.inputs`).
    #[must_use]
    pub fn path(&self) -> &[&'static str] {
        &self.0.path
    }

    /// This error, inside field `name` of the value being decoded.
    #[must_use]
    #[cold]
    pub fn in_field(mut self, name: &'static str) -> Self {
        self.0.path.insert(0, name);
        self
    }
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.0.kind {
            DecodeErrorKind::Truncated { needed, left } => {
                write!(f, "message truncated: {needed} bytes needed, {left} left")?;
            }
            DecodeErrorKind::CountTooLarge { count, left } => {
                write!(
                    f,
                    "sequence of {count} elements cannot fit in the {left} bytes left"
                )?;
            }
            DecodeErrorKind::MissingNul => write!(f, "string not terminated by NUL")?,
            DecodeErrorKind::InvalidUtf8 => write!(f, "string is not UTF-8")?,
            DecodeErrorKind::Encapsulation(h) => write!(
                f,
                "encapsulation header {:02x} {:02x} {:02x} {:02x} is not little-endian plain CDR (00 01 00 00)",
                h[0], h[1], h[2], h[3]
            )?,
            DecodeErrorKind::TrailingBytes(n) => write!(f, "{n} bytes left after the message")?,
            DecodeErrorKind::UnknownCommand(name) => write!(f, "unknown command `{name}`")?,
        }
        write!(f, " at byte {}", self.0.offset)?;
        if !self.0.path.is_empty() {
            write!(f, " in field `{}`", self.0.path.join("."))?;
        }
        Ok(())
    }
}

impl std::error::Error for DecodeError {}

/// Reads CDR from the bytes after the encapsulation header.
#[derive(Debug)]
pub struct Reader<'a> {
    bytes: &'a [u8],
    position: usize,
}

impl<'a> Reader<'a> {
    /// A reader at the start of `payload` (the bytes after the encapsulation header).
    #[must_use]
    pub fn new(payload: &'a [u8]) -> Self {
        Self {
            bytes: payload,
            position: 0,
        }
    }

    /// A reader at `position` of `payload`: to come back to a place an earlier reader
    /// passed (alignment stays relative to the payload's start).
    #[must_use]
    pub(crate) fn at(payload: &'a [u8], position: usize) -> Self {
        Self {
            bytes: payload,
            position: position.min(payload.len()),
        }
    }

    /// The whole payload being read.
    #[must_use]
    pub(crate) fn payload(&self) -> &'a [u8] {
        self.bytes
    }

    /// Bytes consumed.
    #[must_use]
    pub fn position(&self) -> usize {
        self.position
    }

    /// Bytes left.
    #[must_use]
    pub fn remaining(&self) -> usize {
        self.bytes.len() - self.position
    }

    #[cold]
    #[inline(never)]
    fn error(&self, kind: DecodeErrorKind) -> DecodeError {
        DecodeError::at(self.position + super::ENCAPSULATION_LE.len(), kind)
    }

    /// Skips padding up to a multiple of `align`.
    #[inline]
    pub fn align(&mut self, align: usize) -> Result<(), DecodeError> {
        let pad = self.position.wrapping_neg() & (align - 1);
        if pad > self.remaining() {
            return Err(self.error(DecodeErrorKind::Truncated {
                needed: pad,
                left: self.remaining(),
            }));
        }
        self.position += pad;
        Ok(())
    }

    /// Takes the next `len` bytes.
    #[inline]
    pub fn take(&mut self, len: usize) -> Result<&'a [u8], DecodeError> {
        let end = self.position.checked_add(len);
        match end.and_then(|end| self.bytes.get(self.position..end)) {
            Some(slice) => {
                self.position += len;
                Ok(slice)
            }
            None => Err(self.error(DecodeErrorKind::Truncated {
                needed: len,
                left: self.remaining(),
            })),
        }
    }

    /// Takes the next `N` bytes as an array.
    #[inline]
    pub fn take_array<const N: usize>(&mut self) -> Result<[u8; N], DecodeError> {
        let slice = self.take(N)?;
        let mut out = [0; N];
        out.copy_from_slice(slice);
        Ok(out)
    }

    /// Checks that `count` elements of at least `min_len` bytes each can fit in what is
    /// left, before anything is allocated for them.
    #[inline]
    pub fn check_count(&self, count: usize, min_len: usize) -> Result<(), DecodeError> {
        if count.saturating_mul(min_len.max(1)) > self.remaining() {
            return Err(self.error(DecodeErrorKind::CountTooLarge {
                count,
                left: self.remaining(),
            }));
        }
        Ok(())
    }

    /// Reads a string where it lies: a `u32` length counting the NUL, the UTF-8 bytes,
    /// the NUL.
    ///
    /// # Errors
    /// When the string is cut short, lacks its NUL or is not UTF-8.
    pub fn str(&mut self) -> Result<&'a str, DecodeError> {
        let len = u32::decode(self)? as usize;
        if len == 0 {
            // Not what ROS 2 writes for an empty string (length 1, a NUL), but seen in
            // the wild from other CDR writers.
            return Ok("");
        }
        let start = self.position();
        let bytes = self.take(len)?;
        let (last, text) = bytes.split_last().unwrap_or((&0, &[]));
        if *last != 0 {
            return Err(DecodeError::at(
                start + super::ENCAPSULATION_LE.len() + len - 1,
                DecodeErrorKind::MissingNul,
            ));
        }
        std::str::from_utf8(text).map_err(|_| {
            DecodeError::at(
                start + super::ENCAPSULATION_LE.len(),
                DecodeErrorKind::InvalidUtf8,
            )
        })
    }

    /// Reads a field's view, naming the field in the error path on failure.
    #[inline]
    pub fn view_field<T: super::DecodeView<'a>>(
        &mut self,
        name: &'static str,
    ) -> Result<T, DecodeError> {
        T::decode_view(self).map_err(|err| err.in_field(name))
    }

    /// Decodes a field, naming it in the error path on failure.
    #[inline]
    pub fn field<T: Decode>(&mut self, name: &'static str) -> Result<T, DecodeError> {
        T::decode(self).map_err(|err| err.in_field(name))
    }
}

/// A value that can be decoded from CDR.
pub trait Decode: Sized {
    /// The fewest bytes one value can take (alignment aside): bounds what an untrusted
    /// count may allocate.
    const MIN_LEN: usize;

    /// Decodes one value.
    ///
    /// # Errors
    /// When the bytes are not a valid encoding.
    fn decode(reader: &mut Reader<'_>) -> Result<Self, DecodeError>;

    /// Decodes `count` elements of a sequence. Primitive types override this with one
    /// bulk read.
    ///
    /// # Errors
    /// When the bytes are not a valid encoding, or cannot hold `count` elements.
    fn decode_vec(reader: &mut Reader<'_>, count: usize) -> Result<Vec<Self>, DecodeError> {
        reader.check_count(count, Self::MIN_LEN)?;
        let mut items = Vec::with_capacity(count);
        for _ in 0..count {
            items.push(Self::decode(reader)?);
        }
        Ok(items)
    }
}

macro_rules! decode_number {
    ($($ty:ty),*) => {$(
        impl Decode for $ty {
            const MIN_LEN: usize = size_of::<$ty>();

            #[inline]
            fn decode(reader: &mut Reader<'_>) -> Result<Self, DecodeError> {
                reader.align(size_of::<$ty>())?;
                Ok(<$ty>::from_le_bytes(reader.take_array()?))
            }

            #[inline]
            fn decode_vec(reader: &mut Reader<'_>, count: usize) -> Result<Vec<Self>, DecodeError> {
                decode_le_vec(reader, count)
            }
        }
    )*};
}

decode_number!(i8, i16, u16, i32, u32, i64, u64, f32, f64);

/// `count` elements of an array of fixed-size little-endian elements (the numbers, the
/// generated plain structs like `Pose3D`): aligned, checked against the bytes left, then
/// one copy on a little-endian machine, where memory holds them the same way.
///
/// # Errors
/// When the bytes cannot hold `count` elements.
#[doc(hidden)]
pub fn decode_le_vec<T>(reader: &mut Reader<'_>, count: usize) -> Result<Vec<T>, DecodeError>
where
    T: LeItem + zerocopy::FromBytes + zerocopy::IntoBytes,
{
    if count == 0 {
        return Ok(Vec::new());
    }
    reader.align(T::ALIGN)?;
    reader.check_count(count, T::SIZE)?;
    let bytes = reader.take(count * T::SIZE)?;
    if cfg!(target_endian = "little") {
        let Ok(mut items) = T::new_vec_zeroed(count) else {
            // The allocation failed: as `Vec::with_capacity` would, report it and stop.
            std::alloc::handle_alloc_error(std::alloc::Layout::new::<T>());
        };
        zerocopy::IntoBytes::as_mut_bytes(items.as_mut_slice()).copy_from_slice(bytes);
        return Ok(items);
    }
    Ok(bytes.chunks_exact(T::SIZE).map(T::read_le).collect())
}

impl Decode for u8 {
    const MIN_LEN: usize = 1;

    #[inline]
    fn decode(reader: &mut Reader<'_>) -> Result<Self, DecodeError> {
        Ok(reader.take_array::<1>()?[0])
    }

    #[inline]
    fn decode_vec(reader: &mut Reader<'_>, count: usize) -> Result<Vec<Self>, DecodeError> {
        reader.check_count(count, 1)?;
        Ok(reader.take(count)?.to_vec())
    }
}

impl Decode for bool {
    const MIN_LEN: usize = 1;

    /// Any non-zero byte is true, as ROS 2's own decoders read it.
    #[inline]
    fn decode(reader: &mut Reader<'_>) -> Result<Self, DecodeError> {
        Ok(reader.take_array::<1>()?[0] != 0)
    }
}

impl Decode for String {
    const MIN_LEN: usize = 4;

    #[inline]
    fn decode(reader: &mut Reader<'_>) -> Result<Self, DecodeError> {
        reader.str().map(str::to_owned)
    }
}

impl<T: Decode> Decode for Vec<T> {
    const MIN_LEN: usize = 4;

    #[inline]
    fn decode(reader: &mut Reader<'_>) -> Result<Self, DecodeError> {
        let count = u32::decode(reader)? as usize;
        T::decode_vec(reader, count)
    }
}
