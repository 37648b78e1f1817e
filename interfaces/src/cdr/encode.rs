//! Encoding: the [`Encode`] trait and the places bytes can go.

use thiserror::Error;

use super::view::LeItem;

/// Where encoded bytes go. Positions count from the end of the encapsulation header,
/// which is what CDR alignment is relative to.
pub trait Sink {
    /// Bytes written so far (after the encapsulation header).
    fn position(&self) -> usize;

    /// Appends `bytes`.
    fn put(&mut self, bytes: &[u8]);

    /// Appends `len` bytes that `fill` writes; the bulk path for arrays of primitives.
    fn put_with(&mut self, len: usize, fill: impl FnOnce(&mut [u8]));

    /// Leaves `len` bytes for the caller to write later ([`crate::InPlace`]): a slice
    /// keeps what it held there, a `Vec` gets zeros.
    fn skip(&mut self, len: usize);

    /// Appends zero bytes up to a multiple of `align`.
    #[inline]
    fn align(&mut self, align: usize) {
        let pad = self.position().wrapping_neg() & (align - 1);
        if pad != 0 {
            self.put(&[0; 8][..pad]);
        }
    }
}

/// Counts bytes without writing them: sizes a buffer before encoding into it.
#[derive(Debug, Default, Clone, Copy)]
pub struct SizeSink {
    position: usize,
}

impl Sink for SizeSink {
    #[inline]
    fn position(&self) -> usize {
        self.position
    }
    #[inline]
    fn put(&mut self, bytes: &[u8]) {
        self.position += bytes.len();
    }
    #[inline]
    fn put_with(&mut self, len: usize, _fill: impl FnOnce(&mut [u8])) {
        self.position += len;
    }
    #[inline]
    fn skip(&mut self, len: usize) {
        // A reserved length may be absurd (a caller's bug): it must size no buffer, not
        // overflow.
        self.position = self.position.saturating_add(len);
    }
}

/// Writes into a caller's slice (a shared-memory loan). Running out of room is recorded,
/// not panicked on, and reported by [`SliceSink::finish`].
#[derive(Debug)]
pub struct SliceSink<'a> {
    buffer: &'a mut [u8],
    position: usize,
    overflow: bool,
}

impl<'a> SliceSink<'a> {
    /// A sink writing from the start of `buffer`.
    pub fn new(buffer: &'a mut [u8]) -> Self {
        Self {
            buffer,
            position: 0,
            overflow: false,
        }
    }

    /// The bytes written, or `None` if the slice was too small.
    #[must_use]
    pub fn finish(self) -> Option<usize> {
        (!self.overflow).then_some(self.position)
    }

    #[inline]
    fn room(&mut self, len: usize) -> Option<&mut [u8]> {
        let end = self.position.checked_add(len)?;
        let slot = self.buffer.get_mut(self.position..end)?;
        self.position = end;
        Some(slot)
    }
}

impl Sink for SliceSink<'_> {
    #[inline]
    fn position(&self) -> usize {
        self.position
    }
    #[inline]
    fn put(&mut self, bytes: &[u8]) {
        match self.room(bytes.len()) {
            Some(slot) => slot.copy_from_slice(bytes),
            None => self.overflow = true,
        }
    }
    #[inline]
    fn put_with(&mut self, len: usize, fill: impl FnOnce(&mut [u8])) {
        match self.room(len) {
            Some(slot) => fill(slot),
            None => self.overflow = true,
        }
    }
    #[inline]
    fn skip(&mut self, len: usize) {
        if self.room(len).is_none() {
            self.overflow = true;
        }
    }
}

/// Appends to a `Vec`, whose allocation the caller reuses from message to message.
#[derive(Debug)]
pub struct VecSink<'a> {
    buffer: &'a mut Vec<u8>,
    origin: usize,
}

impl<'a> VecSink<'a> {
    /// A sink appending to `buffer`, whose first `origin` bytes (the encapsulation
    /// header) do not count for alignment.
    pub fn new(buffer: &'a mut Vec<u8>, origin: usize) -> Self {
        Self { buffer, origin }
    }
}

