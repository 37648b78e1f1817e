//! Walking CDR bytes with a compiled plan.
//!
//! Plain CDR (XCDR1) as ROS 2 writes it: a 4-byte encapsulation header, then fields in
//! order, each primitive aligned to its size relative to the end of the header; strings and
//! sequences are a u32 length first; fixed arrays have no length. A sequence of primitives
//! aligns its first element only when it has one (as Fast-CDR does). `wstring` is read as
//! Fast-CDR writes it: a u32 count of characters, then 4 bytes per character.

use std::sync::Arc;

use super::error::{DecodeError, DecodeErrorKind};
use super::plan::{Decoder, Element, FieldPlan, Length, StructPlan};
use super::types::Primitive;
use super::value::Value;

const HEADER_LEN: usize = 4;

/// A failure deep in the message; the path is collected in reverse while unwinding, so the
/// happy path builds no strings.
pub(super) struct Failure {
    offset: usize,
    kind: DecodeErrorKind,
    reversed_path: Vec<Segment>,
}

enum Segment {
    Field(Arc<str>),
    Index(usize),
}

pub(super) type Decoded<T> = Result<T, Box<Failure>>;

pub(super) fn decode(decoder: &Decoder, root: usize, message: &[u8]) -> Result<Value, DecodeError> {
    let mut walker = Walker::new(decoder, message)?;
    let value = walker
        .structure(root)
        .and_then(|value| walker.finish().map(|()| value))
        .map_err(|failure| into_error(*failure))?;
    Ok(value)
}

pub(super) fn into_error(failure: Failure) -> DecodeError {
    let mut path = String::new();
    for segment in failure.reversed_path.iter().rev() {
        match segment {
            Segment::Field(name) => {
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(name);
            }
            Segment::Index(index) => {
                path.push('[');
                path.push_str(&index.to_string());
                path.push(']');
            }
        }
    }
    DecodeError {
        path,
        offset: failure.offset + HEADER_LEN,
        kind: failure.kind,
    }
}

fn at(segment: Segment) -> impl FnOnce(Box<Failure>) -> Box<Failure> {
    move |mut failure| {
        failure.reversed_path.push(segment);
        failure
    }
}

pub(super) struct Cursor<'a> {
    /// The bytes after the encapsulation header; alignment is relative to their start.
    data: &'a [u8],
    pos: usize,
    big_endian: bool,
}

macro_rules! read_number {
    ($cursor:expr, $ty:ty) => {{
        let bytes = $cursor.array::<{ size_of::<$ty>() }>()?;
        if $cursor.big_endian {
            <$ty>::from_be_bytes(bytes)
        } else {
            <$ty>::from_le_bytes(bytes)
        }
    }};
}

impl<'a> Cursor<'a> {
    pub(super) fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    fn fail(&self, kind: DecodeErrorKind) -> Box<Failure> {
        Box::new(Failure {
            offset: self.pos,
            kind,
            reversed_path: Vec::new(),
        })
    }

    fn end(&self, needed: usize) -> Box<Failure> {
        self.fail(DecodeErrorKind::UnexpectedEnd {
            needed,
            available: self.remaining(),
        })
    }

    pub(super) fn align(&mut self, size: usize) -> Decoded<()> {
        let padding = (size - self.pos % size) % size;
        if padding > self.remaining() {
            return Err(self.end(padding));
        }
        self.pos += padding;
        Ok(())
    }

