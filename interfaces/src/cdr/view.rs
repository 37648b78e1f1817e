//! Zero-copy reading: a message's fields borrowed from its CDR bytes, wherever they are
//! (a shared-memory sample, an MCAP chunk), instead of decoded into owned vectors.
//!
//! Each generated struct `Foo` has a view `FooView<'a>` with the same fields: numbers
//! are read at once, strings are `&'a str`, byte arrays `&'a [u8]`, arrays of numbers
//! and of plain structs (like `Pose3D`) are [`LeSlice`]s read element by element where
//! they lie, and arrays of other structs are [`SeqView`]s walked on demand. Building a
//! view walks the message once and checks every count, string and bound, as decoding
//! does, but copies nothing and allocates nothing; after that no access can fail.
//!
//! A view is what a consumer of a 1 MiB scan or a camera frame wants: the decode would
//! copy every byte out of shared memory first. `to_owned_value` gives the owned message
//! when one is needed after all.

use std::fmt;
use std::marker::PhantomData;

use super::decode::{Decode, DecodeError, Reader};

/// A value that can be read in place from CDR: the view of a generated struct, or one
/// of the field types below.
pub trait DecodeView<'a>: Sized {
    /// The fewest bytes one value can take (alignment aside): bounds what an untrusted
    /// count may walk.
    const MIN_LEN: usize;

    /// Reads one value at the reader's position, checking it whole.
    ///
    /// # Errors
    /// When the bytes are not a valid encoding.
    fn decode_view(reader: &mut Reader<'a>) -> Result<Self, DecodeError>;
}

/// The owned value a view stands for.
pub trait ViewToOwned {
    /// The owned type: `RangeFinder` for `RangeFinderView`, `Vec<f64>` for a
    /// `LeSlice<f64>`.
    type Owned;

    /// Copies the view into its owned value.
    fn to_owned_value(&self) -> Self::Owned;
}

/// A fixed-size element stored little-endian with no padding inside: the numbers, `bool`,
/// and the generated plain structs (all of whose fields are the same number type).
pub trait LeItem: Sized {
    /// Bytes per element.
    const SIZE: usize;
    /// The CDR alignment of the element's first byte.
    const ALIGN: usize;

    /// Reads one element from exactly [`LeItem::SIZE`] bytes.
    fn read_le(bytes: &[u8]) -> Self;

    /// Writes the element into exactly [`LeItem::SIZE`] bytes.
    fn write_le(&self, bytes: &mut [u8]);
}

macro_rules! le_number {
    ($($ty:ty),*) => {$(
        impl LeItem for $ty {
            const SIZE: usize = size_of::<$ty>();
            const ALIGN: usize = size_of::<$ty>();

            #[inline]
            fn read_le(bytes: &[u8]) -> Self {
                let mut array = [0; size_of::<$ty>()];
                array.copy_from_slice(bytes);
                <$ty>::from_le_bytes(array)
            }

            #[inline]
            fn write_le(&self, bytes: &mut [u8]) {
                bytes.copy_from_slice(&self.to_le_bytes());
            }
        }
    )*};
}

le_number!(u8, i8, i16, u16, i32, u32, i64, u64, f32, f64);

impl LeItem for bool {
    const SIZE: usize = 1;
    const ALIGN: usize = 1;

    /// Any non-zero byte is true, as decoding reads it.
    #[inline]
    fn read_le(bytes: &[u8]) -> Self {
        bytes.first().is_some_and(|b| *b != 0)
    }

    #[inline]
    fn write_le(&self, bytes: &mut [u8]) {
        if let Some(b) = bytes.first_mut() {
            *b = u8::from(*self);
        }
    }
}

/// A value with nothing to borrow is its own view: read as decoding reads it.
macro_rules! view_as_decoded {
    ($($ty:ty),*) => {$(
        impl DecodeView<'_> for $ty {
            const MIN_LEN: usize = <$ty as Decode>::MIN_LEN;

            #[inline]
            fn decode_view(reader: &mut Reader<'_>) -> Result<Self, DecodeError> {
                <$ty as Decode>::decode(reader)
            }
        }

        impl ViewToOwned for $ty {
            type Owned = $ty;

            #[inline]
            fn to_owned_value(&self) -> $ty {
                *self
            }
        }
    )*};
}

view_as_decoded!(u8, i8, i16, u16, i32, u32, i64, u64, f32, f64, bool);

impl<'a> DecodeView<'a> for &'a str {
    const MIN_LEN: usize = 4;

    #[inline]
    fn decode_view(reader: &mut Reader<'a>) -> Result<Self, DecodeError> {
        reader.str()
    }
}

impl ViewToOwned for &str {
    type Owned = String;

    fn to_owned_value(&self) -> String {
        (*self).to_owned()
    }
}

/// A byte sequence (`byte[]`, `uint8[]`, `bytes`): the bytes where they lie.
impl<'a> DecodeView<'a> for &'a [u8] {
    const MIN_LEN: usize = 4;

    #[inline]
    fn decode_view(reader: &mut Reader<'a>) -> Result<Self, DecodeError> {
        let count = u32::decode(reader)? as usize;
        reader.check_count(count, 1)?;
        reader.take(count)
    }
}

impl ViewToOwned for &[u8] {
    type Owned = Vec<u8>;

    fn to_owned_value(&self) -> Vec<u8> {
        self.to_vec()
    }
}