impl Sink for VecSink<'_> {
    #[inline]
    fn position(&self) -> usize {
        self.buffer.len() - self.origin
    }
    #[inline]
    fn put(&mut self, bytes: &[u8]) {
        self.buffer.extend_from_slice(bytes);
    }
    #[inline]
    fn put_with(&mut self, len: usize, fill: impl FnOnce(&mut [u8])) {
        let start = self.buffer.len();
        self.buffer.resize(start + len, 0);
        fill(&mut self.buffer[start..]);
    }
    #[inline]
    fn skip(&mut self, len: usize) {
        self.buffer.resize(self.buffer.len() + len, 0);
    }
}

/// Why encoding failed.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum EncodeError {
    /// The caller's buffer cannot hold the message.
    #[error("the buffer holds {available} bytes but the message needs {needed}")]
    BufferTooSmall {
        /// Bytes the message needs, header included.
        needed: usize,
        /// Bytes the buffer has.
        available: usize,
    },
}

/// A value that has a CDR encoding.
pub trait Encode {
    /// Appends the encoding of `self` to `sink`, aligned.
    fn encode<S: Sink>(&self, sink: &mut S);

    /// Appends the elements of a sequence (its count is written by the caller). Primitive
    /// types override this with one bulk write.
    fn encode_slice<S: Sink>(items: &[Self], sink: &mut S)
    where
        Self: Sized,
    {
        for item in items {
            item.encode(sink);
        }
    }
}

/// The elements of an array of fixed-size little-endian elements (the numbers, the
/// generated plain structs like `Pose3D`), aligned: one copy on a little-endian machine,
/// where memory already holds their encoding.
#[doc(hidden)]
#[inline]
pub fn encode_le_slice<T, S>(items: &[T], sink: &mut S)
where
    T: LeItem + zerocopy::IntoBytes + zerocopy::Immutable,
    S: Sink,
{
    if items.is_empty() {
        return;
    }
    sink.align(T::ALIGN);
    if cfg!(target_endian = "little") {
        sink.put(zerocopy::IntoBytes::as_bytes(items));
        return;
    }
    sink.put_with(items.len() * T::SIZE, |out| {
        for (chunk, item) in out.chunks_exact_mut(T::SIZE).zip(items) {
            item.write_le(chunk);
        }
    });
}

macro_rules! encode_number {
    ($($ty:ty),*) => {$(
        impl Encode for $ty {
            #[inline]
            fn encode<S: Sink>(&self, sink: &mut S) {
                sink.align(size_of::<$ty>());
                sink.put(&self.to_le_bytes());
            }

            #[inline]
            fn encode_slice<S: Sink>(items: &[Self], sink: &mut S) {
                encode_le_slice(items, sink);
            }
        }
    )*};
}

encode_number!(i8, i16, u16, i32, u32, i64, u64, f32, f64);

impl Encode for u8 {
    #[inline]
    fn encode<S: Sink>(&self, sink: &mut S) {
        sink.put(&[*self]);
    }

    #[inline]
    fn encode_slice<S: Sink>(items: &[Self], sink: &mut S) {
        sink.put(items);
    }
}

impl Encode for bool {
    #[inline]
    fn encode<S: Sink>(&self, sink: &mut S) {
        sink.put(&[u8::from(*self)]);
    }
}

impl Encode for str {
    #[inline]
    fn encode<S: Sink>(&self, sink: &mut S) {
        // The length counts the NUL. A string longer than 4 GiB cannot be a CDR string;
        // it is cut at the limit rather than written with a lying length.
        let bytes = self.as_bytes();
        let len = bytes.len().min(u32::MAX as usize - 1);
        (len as u32 + 1).encode(sink);
        sink.put(&bytes[..len]);
        sink.put(&[0]);
    }
}

impl Encode for String {
    #[inline]
    fn encode<S: Sink>(&self, sink: &mut S) {
        self.as_str().encode(sink);
    }
}

impl<T: Encode> Encode for Vec<T> {
    #[inline]
    fn encode<S: Sink>(&self, sink: &mut S) {
        // A sequence of more than u32::MAX elements cannot be CDR; it is cut at the limit.
        let len = self.len().min(u32::MAX as usize);
        (len as u32).encode(sink);
        T::encode_slice(&self[..len], sink);
    }
}
