//! Zero-copy writing: a message whose big arrays are written straight into their place in
//! the encoded bytes (a shared-memory loan), instead of built in vectors and copied.
//!
//! The mirror of [`super::view`]. A camera driver or a simulated laser produces a frame or
//! a scan of known size; encoding it from its own vectors would copy every byte once more.
//! With [`crate::InPlace`] the publisher encodes the small fields of a message (its
//! header, its counts) and leaves room for its arrays of numbers and of plain structs,
//! whose lengths it gives ([`crate::InPlace::Lens`]); it then writes the elements where
//! they lie through the message's bulk writer (`RangeFinderBulk<'a>`): [`LeSliceMut`]s,
//! and `&mut [u8]` for byte arrays.
//!
//! The bytes left for the arrays are not cleared (a shared-memory loan holds whatever an
//! earlier message left): the writer must set every element. Arrays of `bool` are not
//! written in place (not every byte is a valid `bool`); they are encoded from the message.

use std::fmt;
use std::marker::PhantomData;

use super::encode::{Encode, Sink};
use super::view::{LeItem, LeSlice};

/// A sequence of fixed-size little-endian elements, written where they lie in the
/// encoded bytes. As with [`super::LeSlice`], the bytes are not aligned in memory for `T`,
/// so elements are written one by one, not cast.
pub struct LeSliceMut<'a, T> {
    bytes: &'a mut [u8],
    element: PhantomData<T>,
}

impl<'a, T: LeItem> LeSliceMut<'a, T> {
    /// The elements in `bytes` (a whole number of them: any remainder is left out).
    #[must_use]
    pub fn new(bytes: &'a mut [u8]) -> Self {
        let whole = bytes.len() - bytes.len() % T::SIZE;
        Self {
            bytes: &mut bytes[..whole],
            element: PhantomData,
        }
    }

    /// What is written so far, read as a [`LeSlice`].
    #[must_use]
    pub fn as_view(&self) -> LeSlice<'_, T> {
        LeSlice::from_le_bytes(self.bytes)
    }

    /// The number of elements.
    #[must_use]
    pub fn len(&self) -> usize {
        self.as_view().len()
    }

    /// Whether it has no elements.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Element `index`, as written so far, if there is one.
    #[must_use]
    pub fn get(&self, index: usize) -> Option<T> {
        self.as_view().get(index)
    }

    /// Writes element `index`; returns false (writing nothing) when there is no such
    /// element.
    pub fn set(&mut self, index: usize, value: &T) -> bool {
        let Some(start) = index.checked_mul(T::SIZE) else {
            return false;
        };
        let Some(end) = start.checked_add(T::SIZE) else {
            return false;
        };
        match self.bytes.get_mut(start..end) {
            Some(slot) => {
                value.write_le(slot);
                true
            }
            None => false,
        }
    }

    /// Writes `value` into every element. Copies of what is already written double at each
    /// step, so it costs about a `memcpy` of the array, not a store per element.
    pub fn fill(&mut self, value: &T) {
        let total = self.bytes.len();
        if total == 0 {
            return;
        }
        value.write_le(&mut self.bytes[..T::SIZE]);
        let mut done = T::SIZE;
        while done < total {
            let step = done.min(total - done);
            self.bytes.copy_within(..step, done);
            done += step;
        }
    }

    /// Writes the elements from the start, in order, until either runs out; returns how
    /// many were written.
    pub fn fill_from<I: IntoIterator<Item = T>>(&mut self, values: I) -> usize {
        let mut written = 0;
        for (slot, value) in self.bytes.chunks_exact_mut(T::SIZE).zip(values) {
            value.write_le(slot);
            written += 1;
        }
        written
    }

    /// Writes `values` from the start, in order, until either runs out; returns how many
    /// were written. One copy on a little-endian machine.
    pub fn copy_from_slice(&mut self, values: &[T]) -> usize
    where
        T: zerocopy::IntoBytes + zerocopy::Immutable + Clone,
    {
        let count = values.len().min(self.len());
        if cfg!(target_endian = "little") {
            let bytes = zerocopy::IntoBytes::as_bytes(&values[..count]);
            self.bytes[..bytes.len()].copy_from_slice(bytes);
            count
        } else {
            self.fill_from(values.iter().cloned())
        }
    }

    /// The elements' bytes (little-endian, no padding), to write by hand.
    pub fn as_bytes_mut(&mut self) -> &mut [u8] {
        self.bytes
    }
}

impl<T: LeItem + fmt::Debug> fmt::Debug for LeSliceMut<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LeSliceMut")
            .field("len", &self.len())
            .finish_non_exhaustive()
    }
}