/// A sequence of fixed-size little-endian elements, read where they lie. The bytes are
/// not aligned in memory for `T` (CDR aligns relative to the message, which sits after a
/// 4-byte header), so elements are read one by one, not cast.
pub struct LeSlice<'a, T> {
    bytes: &'a [u8],
    element: PhantomData<T>,
}

// Not derived: a derive would ask `T: Copy`, and a view is a reference whatever `T` is.
impl<T> Clone for LeSlice<'_, T> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<T> Copy for LeSlice<'_, T> {}

impl<'a, T> LeSlice<'a, T> {
    /// The elements encoded in `bytes` (a whole number of them, checked by the caller).
    pub(super) fn from_le_bytes(bytes: &'a [u8]) -> Self {
        Self {
            bytes,
            element: PhantomData,
        }
    }
}

impl<'a, T: LeItem + 'a> LeSlice<'a, T> {
    /// The number of elements.
    #[must_use]
    pub fn len(&self) -> usize {
        self.bytes.len() / T::SIZE
    }

    /// Whether it has no elements.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.bytes.is_empty()
    }

    /// Element `index`, if there is one.
    #[must_use]
    pub fn get(&self, index: usize) -> Option<T> {
        let start = index.checked_mul(T::SIZE)?;
        self.bytes
            .get(start..start.checked_add(T::SIZE)?)
            .map(T::read_le)
    }

    /// The elements in order.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = T> + 'a {
        self.bytes.chunks_exact(T::SIZE).map(T::read_le)
    }

    /// The elements' encoded bytes (little-endian, no padding).
    #[must_use]
    pub fn as_bytes(&self) -> &'a [u8] {
        self.bytes
    }

    /// The elements, copied.
    #[must_use]
    pub fn to_vec(&self) -> Vec<T> {
        self.iter().collect()
    }
}

impl<'a, T: LeItem> DecodeView<'a> for LeSlice<'a, T> {
    const MIN_LEN: usize = 4;

    #[inline]
    fn decode_view(reader: &mut Reader<'a>) -> Result<Self, DecodeError> {
        let count = u32::decode(reader)? as usize;
        if count > 0 {
            reader.align(T::ALIGN)?;
        }
        reader.check_count(count, T::SIZE)?;
        Ok(Self::from_le_bytes(reader.take(count * T::SIZE)?))
    }
}

impl<T: LeItem> ViewToOwned for LeSlice<'_, T> {
    type Owned = Vec<T>;

    fn to_owned_value(&self) -> Vec<T> {
        self.to_vec()
    }
}

impl<T: LeItem + fmt::Debug> fmt::Debug for LeSlice<'_, T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// A sequence of variable-size elements (strings, structs with strings or arrays), each
/// read in place as it is reached. Checked whole when the view was built.
pub struct SeqView<'a, V> {
    /// The message payload the elements lie in (CDR alignment is relative to its start).
    payload: &'a [u8],
    /// Where the first element starts in `payload`.
    start: usize,
    count: usize,
    element: PhantomData<V>,
}

impl<V> Clone for SeqView<'_, V> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<V> Copy for SeqView<'_, V> {}

impl<'a, V: DecodeView<'a>> SeqView<'a, V> {
    /// The number of elements.
    #[must_use]
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether it has no elements.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// The elements in order, each read as it is reached.
    pub fn iter(&self) -> SeqIter<'a, V> {
        SeqIter {
            reader: Reader::at(self.payload, self.start),
            left: self.count,
            element: PhantomData,
        }
    }

    /// Element `index` (reached by reading the ones before it).
    #[must_use]
    pub fn get(&self, index: usize) -> Option<V> {
        self.iter().nth(index)
    }
}

impl<'a, V: DecodeView<'a>> DecodeView<'a> for SeqView<'a, V> {
    const MIN_LEN: usize = 4;

    fn decode_view(reader: &mut Reader<'a>) -> Result<Self, DecodeError> {
        let count = u32::decode(reader)? as usize;
        reader.check_count(count, V::MIN_LEN)?;
        let start = reader.position();
        for _ in 0..count {
            V::decode_view(reader)?;
        }
        Ok(Self {
            payload: reader.payload(),
            start,
            count,
            element: PhantomData,
        })
    }
}

impl<'a, V: DecodeView<'a> + ViewToOwned> ViewToOwned for SeqView<'a, V> {
    type Owned = Vec<V::Owned>;

    fn to_owned_value(&self) -> Vec<V::Owned> {
        self.iter().map(|v| v.to_owned_value()).collect()
    }
}

impl<'a, V: DecodeView<'a> + fmt::Debug> fmt::Debug for SeqView<'a, V> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_list().entries(self.iter()).finish()
    }
}

/// The iterator of a [`SeqView`].
#[derive(Debug)]
pub struct SeqIter<'a, V> {
    reader: Reader<'a>,
    left: usize,
    element: PhantomData<V>,
}

impl<'a, V: DecodeView<'a>> Iterator for SeqIter<'a, V> {
    type Item = V;

    fn next(&mut self) -> Option<V> {
        self.left = self.left.checked_sub(1)?;
        // Checked when the sequence's view was built: this cannot fail.
        V::decode_view(&mut self.reader).ok()
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (self.left, Some(self.left))
    }
}

impl<'a, V: DecodeView<'a>> ExactSizeIterator for SeqIter<'a, V> {}