    pub(super) fn take(&mut self, len: usize) -> Decoded<&'a [u8]> {
        let data: &'a [u8] = self.data;
        let bytes = data
            .get(self.pos..)
            .and_then(|rest| rest.get(..len))
            .ok_or_else(|| self.end(len))?;
        self.pos += len;
        Ok(bytes)
    }

    fn array<const N: usize>(&mut self) -> Decoded<[u8; N]> {
        let mut bytes = [0; N];
        bytes.copy_from_slice(self.take(N)?);
        Ok(bytes)
    }

    /// A u32 length, checked to fit in the remaining bytes at `element_size` bytes each.
    pub(super) fn length(&mut self, element_size: usize, bound: Option<usize>) -> Decoded<usize> {
        self.align(4)?;
        let start = self.pos;
        let count = read_number!(self, u32);
        let count_u64 = u64::from(count);
        let fail_at_count = |cursor: &Self, kind| {
            let mut failure = cursor.fail(kind);
            failure.offset = start;
            failure
        };
        if let Some(bound) = bound
            && count_u64 > bound as u64
        {
            let kind = DecodeErrorKind::BoundExceeded {
                count: count_u64,
                bound: bound as u64,
            };
            return Err(fail_at_count(self, kind));
        }
        let remaining = self.remaining();
        let count = usize::try_from(count).unwrap_or(usize::MAX);
        if count.saturating_mul(element_size) > remaining {
            let kind = DecodeErrorKind::LengthTooLarge {
                count: count_u64,
                remaining,
            };
            return Err(fail_at_count(self, kind));
        }
        Ok(count)
    }

    pub(super) fn primitive(&mut self, primitive: Primitive) -> Decoded<Value> {
        self.align(primitive.size_bytes())?;
        Ok(match primitive {
            Primitive::Bool => {
                let [byte] = self.array::<1>()?;
                match byte {
                    0 => Value::Bool(false),
                    1 => Value::Bool(true),
                    other => {
                        self.pos -= 1;
                        return Err(self.fail(DecodeErrorKind::InvalidBool(other)));
                    }
                }
            }
            Primitive::Byte | Primitive::Char | Primitive::UInt8 => {
                Value::UInt(u64::from(read_number!(self, u8)))
            }
            Primitive::Int8 => Value::Int(i64::from(read_number!(self, i8))),
            Primitive::Int16 => Value::Int(i64::from(read_number!(self, i16))),
            Primitive::UInt16 => Value::UInt(u64::from(read_number!(self, u16))),
            Primitive::Int32 => Value::Int(i64::from(read_number!(self, i32))),
            Primitive::UInt32 => Value::UInt(u64::from(read_number!(self, u32))),
            Primitive::Int64 => Value::Int(read_number!(self, i64)),
            Primitive::UInt64 => Value::UInt(read_number!(self, u64)),
            Primitive::Float32 => Value::Float(f64::from(read_number!(self, f32))),
            Primitive::Float64 => Value::Float(read_number!(self, f64)),
        })
    }

    pub(super) fn string(&mut self, bound: Option<usize>) -> Decoded<Value> {
        let len = self.length(1, None)?;
        let start = self.pos;
        let bytes = self.take(len)?;
        let Some((&last, text)) = bytes.split_last() else {
            // Some writers send an empty string as length 0, without the NUL.
            return Ok(Value::String(String::new()));
        };
        if last != 0 {
            self.pos -= 1;
            return Err(self.fail(DecodeErrorKind::StringNotTerminated));
        }
        if let Some(bound) = bound
            && text.len() > bound
        {
            self.pos = start;
            return Err(self.fail(DecodeErrorKind::BoundExceeded {
                count: text.len() as u64,
                bound: bound as u64,
            }));
        }
        match std::str::from_utf8(text) {
            Ok(text) => Ok(Value::String(text.to_owned())),
            Err(error) => {
                self.pos = start + error.valid_up_to();
                Err(self.fail(DecodeErrorKind::InvalidUtf8))
            }
        }
    }

    pub(super) fn wstring(&mut self, bound: Option<usize>) -> Decoded<Value> {
        let len = self.length(4, bound)?;
        let mut text = String::with_capacity(len);
        for _ in 0..len {
            let code = read_number!(self, u32);
            let c = char::from_u32(code).ok_or_else(|| {
                let mut failure = self.fail(DecodeErrorKind::InvalidWideChar(code));
                failure.offset -= 4;
                failure
            })?;
            text.push(c);
        }
        Ok(Value::String(text))
    }
}

/// A walk through one message with a compiled plan.
pub(super) struct Walker<'d, 'a> {
    pub(super) decoder: &'d Decoder,
    pub(super) cursor: Cursor<'a>,
}

