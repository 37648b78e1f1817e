//! The traits that generated types implement, and the catalogue entries that describe
//! them to tools.

use std::fmt::Debug;

use thiserror::Error;

use crate::cdr::{Decode, DecodeError, DecodeView, Encode, Sink, ViewToOwned};
use crate::msg::Header;

/// Any generated struct: it has a CDR encoding and a ros2msg schema.
pub trait Struct:
    Encode + Decode + Clone + Debug + PartialEq + Default + Send + Sync + 'static
{
    /// The schema name, `lewis_interfaces/msg/<Name>`.
    const SCHEMA_NAME: &'static str;
    /// The ros2msg schema text, dependencies appended as ROS 2 does.
    const SCHEMA_TEXT: &'static str;

    /// The zero-copy view of this struct (`RangeFinderView<'a>` for `RangeFinder`): its
    /// fields read in place from the CDR bytes ([`crate::cdr::DecodeView`]).
    type View<'a>: DecodeView<'a> + ViewToOwned<Owned = Self>;

    /// The view of `bytes` (a whole message, header included), checked as
    /// [`crate::cdr::from_bytes`] checks, copying nothing.
    ///
    /// # Errors
    /// When the bytes are not a valid `Self`.
    #[inline]
    fn view(bytes: &[u8]) -> Result<Self::View<'_>, DecodeError> {
        crate::cdr::view(bytes)
    }

    /// Checks that every array has the length its `array_size` field says.
    ///
    /// # Errors
    /// The first array whose length disagrees.
    fn check_sizes(&self) -> Result<(), SizeMismatch>;

    /// The first number that is NaN or infinite, in field order, its place written into
    /// `path` (`points[1].x`; left as it was when there is none). Generated for every
    /// struct that holds numbers, without allocating but for the place of what it finds:
    /// the broker checks every sample of a checked provider with it.
    fn first_non_finite(&self, path: &mut String) -> Option<f64> {
        let _ = path;
        None
    }
}

/// A struct whose arrays of numbers and of plain structs can be written in place in the
/// encoded bytes (see [`crate::cdr::encode_in_place`]): what a publisher of camera frames
/// or scans uses to write them straight into shared memory. Every generated struct has
/// it; `RangeFinder`'s writer is `RangeFinderBulk<'a>`, its lengths `RangeFinderBulkLens`.
pub trait InPlace: Struct {
    /// The writer of the arrays, borrowed from the encoded bytes: a
    /// [`crate::cdr::LeSliceMut`] (or `&mut [u8]` for bytes) per array, named as the field.
    type Bulk<'a>;
    /// One number per array written in place, named as the field: their lengths (or,
    /// from [`InPlace::encode_shape`], where they start).
    type Lens: Copy + Debug + Default + PartialEq + Eq;

    /// Encodes the fields of `self` but for the arrays written in place: for those, the
    /// count from `lens` and the room for the elements, left unwritten (`self`'s own arrays
    /// there are ignored). Returns where each array's elements start in the payload.
    fn encode_shape<S: Sink>(&self, lens: &Self::Lens, sink: &mut S) -> Self::Lens;

    /// The writer of the arrays of a payload encoded by [`InPlace::encode_shape`] with the
    /// same `lens`, which returned `starts`.
    fn bulk<'a>(payload: &'a mut [u8], lens: &Self::Lens, starts: &Self::Lens) -> Self::Bulk<'a>;

    /// The lengths of `self`'s own arrays.
    fn bulk_lens(&self) -> Self::Lens;

    /// Writes `self`'s own arrays: the in-place encoding is then `self`'s encoding.
    fn write_bulk(&self, bulk: Self::Bulk<'_>);

    /// [`Struct::check_sizes`] with the arrays written in place of the lengths `lens`.
    ///
    /// # Errors
    /// The first array whose length disagrees.
    fn check_shape(&self, lens: &Self::Lens) -> Result<(), SizeMismatch>;
}

/// A struct that travels on its own: a publication, a command or a reply. It starts with
/// the common [`Header`].
pub trait Message: Struct {
    /// The header: provider, sequence number, publish time, provenance.
    fn header(&self) -> &Header;
    /// The header, to fill in before sending.
    fn header_mut(&mut self) -> &mut Header;
}

/// An interface, named by the type of its publication: `Client<RangeFinder>`.
pub trait Interface: Message + InPlace {
    /// Its name, as in the XML.
    const NAME: &'static str;
    /// Its version, `MAJOR.MINOR`.
    const VERSION: &'static str;
    /// The XML definition it was generated from.
    const XML: &'static str;
    /// Its commands, as one enum.
    type Command: CommandSet;
    /// The replies to its commands, as one enum.
    type Reply: CommandSet;
}