/// Writes the count of an array of `count` elements of `T` and leaves room for them,
/// aligned as encoding aligns them; returns where the elements start. What the generated
/// [`crate::InPlace::encode_shape`] does for each array written in place.
pub fn reserve_bulk<T: LeItem, S: Sink>(count: usize, sink: &mut S) -> usize {
    // As `Vec::encode`: an array of more than u32::MAX elements is cut at the limit.
    let count = count.min(u32::MAX as usize);
    (count as u32).encode(sink);
    if count > 0 {
        sink.align(T::ALIGN);
    }
    let start = sink.position();
    sink.skip(bulk_len::<T>(count));
    start
}

/// The bytes an array of `count` elements of `T` takes, as [`reserve_bulk`] reserves them.
#[must_use]
pub fn bulk_len<T: LeItem>(count: usize) -> usize {
    count.min(u32::MAX as usize).saturating_mul(T::SIZE)
}

/// Hands out the disjoint byte ranges of the arrays of one message, in the order they lie
/// in the payload. Used by the generated [`crate::InPlace::bulk`].
#[derive(Debug)]
pub struct BulkParts<'a> {
    rest: &'a mut [u8],
    /// Where `rest` starts in the payload.
    offset: usize,
}

impl<'a> BulkParts<'a> {
    /// The payload (the bytes after the encapsulation header).
    #[must_use]
    pub fn new(payload: &'a mut [u8]) -> Self {
        Self {
            rest: payload,
            offset: 0,
        }
    }

    /// The `len` bytes at `start`, which must lie after every range taken before. A range
    /// that does not (a bug in the caller) gives an empty slice rather than the wrong
    /// bytes.
    pub fn take(&mut self, start: usize, len: usize) -> &'a mut [u8] {
        let Some(skip) = start.checked_sub(self.offset) else {
            debug_assert!(false, "bulk range at {start} is before {}", self.offset);
            return &mut [];
        };
        let rest = std::mem::take(&mut self.rest);
        if skip.checked_add(len).is_none_or(|end| end > rest.len()) {
            debug_assert!(false, "bulk range {start}+{len} is past the payload");
            self.rest = rest;
            return &mut [];
        }
        let (_, from_start) = rest.split_at_mut(skip);
        let (taken, rest) = from_start.split_at_mut(len);
        self.rest = rest;
        self.offset = start + len;
        taken
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cdr::{DecodeView, LeSlice, Reader, SizeSink};

    #[test]
    fn a_written_slice_reads_back_as_a_view_of_the_same_bytes() {
        // The count, padding to the elements' alignment, three f64.
        let mut bytes = vec![0xAA_u8; 8 + 3 * 8];
        bytes[..4].copy_from_slice(&3_u32.to_le_bytes());
        let mut slice = LeSliceMut::<f64>::new(&mut bytes[8..]);
        assert_eq!(slice.len(), 3);
        assert!(slice.set(1, &2.5));
        assert!(!slice.set(3, &9.0));
        assert_eq!(slice.fill_from([1.0, 2.0]), 2);
        slice.fill(&-1.5);
        assert_eq!(
            (0..4).map(|i| slice.get(i)).collect::<Vec<_>>(),
            [Some(-1.5), Some(-1.5), Some(-1.5), None]
        );
        assert_eq!(slice.copy_from_slice(&[7.0, 8.0, 9.0, 10.0]), 3);
        let view = LeSlice::<f64>::decode_view(&mut Reader::new(&bytes)).unwrap();
        assert_eq!(view.to_vec(), vec![7.0, 8.0, 9.0]);
    }

    #[test]
    fn fill_writes_every_element_of_any_length() {
        for n in 0..40 {
            let mut bytes = vec![0xAA_u8; n * 4 + 3];
            let mut slice = LeSliceMut::<i32>::new(&mut bytes);
            slice.fill(&-7);
            assert_eq!(slice.len(), n);
            assert!((0..n).all(|i| slice.get(i) == Some(-7)), "{n}");
            assert_eq!(&bytes[n * 4..], &[0xAA; 3], "past the elements, nothing");
        }
    }

    #[test]
    fn reserving_aligns_like_encoding_and_counts_the_room() {
        let mut sink = SizeSink::default();
        1_u8.encode(&mut sink);
        let start = reserve_bulk::<f64, _>(2, &mut sink);
        // count at 4 (after padding), elements at 8, two of 8 bytes.
        assert_eq!((start, sink.position()), (8, 24));
        let empty = reserve_bulk::<f64, _>(0, &mut sink);
        assert_eq!((empty, sink.position()), (28, 28));
    }

    #[test]
    fn parts_are_handed_out_in_order_and_never_overlap() {
        let mut payload = [0_u8; 16];
        let mut parts = BulkParts::new(&mut payload);
        assert_eq!(parts.take(2, 4).len(), 4);
        assert_eq!(parts.take(8, 8).len(), 8);
    }
}