impl<'d, 'a> Walker<'d, 'a> {
    /// A walker at the start of `message`'s fields, after its encapsulation header.
    pub(super) fn new(decoder: &'d Decoder, message: &'a [u8]) -> Result<Self, DecodeError> {
        let header_error = |kind| DecodeError {
            path: String::new(),
            offset: 0,
            kind,
        };
        let (header, payload) = message
            .split_first_chunk::<HEADER_LEN>()
            .ok_or_else(|| header_error(DecodeErrorKind::MissingHeader(message.len())))?;
        let big_endian = match header {
            [0, 0, _, _] => true,
            [0, 1, _, _] => false,
            [a, b, _, _] => {
                return Err(header_error(DecodeErrorKind::UnsupportedEncapsulation(
                    *a, *b,
                )));
            }
        };
        Ok(Self {
            decoder,
            cursor: Cursor {
                data: payload,
                pos: 0,
                big_endian,
            },
        })
    }

    pub(super) fn structure(&mut self, index: usize) -> Decoded<Value> {
        let decoder = self.decoder;
        let Some(StructPlan {
            fields,
            placeholder_only,
        }) = decoder.structs.get(index)
        else {
            // Plans only hold indexes they created; an empty value is the safe answer.
            return Ok(Value::Struct(Vec::new()));
        };
        let mut values = Vec::with_capacity(fields.len());
        for field in fields {
            let value = self.field(field)?;
            values.push((field.name.clone(), value));
        }
        if *placeholder_only {
            values.clear();
        }
        Ok(Value::Struct(values))
    }

    pub(super) fn field(&mut self, field: &FieldPlan) -> Decoded<Value> {
        match field.length {
            Length::Single => self.element(field.element),
            Length::Fixed(len) => self.array(field.element, len),
            Length::Sequence { bound } => {
                let minimum = minimum_size(field.element);
                self.cursor
                    .length(minimum, bound)
                    .and_then(|len| self.array(field.element, len))
            }
        }
        .map_err(at(Segment::Field(field.name.clone())))
    }

    pub(super) fn element(&mut self, element: Element) -> Decoded<Value> {
        match element {
            Element::Primitive(primitive) => self.cursor.primitive(primitive),
            Element::String { bound } => self.cursor.string(bound),
            Element::WString { bound } => self.cursor.wstring(bound),
            Element::Struct(index) => self.structure(index),
        }
    }

    pub(super) fn array(&mut self, element: Element, len: usize) -> Decoded<Value> {
        if len == 0 {
            return Ok(match element {
                Element::Primitive(Primitive::UInt8 | Primitive::Byte) => Value::Bytes(Vec::new()),
                _ => Value::Array(Vec::new()),
            });
        }
        self.array_start(element, len)?;
        if let Element::Primitive(Primitive::UInt8 | Primitive::Byte) = element {
            return Ok(Value::Bytes(self.cursor.take(len)?.to_vec()));
        }
        let mut items = Vec::with_capacity(len);
        for index in 0..len {
            items.push(self.element(element).map_err(at(Segment::Index(index)))?);
        }
        Ok(Value::Array(items))
    }
}

impl Walker<'_, '_> {
    /// Aligns for an array of `len` (at least one) `element`s, and checks that they can fit
    /// in what is left before anything is allocated for them: a length from the schema or
    /// the bytes cannot make us reserve more than the message could hold.
    pub(super) fn array_start(&mut self, element: Element, len: usize) -> Decoded<()> {
        if let Element::Primitive(primitive) = element {
            self.cursor.align(primitive.size_bytes())?;
        }
        let needed = len.saturating_mul(minimum_size(element));
        if needed > self.cursor.remaining() {
            return Err(self.cursor.end(needed));
        }
        Ok(())
    }

    /// Checks that the message ends here, but for the padding that rounds it up to a
    /// multiple of 4 bytes.
    pub(super) fn finish(&self) -> Decoded<()> {
        let left = self.cursor.remaining();
        let padding = (4 - self.cursor.pos % 4) % 4;
        if left > padding {
            Err(self.cursor.fail(DecodeErrorKind::TrailingBytes(left)))
        } else {
            Ok(())
        }
    }
}

/// The fewest bytes an element can take after its alignment (a struct takes at least one:
/// empty ones carry a placeholder byte).
pub(super) fn minimum_size(element: Element) -> usize {
    match element {
        Element::Primitive(primitive) => primitive.size_bytes(),
        Element::String { .. } | Element::WString { .. } => 4,
        Element::Struct(_) => 1,
    }
}