/// A command of an interface, with the type of its reply.
pub trait Command: Message {
    /// Its name, as in the XML (`set_zoom`).
    const NAME: &'static str;
    /// The interface it belongs to.
    type Interface: Interface;
    /// What it answers.
    type Reply: Message;
}

/// The commands (or the replies) of one interface as an enum, for a provider that
/// dispatches on them.
pub trait CommandSet: Sized + Debug + Clone + PartialEq + Send + 'static {
    /// The interface.
    const INTERFACE: &'static str;
    /// Every command name, in definition order.
    const NAMES: &'static [&'static str];
    /// The command name of this value.
    fn name(&self) -> &'static str;
    /// The header of this value.
    fn header(&self) -> &Header;
    /// Encodes the message inside (not its name) into `buffer`, replacing its contents.
    fn encode_to_vec(&self, buffer: &mut Vec<u8>);
    /// Decodes the message of command `command` from CDR bytes.
    ///
    /// # Errors
    /// When the command is not one of [`Self::NAMES`] or the bytes do not decode.
    fn decode(command: &str, bytes: &[u8]) -> Result<Self, CommandDecodeError>;
}

/// Why a command could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum CommandDecodeError {
    /// The interface has no command of that name.
    #[error("interface `{interface}` has no command `{command}`; it has: {known}")]
    Unknown {
        /// The interface.
        interface: &'static str,
        /// The name asked for.
        command: String,
        /// The commands it has, comma-separated.
        known: String,
    },
    /// The bytes are not a valid encoding of the command.
    #[error("{0}")]
    Decode(#[from] DecodeError),
}

impl CommandDecodeError {
    /// The error for an unknown command of the set `S`.
    #[must_use]
    pub fn unknown<S: CommandSet>(command: &str) -> Self {
        Self::Unknown {
            interface: S::INTERFACE,
            command: command.to_owned(),
            known: S::NAMES.join(", "),
        }
    }
}

/// An array whose length disagrees with the field that gives its size.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("`{ty}.{array}` has {len} elements but `{ty}.{size_field}` says {size}")]
pub struct SizeMismatch {
    /// The struct.
    pub ty: &'static str,
    /// The array field.
    pub array: &'static str,
    /// Its length.
    pub len: usize,
    /// The field that gives its size.
    pub size_field: &'static str,
    /// What that field says.
    pub size: i128,
}

impl SizeMismatch {
    /// Checks one array against its size field (used by generated code).
    ///
    /// # Errors
    /// When the two disagree.
    pub fn check(
        ty: &'static str,
        array: &'static str,
        len: usize,
        size_field: &'static str,
        size: i128,
    ) -> Result<(), Self> {
        if i128::try_from(len).ok() == Some(size) {
            Ok(())
        } else {
            Err(Self {
                ty,
                array,
                len,
                size_field,
                size,
            })
        }
    }
}

/// A word that is none of the values a String field declares (`"arived"` for
/// `Mover.status`): the error of a generated vocabulary's `FromStr`.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("`{word}` is not a value of `{field}`; it holds one of: {}", .expected.join(", "))]
pub struct UnknownValue {
    /// The field, as `Struct.field`.
    pub field: &'static str,
    /// The word read.
    pub word: String,
    /// The words the field may hold.
    pub expected: &'static [&'static str],
}

impl UnknownValue {
    /// The error for `word` read from `field` (used by generated code).
    #[must_use]
    pub fn new(field: &'static str, word: &str, expected: &'static [&'static str]) -> Self {
        Self {
            field,
            word: word.to_owned(),
            expected,
        }
    }
}

/// A schema as MCAP stores it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SchemaInfo {
    /// `lewis_interfaces/msg/<Name>`.
    pub name: &'static str,
    /// The ros2msg text.
    pub text: &'static str,
}

/// One command of an interface in the catalogue.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommandInfo {
    /// Its name.
    pub name: &'static str,
    /// The request's schema.
    pub request: SchemaInfo,
    /// The reply's schema.
    pub reply: SchemaInfo,
}

/// One interface in the catalogue: what a recorder stores and a tool shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InterfaceInfo {
    /// Its name.
    pub name: &'static str,
    /// Its version.
    pub version: &'static str,
    /// The XML it was generated from.
    pub xml: &'static str,
    /// The publication's schema.
    pub publication: SchemaInfo,
    /// Its commands.
    pub commands: &'static [CommandInfo],
}

impl InterfaceInfo {
    /// The CDR bytes of the reply to `command` with every field at its default (zeros,
    /// empty strings and sequences), or `None` when the interface has no such command.
    #[must_use]
    pub fn default_reply(&self, command: &str) -> Option<Vec<u8>> {
        let reply = self.commands.iter().find(|c| c.name == command)?.reply;
        crate::msg::default_message(reply.name)
    }
}
